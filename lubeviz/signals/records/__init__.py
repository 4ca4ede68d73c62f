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
  extension of SPEC §6: with an `[oil]` in the model file it fixes the film's viscosity). Comment lines
  without a colon are free comments and are skipped.
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

The modules: `record` (the record and its fields' checks), `fields` (a record built from arrays, or from a
file's columns and metadata), `files` (reading and writing, by format: `csv_format`, `npz_format`,
`mat_format`), `sets`.
"""

from .record import (  # noqa: F401 - the package's public face
    MAX_RECORD_BYTES,
    MIN_REVOLUTIONS,
    MIN_SAMPLES,
    MIN_PROBE_SEPARATION_DEG,
    TIME_RTOL,
    TIME_PRECISION,
    MIN_VIBRATION_PTP,
    MAX_VIBRATION_PTP,
    MIN_BATCHES,
    SET_SPEED_RTOL,
    STATIC_TOLERANCE,
    PROBE_ANGLES_XY_DEG,
    FORMATS,
    CHANNELS,
    COLUMNS,
    META_KEYS,
    OIL_TEMPERATURE_RANGE_C,
    RESERVED,
    INFO_KEYS,
    FREE_TEXT_KEYS,
    FREE_PREFIXES,
    STATIC_ABSOLUTE,
    Record,
    journal_static_position,
    check_speed,
)
from .fields import (  # noqa: F401 - the package's public face
    record_from_arrays,
)
from .files import (  # noqa: F401 - the package's public face
    read_record,
    read_record_bytes,
    write_record,
)
from .sets import (  # noqa: F401 - the package's public face
    read_set,
    check_set,
    group_records,
)
