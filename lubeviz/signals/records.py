"""Measured vibration records: one steady speed, two measurement planes (SPEC §6).

A `Record` holds what two pairs of proximity probes measured at one shaft speed, in metres, with the
sampling, the model nodes of the planes and the probe directions. It is validated when it is built,
so a `Record` that exists is usable: finite samples, uniform sampling, at least `MIN_REVOLUTIONS`
revolutions, the 1X line below the Nyquist frequency, well-conditioned probe pairs.

Files (`read_record` / `write_record`), the same fields in three formats:

- CSV: leading comment lines `# key: value` (metadata), then a header row and numeric rows.
  Metadata: `speed_hz` (required), `sample_rate_hz` (required unless there is a `t` column),
  `units` (required: m, mm, um or mils, via `lubeviz.units`), optional `node1`, `node2`,
  `probe_angles_deg` ("45, 135" for both planes or "45, 135, 30, 120" plane by plane), `machine`,
  `t0_s` (time of the first sample when there is no `t` column). Other `key: value` lines are kept
  as `Record.metadata` (strings); comment lines without a colon are free comments and are skipped.
  Columns, matched by name (case-insensitive, any order): `t` (optional), `x1`, `y1`, `x2`, `y2`
  (probe readings of planes 1 and 2 in `units`), `keyphasor` (optional, stored unscaled). Columns
  with other names are ignored. Delimiter: comma (or semicolon, tab, whitespace, as the header uses).
- `.npz` / `.mat`: variables with the same names; metadata as scalars or strings, the probe angles
  as an array of 2 or 4 numbers (a 2x2 array is read plane by plane, i.e. row by row). Other scalar
  or string variables become `Record.metadata` (as strings); other arrays are ignored. MATLAB v7.3
  (HDF5) files are not read: save with `-v7`.

With a `t` column, the time must increase strictly and uniformly: each step within `TIME_RTOL` of
the median step, so a dropped sample or a jump is pointed at by line; then `sample_rate_hz` is
1/(mean step), or, when also given, the mean step must agree with it to `TIME_RTOL`. Timestamps
printed with too few digits for that (e.g. 51.2 kHz at 6 decimals) are refused: give
`sample_rate_hz` and drop the `t` column. The writers store `sample_rate_hz` and a `t` column (and,
by default, metres), so a record round-trips exactly (CSV numbers are written with Python's shortest
round-trip `repr`).

Probe pairs closer than `MIN_PROBE_SEPARATION_DEG` to parallel are refused when the record is
built, so `Record.xy()` always solves a well-conditioned 2x2 system.

Every problem raises `DataFormatError` naming the file, the field (and the line or index) and what
was expected; no numpy or csv traceback reaches the user.
"""

from __future__ import annotations

import dataclasses

import math
import numbers
import re
import zipfile
import zlib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType

import numpy as np
import scipy.io
from scipy.io.matlab import MatReadError

from ..errors import DataFormatError, InputError
from ..units import length_factor

MAX_RECORD_BYTES = 200_000_000  # files above this are refused before reading (read at call time)
MIN_REVOLUTIONS = 10.0  # the 1X DFT needs several whole revolutions to separate 1X from noise
MIN_SAMPLES = 16
MIN_PROBE_SEPARATION_DEG = 10.0  # two probes closer than this (mod 180°) cannot resolve X and Y
TIME_RTOL = 1e-6  # allowed relative deviation of each time step from the mean step
DEFAULT_NODES = (6, 20)  # the paper machine's bearing centres
DEFAULT_PROBE_ANGLES_DEG = ((0.0, 90.0), (0.0, 90.0))  # probe a along +X, probe b along +Y
FORMATS = (".csv", ".npz", ".mat")

CHANNELS = ("x1", "y1", "x2", "y2")  # file names of displacement[plane][probe], row-major
COLUMNS = ("t", *CHANNELS, "keyphasor")
META_KEYS = ("speed_hz", "sample_rate_hz", "units", "node1", "node2", "probe_angles_deg",
             "machine", "t0_s")
RESERVED = frozenset(COLUMNS + META_KEYS)
_MATLAB_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]{0,62}\Z")


def _fail(where: str, what: str, problem: str, expected: str | None = None) -> DataFormatError:
    """The one message shape: '<file>: <field>: <problem>; expected <expectation>'."""
    return DataFormatError(f"{where}: {what}: {problem}" + (f"; expected {expected}" if expected else ""))


# ---------------------------------------------------------------------------------------------
# The record
# ---------------------------------------------------------------------------------------------

