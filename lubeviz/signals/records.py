"""Measured vibration records: one steady speed, two measurement planes (SPEC §6).

A `Record` holds what two pairs of proximity probes measured at one shaft speed, in metres, with the
sampling, the model nodes of the planes and the probe directions. It is validated when it is built,
so a `Record` that exists is usable: finite samples, uniform sampling, at least `MIN_REVOLUTIONS`
revolutions, the 1X line below the Nyquist frequency, well-conditioned probe pairs.

Files (`read_record` / `write_record`), the same fields in three formats:

- CSV: leading comment lines `# key: value` (metadata), then a header row and numeric rows.
  Metadata: `speed_hz` (required), `sample_rate_hz` (required unless there is a `t` column),
  `units` (required: m, mm, um or mils, via `lubeviz.units`), optional `node1`, `node2`,
  `probe_angles_deg` ("45, 135" for both planes or "45, 135, 30, 120" plane by plane), `machine`
  (a plain model file name: no folder, no `..`, `NAME` or `NAME.toml`), `t0_s` (time of the first
  sample when there is no `t` column), `set` (records of one machine taken together), `static` and
  `rest_position` (below), `oil_temperature_c` (the oil temperature read on the machine, °C, an
  extension of SPEC §6: with an `[oil]` in the model file it fixes the film's viscosity). Comment lines without a colon are free comments and are skipped.
  Columns, matched by name (case-insensitive, any order): `t` (optional), `x1`, `y1`, `x2`, `y2`
  (probe readings of planes 1 and 2 in `units`), `keyphasor` (optional, stored unscaled).
  Delimiter: comma (or semicolon, tab, whitespace, as the header uses).
- `.npz` / `.mat`: variables with the same names; metadata as scalars or strings, the probe angles
  and rest readings as arrays of 2 or 4 numbers (a 2x2 array is read plane by plane, i.e. row by
  row). MATLAB v7.3 (HDF5) files are not read: save with `-v7`. A v5/v7 MAT-file is walked
  element by element before scipy reads it (`_check_mat5`: scipy's reader crashes the process on
  some corrupt files); sparse, object and function-handle variables are skipped with a warning.

Unknown names are never used and never silent. A metadata key that is not a record field is kept
as text in `Record.metadata` and adds a line to `Record.warnings`, naming the closest known key
("unknown key 'node_1' ignored; did you mean 'node1'?"), because a misspelled optional key would
otherwise leave the default in force unnoticed. Without a warning are kept: the informational keys
`lubeviz simulate` writes (`INFO_KEYS`: q1_mlmin, q2_mlmin, snr_db, synthetic, seed, effects,
method, static_shift_um, ratio_2x, stability, whirl_hz, whirl_growth_per_s, orbit_stability,
orbit_stability_state; any `truth_...`) and free
text under `note`, `notes`, `comment`, `description`, `operator`,
`date` or any key starting with `x_` (`x_rig: B`). Columns (CSV) and arrays (.npz/.mat) with other
names are ignored, with a warning unless they start with `x_`; a `# node1 5` comment line that
looks like a known key missing its colon also warns.

Static shaft position (SPEC §6). `# static: absolute` says the columns keep the probes' DC gap and
`# rest_position: X1, Y1, X2, Y2` (record units, along the probe directions like the columns) gives
each probe's reading with the machine at rest, journal at the bottom of its bearing. Both or
neither. The record then carries `static_offset` = mean reading - rest reading, resolved to X and
Y, and its standard error `static_offset_std` (see `_channel_means` for the estimator);
`journal_static_position` adds (0, -c) per plane and checks that the journal lies within its
clearance. Without them the mean of each channel is ignored, as the 1X features always do.

Sets (SPEC §6): `# set: NAME` -> `Record.set_name`; `read_set` reads the records of one set (sorted
by speed, checked by `check_set` to agree on set, machine, nodes and probes, one record per speed),
`group_records` groups records already read by their set.

Physical plausibility is checked when a record is built: a channel that does not move (peak-to-peak
below `MIN_VIBRATION_PTP`) is a dead probe, a peak-to-peak above `MAX_VIBRATION_PTP` (5 mm) is no
shaft vibration but almost always a wrong `units` field; node1 = node2 is refused.

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
import difflib
import io
import math
import numbers
import re
import struct
import zipfile
import zlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType

import numpy as np
import scipy.io
from scipy.io.matlab import MatReadError

from ..errors import DataFormatError, InputError
from ..model.machine import model_name_problem
from ..units import length_factor
from .speed_check import check_speed_label

MAX_RECORD_BYTES = 200_000_000  # files above this are refused before reading (read at call time)
MIN_REVOLUTIONS = 10.0  # the 1X DFT needs several whole revolutions to separate 1X from noise
MIN_SAMPLES = 16
MIN_PROBE_SEPARATION_DEG = 10.0  # two probes closer than this (mod 180°) cannot resolve X and Y
TIME_RTOL = 1e-6  # allowed relative deviation of each time step from the mean step
TIME_PRECISION = 1e-3  # a 't' column whose float64 spacing exceeds this fraction of a step cannot hold the times
MIN_VIBRATION_PTP = 1e-12  # m; a channel moving less than this (1 pm, far below any probe) is dead
MAX_VIBRATION_PTP = 5e-3  # m; no journal-bearing shaft vibrates 5 mm peak-to-peak: wrong units
MIN_BATCHES = 10  # batch means for a mean's standard error: at least this many batches
SET_SPEED_RTOL = 1e-3  # two records of one set closer than this in speed are the same speed
STATIC_TOLERANCE = 0.05  # fraction of c a static position may lie beyond the clearance circle
DEFAULT_NODES = (6, 20)  # the paper machine's bearing centres
DEFAULT_PROBE_ANGLES_DEG = ((0.0, 90.0), (0.0, 90.0))  # probe a along +X, probe b along +Y
FORMATS = (".csv", ".npz", ".mat")

CHANNELS = ("x1", "y1", "x2", "y2")  # file names of displacement[plane][probe], row-major
COLUMNS = ("t", *CHANNELS, "keyphasor")
META_KEYS = ("speed_hz", "sample_rate_hz", "units", "node1", "node2", "probe_angles_deg",
             "machine", "t0_s", "set", "static", "rest_position", "oil_temperature_c")
OIL_TEMPERATURE_RANGE_C = (-20.0, 150.0)
RESERVED = frozenset(COLUMNS + META_KEYS)
# Informational keys `lubeviz simulate` writes, and free-text keys: kept without a warning.
INFO_KEYS = ("q1_mlmin", "q2_mlmin", "snr_db", "synthetic", "seed", "effects", "method", "static_shift_um", "ratio_2x",
             "stability", "whirl_hz", "whirl_growth_per_s", "orbit_stability", "orbit_stability_state")
FREE_TEXT_KEYS = ("note", "notes", "comment", "description", "operator", "date")
FREE_PREFIXES = ("x_", "truth_")  # `x_anything: ...` is the user's own; `truth_*` the simulator's
STATIC_ABSOLUTE = "absolute"
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
    machine: str | None = None  # model file name under models/ (a plain name, no folder)
    keyphasor: np.ndarray | None = None  # (n_samples,), as recorded (not scaled)
    metadata: Mapping[str, str] = field(default_factory=dict)  # other `key: value` pairs, read-only
    source: str | None = None  # the file it came from, for messages
    # `static: absolute`: (2 planes, 2 probes) probe readings at rest (journal at the bottom of its
    # bearing), metres, along the probe directions; the displacement then keeps the DC gap. None:
    # the mean of each channel means nothing.
    rest_position: np.ndarray | None = None
    set_name: str | None = None  # `set: NAME`, records of one machine taken together
    # `oil_temperature_c`: the oil temperature read on the machine (°C; an extension of SPEC §6). With an
    # [oil] in the model file it settles the film's viscosity.
    oil_temperature_c: float | None = None
    warnings: tuple[str, ...] = ()  # what the reader ignored (unknown keys, columns), for the user
    units: str | None = None  # the units the file declared (m, mm, um, mils): named when amplitudes look off
    # Derived when built (never passed): mean reading - rest reading resolved to X, Y (2 planes, 2) in
    # metres, and its standard error; None without `rest_position`.
    static_offset: np.ndarray | None = field(default=None, init=False, repr=False)
    static_offset_std: np.ndarray | None = field(default=None, init=False, repr=False)

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
        put("displacement", d if _owned_frozen(d) else _frozen_copy(d))
        n = d.shape[2]
        if n < MIN_SAMPLES:
            raise _fail(where, "samples", f"too few samples ({n})", f"at least {MIN_SAMPLES}")
        _check_vibration(self.displacement, where)
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
        nodes = tuple(_node(v, where, f"node{k + 1}") for k, v in enumerate(nodes))
        if nodes[0] == nodes[1]:
            raise _fail(where, "node2", f"{nodes[1]} is the same node as node1",
                        "two different model nodes, one per measurement plane")
        put("nodes", nodes)
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
            put("machine", _machine_name(self.machine, where))
        if self.set_name is not None:
            put("set_name", _text(self.set_name, where, "set", "a set name on one line"))
        if self.oil_temperature_c is not None:
            t = _finite(self.oil_temperature_c, where, "oil_temperature_c", "the oil temperature in °C")
            lo, hi = OIL_TEMPERATURE_RANGE_C
            if not lo <= t <= hi:
                raise _fail(where, "oil_temperature_c", f"{t:g} °C is outside {lo:g}..{hi:g} °C",
                            "the oil temperature in °C (not K or °F)")
            put("oil_temperature_c", t)
        put("metadata", _metadata(self.metadata, where))
        put("warnings", _warnings(self.warnings, where))

        if self.rest_position is not None:
            rest = _frozen_copy(_rest_position(self.rest_position, where))
            put("rest_position", rest)
            mean, mean_std = _channel_means(self.displacement, self.speed_hz, self.sample_rate_hz)
            offset = np.stack([self._resolve(k, mean[k] - rest[k]) for k in range(2)])
            std = np.stack([self._resolve_std(k, mean_std[k]) for k in range(2)])
            for k, xy in enumerate(offset):
                big = np.flatnonzero(np.abs(xy) > MAX_VIBRATION_PTP)
                if big.size:
                    axis = "XY"[big[0]]
                    raise _fail(where, f"rest_position (plane {k + 1})",
                                f"static offset {axis} = mean reading - rest reading ="
                                f" {xy[big[0]] * 1e3:.4g} mm, more than any journal moves in its"
                                " bearing", f"at most {MAX_VIBRATION_PTP * 1e3:g} mm; check the"
                                " 'units' field and that rest_position is in the same units")
            put("static_offset", _frozen_copy(offset))
            put("static_offset_std", _frozen_copy(std))

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

    @property
    def is_static(self) -> bool:
        """True for `static: absolute` records (the readings keep the DC gap, `static_offset` is set)."""
        return self.rest_position is not None

    def xy(self) -> np.ndarray:
        """(2, 2, n) shaft displacement along X and Y (SPEC §1 axes), from the probe readings.

        Each probe at angle a from +X reads s = x cos a + y sin a; the 2x2 system of a plane is
        solved exactly (for the default probes at 0° and 90° the result equals `displacement`).
        A static record's readings keep their DC gap, so its `xy()` does too (the 1X features
        fit and drop the mean).
        """
        return np.stack([self._plane_xy(k) for k in range(2)])

    def complex_signal(self, plane: int) -> np.ndarray:
        """Z = V + iW = x + iy (Eq. 10) of plane 0 or 1 (node `nodes[plane]`)."""
        if plane not in (0, 1) or isinstance(plane, bool):
            raise InputError(f"plane must be 0 or 1 (index into nodes {self.nodes}), not {plane!r}")
        x, y = self._plane_xy(plane)
        return x + 1j * y

    def _plane_xy(self, k: int) -> np.ndarray:
        return self._resolve(k, self.displacement[k])

    def _resolve(self, k: int, readings) -> np.ndarray:
        """X, Y from the readings (s_a, s_b) of plane k's probes: s = x cos a + y sin a, solved."""
        (ca, sa), (cb, sb) = (_cos_sin_deg(a) for a in self.probe_angles_deg[k])
        det = ca * sb - sa * cb  # = sin(b - a); bounded away from 0 by construction
        s_a, s_b = readings
        return np.stack([(sb * s_a - sa * s_b) / det, (ca * s_b - cb * s_a) / det])

    def _resolve_std(self, k: int, std) -> np.ndarray:
        """Standard errors of `_resolve`'s X, Y for independent readings with standard errors `std`."""
        (ca, sa), (cb, sb) = (_cos_sin_deg(a) for a in self.probe_angles_deg[k])
        det = ca * sb - sa * cb
        var_a, var_b = np.square(std)
        return np.sqrt([(sb * sb * var_a + sa * sa * var_b), (cb * cb * var_a + ca * ca * var_b)]) / abs(det)

    # -- identity and display ----------------------------------------------------------------
    def __eq__(self, other):
        """Same measurement: every field equal (arrays exactly), whatever file it came from.

        `source` and `warnings` (where the record came from and what its file also held) do not count.
        """
        if not isinstance(other, Record):
            return NotImplemented

        def same(a, b):
            return (a is None) == (b is None) and (a is None or np.array_equal(a, b))

        return ((self.speed_hz, self.sample_rate_hz, self.nodes, self.probe_angles_deg, self.t0,
                 self.machine, self.set_name, self.oil_temperature_c, dict(self.metadata))
                == (other.speed_hz, other.sample_rate_hz, other.nodes, other.probe_angles_deg,
                    other.t0, other.machine, other.set_name, other.oil_temperature_c, dict(other.metadata))
                and np.array_equal(self.displacement, other.displacement)
                and same(self.keyphasor, other.keyphasor)
                and same(self.rest_position, other.rest_position))

    __hash__ = None

    def __repr__(self):
        return (f"Record(speed_hz={self.speed_hz!r}, sample_rate_hz={self.sample_rate_hz!r},"
                f" n_samples={self.n_samples}, nodes={self.nodes}, probe_angles_deg="
                f"{self.probe_angles_deg}, machine={self.machine!r}, set_name={self.set_name!r},"
                f" static={self.is_static}, warnings={len(self.warnings)}, source={self.source!r})")


