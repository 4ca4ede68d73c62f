"""The declared speed against the record's own 1X line (issue 34, item 7): simulated records pass without a
warning; a speed label within 1 % of the 1X line is read at the line's speed with a warning; farther (or a
sample rate 2 % off) is refused naming the file, the declared and the measured speed; a label off by a
sliver of the record's resolution is a warning."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from lubeviz.errors import DataFormatError, InputError
from lubeviz.identify.forward.measured import measure
from lubeviz.model.machine import load_machine
from lubeviz.signals.records import write_record
from lubeviz.signals.speed_check import check_speed_label, spectrum_speed_check
from lubeviz.signals.synthesize import synthesize_record
from lubeviz.units import MLMIN_PER_M3S
from tests.records import read_record, record_from_arrays

FLOWS = (450 / MLMIN_PER_M3S, 600 / MLMIN_PER_M3S)


@pytest.fixture(scope="module")
def simulated(tmp_path_factory):
    """Records as `lubeviz simulate` writes them: 40-120 Hz, 12 dB, several seeds (steady and time)."""
    machine = load_machine()
    folder = tmp_path_factory.mktemp("speed-check")
    out = {}
    for speed, seed, method in ((40.0, 1, "steady"), (75.0, 2, "time"), (75.0, 3, "steady"),
                                (120.0, 4, "steady")):
        rec = synthesize_record(machine, FLOWS, snr_db=12.0, rng=np.random.default_rng(seed), speed_hz=speed,
                                method=method)
        out[(speed, seed)] = write_record(rec, folder / f"sim-{speed:g}-{seed}.csv")
    return out


def test_simulated_records_read_without_a_speed_warning(simulated):
    for path in simulated.values():
        rec = read_record(path)
        assert rec.warnings == ()
        check = spectrum_speed_check(rec)
        assert check.verdict == "ok"
        # the refined 1X line sits on the simulated speed far better than 0.1 %
        assert abs(check.line_hz / rec.speed_hz - 1) < 1e-5


def _relabel(path, tmp_path, key, factor):
    lines = path.read_text().splitlines()
    for i, line in enumerate(lines):
        if line.startswith(f"# {key}:"):
            value = float(line.split(":", 1)[1])
            lines[i] = f"# {key}: {value * factor!r}"
    out = tmp_path / f"{path.stem}-{key}-{factor:g}.csv"
    out.write_text("\n".join(lines) + "\n")
    return out


@pytest.mark.parametrize("factor", [1.003, 1.005, 1.0099, 0.997, 0.991])
def test_a_label_within_one_percent_is_read_at_its_1x_line_with_a_warning(simulated, tmp_path, factor):
    """A label rounded to whole rpm or a drifted speed: the record is read at the shaft's own 1X (the speed
    the simulation ran at), and the warning names the declared speed, the measured one and the alternative
    cause (the sample rate)."""
    for (speed, _), path in simulated.items():
        rec = read_record(_relabel(path, tmp_path, "speed_hz", factor))
        assert rec.speed_hz == pytest.approx(speed, rel=1e-5)
        (note,) = [w for w in rec.warnings if "speed_hz" in w]
        assert f"{speed * factor:g} Hz" in note and "sample_rate_hz" in note


def test_a_relabelled_record_read_at_its_1x_gives_the_features_of_the_true_label(simulated, tmp_path):
    path = simulated[(75.0, 3)]
    good = measure(read_record(path))
    relabelled = measure(read_record(_relabel(path, tmp_path, "speed_hz", 1.005)))
    assert np.allclose(relabelled.values, good.values, atol=3 * good.std)


@pytest.mark.parametrize("factor", [1.05, 0.95, 1.02])
def test_a_wrong_speed_label_is_refused_naming_file_declared_and_measured_speed(simulated, tmp_path, factor):
    for (speed, _), path in simulated.items():
        bad = _relabel(path, tmp_path, "speed_hz", factor)
        with pytest.raises(DataFormatError) as err:
            read_record(bad)
        msg = str(err.value)
        assert str(bad) in msg and "speed_hz" in msg and "check the speed_hz label or the sample rate" in msg
        assert f"{speed * factor:g} Hz" in msg  # the declared speed
        measured = float(msg.split(" is at ")[1].split(" Hz")[0]) if " is at " in msg else \
            float(msg.split("strongest line is at ")[1].split(" Hz")[0])
        assert measured == pytest.approx(speed, rel=1e-4)  # the speed the simulation ran at


def test_a_sample_rate_two_percent_off_is_refused_as_every_line_scaled(simulated, tmp_path):
    for (speed, _), path in simulated.items():
        text = path.read_text().splitlines()
        head = [ln for ln in text if ln.startswith("#")]
        body = text[len(head):]
        # drop the t column (it would disagree with the rate) and declare the rate 2 % high
        rows = [",".join(r.split(",")[1:]) for r in body]
        head = [f"# sample_rate_hz: {1.02e4!r}" if ln.startswith("# sample_rate_hz") else ln for ln in head]
        bad = tmp_path / f"rate-{speed:g}.csv"
        bad.write_text("\n".join(head + rows) + "\n")
        with pytest.raises(DataFormatError, match="sample_rate_hz off by x1.02") as err:
            read_record(bad)
        assert str(bad) in str(err.value) and f"{speed * 1.02:.4g}" in str(err.value)


def _tone_record(speed_true, speed_label, duration=5.0, fs=2000.0, source=None):
    t = np.arange(int(duration * fs)) / fs
    rng = np.random.default_rng(7)
    w = 2 * math.pi * speed_true * t
    ch = [a * np.cos(w + p) + 0.05 * a * rng.standard_normal(t.size)
          for a, p in ((20.0, 0.0), (15.0, -1.4), (10.0, 0.5), (9.0, -1.0))]
    return record_from_arrays(*ch, speed_hz=speed_label, sample_rate_hz=fs, units="um", source=source)


def test_a_label_off_by_a_fraction_of_the_resolution_is_a_warning_naming_the_line():
    # 5 s at 75 Hz: resolution 0.2 Hz; 0.01 Hz off (0.013 %) is 1/20 of a bin: the 1X fit still holds
    rec = _tone_record(75.0, 75.01, source="rig.csv")
    out = check_speed_label(rec)
    assert len(out.warnings) == 1
    w = out.warnings[0]
    assert w.startswith("rig.csv: speed_hz:") and "75.01 Hz" in w and "75 Hz" in w and "below" in w


def test_a_label_within_a_fiftieth_of_a_bin_passes_silently():
    rec = _tone_record(75.0, 75.002)  # 0.01 bins
    assert check_speed_label(rec).warnings == ()


def test_speed_given_in_rpm_is_named():
    rec = _tone_record(75.0, 75.0 * 60, fs=20000.0, duration=1.0)
    with pytest.raises(DataFormatError, match="rev/min"):
        check_speed_label(rec)


def test_features_do_not_depend_on_a_huge_t0():
    base = _tone_record(75.0, 75.0)
    late = dataclasses.replace(base, t0=1.7e15)  # epoch nanoseconds written as seconds
    a, b = measure(base), measure(late)
    # the features are the same to rounding (before: "Matrix is not positive definite")
    np.testing.assert_allclose(b.values, a.values, rtol=0, atol=1e-9)
    np.testing.assert_allclose(b.std, a.std, rtol=1e-9)


def test_a_huge_t0_round_trips_through_every_format(tmp_path):
    rec = dataclasses.replace(_tone_record(75.0, 75.0), t0=1.7e15)
    for suffix in (".csv", ".npz", ".mat"):
        back = read_record(write_record(rec, tmp_path / f"late{suffix}"))
        assert back.t0 == 1.7e15 and np.array_equal(back.displacement, rec.displacement)


def test_a_t_column_too_large_for_its_step_is_refused_naming_t(tmp_path):
    path = tmp_path / "epoch.csv"
    n = 400
    t = 1.7e15 + np.arange(n) / 2000.0  # float64 holds these to 0.25 s
    x = np.cos(2 * math.pi * 75 * np.arange(n) / 2000.0)
    rows = "\n".join(f"{a!r},{b!r},{b!r},{b!r},{b!r}" for a, b in zip(t.tolist(), x.tolist()))
    path.write_text(f"# speed_hz: 75\n# units: um\nt,x1,y1,x2,y2\n{rows}\n")
    with pytest.raises(DataFormatError, match=r"epoch\.csv: t: times near 1\.7e\+15 s") as err:
        read_record(path)
    assert "t0_s" in str(err.value)


def test_no_usable_1x_message_names_the_file_the_speed_and_the_strongest_line():
    from lubeviz.identify.fit.result import check_record
    from lubeviz.identify.fit.settings import IdentificationSettings

    # a tone at 60 Hz in a record labelled 75 Hz, built in memory (the reader would refuse the file)
    rec = _tone_record(60.0, 75.0, source="coast.csv")
    meas = measure(rec)

    class Model:
        omega, nodes = 2 * math.pi * 75.0, rec.nodes

    with pytest.raises(InputError) as err:
        check_record(Model(), meas, IdentificationSettings())
    msg = str(err.value)
    assert msg.startswith("coast.csv: plane 1") and "no usable 1X line" in msg
    assert "75 Hz" in msg and "60 Hz" in msg and "0.8 x" in msg and "speed_hz label or the sample rate" in msg