@dataclass(frozen=True, eq=False)
class Record:
    """One steady-speed measurement at two planes; SI inside (metres, seconds, rev/s)."""

    speed_hz: float  # shaft speed, rev/s
    sample_rate_hz: float  # samples per second, uniform sampling
    displacement: np.ndarray  # (2 planes, 2 probes, n_samples) probe readings in metres, read-only
    nodes: tuple[int, int] = DEFAULT_NODES  # model nodes of the two planes
    probe_angles_deg: tuple[tuple[float, float], tuple[float, float]] = DEFAULT_PROBE_ANGLES_DEG
    t0: float = 0.0  # time of the first sample, s
    machine: str | None = None  # model file name under models/
    keyphasor: np.ndarray | None = None  # (n_samples,), as recorded (not scaled)
    metadata: Mapping[str, str] = field(default_factory=dict)  # other `key: value` pairs, read-only
    source: str | None = None  # the file it came from, for messages

    def __post_init__(self):
        where = str(self.source) if self.source is not None else "record"

        def put(name, value):  # frozen: fields are normalised once, here
            object.__setattr__(self, name, value)

        if self.source is not None:
            put("source", str(self.source))
        put("speed_hz", _positive(self.speed_hz, where, "speed_hz", "the shaft speed in rev/s"))
        put("sample_rate_hz", _positive(self.sample_rate_hz, where, "sample_rate_hz",
                                        "samples per second"))
        put("t0", _finite(self.t0, where, "t0_s", "the time of the first sample in s"))

        d = _numeric_array(self.displacement, where, "displacement")
        if d.ndim != 3 or d.shape[:2] != (2, 2):
            raise _fail(where, "displacement", f"shape {d.shape}",
                        "(2 planes, 2 probes, n_samples)")
        for k, a in zip(*np.nonzero(~np.isfinite(d).all(axis=2))):
            i = int(np.flatnonzero(~np.isfinite(d[k, a]))[0])
            raise _fail(where, f"{CHANNELS[2 * k + a]}, index {i}", f"{d[k, a, i]} is not finite",
                        "finite displacements")
        put("displacement", _frozen_copy(d))
        n = d.shape[2]
        if n < MIN_SAMPLES:
            raise _fail(where, "samples", f"too few samples ({n})", f"at least {MIN_SAMPLES}")
        if self.sample_rate_hz <= 2.0 * self.speed_hz:
            raise _fail(where, "sample_rate_hz",
                        f"{self.sample_rate_hz:g} Hz is not above twice speed_hz ({self.speed_hz:g} Hz),"
                        " so the 1X line would alias", f"sample_rate_hz > {2 * self.speed_hz:g} Hz")
        if self.revolutions < MIN_REVOLUTIONS:
            raise _fail(where, "duration",
                        f"too few revolutions: {n} samples at {self.sample_rate_hz:g} Hz last"
                        f" {self.duration:.6g} s = {self.revolutions:.3g} revolutions at"
                        f" {self.speed_hz:g} Hz", f"at least {MIN_REVOLUTIONS:g} revolutions")

        try:
            nodes = tuple(self.nodes)
        except TypeError:
            nodes = ()
        if len(nodes) != 2:
            raise _fail(where, "nodes", f"{self.nodes!r}", "two node numbers (node1, node2)")
        put("nodes", tuple(_node(v, where, f"node{k + 1}") for k, v in enumerate(nodes)))
        put("probe_angles_deg", _probe_angles(self.probe_angles_deg, where))

        if self.keyphasor is not None:
            kp = _numeric_array(self.keyphasor, where, "keyphasor")
            if kp.shape != (n,):
                raise _fail(where, "keyphasor", f"shape {kp.shape}", f"({n},), one value per sample")
            bad = np.flatnonzero(~np.isfinite(kp))
            if bad.size:
                raise _fail(where, f"keyphasor, index {bad[0]}", f"{kp[bad[0]]} is not finite",
                            "finite values")
            put("keyphasor", _frozen_copy(kp))
        if self.machine is not None:
            put("machine", _text(self.machine, where, "machine", "a model file name"))
        put("metadata", _metadata(self.metadata, where))

    # -- derived quantities ------------------------------------------------------------------
    @property
    def n_samples(self) -> int:
        return self.displacement.shape[2]

    @property
    def duration(self) -> float:
        """n_samples / sample_rate_hz: the span a DFT over all samples covers (s)."""
        return self.n_samples / self.sample_rate_hz

    @property
    def t(self) -> np.ndarray:
        """Sample times t0 + i / sample_rate_hz (s)."""
        return self.t0 + np.arange(self.n_samples) / self.sample_rate_hz

    @property
    def revolutions(self) -> float:
        return self.duration * self.speed_hz

    def xy(self) -> np.ndarray:
        """(2, 2, n) shaft displacement along X and Y (SPEC §1 axes), from the probe readings.

        Each probe at angle a from +X reads s = x cos a + y sin a; the 2x2 system of a plane is
        solved exactly (for the default probes at 0° and 90° the result equals `displacement`).
        """
        return np.stack([self._plane_xy(k) for k in range(2)])

    def complex_signal(self, plane: int) -> np.ndarray:
        """Z = V + iW = x + iy (Eq. 10) of plane 0 or 1 (node `nodes[plane]`)."""
        if plane not in (0, 1) or isinstance(plane, bool):
            raise InputError(f"plane must be 0 or 1 (index into nodes {self.nodes}), not {plane!r}")
        x, y = self._plane_xy(plane)
        return x + 1j * y

    def _plane_xy(self, k: int) -> np.ndarray:
        (ca, sa), (cb, sb) = (_cos_sin_deg(a) for a in self.probe_angles_deg[k])
        det = ca * sb - sa * cb  # = sin(b - a); bounded away from 0 by construction
        s_a, s_b = self.displacement[k]
        return np.stack([(sb * s_a - sa * s_b) / det, (ca * s_b - cb * s_a) / det])

    # -- identity and display ----------------------------------------------------------------
    def __eq__(self, other):
        """Same measurement: every field equal (arrays exactly), whatever file it came from."""
        if not isinstance(other, Record):
            return NotImplemented
        return ((self.speed_hz, self.sample_rate_hz, self.nodes, self.probe_angles_deg, self.t0,
                 self.machine, dict(self.metadata))
                == (other.speed_hz, other.sample_rate_hz, other.nodes, other.probe_angles_deg,
                    other.t0, other.machine, dict(other.metadata))
                and np.array_equal(self.displacement, other.displacement)
                and (self.keyphasor is None) == (other.keyphasor is None)
                and (self.keyphasor is None or np.array_equal(self.keyphasor, other.keyphasor)))

    __hash__ = None

    def __repr__(self):
        return (f"Record(speed_hz={self.speed_hz!r}, sample_rate_hz={self.sample_rate_hz!r},"
                f" n_samples={self.n_samples}, nodes={self.nodes}, probe_angles_deg="
                f"{self.probe_angles_deg}, machine={self.machine!r}, source={self.source!r})")