def journal_static_position(record: Record, clearances, *,
                            tolerance: float = STATIC_TOLERANCE) -> np.ndarray:
    """(2 planes, 2) journal centre X, Y relative to its bearing centre, metres (SPEC §6).

    `static_offset` + (0, -c_k): at rest the journal lies at the bottom of its bearing, (0, -c).
    `clearances` are the true radial clearances c_k (m) of the bearings at the record's two planes
    (meaningful at a bearing's centre plane). A point farther from the centre than
    c_k (1 + `tolerance`) + 3 standard errors cannot be a journal inside its bearing: refused.
    """
    where = record.source or "record"
    if record.static_offset is None:
        raise _fail(where, "static", "the record has no static shaft position",
                    "'# static: absolute' with '# rest_position: X1, Y1, X2, Y2'")
    try:
        c = np.asarray(clearances, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise InputError(f"clearances {clearances!r}: expected two radial clearances in metres") from None
    if c.size != 2 or not np.all(np.isfinite(c)) or not np.all(c > 0):
        raise InputError(f"clearances {clearances!r}: expected two positive radial clearances in metres")
    if not (math.isfinite(tolerance) and tolerance >= 0):
        raise InputError(f"tolerance {tolerance!r}: expected a non-negative fraction of the clearance")
    position = record.static_offset + np.stack([np.zeros(2), -c], axis=1)
    for k in range(2):
        r = float(np.hypot(*position[k]))
        limit = c[k] * (1.0 + tolerance) + 3.0 * float(np.hypot(*record.static_offset_std[k]))
        if r > limit:
            raise _fail(where, f"static position, plane {k + 1} (node {record.nodes[k]})",
                        f"the journal would lie {r * 1e6:.4g} µm from the bearing centre, outside"
                        f" the clearance c = {c[k] * 1e6:.4g} µm (offset from rest"
                        f" X = {record.static_offset[k, 0] * 1e6:.4g} µm,"
                        f" Y = {record.static_offset[k, 1] * 1e6:.4g} µm)",
                        f"at most {limit * 1e6:.4g} µm (c + {100 * tolerance:g} % + 3 std); check"
                        " rest_position, units, probe_angles_deg and the nodes")
    return position


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
                       source: str | None = None, rest_position=None, static_offset=None,
                       set_name: str | None = None, oil_temperature_c: float | None = None) -> Record:
    """A `Record` from probe readings in `units`, validated exactly as a file would be.

    Give `sample_rate_hz` or a time array `t` (or both, then they must agree); `t0` (s) only
    without `t`. Record fields found in `metadata` (`set`, `static`, `rest_position`, ...) are read
    as a file's would be; one given both as an argument and in `metadata` is refused.

    Static shaft position (both in `units`, like the readings):
    - `rest_position` alone (4 numbers X1, Y1, X2, Y2 or 2x2, along the probe directions): the
      readings are absolute (they keep the DC gap), as in a `static: absolute` file.
    - `static_offset` (2 planes x (X, Y), the journal's displacement from its rest position): the
      readings are taken as the dynamic part; each channel's mean (as `Record` estimates it) is
      replaced by rest reading + the offset seen along that probe, so the record's `static_offset`
      equals the one given (to rounding). `rest_position` defaults to zero readings then.
    """
    where = str(source) if source is not None else "record"
    if np.ndim(nodes) != 1 or len(nodes) != 2:
        raise _fail(where, "nodes", f"{nodes!r}", "two node numbers (node1, node2)")
    columns = {"x1": x1, "y1": y1, "x2": x2, "y2": y2, "t": t, "keyphasor": keyphasor}
    meta = {"speed_hz": speed_hz, "sample_rate_hz": sample_rate_hz, "units": units,
            "node1": nodes[0], "node2": nodes[1], "probe_angles_deg": probe_angles_deg,
            "machine": machine, "t0_s": t0, "set": set_name, "rest_position": rest_position,
            "oil_temperature_c": oil_temperature_c,
            "static": None if rest_position is None else STATIC_ABSOLUTE}
    extra = {}
    for key, value in dict(metadata or {}).items():  # file fields given as metadata act as in a file
        low = key.lower() if isinstance(key, str) else None
        if low in META_KEYS:
            if meta[low] is not None:
                raise _fail(where, f"metadata {key!r}", "also given as an argument (or by its default)",
                            "each field once")
            meta[low] = value
        else:
            extra[key] = value
    if static_offset is not None and meta["rest_position"] is None:
        meta["rest_position"], meta["static"] = np.zeros((2, 2)), STATIC_ABSOLUTE
    columns = {k: _column(v, where, k) for k, v in columns.items() if v is not None}
    meta = {k: v for k, v in meta.items() if v is not None}
    if static_offset is not None:
        static_offset = _four_numbers(static_offset, where, "static_offset",
                                      "X1, Y1, X2, Y2 (2 planes x 2) in the record's units")
    return _assemble(columns, meta, extra, _Origin(where), DEFAULT_NODES, static_offset=static_offset)


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
    record = _assemble(columns, meta, extra, origin, default_nodes)
    del columns  # _assemble took the samples over
    # The declared speed against the spectrum's own 1X line (a wrong speed label or sample rate):
    # every record read for identification passes here (CLI, app uploads, sets).
    return check_speed_label(record)


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
    suffix = _suffix(Path(name))
    with tempfile.TemporaryDirectory(prefix="lubeviz-upload-") as tmp:
        path = Path(tmp) / ("upload" + suffix)  # the user's name may be longer than a file system allows
        path.write_bytes(data)
        try:
            rec = read_record(path, default_nodes=default_nodes)
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
    for k, a in np.ndindex(2, 2):
        reading = record.displacement[k, a]
        columns[CHANNELS[2 * k + a]] = reading if scale == 1.0 else reading / scale
    if record.keyphasor is not None:
        columns["keyphasor"] = record.keyphasor
    meta = {"speed_hz": record.speed_hz, "sample_rate_hz": record.sample_rate_hz,
            "units": units.strip().lower(), "node1": record.nodes[0], "node2": record.nodes[1]}
    if lossy_t:
        meta["t0_s"] = record.t0
    if record.probe_angles_deg != DEFAULT_PROBE_ANGLES_DEG:
        meta["probe_angles_deg"] = record.probe_angles_deg
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


