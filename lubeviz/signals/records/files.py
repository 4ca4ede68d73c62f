"""Reading and writing records: the format chosen by suffix, size refused before reading, errors naming the file."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import scipy.io

from ...errors import DataFormatError
from ...units import length_factor
from ..speed_check import check_speed_label
from .csv_format import _read_csv, _write_csv
from .fields import _assemble, _time_spacing
from .mat_format import _MATLAB_NAME, _read_mat
from .npz_format import _read_npz, _write_npz
from .record import (
    FORMATS, Record, STATIC_ABSOLUTE, TIME_PRECISION, _fail, channel_names,
)
from . import record as _record  # its MAX_RECORD_BYTES read at call time


def read_record(path, *, default_nodes=None, default_probe_angles=None) -> Record:
    """Read a `.csv`, `.npz` or `.mat` record (SPEC §6); `default_nodes` and `default_probe_angles` (the machine's
    measurement planes, `Machine.record_defaults`) when the file names none. Without `default_nodes` a file that
    names no nodes is refused (no machine's nodes are assumed); without angles the probes are taken along X, Y."""
    path = Path(path)
    where = str(path)
    suffix = _suffix(path)
    try:
        size = path.stat().st_size
    except FileNotFoundError:
        raise _fail(where, "file", "no such file", "an existing record file") from None
    except OSError as exc:
        raise _fail(where, "file", f"cannot be read ({exc.strerror or exc})") from None
    if not path.is_file():
        raise _fail(where, "file", "is not a regular file", "a record file")
    if size > _record.MAX_RECORD_BYTES:
        raise _fail(where, "file", f"{size / 1e6:.1f} MB is larger than the limit",
                    f"at most {_record.MAX_RECORD_BYTES / 1e6:g} MB (lubeviz.signals.records.MAX_RECORD_BYTES)")
    if size == 0:
        raise _fail(where, "file", "is empty", f"a {suffix} record")
    reader = {".csv": _read_csv, ".npz": _read_npz, ".mat": _read_mat}[suffix]
    columns, meta, extra, origin = reader(path, where)
    record = _assemble(columns, meta, extra, origin, default_nodes, default_probe_angles=default_probe_angles)
    del columns  # _assemble took the samples over
    # The declared speed against the spectrum's own 1X line (a wrong speed label or sample rate):
    # every record read for identification passes here (CLI, app uploads, sets).
    return check_speed_label(record)


def read_record_bytes(content, filename: str, *, default_nodes=None, default_probe_angles=None) -> Record:
    """Read a record uploaded as bytes (or text) under its original `filename` (its suffix gives the format).

    Messages name `filename`, not the temporary file the bytes pass through. The size limit is checked
    before anything is written.
    """
    import tempfile

    name = Path(str(filename)).name or "upload"
    data = content.encode("utf-8") if isinstance(content, str) else bytes(content or b"")
    if len(data) > _record.MAX_RECORD_BYTES:
        raise _fail(name, "file", f"{len(data) / 1e6:.1f} MB is larger than the limit",
                    f"at most {_record.MAX_RECORD_BYTES / 1e6:g} MB (lubeviz.signals.records.MAX_RECORD_BYTES)")
    suffix = _suffix(Path(name))
    with tempfile.TemporaryDirectory(prefix="lubeviz-upload-") as tmp:
        path = Path(tmp) / ("upload" + suffix)  # the user's name may be longer than a file system allows
        path.write_bytes(data)
        try:
            rec = read_record(path, default_nodes=default_nodes, default_probe_angles=default_probe_angles)
        except DataFormatError as exc:
            raise DataFormatError(str(exc).replace(str(path), name)) from None
    return dataclasses.replace(rec, source=name,
                               warnings=tuple(w.replace(str(path), name) for w in rec.warnings))


def write_record(record: Record, path, *, units: str = "m") -> Path:
    """Write `record` as `.csv`, `.npz` or `.mat`. In metres (the default) it reads back equal."""
    path = Path(path)
    where = str(path)
    suffix = _suffix(path)
    try:
        scale = length_factor(units)
    except ValueError as exc:
        raise _fail(where, "units", str(exc)) from None
    t_end = record.t0 + record.duration
    lossy_t = _time_spacing(record.t0, t_end) > TIME_PRECISION / record.sample_rate_hz
    columns = {} if lossy_t else {"t": record.t}  # a t0 too large for a t column: '# t0_s' instead
    names = channel_names(record.n_planes)
    for k, a in np.ndindex(record.n_planes, 2):
        reading = record.displacement[k, a]
        columns[names[2 * k + a]] = reading if scale == 1.0 else reading / scale
    if record.keyphasor is not None:
        columns["keyphasor"] = record.keyphasor
    meta = {"speed_hz": record.speed_hz, "sample_rate_hz": record.sample_rate_hz,
            "units": units.strip().lower(),
            **({"node1": record.nodes[0], "node2": record.nodes[1]} if record.n_planes == 2 else
               {"nodes": ", ".join(str(n) for n in record.nodes)})}
    if lossy_t:
        meta["t0_s"] = record.t0
    meta["probe_angles_deg"] = record.probe_angles_deg  # always: a machine's planes may default to others (SPEC §8)
    if record.machine is not None:
        meta["machine"] = record.machine
    if record.set_name is not None:
        meta["set"] = record.set_name
    if record.oil_temperature_c is not None:
        meta["oil_temperature_c"] = record.oil_temperature_c
    if record.rest_position is not None:  # the readings keep their DC gap: say so, with the rest
        meta["static"] = STATIC_ABSOLUTE
        meta["rest_position"] = record.rest_position if scale == 1.0 else record.rest_position / scale
    try:
        if suffix == ".csv":
            _write_csv(path, columns, meta, record.metadata)
        else:
            arrays = {**columns, **meta, **record.metadata}
            arrays["probe_angles_deg"] = np.array(record.probe_angles_deg)
            if record.n_planes == 2:
                arrays["node1"], arrays["node2"] = (np.int64(v) for v in record.nodes)
            else:
                arrays["nodes"] = np.array(record.nodes, dtype=np.int64)
            if suffix == ".npz":
                _write_npz(path, arrays)
            else:
                bad = [k for k in record.metadata if not _MATLAB_NAME.match(k)]
                if bad:
                    raise _fail(where, f"metadata {bad[0]!r}", "is not a valid MATLAB variable name",
                                "a letter, then letters, digits or '_' (at most 63)")
                with open(path, "wb") as f:
                    scipy.io.savemat(f, arrays, oned_as="column")
    except OSError as exc:
        raise _fail(where, "file", f"cannot be written ({exc.strerror or exc})") from None
    return path


def _name(record: Record) -> str:
    return record.source or "record"


def _suffix(path: Path) -> str:
    suffix = path.suffix.lower()
    if suffix not in FORMATS:
        raise _fail(str(path), "suffix", f"{path.suffix or '(none)'!r} is not a record format",
                    f"one of {', '.join(FORMATS)}")
    return suffix