def check_speed(record: Record, machine_speed_hz: float, tolerance: float = 0.2) -> None:
    """Refuse a record whose speed is more than `tolerance` (relative) away from the model's speed."""
    if not (machine_speed_hz > 0 and math.isfinite(machine_speed_hz)):
        raise InputError(f"machine_speed_hz must be a positive finite speed, not {machine_speed_hz!r}")
    if not (tolerance >= 0 and math.isfinite(tolerance)):
        raise InputError(f"tolerance must be a non-negative fraction, not {tolerance!r}")
    off = abs(record.speed_hz - machine_speed_hz) / machine_speed_hz
    if off > tolerance:
        raise _fail(record.source or "record", "speed_hz",
                    f"{record.speed_hz:g} Hz is {100 * off:.3g} % away from the model's speed"
                    f" {machine_speed_hz:g} Hz", f"within {100 * tolerance:g} % of it")


def record_from_arrays(x1, y1, x2, y2, *, speed_hz: float, sample_rate_hz: float | None = None,
                       t=None, units: str = "m", nodes=DEFAULT_NODES,
                       probe_angles_deg=DEFAULT_PROBE_ANGLES_DEG, t0: float | None = None,
                       machine: str | None = None, keyphasor=None,
                       metadata: Mapping[str, str] | None = None,
                       source: str | None = None) -> Record:
    """A `Record` from probe readings in `units`, validated exactly as a file would be.

    Give `sample_rate_hz` or a time array `t` (or both, then they must agree); `t0` (s) only
    without `t`.
    """
    where = str(source) if source is not None else "record"
    if np.ndim(nodes) != 1 or len(nodes) != 2:
        raise _fail(where, "nodes", f"{nodes!r}", "two node numbers (node1, node2)")
    columns = {"x1": x1, "y1": y1, "x2": x2, "y2": y2, "t": t, "keyphasor": keyphasor}
    meta = {"speed_hz": speed_hz, "sample_rate_hz": sample_rate_hz, "units": units,
            "node1": nodes[0], "node2": nodes[1], "probe_angles_deg": probe_angles_deg,
            "machine": machine, "t0_s": t0}
    columns = {k: _column(v, where, k) for k, v in columns.items() if v is not None}
    meta = {k: v for k, v in meta.items() if v is not None}
    return _assemble(columns, meta, dict(metadata or {}), _Origin(where), DEFAULT_NODES)