# ---------------------------------------------------------------------------------------------
# Sets: records of one machine at several steady speeds (SPEC §6, `set: NAME`)
# ---------------------------------------------------------------------------------------------

def read_set(paths, *, default_nodes=DEFAULT_NODES) -> list[Record]:
    """The records of one `set:`, read and checked together (`check_set`), sorted by speed."""
    paths = [Path(p) for p in ([paths] if isinstance(paths, (str, Path)) else paths)]
    return check_set([read_record(p, default_nodes=default_nodes) for p in paths])


def check_set(records: Sequence[Record]) -> list[Record]:
    """Records of one set, sorted by speed; refused unless they can be identified together.

    A set needs at least two records, each naming the same `set:`, with the same machine, the same
    nodes and the same probe angles, and no two at the same speed (within `SET_SPEED_RTOL`).
    """
    records = list(records)
    names = ", ".join(_name(r) for r in records) or "no files"
    if len(records) < 2:
        raise DataFormatError(f"{names}: set: a set needs at least 2 records at different speeds;"
                              f" got {len(records)}")
    first = records[0]
    for r in records:
        if r.set_name is None:
            raise _fail(_name(r), "set", "no '# set: NAME' line, so it is not part of a set",
                        f"'# set: {first.set_name or 'NAME'}' in every record of the set")
    for label, get in (("set", lambda r: r.set_name), ("machine", lambda r: r.machine),
                       ("nodes (node1, node2)", lambda r: r.nodes),
                       ("probe_angles_deg", lambda r: r.probe_angles_deg)):
        for r in records[1:]:
            if get(r) != get(first):
                raise DataFormatError(
                    f"{_name(r)}: {label}: {get(r)!r} disagrees with {get(first)!r} in {_name(first)};"
                    f" expected the records of one set to share the set name, machine, nodes and"
                    f" probe angles (set {first.set_name!r}: {names})")
    ordered = sorted(records, key=lambda r: r.speed_hz)
    for a, b in zip(ordered, ordered[1:]):
        if b.speed_hz - a.speed_hz <= SET_SPEED_RTOL * b.speed_hz:
            raise DataFormatError(
                f"{_name(b)}: speed_hz: {b.speed_hz:g} Hz is the speed of {_name(a)}"
                f" ({a.speed_hz:g} Hz, within {100 * SET_SPEED_RTOL:g} %); expected one record per"
                f" speed in set {first.set_name!r}")
    return ordered


