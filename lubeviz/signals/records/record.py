"""The record: one steady-speed measurement at its planes, validated when built, with its fields' checks."""

from __future__ import annotations

import math
import numbers
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np

from ...errors import DataFormatError, InputError
from ...model.machine import model_name_problem



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


PROBE_ANGLES_XY_DEG = (0.0, 90.0)  # a plane's probes when nothing says otherwise: a along +X, b along +Y


FORMATS = (".csv", ".npz", ".mat")


MAX_PLANES = 12  # measurement planes a record may hold (SPEC §8: columns x1, y1, ..., xP, yP)


def channel_names(n_planes: int) -> tuple[str, ...]:
    """The columns of `n_planes` planes, displacement[plane][probe] row-major: x1, y1, x2, y2, ..."""
    return tuple(f"{a}{p}" for p in range(1, n_planes + 1) for a in "xy")


CHANNELS = channel_names(2)  # the paper's two planes (SPEC §6); any record: `channel_names(P)`
ALL_CHANNELS = channel_names(MAX_PLANES)


COLUMNS = ("t", *ALL_CHANNELS, "keyphasor")


META_KEYS = ("speed_hz", "sample_rate_hz", "units", "nodes", *(f"node{p}" for p in range(1, MAX_PLANES + 1)),
             "probe_angles_deg",
             "machine", "t0_s", "set", "static", "rest_position", "oil_temperature_c")


OIL_TEMPERATURE_RANGE_C = (-20.0, 150.0)


RESERVED = frozenset(COLUMNS + META_KEYS)


# Informational keys `lubeviz simulate` writes, and free-text keys: kept without a warning.
INFO_KEYS = (*(f"q{k}_mlmin" for k in range(1, 7)), "snr_db", "synthetic", "seed", "effects", "method", "static_shift_um", "ratio_2x",
             "stability", "whirl_hz", "whirl_growth_per_s", "orbit_stability", "orbit_stability_state")


FREE_TEXT_KEYS = ("note", "notes", "comment", "description", "operator", "date")


FREE_PREFIXES = ("x_", "truth_")  # `x_anything: ...` is the user's own; `truth_*` the simulator's


STATIC_ABSOLUTE = "absolute"


def _fail(where: str, what: str, problem: str, expected: str | None = None) -> DataFormatError:
    """The one message shape: '<file>: <field>: <problem>; expected <expectation>'."""
    return DataFormatError(f"{where}: {what}: {problem}" + (f"; expected {expected}" if expected else ""))


@dataclass(frozen=True, eq=False)