# ---------------------------------------------------------------------------------------------
# Reading and writing
# ---------------------------------------------------------------------------------------------

def read_record(path, *, default_nodes=DEFAULT_NODES) -> Record:
    """Read a `.csv`, `.npz` or `.mat` record (SPEC §6); `default_nodes` when the file names none."""
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
    if size > MAX_RECORD_BYTES:
        raise _fail(where, "file", f"{size / 1e6:.1f} MB is larger than the limit",
                    f"at most {MAX_RECORD_BYTES / 1e6:g} MB (lubeviz.signals.records.MAX_RECORD_BYTES)")
    if size == 0:
        raise _fail(where, "file", "is empty", f"a {suffix} record")
    reader = {".csv": _read_csv, ".npz": _read_npz, ".mat": _read_mat}[suffix]
    columns, meta, extra, origin = reader(path, where)
    return _assemble(columns, meta, extra, origin, default_nodes)


def read_record_bytes(content, filename: str, *, default_nodes=DEFAULT_NODES) -> Record:
    """Read a record uploaded as bytes (or text) under its original `filename` (its suffix gives the format).

    Messages name `filename`, not the temporary file the bytes pass through. The size limit is checked
    before anything is written.
    """
    import tempfile

    name = Path(str(filename)).name or "upload"
    data = content.encode("utf-8") if isinstance(content, str) else bytes(content or b"")
    if len(data) > MAX_RECORD_BYTES:
        raise _fail(name, "file", f"{len(data) / 1e6:.1f} MB is larger than the limit",
                    f"at most {MAX_RECORD_BYTES / 1e6:g} MB (lubeviz.signals.records.MAX_RECORD_BYTES)")
    _suffix(Path(name))
    with tempfile.TemporaryDirectory(prefix="lubeviz-upload-") as tmp:
        path = Path(tmp) / name
        path.write_bytes(data)
        try:
            rec = read_record(path, default_nodes=default_nodes)
        except DataFormatError as exc:
            raise DataFormatError(str(exc).replace(str(path), name)) from None
    return dataclasses.replace(rec, source=name)


def write_record(record: Record, path, *, units: str = "m") -> Path:
    """Write `record` as `.csv`, `.npz` or `.mat`. In metres (the default) it reads back equal."""
    path = Path(path)
    where = str(path)
    suffix = _suffix(path)
    try:
        scale = length_factor(units)
    except ValueError as exc:
        raise _fail(where, "units", str(exc)) from None
    columns = {"t": record.t}
    for k, a in np.ndindex(2, 2):
        reading = record.displacement[k, a]
        columns[CHANNELS[2 * k + a]] = reading if scale == 1.0 else reading / scale
    if record.keyphasor is not None:
        columns["keyphasor"] = record.keyphasor
    meta = {"speed_hz": record.speed_hz, "sample_rate_hz": record.sample_rate_hz,
            "units": units.strip().lower(), "node1": record.nodes[0], "node2": record.nodes[1]}
    if record.probe_angles_deg != DEFAULT_PROBE_ANGLES_DEG:
        meta["probe_angles_deg"] = record.probe_angles_deg
    if record.machine is not None:
        meta["machine"] = record.machine
    try:
        if suffix == ".csv":
            _write_csv(path, columns, meta, record.metadata)
        else:
            arrays = {**columns, **meta, **record.metadata}
            arrays["probe_angles_deg"] = np.array(record.probe_angles_deg)
            arrays["node1"], arrays["node2"] = (np.int64(v) for v in record.nodes)
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


def _suffix(path: Path) -> str:
    suffix = path.suffix.lower()
    if suffix not in FORMATS:
        raise _fail(str(path), "suffix", f"{path.suffix or '(none)'!r} is not a record format",
                    f"one of {', '.join(FORMATS)}")
    return suffix


@dataclass(frozen=True)
class _Origin:
    """Where samples came from, to name them in messages: file lines (CSV) or array indices."""

    where: str
    lines: np.ndarray | None = None  # CSV: the file line number of each data row
    names: tuple[str, ...] = ()  # the column / variable names the file holds, for messages

    def at(self, name: str, i: int) -> str:
        return f"column {name!r}, line {self.lines[i]}" if self.lines is not None \
            else f"{name!r}, index {i}"