def group_records(records: Sequence[Record]) -> list[list[Record]]:
    """Records grouped by `set_name`, groups in order of first appearance, records in input order.

    A record without a set is a group of its own. Nothing is checked here: pass a group of several
    records to `check_set`.
    """
    groups: list[list[Record]] = []
    by_name: dict[str, list[Record]] = {}
    for r in records:
        if r.set_name is None:
            groups.append([r])
        elif r.set_name in by_name:
            by_name[r.set_name].append(r)
        else:
            by_name[r.set_name] = [r]
            groups.append(by_name[r.set_name])
    return groups


def _name(record: Record) -> str:
    return record.source or "record"


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
    notes: tuple[str, ...] = ()  # the reader's warnings (ignored columns, arrays, comment lines)

    def at(self, name: str, i: int) -> str:
        return f"column {name!r}, line {self.lines[i]}" if self.lines is not None \
            else f"{name!r}, index {i}"


def _assemble(columns: dict, meta: dict, extra: dict, origin: _Origin, default_nodes,
              static_offset: np.ndarray | None = None) -> Record:
    """The format-independent part: required fields, finiteness, time axis, units; then `Record`."""
    where = origin.where
    warnings = list(origin.notes) + [_unknown_key_warning(where, key) for key in extra
                                     if not _is_free_key(key)]
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
        rate, t_first = _time_axis(columns.pop("t"), rate, origin)
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
    rest = _static_fields(meta, where)
    # One (2, 2, n) array filled channel by channel; each column is let go once copied (peak memory of a
    # large record: the samples about once, not three times).
    displacement = np.empty((2, 2, lengths["x1"]))
    for j, c in enumerate(CHANNELS):
        displacement[j // 2, j % 2] = columns.pop(c)
    _check_vibration(displacement, where, units, scale=scale)
    if scale != 1.0:
        displacement *= scale
    displacement.flags.writeable = False  # handed to Record without a copy
    if rest is not None:
        rest = rest * scale
        if static_offset is not None:  # the readings were the dynamic part: give them this mean
            angles = _probe_angles(angles, where)
            probe_offset = np.array([[ca * x + sa * y for ca, sa in map(_cos_sin_deg, pair)]
                                     for pair, (x, y) in zip(angles, static_offset * scale)])
            mean, _ = _channel_means(displacement, speed, rate)
            displacement = displacement - mean[..., None] + (rest + probe_offset)[..., None]
    return Record(speed_hz=speed, sample_rate_hz=rate, displacement=displacement, nodes=nodes,
                  probe_angles_deg=angles, t0=0.0 if t0 is None else t0,
                  machine=meta.get("machine"), keyphasor=columns.get("keyphasor"),
                  metadata=extra, source=where, rest_position=rest, set_name=meta.get("set"),
                  oil_temperature_c=meta.get("oil_temperature_c"),  # checked by Record
                  warnings=tuple(warnings), units=units.strip().lower())


def _static_fields(meta: dict, where: str) -> np.ndarray | None:
    """The rest readings (2 planes, 2 probes, record units) of a `static: absolute` record, else None."""
    has_static, has_rest = "static" in meta, "rest_position" in meta
    if has_static:
        value = _text(meta["static"], where, "static", f"'{STATIC_ABSOLUTE}'")
        if value.lower() != STATIC_ABSOLUTE:
            raise _fail(where, "static", f"{value!r} is not a known static convention",
                        f"'{STATIC_ABSOLUTE}' (the columns keep the probes' DC gap), or no 'static'"
                        " key (the mean of each channel is then ignored)")
    if has_static and not has_rest:
        raise _fail(where, "rest_position", "missing metadata, although 'static: absolute' is given",
                    "'# rest_position: X1, Y1, X2, Y2', each probe's reading with the machine at rest")
    if has_rest and not has_static:
        raise _fail(where, "static", "missing metadata, although 'rest_position' is given",
                    "'# static: absolute' (the columns keep the probes' DC gap), or no rest_position")
    return _rest_position(meta["rest_position"], where) if has_rest else None


def _time_spacing(*times: float) -> float:
    """Distance between adjacent float64 numbers at the largest of `times` (s)."""
    return float(np.spacing(max(abs(t) for t in times)))


def _time_axis(t: np.ndarray, rate: float | None, origin: _Origin) -> tuple[float, float]:
    """Sample rate and start of a strictly increasing, uniform time column (s)."""
    where = origin.where
    if t.size < 2:
        raise _fail(where, "t", f"too few samples ({t.size})", f"at least {MIN_SAMPLES}")
    span = float(t[-1]) - float(t[0])
    if span > 0:  # times so large that float64 cannot tell one sample from the next
        step, spacing = span / (t.size - 1), _time_spacing(float(t[0]), float(t[-1]))
        if spacing > TIME_PRECISION * step:
            raise _fail(where, "t", f"times near {float(t[0]):.6g} s are held in float64 only to"
                        f" {spacing:.3g} s, too coarse for the sample step of {step:.3g} s",
                        "times counted from the record's start (or no 't' column: 'sample_rate_hz' and,"
                        " for the absolute start, '# t0_s: ...')")
    steps = np.diff(t)
    bad = np.flatnonzero(steps <= 0)
    if bad.size:
        i = int(bad[0]) + 1
        raise _fail(where, origin.at("t", i),
                    f"non-monotonic time: t = {float(t[i])!r} after {float(t[i - 1])!r}",
                    "strictly increasing time")
    typical = float(np.median(steps, overwrite_input=True))  # robust to the one gap or jump we point at
    steps = np.diff(t)  # (the median scrambled them) the deviations, in place: one temporary array
    steps -= typical
    np.abs(steps, out=steps)
    bad = np.flatnonzero(steps > TIME_RTOL * typical)
    del steps
    if bad.size:
        i = int(bad[0]) + 1
        raise _fail(where, origin.at("t", i),
                    f"non-uniform sampling: step {float(t[i] - t[i - 1])!r} s, typical step"
                    f" {float(typical)!r} s", f"uniform steps (relative tolerance {TIME_RTOL:g})")
    dt = float(t[-1] - t[0]) / (t.size - 1)
    if rate is None:
        return 1.0 / dt, float(t[0])
    if abs(dt * rate - 1.0) > TIME_RTOL:
        raise _fail(where, "t", f"time step {dt!r} s disagrees with sample_rate_hz {rate!r}",
                    f"a step of 1/sample_rate_hz = {1.0 / rate!r} s")
    return rate, float(t[0])


# -- CSV ----------------------------------------------------------------------------------------

_CSV_CHUNK_BYTES = 1 << 20  # bytes decoded at a time
_CSV_BATCH_ROWS = 1 << 14  # data rows parsed at a time


def _text_lines(path: Path, where: str):
    """The file's lines, as `str.splitlines` splits them (any line ending), decoded chunk by chunk.

    A partial last line of a chunk (or a CR that a LF may follow) waits for the next chunk, so the lines
    and their numbers are those of the whole text; a byte that is not UTF-8 is named by its file offset.
    """
    import codecs

    decoder = codecs.getincrementaldecoder("utf-8-sig")()
    carry, offset = "", 0
    try:
        with open(path, "rb") as f:
            while True:
                chunk = f.read(_CSV_CHUNK_BYTES)
                try:
                    text = decoder.decode(chunk, final=not chunk)
                except UnicodeDecodeError as exc:
                    raise _fail(where, "file", f"is not UTF-8 text (byte {offset + exc.start})",
                                "a CSV text file") from None
                offset += len(chunk)
                parts = (carry + text).splitlines()
                if not chunk:
                    yield from parts
                    return
                # the last part may be cut: keep it, with its line ending, for the next round
                keep = (carry + text).splitlines(keepends=True)
                carry = keep.pop() if keep else ""
                yield from parts[:len(keep)]
    except OSError as exc:
        raise _fail(where, "file", f"cannot be read ({exc.strerror or exc})") from None


def _read_csv(path: Path, where: str):
    """Metadata and header line by line, then the data in batches of rows parsed by numpy's C parser
    straight into float arrays: the text is never held whole (a 200 MB file reads in a few times the
    memory of its numbers)."""
    lines = iter(_text_lines(path, where))
    meta, extra, seen, notes = {}, {}, {}, []
    i, header = 0, None
    for line in lines:
        s = line.strip()
        if s and not s.startswith("#"):
            header = line
            break
        body = s[1:].strip()
        if ":" not in body:  # a free comment, unless it looks like a known key without its colon
            word = re.split(r"[\s=]+", body, maxsplit=1)[0].lower()
            close = difflib.get_close_matches(word, META_KEYS, n=1, cutoff=0.8) if word else []
            if close:
                notes.append(f"{where}: line {i + 1}: '{s}' has no ':' and is read as a free"
                             f" comment; did you mean '# {close[0]}: ...'?")
        else:  # '# key: value'
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
    if header is None:
        raise _fail(where, "header", "no header row and no data", "a header row such as 't,x1,y1,x2,y2'")
    header_line = i + 1
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
        elif name and not name.startswith(FREE_PREFIXES):
            notes.append(_ignored_warning(where, f"column {name!r}", name, COLUMNS))

    tables, numbers = [], []
    line_no = header_line
    batch: list[str] = []
    batch_lines: list[int] = []
    for line in lines:
        line_no += 1
        if line.strip():  # blank lines carry no sample: dropped, the line numbers kept right
            batch.append(line)
            batch_lines.append(line_no)
            if len(batch) == _CSV_BATCH_ROWS:
                tables.append(_csv_batch(batch, batch_lines, where, delimiter, names, positions, header_line))
                numbers.append(np.array(batch_lines, dtype=np.int64))
                batch, batch_lines = [], []
    if batch:
        tables.append(_csv_batch(batch, batch_lines, where, delimiter, names, positions, header_line))
        numbers.append(np.array(batch_lines, dtype=np.int64))
    del batch, batch_lines
    if not numbers:
        raise _fail(where, "data", f"no data rows after the header (line {header_line})",
                    f"at least {MIN_SAMPLES} rows of numbers")
    line_numbers = np.concatenate(numbers)
    columns = {}
    for k, name in enumerate(positions):  # one column at a time: the batches are let go as they are joined
        columns[name] = np.concatenate([table[k] for table in tables])
    del tables
    return columns, meta, extra, _Origin(where, line_numbers, tuple(n for n in names if n), tuple(notes))


def _csv_batch(body: list[str], line_numbers: list[int], where: str, delimiter, names, positions,
               header_line: int) -> list[np.ndarray]:
    """The used columns of a batch of non-blank data rows, each a float64 array; every bad row named by line."""
    stripped = [line.strip() for line in body]
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
    if not positions:
        return []
    try:  # fast path: numpy's C parser on the columns we use
        table = np.loadtxt(body, delimiter=delimiter, usecols=list(positions.values()),
                           comments=None, ndmin=2, dtype=np.float64)
    except ValueError:  # slow path, only to name the first bad cell
        rows = [line.split(delimiter) for line in body]
        table = np.array([[_cell(r[j], where, name, n) for name, j in positions.items()]
                          for r, n in zip(rows, line_numbers)])
    return [np.ascontiguousarray(table[:, k]) for k in range(table.shape[1])]


def _write_csv(path: Path, columns: dict, meta: dict, extra: Mapping[str, str]) -> None:
    head = []
    for key, value in {**meta, **extra}.items():
        if key == "probe_angles_deg":
            flat = value[0] if value[0] == value[1] else (*value[0], *value[1])
            value = ", ".join(repr(float(a)) for a in flat)
        elif key == "rest_position":
            value = ", ".join(repr(float(a)) for a in np.ravel(value))
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
    """Members one by one, each .npy header read first (`_npz_member`): no header can make us allocate
    more than the member holds or `MAX_RECORD_BYTES`, and each array is read straight into its own buffer."""
    entries = {}
    try:
        with open(path, "rb") as f:
            if f.read(6) == b"\x93NUMPY":  # a .npy file named .npz
                raise _fail(where, "file", "holds a single array", "an .npz archive of named arrays")
        with zipfile.ZipFile(path) as archive:
            infos = archive.infolist()
            unpacked = sum(info.file_size for info in infos)
            if unpacked > MAX_RECORD_BYTES:  # a small archive may inflate to anything: ask first
                raise _fail(where, "file", f"unpacks to {unpacked / 1e6:.1f} MB",
                            f"at most {MAX_RECORD_BYTES / 1e6:g} MB (lubeviz.signals.records.MAX_RECORD_BYTES)")
            for info in infos:
                if info.is_dir():
                    continue
                key = info.filename[:-4] if info.filename.endswith(".npy") else info.filename
                entries[key] = _npz_member(archive, info, key, where)
    except (ValueError, OSError, EOFError, zipfile.BadZipFile, zlib.error, struct.error,
            NotImplementedError, RuntimeError) as exc:  # zipfile: unknown versions, encryption
        if isinstance(exc, DataFormatError):
            raise
        raise _fail(where, "file", f"is not a readable .npz archive ({exc})") from None
    return _split_entries(entries, where)


_NPZ_SMALL = 4  # values a metadata array may hold (probe angles and rest readings: 4)
_READ_CHUNK = 1 << 20  # bytes read from a member at a time (zipfile copies each read once)


def _npz_member(archive: zipfile.ZipFile, info: zipfile.ZipInfo, key: str, where: str):
    """One .npz member as an array, its header checked before anything is allocated.

    Refused (naming the member): a header numpy cannot read, Python objects, structured or other
    non-numeric, non-text data, a shape whose bytes exceed what the member holds or MAX_RECORD_BYTES, a
    record column that is not a vector, a metadata field of more than a few values. A large array under
    a name the record format does not use is not read at all: an empty stand-in, reported as ignored.
    """
    member = f"member {info.filename!r}"
    low = key.lower()
    with archive.open(info) as f:
        try:
            version = np.lib.format.read_magic(f)
            if version == (1, 0):
                shape, fortran, dtype = np.lib.format.read_array_header_1_0(f)
            elif version == (2, 0):
                shape, fortran, dtype = np.lib.format.read_array_header_2_0(f)
            else:  # (3, 0): utf-8 field names, i.e. structured data, which a record never holds
                raise ValueError(f"format version {version[0]}.{version[1]}")
        except (ValueError, TypeError, SyntaxError, EOFError) as exc:
            raise _fail(where, member, f"is not a readable .npy array ({exc})",
                        "arrays saved by numpy.savez") from None
        if dtype.hasobject:
            raise _fail(where, repr(key), "holds Python objects (pickled data)", "numbers or text")
        if dtype.fields is not None or dtype.kind not in "biufcUS":
            raise _fail(where, member, f"holds {dtype} values", "numbers or text")
        count = math.prod(shape)
        nbytes = count * dtype.itemsize
        held = info.file_size - f.tell()  # bytes after the header (uncompressed)
        if nbytes > held or nbytes > MAX_RECORD_BYTES:
            raise _fail(where, member, f"its header claims shape {shape} of {dtype} ({nbytes / 1e6:.6g} MB)"
                        f" but the member holds {max(held, 0)} bytes of data",
                        f"a header that agrees with its data, at most {MAX_RECORD_BYTES / 1e6:g} MB")
        spread = sum(1 for d in shape if d != 1)
        if low in COLUMNS and (spread > 1 or dtype.kind not in "biuf"):
            if dtype.kind not in "biuf":
                raise _fail(where, repr(key), f"holds {dtype} values", "real numbers")
            raise _fail(where, repr(key), f"shape {shape}", "a vector of samples")
        if low in META_KEYS and count > _NPZ_SMALL:
            raise _fail(where, repr(key), f"array of shape {shape}", "a single value, a text or a few numbers")
        if low not in RESERVED and count > 1:
            return np.empty((0, 0))  # not used by a record: not read (reported as ignored)
        flat = np.empty(count, dtype=dtype)
        view = memoryview(flat.view(np.uint8)) if nbytes else memoryview(bytearray())
        pos = 0
        while pos < nbytes:
            got = f.readinto(view[pos:pos + _READ_CHUNK])
            if not got:
                raise _fail(where, member, f"data cut short after {pos} of {nbytes} bytes",
                            "a complete .npz archive")
            pos += got
        f.read(1)  # to the member's end, so zipfile checks its CRC
        return flat.reshape(shape, order="F" if fortran else "C")


def _read_mat(path: Path, where: str):
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise _fail(where, "file", f"cannot be read ({exc.strerror or exc})") from None
    readable, notes = _check_mat5(data, where)
    try:
        entries = scipy.io.loadmat(io.BytesIO(data), squeeze_me=True, chars_as_strings=True,
                                   variable_names=readable)
    except NotImplementedError:
        raise _fail(where, "file", "is a MATLAB v7.3 (HDF5) file",
                    "a v5/v7 MAT-file (save(..., '-v7'))") from None
    except (MatReadError, ValueError, TypeError, OSError, EOFError, IndexError, KeyError,
            zlib.error) as exc:
        raise _fail(where, "file", f"is not a readable MAT-file ({exc})") from None
    columns, meta, extra, origin = _split_entries({k: v for k, v in entries.items()
                                                   if not k.startswith("__")}, where)
    return columns, meta, extra, dataclasses.replace(origin, notes=tuple(notes) + origin.notes)


class _MatUnsupported(Exception):
    """A MAT-file variable of a class a record cannot hold (sparse, object, function handle)."""


# MAT v5 data types: bytes per value of the numeric and text ones (miINT8 ... miUTF32)
_MAT_VALUE_BYTES = {1: 1, 2: 1, 3: 2, 4: 2, 5: 4, 6: 4, 7: 4, 9: 8, 12: 8, 13: 8, 16: 1, 17: 2, 18: 4}
_MI_INT32, _MI_UINT32, _MI_MATRIX, _MI_COMPRESSED, _MI_UTF8 = 5, 6, 14, 15, 16
_MAT_ARRAYS = {4: "char", **{c: "numeric" for c in range(6, 16)}}  # mxCHAR, mxDOUBLE ... mxUINT64
_MAT_CLASS_NAMES = {3: "object", 5: "sparse", 16: "function handle", 17: "opaque"}  # not read


def _check_mat5(data: bytes, where: str) -> tuple[list[str] | None, list[str]]:
    """Walk the data elements of a MAT v5 (v6/v7) file before scipy reads it.

    scipy's v5 reader is not hardened against corrupt files (its `loadmat` docs say so): an element
    type code out of range is used as an index into a C array and crashes the whole process (scipy
    PR #25349), which a record upload must never do. So every element is checked here first: a
    known type code, a size that fits its container, dimensions that agree with the number of
    values. Returns the names of the variables scipy may read (None: all, for other MAT versions,
    v4 and v7.3, which are left to scipy) and a warning for each variable skipped because a record
    cannot hold it (sparse, object, function handle; scipy then never parses it).
    """
    if len(data) < 128 or data[126:128] not in (b"IM", b"MI") or 0 in data[:4]:
        return None, []  # not a v5 header: scipy decides (v4, v7.3 or not a MAT-file)
    order = "<" if data[126:128] == b"IM" else ">"
    budget = [MAX_RECORD_BYTES]  # decompressed bytes allowed over the whole file

    def bad(problem: str):
        return _fail(where, "file", f"is not a readable MAT-file ({problem})",
                     "a MAT-file of numeric arrays and text, saved with save(..., '-v7')")

    def tag(buf: bytes, pos: int, limit: int):
        """(type, byte count, data start, data end, next element) of the element at `pos`."""
        if pos + 8 > limit:
            raise bad(f"element cut short at byte {pos}")
        first, second = struct.unpack_from(order + "II", buf, pos)
        if first >> 16:  # small data element: type, size and up to 4 bytes in 8
            mdtype, nbytes = first & 0xFFFF, first >> 16
            if nbytes > 4:
                raise bad(f"small element of {nbytes} bytes at byte {pos}")
            return mdtype, nbytes, pos + 4, pos + 4 + nbytes, pos + 8
        end = pos + 8 + second
        if end > limit:
            raise bad(f"element at byte {pos} ({second} bytes) runs past its end")
        return first, second, pos + 8, end, pos + 8 + second + (-second) % 8

    def values(buf: bytes, pos: int, limit: int, count: int | None) -> int:
        mdtype, nbytes, _, _, after = tag(buf, pos, limit)
        size = _MAT_VALUE_BYTES.get(mdtype)
        if size is None:
            raise bad(f"unknown data type code {mdtype} at byte {pos}")
        if nbytes % size or (count is not None and nbytes // size != count):
            raise bad(f"{nbytes} bytes of type {mdtype} at byte {pos} where {count} values are declared")
        return after

    def matrix(buf: bytes, pos: int, limit: int, names: list[str] | None = None, depth: int = 0) -> int:
        if depth > 32:
            raise _MatUnsupported("cells or structs nested more than 32 deep")
        mdtype, nbytes, start, end, after = tag(buf, pos, limit)
        if mdtype != _MI_MATRIX:
            raise bad(f"array expected at byte {pos}, found type code {mdtype}")
        if nbytes == 0:  # an empty cell element
            return after
        fmd, fn, fs, _, p = tag(buf, start, end)
        if fmd != _MI_UINT32 or fn != 8:
            raise bad(f"array flags at byte {start}")
        flags, = struct.unpack_from(order + "I", buf, fs)
        cls, is_complex = flags & 0xFF, bool(flags & 0x0800)
        dmd, dn, ds, _, p = tag(buf, p, end)
        if dmd not in (_MI_INT32, _MI_UINT32) or dn % 4 or dn < 8:
            raise bad(f"array dimensions at byte {ds - 8}")
        dims = struct.unpack_from(order + f"{dn // 4}i", buf, ds)
        if min(dims) < 0 or math.prod(dims) > MAX_RECORD_BYTES:
            raise bad(f"array dimensions {dims} at byte {ds - 8}")
        count = math.prod(dims)
        nmd, nn, ns, ne, p = tag(buf, p, end)
        if nmd not in (1, 2, _MI_UTF8):
            raise bad(f"array name at byte {ns - 8}")
        name = bytes(buf[ns:ne]).decode("latin-1")
        if names is not None:
            names.append(name)
        if cls in _MAT_ARRAYS:  # text may be stored in fewer values (UTF-8, empty): count not checked
            p = values(buf, p, end, count if _MAT_ARRAYS[cls] == "numeric" else None)
            if is_complex:
                p = values(buf, p, end, count)
        elif cls == 1:
            for _ in range(count):
                p = matrix(buf, p, end, depth=depth + 1)
        elif cls == 2:
            lmd, ln, ls, _, p = tag(buf, p, end)
            if lmd != _MI_INT32 or ln != 4:
                raise bad(f"struct field name length at byte {ls - 8}")
            field_len, = struct.unpack_from(order + "i", buf, ls)
            _, names_bytes, _, _, p = tag(buf, p, end)
            if field_len <= 0 or names_bytes % field_len:
                raise bad(f"struct field names at byte {p}")
            for _ in range(count * (names_bytes // field_len)):
                p = matrix(buf, p, end, depth=depth + 1)
        elif cls in _MAT_CLASS_NAMES:
            raise _MatUnsupported(f"a MATLAB {_MAT_CLASS_NAMES[cls]} array")
        else:
            raise bad(f"unknown array class code {cls} at byte {start}")
        if p > after:
            raise bad(f"array {name!r} overruns its element")
        return after

    readable, notes = [], []
    pos = 128
    while pos < len(data):
        mdtype, _, start, end, _ = tag(data, pos, len(data))
        names: list[str] = []
        try:
            if mdtype == _MI_COMPRESSED:
                inflate = zlib.decompressobj()
                try:
                    raw = inflate.decompress(data[start:end], budget[0] + 1)
                except zlib.error as exc:
                    raise bad(f"compressed variable at byte {pos}: {exc}") from None
                if len(raw) > budget[0]:
                    raise bad(f"decompresses to more than {MAX_RECORD_BYTES / 1e6:g} MB")
                budget[0] -= len(raw)
                matrix(raw, 0, len(raw), names)
            elif mdtype == _MI_MATRIX:
                matrix(data, pos, len(data), names)
            else:
                raise bad(f"unexpected element type code {mdtype} at byte {pos}")
            readable.append(names[0])
        except _MatUnsupported as exc:
            notes.append(f"{where}: variable {names[0]!r} ignored; {exc}, which a record cannot hold")
        pos = end
    return readable, notes


def _split_entries(entries: dict, where: str):
    """Sort named arrays into columns, known metadata and other (string) metadata."""
    columns, meta, extra, seen, notes = {}, {}, {}, {}, []
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
            elif not low.startswith(FREE_PREFIXES):  # not part of the record format: ignored, said
                notes.append(_ignored_warning(where, f"variable {key!r}", low, COLUMNS + META_KEYS))
    return columns, meta, extra, _Origin(where, names=tuple(entries), notes=tuple(notes))


def _column(value, where: str, name: str) -> np.ndarray:
    """A 1-D float array of samples (1 x N and N x 1 accepted)."""
    a = np.asarray(value)
    if a.dtype.kind not in "iuf":
        raise _fail(where, name, f"holds {a.dtype} values", "real numbers")
    a = np.squeeze(a)
    if a.ndim != 1:
        raise _fail(where, name, f"shape {np.shape(value)}", "a vector of samples")
    return np.asarray(a, dtype=np.float64)  # no copy when the file already holds float64


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
    if not v.isprintable():
        raise _fail(where, name, f"{v!r} holds control characters", expected)
    return v


def _machine_name(value, where: str) -> str:
    """A plain model file name (`lubeviz.model.machine.model_name_problem`), never a path."""
    expected = "a model file name under models/, e.g. 'paper_machine.toml' or 'paper_machine'"
    name = _text(value, where, "machine", expected)
    problem = model_name_problem(name)
    if problem:
        raise _fail(where, "machine", f"{name!r} {problem}", expected)
    return name


def _numbers(value, where: str, name: str, expected: str) -> list[float]:
    """Finite numbers from text ('45, 135', '[1; 2]') or an array of any shape (row-major)."""
    if isinstance(value, np.ndarray) and value.dtype.kind == "U" and value.size == 1:
        value = str(value.reshape(-1)[0])
    if isinstance(value, str):
        cells = [c for c in re.split(r"[,;\s]+", value.strip().strip("[]()")) if c]
        return [_finite(c, where, name, expected) for c in cells]
    try:
        a = np.asarray(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise _fail(where, name, f"{value!r} is not a list of numbers", expected) from None
    return [_finite(x, where, name, expected) for x in a]


def _four_numbers(value, where: str, name: str, expected: str) -> np.ndarray:
    flat = _numbers(value, where, name, expected)
    if len(flat) != 4:
        raise _fail(where, name, f"{len(flat)} values", expected)
    return np.array(flat, dtype=np.float64).reshape(2, 2)


def _rest_position(value, where: str) -> np.ndarray:
    return _four_numbers(value, where, "rest_position",
                         "4 finite numbers X1, Y1, X2, Y2: each probe's reading at rest, in the"
                         " record's units, along the probe directions")


def _probe_angles(value, where: str) -> tuple[tuple[float, float], tuple[float, float]]:
    name = "probe_angles_deg"
    expected = "2 angles (both planes) or 4 (plane 1 a, b, plane 2 a, b) in degrees from +X"
    flat = _numbers(value, where, name, expected)
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


def _warnings(value, where: str) -> tuple[str, ...]:
    if isinstance(value, str) or not all(isinstance(w, str) for w in value):
        raise _fail(where, "warnings", f"{value!r}", "a sequence of messages (str)")
    return tuple(value)


def _is_free_key(key: str) -> bool:
    low = key.lower()
    return low in INFO_KEYS or low in FREE_TEXT_KEYS or low.startswith(FREE_PREFIXES)


def _unknown_key_warning(where: str, key: str) -> str:
    return _ignored_warning(where, f"unknown key {key!r}", key.lower(),
                            META_KEYS + COLUMNS + INFO_KEYS + FREE_TEXT_KEYS)


def _ignored_warning(where: str, what: str, name: str, known) -> str:
    """'<file>: <what> ignored; did you mean '<closest>'?' (difflib), or how to silence it."""
    close = difflib.get_close_matches(name, known, n=1, cutoff=0.6)
    hint = f"did you mean {close[0]!r}?" if close else \
        "not a record field (start a name with 'x_' to keep it silently)"
    return f"{where}: {what} ignored; {hint}"


def _check_vibration(displacement: np.ndarray, where: str, units: str | None = None, *,
                     scale: float = 1.0) -> None:
    """Refuse a channel that does not move (dead probe) or moves more than a shaft can (wrong units).

    `displacement` x `scale` in metres; `units` is the file's units field, named in the message when known.
    The peak-to-peak does not see the DC gap, so this holds for `static: absolute` records too.
    """
    if displacement.shape[-1] < MIN_SAMPLES:
        return  # too short to judge; refused for its length where that is checked
    ptp = np.ptp(displacement, axis=-1) * scale
    for k, a in np.ndindex(2, 2):
        name = CHANNELS[2 * k + a]
        if ptp[k, a] < MIN_VIBRATION_PTP:
            raise _fail(where, name, f"no vibration: the channel is constant"
                        f" ({float(displacement[k, a, 0]) * scale!r} m throughout)",
                        "a probe signal that moves (a disconnected, saturated or unpowered probe"
                        " reads a constant)")
        if ptp[k, a] > MAX_VIBRATION_PTP:
            said = f"the file says units: {units}" if units else "the readings' units"
            raise _fail(where, name, f"peak-to-peak {ptp[k, a] * 1e3:.4g} mm is far more than a"
                        " shaft vibrates in journal bearings",
                        f"at most {MAX_VIBRATION_PTP * 1e3:g} mm; check the units ({said};"
                        " m, mm, um or mils)")


def _channel_means(displacement: np.ndarray, speed_hz: float, sample_rate_hz: float
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Mean reading of each channel and its standard error, (2, 2) each, units of `displacement`.

    Mean: the constant of a least-squares fit of the mean plus the 1X..3X lines (those below 0.45 of
    the sample rate), so a non-whole number of revolutions leaks no 1X into it; for whole
    revolutions it is the plain mean. Standard error, by batch means (the "blocking" of Flyvbjerg &
    Petersen 1989, sized by a lag-1 correlation test as sequential batch-means procedures do): the
    residual of that fit (noise, sub- and non-synchronous motion) is averaged over batches of whole
    revolutions, and
    std(batch means, ddof=1) / sqrt(n_batches) estimates the standard error of the mean. Batches
    start at one revolution and double while the batch means stay correlated (lag-1
    autocorrelation >= 2/sqrt(n_batches)) and at least `MIN_BATCHES` remain. Unlike
    std(residual)/sqrt(n), which only holds for white noise, this keeps slow wander (low-frequency
    noise correlated over many samples), which is what moves a mean: checked against the scatter of
    repeated records for white and AR(1) noise (tests/signals/test_static_and_sets.py). Noise slower
    than about a tenth of the record cannot be told from the mean and is under-counted. The rest
    reading is taken as exact (the record gives no uncertainty for it).
    """
    d = displacement.reshape(4, -1)
    n = d.shape[1]
    omega = 2.0 * math.pi * speed_hz / sample_rate_hz  # rad per sample
    harmonics = [h for h in (1, 2, 3) if h * speed_hz < 0.45 * sample_rate_hz] or [1]
    i = np.arange(n, dtype=np.float64)
    design = np.column_stack([np.ones(n)] + [f(h * omega * i) for h in harmonics
                                             for f in (np.cos, np.sin)])
    # normal equations: over >= 10 revolutions the columns are nearly orthogonal, well conditioned
    coef, *_ = np.linalg.lstsq(design.T @ design, design.T @ d.T, rcond=None)
    residual = d - (design @ coef).T
    per_rev = sample_rate_hz / speed_hz
    n_rev = int(math.floor(n / per_rev + 1e-9))
    std = np.full(4, np.inf)  # too short to tell (such a record is refused for its length anyway)
    for c in range(4):
        revs = 1
        while n_rev // revs >= MIN_BATCHES:
            n_batch = n_rev // revs
            edges = np.minimum(np.round(np.arange(n_batch + 1) * revs * per_rev).astype(np.int64), n)
            means = np.add.reduceat(residual[c, :edges[-1]], edges[:-1]) / np.diff(edges)
            std[c] = np.std(means, ddof=1) / math.sqrt(n_batch)
            dev = means - means.mean()
            lag1 = float(dev[1:] @ dev[:-1]) / max(float(dev @ dev), np.finfo(float).tiny)
            if lag1 < 2.0 / math.sqrt(n_batch):  # batches longer than the noise's memory: done
                break
            revs *= 2
    return coef[0].reshape(2, 2), std.reshape(2, 2)


def _numeric_array(value, where: str, name: str) -> np.ndarray:
    a = np.asarray(value)
    if a.dtype.kind not in "iuf":
        raise _fail(where, name, f"holds {a.dtype} values", "real numbers")
    return a


def _owned_frozen(a: np.ndarray) -> bool:
    """A float64 array nobody else can write: read-only, owning its C-contiguous data (the reader's own,
    handed over without a copy; `_assemble` makes them so, and `dataclasses.replace` passes them on)."""
    return (a.dtype == np.float64 and a.base is None and a.flags.c_contiguous and not a.flags.writeable)


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
