"""`lubeviz identify FILE` and `lubeviz diagnose FILE` on the hostile records of issue 34 (items 6, 7): exit 2
with one line naming the file and the field, never a traceback (the fuzz corpus covers the reader alone)."""

import io
import math
import zipfile

import numpy as np
import pytest

from lubeviz.cli.main import main
from lubeviz.signals.records import write_record
from tests.records import record_from_arrays

SPEED, RATE, N = 75.0, 2000.0, 2000  # 1 s, resolution 1 Hz


def _record():
    t = np.arange(N) / RATE
    w = 2 * math.pi * SPEED * t
    rng = np.random.default_rng(3)
    ch = [a * np.cos(w + p) + 0.02 * a * rng.standard_normal(N) for a, p in ((20, 0), (15, -1.4), (10, .5), (9, -1))]
    return record_from_arrays(*ch, speed_hz=SPEED, sample_rate_hz=RATE, units="um")


def _huge_header_npz(path):
    base = path.with_name("base.npz")
    write_record(_record(), base)
    head = io.BytesIO()
    np.lib.format.write_array_header_1_0(head, {"descr": "<f8", "fortran_order": False, "shape": (10**12,)})
    src = zipfile.ZipFile(base)
    with zipfile.ZipFile(path, "w") as z:
        for info in src.infolist():
            z.writestr(info.filename, head.getvalue() + b"\0" * 64 if info.filename == "x1.npy" else src.read(info))
    return "x1.npy"


def _relabelled(key, factor, drop_t=False):
    def make(path):
        write_record(_record(), path)
        lines = path.read_text().splitlines()
        out = []
        for line in lines:
            if line.startswith(f"# {key}:"):
                line = f"# {key}: {float(line.split(':', 1)[1]) * factor!r}"
            elif drop_t and not line.startswith("#"):
                line = ",".join(line.split(",")[1:])
            out.append(line)
        path.write_text("\n".join(out) + "\n")
        return key
    return make


def _epoch_t(path):
    write_record(_record(), path)
    lines = path.read_text().splitlines()
    out = [ln if ln.startswith("#") or ln.startswith("t,") else
           ",".join([repr(1.7e15 + float(ln.split(",")[0]))] + ln.split(",")[1:]) for ln in lines]
    path.write_text("\n".join(out) + "\n")
    return "t"


CASES = {
    "npz-header-claims-1e12-samples": (".npz", _huge_header_npz),
    "speed-label-2pct-high": (".csv", _relabelled("speed_hz", 1.02)),
    "speed-label-5pct-low": (".csv", _relabelled("speed_hz", 0.95)),
    "sample-rate-2pct-high": (".csv", _relabelled("sample_rate_hz", 1.02, drop_t=True)),
    "t-column-in-epoch-seconds": (".csv", _epoch_t),
}


@pytest.mark.parametrize("command", ["identify", "diagnose"])
@pytest.mark.parametrize("case", sorted(CASES))
def test_hostile_record_exits_2_with_one_line_naming_file_and_field(tmp_path, capsys, command, case):
    suffix, make = CASES[case]
    path = tmp_path / f"hostile{suffix}"
    field = make(path)
    assert main([command, str(path)]) == 2
    err = capsys.readouterr().err
    errors = [ln for ln in err.splitlines() if "error" in ln]
    assert len(errors) == 1, err
    assert str(path) in errors[0] and field in errors[0]
    assert "Traceback" not in err and "MemoryError" not in err