def _assemble(columns: dict, meta: dict, extra: dict, origin: _Origin, default_nodes) -> Record:
    """The format-independent part: required fields, finiteness, time axis, units; then `Record`."""
    where = origin.where
    for name in CHANNELS:
        if name not in columns:
            found = ", ".join(repr(c) for c in origin.names or columns) or "none"
            raise _fail(where, name, "missing column", f"columns x1, y1, x2, y2 (found: {found})")
    lengths = {name: len(col) for name, col in columns.items()}
    if len(set(lengths.values())) > 1:
        raise _fail(where, "columns", f"different lengths {lengths}", "the same number of samples")
    for name, col in columns.items():
        bad = np.flatnonzero(~np.isfinite(col))
        if bad.size:
            raise _fail(where, origin.at(name, int(bad[0])), f"{col[bad[0]]} is not finite",
                        "a finite number")
    for key, expected in (("speed_hz", "the shaft speed in rev/s (CSV: '# speed_hz: 75')"),
                          ("units", "m, mm, um or mils (CSV: '# units: um')")):
        if key not in meta:
            raise _fail(where, key, "missing metadata", expected)
    speed = _positive(meta["speed_hz"], where, "speed_hz", "the shaft speed in rev/s")
    units = _text(meta["units"], where, "units", "m, mm, um or mils")
    try:
        scale = length_factor(units)
    except ValueError as exc:
        raise _fail(where, "units", str(exc)) from None

    rate = meta.get("sample_rate_hz")
    if rate is not None:
        rate = _positive(rate, where, "sample_rate_hz", "samples per second")
    t0 = _finite(meta["t0_s"], where, "t0_s", "seconds") if "t0_s" in meta else None
    if "t" in columns:
        rate, t_first = _time_axis(columns["t"], rate, origin)
        if t0 is not None and t0 != t_first:
            raise _fail(where, "t0_s", f"{t0!r} disagrees with the first time {t_first!r}",
                        "no t0_s, or the same value as t")
        t0 = t_first
    elif rate is None:
        raise _fail(where, "sample_rate_hz", "missing metadata",
                    "samples per second (CSV: '# sample_rate_hz: 10000') or a 't' column")

    nodes = tuple(_node(meta[f"node{k + 1}"], where, f"node{k + 1}") if f"node{k + 1}" in meta
                  else default_nodes[k] for k in range(2))
    angles = meta.get("probe_angles_deg", DEFAULT_PROBE_ANGLES_DEG)
    displacement = np.stack([columns[c] for c in CHANNELS]).reshape(2, 2, -1)
    if scale != 1.0:
        displacement = displacement * scale
    return Record(speed_hz=speed, sample_rate_hz=rate, displacement=displacement, nodes=nodes,
                  probe_angles_deg=angles, t0=0.0 if t0 is None else t0,
                  machine=meta.get("machine"), keyphasor=columns.get("keyphasor"),
                  metadata=extra, source=where)


def _time_axis(t: np.ndarray, rate: float | None, origin: _Origin) -> tuple[float, float]:
    """Sample rate and start of a strictly increasing, uniform time column (s)."""
    where = origin.where
    if t.size < 2:
        raise _fail(where, "t", f"too few samples ({t.size})", f"at least {MIN_SAMPLES}")
    steps = np.diff(t)
    bad = np.flatnonzero(steps <= 0)
    if bad.size:
        i = int(bad[0]) + 1
        raise _fail(where, origin.at("t", i),
                    f"non-monotonic time: t = {float(t[i])!r} after {float(t[i - 1])!r}",
                    "strictly increasing time")
    typical = np.median(steps)  # robust to the one gap or jump we want to point at
    bad = np.flatnonzero(np.abs(steps - typical) > TIME_RTOL * typical)
    if bad.size:
        i = int(bad[0]) + 1
        raise _fail(where, origin.at("t", i),
                    f"non-uniform sampling: step {float(steps[i - 1])!r} s, typical step"
                    f" {float(typical)!r} s", f"uniform steps (relative tolerance {TIME_RTOL:g})")
    dt = float(t[-1] - t[0]) / (t.size - 1)
    if rate is None:
        return 1.0 / dt, float(t[0])
    if abs(dt * rate - 1.0) > TIME_RTOL:
        raise _fail(where, "t", f"time step {dt!r} s disagrees with sample_rate_hz {rate!r}",
                    f"a step of 1/sample_rate_hz = {1.0 / rate!r} s")
    return rate, float(t[0])


# -- CSV ----------------------------------------------------------------------------------------

