"""A record built from a file's (or a caller's) columns and metadata: names matched, units, time axis,
static offsets."""

from __future__ import annotations

import difflib
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ...units import length_factor
from .record import (
    COLUMNS, FREE_PREFIXES, MAX_PLANES, PROBE_ANGLES_XY_DEG, FREE_TEXT_KEYS, INFO_KEYS,
    META_KEYS, MIN_SAMPLES, Record, STATIC_ABSOLUTE, TIME_PRECISION, TIME_RTOL, _channel_means,
    _check_vibration, _column, _cos_sin_deg, _fail, _finite, _node, _plane_numbers, _positive, _probe_angles,
    _numbers, _rest_position, _text, channel_names,
)


def record_from_arrays(*channels, speed_hz: float, nodes, sample_rate_hz: float | None = None,
                       t=None, units: str = "m",
                       probe_angles_deg=PROBE_ANGLES_XY_DEG, t0: float | None = None,
                       machine: str | None = None, keyphasor=None,
                       metadata: Mapping[str, str] | None = None,
                       source: str | None = None, rest_position=None, static_offset=None,
                       set_name: str | None = None, oil_temperature_c: float | None = None) -> Record:
    """A `Record` from probe readings x1, y1, ..., xP, yP in `units`, validated exactly as a file would be.

    `nodes`: the P planes' model nodes (no default: a machine's planes are `Machine.record_defaults`).

    Give `sample_rate_hz` or a time array `t` (or both, then they must agree); `t0` (s) only
    without `t`. Record fields found in `metadata` (`set`, `static`, `rest_position`, ...) are read
    as a file's would be; one given both as an argument and in `metadata` is refused.

    Static shaft position (both in `units`, like the readings):
    - `rest_position` alone (2P numbers X1, Y1, ..., XP, YP or P x 2, along the probe directions): the
      readings are absolute (they keep the DC gap), as in a `static: absolute` file.
    - `static_offset` (P planes x (X, Y), the journal's displacement from its rest position): the
      readings are taken as the dynamic part; each channel's mean (as `Record` estimates it) is
      replaced by rest reading + the offset seen along that probe, so the record's `static_offset`
      equals the one given (to rounding). `rest_position` defaults to zero readings then.
    """
    where = str(source) if source is not None else "record"
    n_planes = len(channels) // 2
    if len(channels) % 2 or not 2 <= n_planes <= MAX_PLANES:
        raise _fail(where, "channels", f"{len(channels)} arrays",
                    f"x1, y1, ..., xP, yP: an even number, 2 <= P <= {MAX_PLANES} planes")
    if nodes is None or np.ndim(nodes) != 1 or len(nodes) != n_planes:
        raise _fail(where, "nodes", f"{nodes!r}", f"{n_planes} node numbers, one per plane")
    columns = dict(zip(channel_names(n_planes), channels))
    columns.update({"t": t, "keyphasor": keyphasor})
    meta = {"speed_hz": speed_hz, "sample_rate_hz": sample_rate_hz, "units": units,
            "nodes": tuple(nodes), "probe_angles_deg": probe_angles_deg,
            "machine": machine, "t0_s": t0, "set": set_name, "rest_position": rest_position,
            "oil_temperature_c": oil_temperature_c,
            "static": None if rest_position is None else STATIC_ABSOLUTE}
    extra = {}
    for key, value in dict(metadata or {}).items():  # file fields given as metadata act as in a file
        low = key.lower() if isinstance(key, str) else None
        if low in META_KEYS:
            if meta.get(low) is not None:
                raise _fail(where, f"metadata {key!r}", "also given as an argument (or by its default)",
                            "each field once")
            meta[low] = value
        else:
            extra[key] = value
    if static_offset is not None and meta["rest_position"] is None:
        meta["rest_position"], meta["static"] = np.zeros((n_planes, 2)), STATIC_ABSOLUTE
    columns = {k: _column(v, where, k) for k, v in columns.items() if v is not None}
    meta = {k: v for k, v in meta.items() if v is not None}
    if static_offset is not None:
        static_offset = _plane_numbers(static_offset, where, "static_offset",
                                       f"X, Y of each plane ({n_planes} planes x 2) in the record's units", n_planes)
    return _assemble(columns, meta, extra, _Origin(where), None, static_offset=static_offset)


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
              static_offset: np.ndarray | None = None, default_probe_angles=None) -> Record:
    """The format-independent part: required fields, finiteness, time axis, units; then `Record`."""
    where = origin.where
    warnings = list(origin.notes) + [_unknown_key_warning(where, key) for key in extra
                                     if not _is_free_key(key)]
    # the planes: x1, y1, ..., xP, yP (SPEC §8), P the highest plane any column names, at least two
    given = [int(c[1:]) for c in columns if len(c) > 1 and c[0] in "xy" and c[1:].isdigit()]
    n_planes = max([2, *given])
    channels = channel_names(n_planes)
    for name in channels:
        if name not in columns:
            found = ", ".join(repr(c) for c in origin.names or columns) or "none"
            listed = "x1, y1, x2, y2" if n_planes == 2 else f"x1, y1, ..., x{n_planes}, y{n_planes}"
            raise _fail(where, name, "missing column", f"columns {listed} (found: {found})")
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

    nodes = _nodes(meta, where, n_planes, default_nodes)
    angles = meta.get("probe_angles_deg")
    if angles is None:
        defaults = default_probe_angles or ()
        angles = tuple(tuple(a) for a in defaults) if len(defaults) == n_planes else PROBE_ANGLES_XY_DEG
    rest = _static_fields(meta, where, n_planes)
    # One (P, 2, n) array filled channel by channel; each column is let go once copied (peak memory of a
    # large record: the samples about once, not three times).
    displacement = np.empty((n_planes, 2, lengths["x1"]))
    for j, c in enumerate(channels):
        displacement[j // 2, j % 2] = columns.pop(c)
    _check_vibration(displacement, where, units, scale=scale)
    if scale != 1.0:
        displacement *= scale
    displacement.flags.writeable = False  # handed to Record without a copy
    if rest is not None:
        rest = rest * scale
        if static_offset is not None:  # the readings were the dynamic part: give them this mean
            angles = _probe_angles(angles, where, n_planes)
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


def _nodes(meta: dict, where: str, n_planes: int, default_nodes) -> tuple[int, ...]:
    """The planes' model nodes: `nodes: n1, ..., nP`, or node1 ... nodeP, or the machine's planes (`default_nodes`)
    when the file names none and they are as many as its planes."""
    if "nodes" in meta:
        if any(f"node{k + 1}" in meta for k in range(n_planes)):
            raise _fail(where, "nodes", "given both as 'nodes' and as node1, node2, ...", "one of the two forms")
        values = _numbers(meta["nodes"], where, "nodes", f"{n_planes} node numbers n1, ..., n{n_planes}")
        if len(values) != n_planes:
            raise _fail(where, "nodes", f"{len(values)} values for {n_planes} planes",
                        f"{n_planes} node numbers, one per plane (columns x1 ... y{n_planes})")
        return tuple(_node(v, where, f"nodes ({k + 1})") for k, v in enumerate(values))
    named = [f"node{k + 1}" in meta for k in range(n_planes)]
    if not any(named) and default_nodes is None:
        listed = ", ".join(f"n{k + 1}" for k in range(n_planes)) if n_planes <= 3 else f"n1, ..., n{n_planes}"
        raise _fail(where, "nodes", f"missing: the record does not name the model nodes of its {n_planes} planes"
                    " and was read without a machine",
                    f"'nodes: {listed}' in the record, or the record read with its machine's model file")
    default_nodes = default_nodes or ()
    if not any(named) and len(default_nodes) != n_planes:
        raise _fail(where, "nodes", f"missing: the record has {n_planes} planes and the machine {len(default_nodes)}",
                    f"'nodes: n1, ..., n{n_planes}', the model node of each plane")
    out = []
    for k in range(n_planes):
        if named[k]:
            out.append(_node(meta[f"node{k + 1}"], where, f"node{k + 1}"))
        elif k < len(default_nodes):
            out.append(default_nodes[k])
        else:
            raise _fail(where, f"node{k + 1}", "missing metadata", f"the model node of plane {k + 1}")
    return tuple(out)


def _static_fields(meta: dict, where: str, n_planes: int = 2) -> np.ndarray | None:
    """The rest readings (P planes, 2 probes, record units) of a `static: absolute` record, else None."""
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
    return _rest_position(meta["rest_position"], where, n_planes) if has_rest else None


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