class Record:
    """One steady-speed measurement at P planes; SI inside (metres, seconds, rev/s).

    `nodes` has no default: a record names its planes' model nodes, or is read with its machine (whose planes
    stand in, `Machine.record_defaults`). `probe_angles_deg` defaults to X and Y at every plane."""

    speed_hz: float  # shaft speed, rev/s
    sample_rate_hz: float  # samples per second, uniform sampling
    displacement: np.ndarray  # (P planes, 2 probes, n_samples) probe readings in metres, read-only
    nodes: tuple[int, ...] | None = None  # model nodes of the P planes (required: see the class doc)
    probe_angles_deg: tuple[tuple[float, float], ...] | None = None  # per plane; None: X and Y everywhere
    t0: float = 0.0  # time of the first sample, s
    machine: str | None = None  # model file name under models/ (a plain name, no folder)
    keyphasor: np.ndarray | None = None  # (n_samples,), as recorded (not scaled)
    metadata: Mapping[str, str] = field(default_factory=dict)  # other `key: value` pairs, read-only
    source: str | None = None  # the file it came from, for messages
    # `static: absolute`: (P planes, 2 probes) probe readings at rest (journal at the bottom of its
    # bearing), metres, along the probe directions; the displacement then keeps the DC gap. None:
    # the mean of each channel means nothing.
    rest_position: np.ndarray | None = None
    set_name: str | None = None  # `set: NAME`, records of one machine taken together
    # `oil_temperature_c`: the oil temperature read on the machine (°C; an extension of SPEC §6). With an
    # [oil] in the model file it settles the film's viscosity.
    oil_temperature_c: float | None = None
    warnings: tuple[str, ...] = ()  # what the reader ignored (unknown keys, columns), for the user
    units: str | None = None  # the units the file declared (m, mm, um, mils): named when amplitudes look off
    # Derived when built (never passed): mean reading - rest reading resolved to X, Y (P planes, 2) in
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
        if d.ndim != 3 or d.shape[1] != 2 or not 2 <= d.shape[0] <= MAX_PLANES:
            raise _fail(where, "displacement", f"shape {d.shape}",
                        f"(P planes, 2 probes, n_samples) with 2 <= P <= {MAX_PLANES}")
        names = channel_names(d.shape[0])
        for k, a in zip(*np.nonzero(~np.isfinite(d).all(axis=2))):
            i = int(np.flatnonzero(~np.isfinite(d[k, a]))[0])
            raise _fail(where, f"{names[2 * k + a]}, index {i}", f"{d[k, a, i]} is not finite",
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

        n_planes = d.shape[0]
        if self.nodes is None:
            raise _fail(where, "nodes", "missing: the record does not name its planes' model nodes",
                        f"{n_planes} node numbers, one per plane, or the record read with its machine")
        try:
            nodes = tuple(self.nodes)
        except TypeError:
            nodes = ()
        if len(nodes) != n_planes:
            raise _fail(where, "nodes", f"{self.nodes!r}", f"{n_planes} node numbers, one per plane"
                        + (" (node1, node2)" if n_planes == 2 else f" (nodes: n1, ..., n{n_planes})"))
        nodes = tuple(_node(v, where, f"node{k + 1}") for k, v in enumerate(nodes))
        for k in range(1, n_planes):
            if nodes[k] in nodes[:k]:
                j = nodes.index(nodes[k])
                raise _fail(where, f"node{k + 1}", f"{nodes[k]} is the same node as node{j + 1}",
                            "different model nodes, one per measurement plane")
        put("nodes", nodes)
        angles = PROBE_ANGLES_XY_DEG if self.probe_angles_deg is None else self.probe_angles_deg
        put("probe_angles_deg", _probe_angles(angles, where, n_planes))

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
            rest = _frozen_copy(_rest_position(self.rest_position, where, n_planes))
            put("rest_position", rest)
            mean, mean_std = _channel_means(self.displacement, self.speed_hz, self.sample_rate_hz)
            offset = np.stack([self._resolve(k, mean[k] - rest[k]) for k in range(n_planes)])
            std = np.stack([self._resolve_std(k, mean_std[k]) for k in range(n_planes)])
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
    def n_planes(self) -> int:
        return self.displacement.shape[0]

    @property
    def is_static(self) -> bool:
        """True for `static: absolute` records (the readings keep the DC gap, `static_offset` is set)."""
        return self.rest_position is not None

    def xy(self) -> np.ndarray:
        """(P, 2, n) shaft displacement along X and Y (SPEC §1 axes), from the probe readings.

        Each probe at angle a from +X reads s = x cos a + y sin a; the 2x2 system of a plane is
        solved exactly (for the default probes at 0° and 90° the result equals `displacement`).
        A static record's readings keep their DC gap, so its `xy()` does too (the 1X features
        fit and drop the mean).
        """
        return np.stack([self._plane_xy(k) for k in range(self.n_planes)])

    def complex_signal(self, plane: int) -> np.ndarray:
        """Z = V + iW = x + iy (Eq. 10) of plane `plane` (0-based; node `nodes[plane]`)."""
        if isinstance(plane, bool) or plane not in range(self.n_planes):
            raise InputError(f"plane must be 0..{self.n_planes - 1} (index into nodes {self.nodes}), not {plane!r}")
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
    """(P planes, 2) journal centre X, Y relative to its bearing centre, metres (SPEC §6).

    `static_offset` + (0, -c_k): at rest the journal lies at the bottom of its bearing, (0, -c).
    `clearances` are the true radial clearances c_k (m) of the bearings at the record's planes
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
        raise InputError(f"clearances {clearances!r}: expected one radial clearance per plane, in metres") from None
    if c.size != record.n_planes or not np.all(np.isfinite(c)) or not np.all(c > 0):
        raise InputError(f"clearances {clearances!r}: expected {record.n_planes} positive radial clearances in "
                         "metres, one per plane")
    if not (math.isfinite(tolerance) and tolerance >= 0):
        raise InputError(f"tolerance {tolerance!r}: expected a non-negative fraction of the clearance")
    position = record.static_offset + np.stack([np.zeros(c.size), -c], axis=1)
    for k in range(c.size):
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


def _column(value, where: str, name: str) -> np.ndarray:
    """A 1-D float array of samples (1 x N and N x 1 accepted)."""
    a = np.asarray(value)
    if a.dtype.kind not in "iuf":
        raise _fail(where, name, f"holds {a.dtype} values", "real numbers")
    a = np.squeeze(a)
    if a.ndim != 1:
        raise _fail(where, name, f"shape {np.shape(value)}", "a vector of samples")
    return np.asarray(a, dtype=np.float64)  # no copy when the file already holds float64


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


def _plane_numbers(value, where: str, name: str, expected: str, n_planes: int) -> np.ndarray:
    flat = _numbers(value, where, name, expected)
    if len(flat) != 2 * n_planes:
        raise _fail(where, name, f"{len(flat)} values", expected)
    return np.array(flat, dtype=np.float64).reshape(n_planes, 2)


def _rest_position(value, where: str, n_planes: int = 2) -> np.ndarray:
    names = ", ".join(f"X{p}, Y{p}" for p in range(1, n_planes + 1))
    return _plane_numbers(value, where, "rest_position",
                          f"{2 * n_planes} finite numbers {names}: each probe's reading at rest, in the record's "
                          "units, along the probe directions", n_planes)


def _probe_angles(value, where: str, n_planes: int = 2) -> tuple[tuple[float, float], ...]:
    name = "probe_angles_deg"
    expected = (f"2 angles (every plane) or {2 * n_planes} (plane 1 a, b, plane 2 a, b"
                + (", ..." if n_planes > 2 else "") + ") in degrees from +X")
    flat = _numbers(value, where, name, expected)
    if len(flat) == 2:
        flat = flat * n_planes
    if len(flat) != 2 * n_planes:
        raise _fail(where, name, f"wrong probe-angle count: {len(flat)} values", expected)
    pairs = tuple((flat[2 * k], flat[2 * k + 1]) for k in range(n_planes))
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


def _check_vibration(displacement: np.ndarray, where: str, units: str | None = None, *,
                     scale: float = 1.0) -> None:
    """Refuse a channel that does not move (dead probe) or moves more than a shaft can (wrong units).

    `displacement` x `scale` in metres; `units` is the file's units field, named in the message when known.
    The peak-to-peak does not see the DC gap, so this holds for `static: absolute` records too.
    """
    if displacement.shape[-1] < MIN_SAMPLES:
        return  # too short to judge; refused for its length where that is checked
    ptp = np.ptp(displacement, axis=-1) * scale
    names = channel_names(displacement.shape[0])
    for k, a in np.ndindex(displacement.shape[0], 2):
        name = names[2 * k + a]
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
    """Mean reading of each channel and its standard error, (P, 2) each, units of `displacement`.

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
    n_channels = displacement.shape[0] * displacement.shape[1]
    d = displacement.reshape(n_channels, -1)
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
    std = np.full(n_channels, np.inf)  # too short to tell (such a record is refused for its length anyway)
    for c in range(n_channels):
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
    return coef[0].reshape(displacement.shape[:2]), std.reshape(displacement.shape[:2])


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