def _read_csv(path: Path, where: str):
    try:
        text = path.read_bytes().decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise _fail(where, "file", f"is not UTF-8 text (byte {exc.start})", "a CSV text file") from None
    except OSError as exc:
        raise _fail(where, "file", f"cannot be read ({exc.strerror or exc})") from None
    lines = text.splitlines()
    meta, extra, seen = {}, {}, {}
    i = 0
    while i < len(lines):
        s = lines[i].strip()
        if s and not s.startswith("#"):
            break
        body = s[1:].strip()
        if ":" in body:  # '# key: value'; a comment line without a colon is a free comment
            key, value = (p.strip() for p in body.split(":", 1))
            low = key.lower()
            if low in seen:
                raise _fail(where, f"metadata {key!r}", f"given twice (lines {seen[low]} and {i + 1})",
                            "each key once")
            seen[low] = i + 1
            if low in META_KEYS:
                meta[low] = value
            elif low in COLUMNS:
                raise _fail(where, f"metadata {key!r}, line {i + 1}", "is a column name",
                            f"'{low}' as a column, not as metadata")
            elif key:
                extra[key] = value
        i += 1
    if i == len(lines):
        raise _fail(where, "header", "no header row and no data", "a header row such as 't,x1,y1,x2,y2'")
    header_line = i + 1
    header = lines[i]
    delimiter = next((d for d in (",", ";", "\t") if d in header), None)
    names = [c.strip().strip("\"'").strip().lower() for c in header.split(delimiter)]
    if all(_is_number(c) for c in names):
        raise _fail(where, f"header, line {header_line}", "holds numbers, not column names",
                    "a header row such as 't,x1,y1,x2,y2' before the data (not commented out)")
    positions = {}
    for j, name in enumerate(names):
        if name in COLUMNS:
            if name in positions:
                raise _fail(where, f"column {name!r}", "appears twice in the header", "each column once")
            positions[name] = j

    body = lines[i + 1:]
    line_numbers = np.arange(header_line + 1, header_line + 1 + len(body))
    stripped = [line.strip() for line in body]
    if not all(stripped):  # blank lines carry no sample: drop them, keep the line numbers right
        keep = [k for k, s in enumerate(stripped) if s]
        body, stripped, line_numbers = [body[k] for k in keep], [stripped[k] for k in keep], \
            line_numbers[keep]
    if not body:
        raise _fail(where, "data", f"no data rows after the header (line {header_line})",
                    f"at least {MIN_SAMPLES} rows of numbers")
    comments = [k for k, s in enumerate(stripped) if s[0] == "#"]
    if comments:
        raise _fail(where, f"line {line_numbers[comments[0]]}", "comment after the header",
                    "metadata comments only before the header row")
    widths = np.array([len(line.split()) for line in body] if delimiter is None
                      else [line.count(delimiter) + 1 for line in body])
    bad = np.flatnonzero(widths != len(names))
    if bad.size:
        k = int(bad[0])
        raise _fail(where, f"line {line_numbers[k]}", f"ragged row: {widths[k]} cells",
                    f"{len(names)} cells, as in the header (line {header_line})")

    columns = {}
    if positions:
        try:  # fast path: numpy's C parser on the columns we use
            table = np.loadtxt(body, delimiter=delimiter, usecols=list(positions.values()),
                               comments=None, ndmin=2, dtype=np.float64)
        except ValueError:  # slow path, only to name the first bad cell
            rows = [line.split(delimiter) for line in body]
            table = np.array([[_cell(r[j], where, name, n) for name, j in positions.items()]
                              for r, n in zip(rows, line_numbers)])
        columns = dict(zip(positions, table.T))
    return columns, meta, extra, _Origin(where, line_numbers, tuple(n for n in names if n))


def _write_csv(path: Path, columns: dict, meta: dict, extra: Mapping[str, str]) -> None:
    head = []
    for key, value in {**meta, **extra}.items():
        if key == "probe_angles_deg":
            flat = value[0] if value[0] == value[1] else (*value[0], *value[1])
            value = ", ".join(repr(float(a)) for a in flat)
        elif isinstance(value, float):
            value = repr(value)
        head.append(f"# {key}: {value}")
    head.append(",".join(columns))
    table = np.column_stack(list(columns.values())).tolist()
    body = [",".join(map(repr, row)) for row in table]
    with open(path, "w", encoding="utf-8", newline="\n") as f:
        f.write("\n".join(head + body) + "\n")


def _cell(cell: str, where: str, name: str, line: int) -> float:
    try:
        return float(cell)
    except ValueError:
        problem = "empty cell" if not cell.strip() else f"{cell.strip()!r} is not a number"
        raise _fail(where, f"column {name!r}, line {line}", problem, "a number") from None


def _write_npz(path: Path, arrays: dict) -> None:
    """np.savez without its keyword arguments (a metadata key 'file' must not collide)."""
    with zipfile.ZipFile(path, "w", zipfile.ZIP_STORED, allowZip64=True) as archive:
        for key, value in arrays.items():
            with archive.open(key + ".npy", "w", force_zip64=True) as f:
                np.lib.format.write_array(f, np.asanyarray(value), allow_pickle=False)


def _is_number(cell: str) -> bool:
    try:
        float(cell)
    except ValueError:
        return False
    return True


# -- NumPy .npz and MATLAB .mat ----------------------------------------------------------------

def _read_npz(path: Path, where: str):
    entries = {}
    try:
        archive = np.load(path, allow_pickle=False)
        if not isinstance(archive, np.lib.npyio.NpzFile):  # a .npy file named .npz
            raise _fail(where, "file", "holds a single array", "an .npz archive of named arrays")
        with archive:
            for key in archive.files:
                try:
                    entries[key] = archive[key]
                except ValueError:
                    raise _fail(where, repr(key), "holds Python objects (pickled data)",
                                "numbers or text") from None
    except (ValueError, OSError, EOFError, zipfile.BadZipFile, zlib.error) as exc:
        if isinstance(exc, DataFormatError):
            raise
        raise _fail(where, "file", f"is not a readable .npz archive ({exc})") from None
    return _split_entries(entries, where)


def _read_mat(path: Path, where: str):
    try:
        entries = scipy.io.loadmat(path, squeeze_me=True, chars_as_strings=True)
    except NotImplementedError:
        raise _fail(where, "file", "is a MATLAB v7.3 (HDF5) file",
                    "a v5/v7 MAT-file (save(..., '-v7'))") from None
    except (MatReadError, ValueError, TypeError, OSError, EOFError, IndexError, KeyError,
            zlib.error) as exc:
        raise _fail(where, "file", f"is not a readable MAT-file ({exc})") from None
    return _split_entries({k: v for k, v in entries.items() if not k.startswith("__")}, where)


def _split_entries(entries: dict, where: str):
    """Sort named arrays into columns, known metadata and other (string) metadata."""
    columns, meta, extra, seen = {}, {}, {}, {}
    for key, value in entries.items():
        low = key.lower()
        if low in seen:
            raise _fail(where, repr(key), f"clashes with {seen[low]!r} (names are case-insensitive)",
                        "each name once")
        seen[low] = key
        if low in COLUMNS:
            columns[low] = _column(value, where, low)
        elif low in META_KEYS:
            meta[low] = value
        else:
            v = np.asarray(value)
            if v.dtype.kind == "U" and v.size <= 1:
                extra[key] = str(v.reshape(-1)[0]) if v.size else ""
            elif v.dtype.kind in "biuf" and v.size == 1:
                extra[key] = str(v.reshape(-1)[0].item())
            # other arrays: not part of the record format, ignored like unknown CSV columns
    return columns, meta, extra, _Origin(where, names=tuple(entries))


def _column(value, where: str, name: str) -> np.ndarray:
    """A 1-D float array of samples (1 x N and N x 1 accepted)."""
    a = np.asarray(value)
    if a.dtype.kind not in "iuf":
        raise _fail(where, name, f"holds {a.dtype} values", "real numbers")
    a = np.squeeze(a)
    if a.ndim != 1:
        raise _fail(where, name, f"shape {np.shape(value)}", "a vector of samples")
    return a.astype(np.float64)


# -- field coercion (strings from CSV, numbers or 0-d arrays from .npz/.mat or the API) -------

def _scalar(value, where: str, name: str):
    if isinstance(value, np.ndarray):
        if value.size != 1:
            raise _fail(where, name, f"array of shape {value.shape}", "a single value")
        value = value.reshape(-1)[0]
    return value.item() if isinstance(value, np.generic) else value


def _finite(value, where: str, name: str, expected: str) -> float:
    v = _scalar(value, where, name)
    if isinstance(v, bool) or not isinstance(v, (numbers.Real, str)):
        raise _fail(where, name, f"{v!r} is not a number", expected)
    try:
        x = float(v)
    except ValueError:
        raise _fail(where, name, f"{v!r} is not a number", expected) from None
    if not math.isfinite(x):
        raise _fail(where, name, f"{v!r} is not finite", expected)
    return x


def _positive(value, where: str, name: str, expected: str) -> float:
    x = _finite(value, where, name, f"a positive number: {expected}")
    if x <= 0:
        raise _fail(where, name, f"{x!r} is not positive", f"a positive number: {expected}")
    return x


def _node(value, where: str, name: str) -> int:
    v = _scalar(value, where, name)
    if isinstance(v, str):
        try:
            v = int(v.strip())
        except ValueError:
            raise _fail(where, name, f"{v!r} is not a whole number", "a positive node number") from None
    if isinstance(v, float) and v.is_integer():
        v = int(v)
    if isinstance(v, bool) or not isinstance(v, numbers.Integral) or v < 1:
        raise _fail(where, name, f"{v!r} is not a positive integer", "a model node number (1, 2, ...)")
    return int(v)


def _text(value, where: str, name: str, expected: str) -> str:
    v = value
    if isinstance(v, np.ndarray) and v.dtype.kind == "U" and v.size <= 1:
        v = str(v.reshape(-1)[0]) if v.size else ""
    if not isinstance(v, str):
        raise _fail(where, name, f"{v!r} is not text", expected)
    v = v.strip()
    if not v or v.splitlines() != [v]:
        raise _fail(where, name, f"{v!r} is empty or spans lines", expected)
    return v


def _probe_angles(value, where: str) -> tuple[tuple[float, float], tuple[float, float]]:
    name = "probe_angles_deg"
    expected = "2 angles (both planes) or 4 (plane 1 a, b, plane 2 a, b) in degrees from +X"
    if isinstance(value, np.ndarray) and value.dtype.kind == "U" and value.size == 1:
        value = str(value.reshape(-1)[0])
    if isinstance(value, str):
        cells = [c for c in re.split(r"[,;\s]+", value.strip().strip("[]()")) if c]
        flat = [_finite(c, where, name, expected) for c in cells]
    else:
        try:
            a = np.asarray(value, dtype=np.float64).reshape(-1)
        except (TypeError, ValueError):
            raise _fail(where, name, f"{value!r} is not a list of numbers", expected) from None
        flat = [_finite(x, where, name, expected) for x in a]
    if len(flat) == 2:
        flat = flat * 2
    if len(flat) != 4:
        raise _fail(where, name, f"wrong probe-angle count: {len(flat)} values", expected)
    pairs = ((flat[0], flat[1]), (flat[2], flat[3]))
    for k, (a, b) in enumerate(pairs):
        separation = abs(math.remainder(b - a, 180.0))  # distance to the nearest parallel pair
        if separation < MIN_PROBE_SEPARATION_DEG:
            raise _fail(where, f"{name} (plane {k + 1})",
                        f"probes at {a:g}° and {b:g}° are {separation:.3g}° from parallel,"
                        " too ill-conditioned to resolve X and Y",
                        f"probes at least {MIN_PROBE_SEPARATION_DEG:g}° from parallel (ideally 90° apart)")
    return pairs


def _metadata(value, where: str) -> Mapping[str, str]:
    if not isinstance(value, Mapping):
        raise _fail(where, "metadata", f"{type(value).__name__}", "a mapping of text keys to text")
    out, seen = {}, set()
    for key, v in value.items():
        k = key.strip() if isinstance(key, str) else None
        if not k or ":" in k or k.splitlines() != [k]:
            raise _fail(where, f"metadata key {key!r}", "is not one line of text without ':'",
                        "a key usable as '# key: value'")
        if k.lower() in RESERVED or k.lower() in seen:
            raise _fail(where, f"metadata key {k!r}", "is a record field or given twice",
                        f"a key other than {', '.join(sorted(RESERVED))}")
        seen.add(k.lower())
        if not isinstance(v, str):
            raise _fail(where, f"metadata {k!r}", f"{v!r} is not text", "a string value")
        v = v.strip()
        if v and v.splitlines() != [v]:
            raise _fail(where, f"metadata {k!r}", "spans several lines", "a one-line value")
        out[k] = v
    return MappingProxyType(out)


def _numeric_array(value, where: str, name: str) -> np.ndarray:
    a = np.asarray(value)
    if a.dtype.kind not in "iuf":
        raise _fail(where, name, f"holds {a.dtype} values", "real numbers")
    return a


def _frozen_copy(a: np.ndarray) -> np.ndarray:
    out = np.array(a, dtype=np.float64, copy=True)
    out.flags.writeable = False
    return out


def _cos_sin_deg(angle: float) -> tuple[float, float]:
    """cos and sin of an angle in degrees, exact at multiples of 90° (so default probes are exact)."""
    quarter = angle / 90.0
    if quarter.is_integer():
        return ((1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0))[int(quarter) % 4]
    r = math.radians(angle)
    return math.cos(r), math.sin(r)
