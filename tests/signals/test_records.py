"""Measured records (SPEC §6): exact round trips, units and probe geometry, and a clear
DataFormatError naming the file and the field for every kind of bad input."""

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
import scipy.io

from lubeviz.errors import DataFormatError, InputError
from lubeviz.signals import records
from lubeviz.signals.records import (
    Record,
    check_speed,
    write_record,
)
from tests.records import PAPER_NODES, read_record, record_from_arrays

SPEED = 75.0
RATE = 2000.0
N = 400  # 0.2 s = 15 revolutions at 75 Hz
META = {"speed_hz": "75", "sample_rate_hz": "2000", "units": "um"}


def channels(n=N, rate=RATE):
    """Four elliptical 1X orbit channels in µm, as plain float lists (plus the time)."""
    t = np.arange(n) / rate
    w = 2 * math.pi * SPEED * t
    return {"t": t.tolist(), "x1": (10 * np.cos(w)).tolist(), "y1": (8 * np.sin(w + 0.2)).tolist(),
            "x2": (5 * np.cos(w + 0.3)).tolist(), "y2": (4 * np.sin(w - 0.1)).tolist()}


def write_csv(path, meta=META, columns=None, *, sep=","):
    columns = channels() if columns is None else columns
    lines = [f"# {k}: {v}" for k, v in meta.items()]
    lines.append(sep.join(columns))
    lines += [sep.join(str(v) for v in row) for row in zip(*columns.values())]
    path.write_text("\n".join(lines) + "\n")
    return path


def data_line(k, meta=META):
    """File line number (1-based) of data row k."""
    return len(meta) + 2 + k


def rich_record(n=N):
    rng = np.random.default_rng(7)
    x1, y1, x2, y2 = rng.normal(scale=1e-5, size=(4, n))
    return record_from_arrays(x1, y1, x2, y2, speed_hz=SPEED, sample_rate_hz=RATE, t0=0.125,
                              nodes=(5, 21), probe_angles_deg=((45, 135), (30, 100)),
                              machine="paper_machine.toml", keyphasor=rng.normal(size=n),
                              metadata={"operator": "A. Lab", "note": "run 3, bearing 2 warm"})


# --- round trips ------------------------------------------------------------------------------

@pytest.mark.parametrize("suffix", [".csv", ".npz", ".mat", ".CSV"])
def test_round_trip_is_exact(tmp_path, suffix):
    rec = rich_record()
    back = read_record(write_record(rec, tmp_path / f"rec{suffix}"))
    assert back == rec
    assert np.array_equal(back.displacement, rec.displacement)
    assert np.array_equal(back.keyphasor, rec.keyphasor)
    assert (back.speed_hz, back.sample_rate_hz, back.t0) == (SPEED, RATE, 0.125)
    assert back.nodes == (5, 21) and back.probe_angles_deg == ((45.0, 135.0), (30.0, 100.0))
    assert back.machine == "paper_machine.toml"
    assert dict(back.metadata) == {"operator": "A. Lab", "note": "run 3, bearing 2 warm"}
    assert back.source == str(tmp_path / f"rec{suffix}")


@pytest.mark.parametrize("suffix", [".csv", ".npz", ".mat"])
def test_round_trip_with_defaults_and_no_keyphasor(tmp_path, suffix):
    c = channels()
    rec = record_from_arrays(c["x1"], c["y1"], c["x2"], c["y2"], speed_hz=SPEED, sample_rate_hz=RATE,
                             units="um")
    back = read_record(write_record(rec, tmp_path / f"rec{suffix}"))
    assert back == rec and back.keyphasor is None and back.nodes == (6, 20)
    assert back.probe_angles_deg == ((0.0, 90.0), (0.0, 90.0)) and back.machine is None


@pytest.mark.parametrize("units,factor,value,hand", [
    ("m", 1.0, 1.5e-5, 1.5e-5), ("mm", 1e-3, 0.015, 1.5e-5), ("um", 1e-6, 15.0, 1.5e-5),
    ("mils", 25.4e-6, 1.5, 3.81e-5),  # 1 mil = 25.4 µm
])
def test_units_convert_to_metres(tmp_path, units, factor, value, hand):
    c = {k: [v * 1e-6 / factor for v in col] if k != "t" else col for k, col in channels().items()}
    c["x1"][0], c["y2"][3] = value, -2.0 * value  # the other readings: the same µm orbit in `units`
    rec = read_record(write_csv(tmp_path / "r.csv", {**META, "units": units}, c))
    assert rec.displacement[0, 0, 0] == pytest.approx(value * factor, rel=1e-15)
    assert rec.displacement[1, 1, 3] == pytest.approx(-2.0 * value * factor, rel=1e-15)
    assert rec.displacement[0, 0, 0] == pytest.approx(hand, rel=1e-14)
    np.testing.assert_allclose(rec.displacement[0, 1], np.array(channels()["y1"]) * 1e-6, rtol=1e-14)


def test_writing_in_micrometres_reads_back_to_rounding(tmp_path):
    rec = rich_record()
    path = write_record(rec, tmp_path / "r.csv", units="um")
    assert "# units: um" in path.read_text()
    back = read_record(path)
    np.testing.assert_allclose(back.displacement, rec.displacement, rtol=1e-14, atol=0)


# --- probes, time axis, derived quantities ----------------------------------------------------

@pytest.mark.parametrize("angles", [(45.0, 135.0), (30.0, 100.0), (100.0, 30.0), (-60.0, 200.0)])
def test_probe_readings_resolve_to_x_and_y(angles):
    rng = np.random.default_rng(3)
    xy = rng.normal(scale=2e-5, size=(2, 2, 500))
    a, b = np.radians(angles)
    probes = np.stack([[x * np.cos(a) + y * np.sin(a), x * np.cos(b) + y * np.sin(b)] for x, y in xy])
    rec = Record(SPEED, RATE, probes, nodes=PAPER_NODES, probe_angles_deg=(angles, angles))
    np.testing.assert_allclose(rec.xy(), xy, rtol=0, atol=1e-12 * np.abs(xy).max())
    z = rec.complex_signal(1)
    np.testing.assert_allclose(z, xy[1, 0] + 1j * xy[1, 1], rtol=0, atol=1e-12 * np.abs(xy).max())


@pytest.mark.parametrize("text,expected", [
    ("45, 135", ((45.0, 135.0), (45.0, 135.0))),
    ("[30; 100; 45 135]", ((30.0, 100.0), (45.0, 135.0))),
])
def test_probe_angles_from_csv_one_or_both_planes(tmp_path, text, expected):
    rec = read_record(write_csv(tmp_path / "r.csv", {**META, "probe_angles_deg": text}))
    assert rec.probe_angles_deg == expected


def test_default_probes_give_the_readings_exactly():
    rec = rich_record()
    plain = dataclasses.replace(rec, probe_angles_deg=((0, 90), (0, 90)))
    assert np.array_equal(plain.xy(), plain.displacement)
    assert np.array_equal(plain.complex_signal(0), rec.displacement[0, 0] + 1j * rec.displacement[0, 1])
    with pytest.raises(InputError, match="plane"):
        plain.complex_signal(2)


def test_time_column_and_sample_rate_are_equivalent(tmp_path):
    c = channels()
    only_t = read_record(write_csv(tmp_path / "t.csv", {"speed_hz": 75, "units": "um"}, c))
    del c["t"]
    only_rate = read_record(write_csv(tmp_path / "rate.csv", META, c))
    assert only_t.sample_rate_hz == pytest.approx(RATE, rel=1e-12)
    assert only_rate.sample_rate_hz == RATE and only_t.t0 == only_rate.t0 == 0.0
    assert np.array_equal(only_t.displacement, only_rate.displacement)
    np.testing.assert_allclose(only_t.t, only_rate.t, rtol=0, atol=1e-15)


def test_time_column_offset_sets_t0(tmp_path):
    c = channels()
    c["t"] = [3.5 + v for v in c["t"]]
    rec = read_record(write_csv(tmp_path / "r.csv", columns=c))
    assert rec.t0 == 3.5 and rec.t[0] == 3.5
    assert rec.n_samples == N and rec.duration == pytest.approx(0.2) and rec.revolutions == pytest.approx(15)


def test_record_is_immutable():
    rec = rich_record()
    with pytest.raises(ValueError):
        rec.displacement[0, 0, 0] = 1.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        rec.speed_hz = 50.0
    with pytest.raises(TypeError):
        rec.metadata["operator"] = "x"


# --- tolerant CSV reading ---------------------------------------------------------------------

def test_csv_header_is_matched_by_name_in_any_order(tmp_path):
    c = channels()
    ref = read_record(write_csv(tmp_path / "ref.csv", META, c))
    shuffled = {" Y2 ": c["y2"], "temperature": [20.0] * N, "X1": c["x1"], "t": c["t"],
                "x2 ": c["x2"], "y1": c["y1"]}
    path = write_csv(tmp_path / "messy.csv", {**META, "Operator": "me"}, shuffled, sep=";")
    text = "\ufeff# a free comment without a colon\n" + path.read_text().replace("\n", "\r\n") + "\r\n\r\n"
    path.write_bytes(text.encode("utf-8"))
    rec = read_record(path)
    assert np.array_equal(rec.displacement, ref.displacement)
    assert dict(rec.metadata) == {"Operator": "me"}


def test_whitespace_delimited_csv(tmp_path):
    c = channels()
    ref = read_record(write_csv(tmp_path / "ref.csv", META, c))
    assert read_record(write_csv(tmp_path / "ws.csv", META, c, sep="  ")) == ref


def test_plain_numpy_and_matlab_files_are_read(tmp_path):
    c = channels()
    arrays = {k: np.array(v) for k, v in c.items() if k != "t"}
    np.savez(tmp_path / "r.npz", **arrays, speed_hz=75.0, sample_rate_hz="2000", units="um", node1=5)
    rec = read_record(tmp_path / "r.npz")
    assert rec.nodes == (5, 20) and rec.sample_rate_hz == RATE
    # MATLAB style: row vectors, node numbers as doubles, 2x2 probe angles, a stray struct-free extra
    scipy.io.savemat(tmp_path / "r.mat", {**{k: v[None, :] for k, v in arrays.items()},
                                         "speed_hz": 75.0, "sample_rate_hz": 2000.0, "units": "um",
                                         "node1": 6.0, "node2": 21.0, "gain": 2.5,
                                         "probe_angles_deg": np.array([[45.0, 135.0], [0.0, 90.0]])})
    rec = read_record(tmp_path / "r.mat")
    assert rec.nodes == (6, 21) and rec.probe_angles_deg == ((45.0, 135.0), (0.0, 90.0))
    assert dict(rec.metadata) == {"gain": "2.5"}


def test_a_full_size_record_round_trips_through_csv(tmp_path):
    n = 50_000
    rng = np.random.default_rng(0)
    rec = record_from_arrays(*rng.normal(scale=1e-5, size=(4, n)), speed_hz=SPEED, sample_rate_hz=10_000.0)
    path = write_record(rec, tmp_path / "big.csv")
    assert read_record(path) == rec  # reading speed is a benchmark (BENCHMARKS.md), not a test


# --- bad input: DataFormatError naming the file and the field ----------------------------------

def _bad_csv_cases():
    def edit(k, col, value):
        def f(c):
            c[col][k] = value
            return META, c
        return f

    def meta(**changes):
        def f(c):
            m = {**META, **changes}
            return {k: v for k, v in m.items() if v is not None}, c
        return f

    def swap_t(c):
        c["t"][10], c["t"][11] = c["t"][11], c["t"][10]
        return META, c

    def gap_t(c):
        c["t"] = c["t"][:200] + [v + 0.5 / RATE for v in c["t"][200:]]
        return META, c

    def drop(col):
        def f(c):
            del c[col]
            return META, c
        return f

    def no_rate_no_t(c):
        del c["t"]
        return {"speed_hz": "75", "units": "um"}, c

    def low_rate(c):  # a consistent file whose rate is simply too low for 75 Hz
        del c["t"]
        return {**META, "sample_rate_hz": "100"}, c

    def short(n):
        return lambda c: (META, channels(n))

    L = data_line
    return [
        ("speed_hz", meta(speed_hz=None), ["missing"]),
        ("units", meta(units=None), ["missing"]),
        ("units", meta(units="inch"), ["'inch'", "mils"]),
        ("speed_hz", meta(speed_hz="0"), ["not positive"]),
        ("speed_hz", meta(speed_hz="-75"), ["not positive"]),
        ("speed_hz", meta(speed_hz="fast"), ["'fast' is not a number"]),
        ("speed_hz", meta(speed_hz="nan"), ["not finite"]),
        ("sample_rate_hz", meta(sample_rate_hz="0"), ["not positive"]),
        ("sample_rate_hz", no_rate_no_t, ["missing", "'t' column"]),
        ("sample_rate_hz", meta(sample_rate_hz="1000"), ["disagrees"]),
        ("x2", drop("x2"), ["missing column"]),
        ("'y1'", edit(7, "y1", "nan"), [f"line {L(7)}", "not finite"]),
        ("'x2'", edit(9, "x2", "-inf"), [f"line {L(9)}", "not finite"]),
        ("'x1'", edit(3, "x1", "abc"), [f"line {L(3)}", "'abc' is not a number"]),
        ("'y2'", edit(4, "y2", ""), [f"line {L(4)}", "empty cell"]),
        ("'t'", swap_t, ["non-monotonic time", f"line {L(11)}"]),
        ("'t'", gap_t, ["non-uniform sampling", f"line {L(200)}"]),
        ("duration", short(100), ["too few revolutions", "3.75"]),
        ("samples", short(10), ["too few samples"]),
        ("node1", meta(node1="6.5"), ["not a whole number"]),
        ("node2", meta(node2="0"), ["not a positive integer"]),
        ("node1", meta(node1="-1"), ["not a positive integer"]),
        ("node2", meta(node2="six"), ["not a whole number"]),
        ("probe_angles_deg", meta(probe_angles_deg="45, 135, 45"), ["wrong probe-angle count: 3"]),
        ("probe_angles_deg", meta(probe_angles_deg="45, 50"), ["5° from parallel"]),
        ("probe_angles_deg", meta(probe_angles_deg="0, 90, 0, 175"), ["plane 2", "from parallel"]),
        ("probe_angles_deg", meta(probe_angles_deg="0, x"), ["'x' is not a number"]),
        ("machine", meta(machine=""), ["empty"]),
        ("sample_rate_hz", low_rate, ["alias"]),
    ]


@pytest.mark.parametrize("field,make,phrases", _bad_csv_cases(),
                         ids=[f"{c[0]}-{c[2][0]}" for c in _bad_csv_cases()])
def test_bad_csv_is_refused_with_file_and_field(tmp_path, field, make, phrases):
    meta, cols = make(channels())
    path = write_csv(tmp_path / "bad.csv", meta, cols)
    with pytest.raises(DataFormatError) as err:
        read_record(path)
    message = str(err.value)
    assert str(path) in message and field in message
    for phrase in phrases:
        assert phrase in message


@pytest.mark.parametrize("text,field,phrase", [
    ("", "file", "empty"),
    ("# speed_hz: 75\n# units: m\n", "header", "no header"),
    ("# speed_hz: 75\n# units: m\nt,x1,y1,x2,y2\n\n", "data", "no data rows"),
    ("# speed_hz: 75\n# units: m\n0,1,2,3,4\n", "header", "holds numbers"),
    ("# speed_hz: 75\n# Speed_Hz: 60\n", "Speed_Hz", "given twice"),
    ("# speed_hz: 75\n# units: m\nt,x1,y1,x1,y2\n0,1,2,3,4\n", "'x1'", "appears twice"),
    ("# speed_hz: 75\n# units: m\nt,x1,y1,x2,y2\n0,1,2,3,4\n0.1,1,2,3,4,5\n", "line 5", "this row has 6 cells; expected one number per column of the header row (line 3: t, x1, y1, x2, y2)"),
    ("# speed_hz: 75\n# units: m\nt,x1,y1,x2,y2\n0,1,2,3,4\n# units: mm\n", "line 5", "comment after"),
])
def test_malformed_csv_text_is_refused(tmp_path, text, field, phrase):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(DataFormatError) as err:
        read_record(path)
    assert str(path) in str(err.value) and field in str(err.value) and phrase in str(err.value)


def test_not_utf8_is_refused(tmp_path):
    path = tmp_path / "bad.csv"
    path.write_bytes(b"# speed_hz: 75\n\xff\xfe\x00garbage")
    with pytest.raises(DataFormatError, match="not UTF-8") as err:
        read_record(path)
    assert str(path) in str(err.value)


def test_missing_file_and_unknown_suffix(tmp_path):
    with pytest.raises(DataFormatError, match="no such file") as err:
        read_record(tmp_path / "nothere.csv")
    assert "nothere.csv" in str(err.value)
    (tmp_path / "r.txt").write_text("x")
    with pytest.raises(DataFormatError, match=r"'\.txt'.*\.csv, \.npz, \.mat"):
        read_record(tmp_path / "r.txt")
    with pytest.raises(DataFormatError, match=r"'\.h5'"):
        write_record(rich_record(), tmp_path / "r.h5")
    (tmp_path / "dir.csv").mkdir()
    with pytest.raises(DataFormatError, match="not a regular file"):
        read_record(tmp_path / "dir.csv")


def test_file_larger_than_the_limit_is_refused_before_reading(tmp_path, monkeypatch):
    path = write_csv(tmp_path / "r.csv")
    monkeypatch.setattr(records.record, "MAX_RECORD_BYTES", 1000)
    with pytest.raises(DataFormatError, match="larger than the limit") as err:
        read_record(path)
    assert str(path) in str(err.value) and "MAX_RECORD_BYTES" in str(err.value)


def _npz(path, **arrays):
    c = {k: np.array(v) for k, v in channels().items()}
    full = {**c, "speed_hz": 75.0, "units": "um", **arrays}
    np.savez(path, **{k: v for k, v in full.items() if v is not None})
    return path


@pytest.mark.parametrize("changes,field,phrase", [
    ({"x2": None}, "x2", "missing column"),
    ({"units": None}, "units", "missing"),
    ({"x1": np.array(["a", "b"])}, "x1", "real numbers"),
    ({"y1": np.zeros((3, N))}, "y1", "shape"),
    ({"y2": np.zeros(N - 1)}, "columns", "different lengths"),
    ({"speed_hz": np.array([75.0, 76.0])}, "speed_hz", "a single value"),
    ({"node1": 2.5}, "node1", "not a positive integer"),
    ({"probe_angles_deg": np.array([45.0, 135.0, 0.0])}, "probe_angles_deg", "count"),
    ({"X1": np.zeros(N)}, "'X1'", "case-insensitive"),
])
def test_bad_npz_is_refused(tmp_path, changes, field, phrase):
    path = _npz(tmp_path / "bad.npz", **changes)
    with pytest.raises(DataFormatError) as err:
        read_record(path)
    assert str(path) in str(err.value) and field in str(err.value) and phrase in str(err.value)


def test_npz_with_pickled_objects_is_refused_without_unpickling(tmp_path):
    path = _npz(tmp_path / "bad.npz", machine=np.array([{"evil": 1}], dtype=object))
    with pytest.raises(DataFormatError, match="'machine'.*pickled") as err:
        read_record(path)
    assert str(path) in str(err.value)


@pytest.mark.parametrize("suffix,phrase", [(".npz", "npz"), (".mat", "MAT-file")])
def test_corrupt_binary_files_are_refused(tmp_path, suffix, phrase):
    path = tmp_path / f"bad{suffix}"
    path.write_bytes(b"this is not a binary record at all" * 10)
    with pytest.raises(DataFormatError, match=phrase) as err:
        read_record(path)
    assert str(path) in str(err.value)


def test_mat_missing_variable_is_named(tmp_path):
    path = tmp_path / "bad.mat"
    scipy.io.savemat(path, {k: np.array(v) for k, v in channels().items() if k != "y1"}
                     | {"speed_hz": 75.0, "units": "um"})
    with pytest.raises(DataFormatError, match="y1: missing column") as err:
        read_record(path)
    assert str(path) in str(err.value)


def test_mat_refuses_metadata_keys_matlab_cannot_name(tmp_path):
    rec = dataclasses.replace(rich_record(), metadata={"test rig": "B"})
    with pytest.raises(DataFormatError, match="'test rig'.*MATLAB"):
        write_record(rec, tmp_path / "r.mat")
    assert read_record(write_record(rec, tmp_path / "r.npz")) == rec  # fine elsewhere


@pytest.mark.parametrize("metadata,phrase", [
    ({"speed_hz": "80"}, "record field"),
    ({"X1": "a"}, "record field"),
    ({"a:b": "c"}, "without ':'"),
    ({"note": "two\nlines"}, "several lines"),
    ({"note": 3}, "not text"),
])
def test_record_refuses_metadata_that_would_not_round_trip(metadata, phrase):
    with pytest.raises(DataFormatError, match=phrase):
        dataclasses.replace(rich_record(), metadata=metadata)


def test_arrays_are_validated_like_files():
    c = {k: np.array(v) for k, v in channels().items()}
    c["x2"][5] = np.nan
    with pytest.raises(DataFormatError, match=r"sim\.npz: 'x2', index 5: nan is not finite"):
        record_from_arrays(c["x1"], c["y1"], c["x2"], c["y2"], speed_hz=SPEED, sample_rate_hz=RATE,
                           source="sim.npz")
    with pytest.raises(DataFormatError, match="sample_rate_hz: missing"):
        record_from_arrays(c["x1"], c["y1"], c["y1"], c["y2"], speed_hz=SPEED)
    rec = record_from_arrays(c["x1"], c["y1"], c["y1"], c["y2"], speed_hz=SPEED, t=c["t"] + 1.0, units="um")
    assert rec.t0 == 1.0 and rec.sample_rate_hz == pytest.approx(RATE)
    with pytest.raises(DataFormatError, match="displacement: shape"):
        Record(SPEED, RATE, np.zeros((2, 3, N)))  # three probes in a plane
    with pytest.raises(DataFormatError, match="displacement: shape"):
        Record(SPEED, RATE, np.zeros((1, 2, N)))  # one plane


def test_check_speed_refuses_a_record_far_from_the_model_speed():
    rec = dataclasses.replace(rich_record(), speed_hz=95.0, source="run7.csv")
    with pytest.raises(DataFormatError) as err:
        check_speed(rec, 75.0)
    message = str(err.value)
    assert "run7.csv" in message and "speed_hz" in message and "95" in message and "75" in message
    check_speed(dataclasses.replace(rec, speed_hz=80.0), 75.0)  # 6.7 % off: accepted
    check_speed(rec, 75.0, tolerance=0.3)


# --- no silent wrong answers: unknown names warn, implausible records are refused ---------------

@pytest.mark.parametrize("key,value,suggestion", [
    ("node_1", "5", "node1"),
    ("Node 2", "21", "node2"),
    ("probe_angle_deg", "45, 135", "probe_angles_deg"),
    ("probe_angles", "45, 135", "probe_angles_deg"),
    ("machne", "paper_machine.toml", "machine"),
    ("rest_positon", "1, 2, 3, 4", "rest_position"),
    ("sets", "coast", "set"),
])
def test_misspelled_optional_key_warns_naming_the_closest_known_key(tmp_path, key, value, suggestion):
    path = write_csv(tmp_path / "typo.csv", {**META, key: value})
    rec = read_record(path)
    assert rec.warnings == (f"{path}: unknown key {key!r} ignored; did you mean {suggestion!r}?",)
    assert rec.nodes == (6, 20) and rec.probe_angles_deg == ((0.0, 90.0), (0.0, 90.0))  # not used
    assert rec.metadata[key] == value  # kept as text, for the user to see


def test_unknown_key_far_from_any_known_key_says_how_to_keep_it_silently(tmp_path):
    rec = read_record(write_csv(tmp_path / "r.csv", {**META, "humidity_pct": "41"}))
    assert len(rec.warnings) == 1 and "'humidity_pct' ignored; not a record field" in rec.warnings[0]
    assert "'x_'" in rec.warnings[0]


def test_informational_and_free_text_keys_are_kept_silently(tmp_path):
    # what `lubeviz simulate` writes (lubeviz/signals/synthesize.py, lubeviz/cli/rotor_cmd.py) and free text
    info = {"q1_mlmin": "450", "q2_mlmin": "600", "snr_db": "12", "synthetic": "lubeviz simulate",
            "seed": "3", "effects": "viscosity:factor=1.2", "method": "time", "truth_viscosity.factor": "1.2",
            "note": "warm", "Comment": "after overhaul", "operator": "A. Lab", "x_rig": "B", "X_Temp_C": "41"}
    rec = read_record(write_csv(tmp_path / "r.csv", {**META, **info}))
    assert rec.warnings == ()
    assert dict(rec.metadata) == info


def test_key_missing_its_colon_warns_instead_of_becoming_a_comment(tmp_path):
    path = write_csv(tmp_path / "r.csv", {**META})
    path.write_text("# node1 5\n# node2 = 21\n# a free comment about the run\n" + path.read_text())
    rec = read_record(path)
    assert rec.nodes == (6, 20)
    assert rec.warnings == (f"{path}: line 1: '# node1 5' has no ':' and is read as a free comment;"
                            " did you mean '# node1: ...'?",
                            f"{path}: line 2: '# node2 = 21' has no ':' and is read as a free comment;"
                            " did you mean '# node2: ...'?")


def test_unknown_columns_warn_unless_marked_free(tmp_path):
    c = channels()
    c["keyphaser"] = [0.0] * N
    c["x_temperature"] = [20.0] * N
    path = write_csv(tmp_path / "r.csv", META, c)
    rec = read_record(path)
    assert rec.keyphasor is None
    assert rec.warnings == (f"{path}: column 'keyphaser' ignored; did you mean 'keyphasor'?",)


def test_unknown_npz_and_mat_variables_warn(tmp_path):
    c = {k: np.array(v) for k, v in channels().items()}
    np.savez(tmp_path / "r.npz", **c, speed_hz=75.0, units="um", node_1=5, keyphaser=np.zeros(N),
             x_gain=2.0, q1_mlmin=450.0)
    rec = read_record(tmp_path / "r.npz")
    where = str(tmp_path / "r.npz")
    assert sorted(rec.warnings) == [f"{where}: unknown key 'node_1' ignored; did you mean 'node1'?",
                                    f"{where}: variable 'keyphaser' ignored; did you mean 'keyphasor'?"]
    assert rec.nodes == (6, 20) and dict(rec.metadata) == {"node_1": "5", "x_gain": "2.0", "q1_mlmin": "450.0"}
    scipy.io.savemat(tmp_path / "r.mat", {**c, "speed_hz": 75.0, "units": "um", "probe_angle_deg": [45, 135]})
    rec = read_record(tmp_path / "r.mat")
    assert rec.warnings == (f"{tmp_path / 'r.mat'}: variable 'probe_angle_deg' ignored;"
                            " did you mean 'probe_angles_deg'?",)


def test_uploaded_bytes_warn_under_the_upload_name(tmp_path):
    text = write_csv(tmp_path / "r.csv", {**META, "node_1": "5"}).read_text()
    rec = records.read_record_bytes(text, "run 7.csv", default_nodes=PAPER_NODES)
    assert rec.warnings == ("run 7.csv: unknown key 'node_1' ignored; did you mean 'node1'?",)


def test_a_record_round_trips_its_warnings_away_but_not_its_notes(tmp_path):
    rec = read_record(write_csv(tmp_path / "r.csv", {**META, "node_1": "5"}))
    back = read_record(write_record(rec, tmp_path / "back.csv"))
    assert back == rec and dict(back.metadata) == {"node_1": "5"} and len(back.warnings) == 1


def test_equal_nodes_are_refused(tmp_path):
    path = write_csv(tmp_path / "r.csv", {**META, "node1": "6", "node2": "6"})
    with pytest.raises(DataFormatError, match=r"node2: 6 is the same node as node1") as err:
        read_record(path)
    assert str(path) in str(err.value)
    with pytest.raises(DataFormatError, match="same node"):
        dataclasses.replace(rich_record(), nodes=(5, 5))


@pytest.mark.parametrize("value", [0.0, 3.25])
def test_a_channel_that_does_not_move_is_refused_as_no_vibration(tmp_path, value):
    c = channels()
    c["y2"] = [value] * N
    path = write_csv(tmp_path / "r.csv", META, c)
    with pytest.raises(DataFormatError) as err:
        read_record(path)
    message = str(err.value)
    assert f"{path}: y2: no vibration: the channel is constant" in message


@pytest.mark.parametrize("units", ["m", "mm"])
def test_micrometre_readings_declared_in_metres_or_millimetres_are_refused_naming_the_units(tmp_path, units):
    path = write_csv(tmp_path / "r.csv", {**META, "units": units})  # a 20 µm p-p orbit written in µm
    with pytest.raises(DataFormatError) as err:
        read_record(path)
    message = str(err.value)
    assert str(path) in message and "x1: peak-to-peak" in message and f"units: {units}" in message
    assert "at most 5 mm" in message


def test_large_but_possible_vibration_is_accepted(tmp_path):
    c = {k: [v * 240.0 if k != "t" else v for v in col] for k, col in channels().items()}  # 4.8 mm p-p
    assert read_record(write_csv(tmp_path / "r.csv", META, c)).displacement.max() == pytest.approx(2.4e-3)


@pytest.mark.parametrize("name,phrase", [
    ("../models/paper_machine.toml", "is a path"),
    ("/etc/passwd", "is a path"),
    ("models/paper_machine.toml", "is a path"),
    ("C:paper.toml", "is a path"),
    ("..", "'..'"),
    (".hidden.toml", "starts with '.'"),
    ("paper_machine.txt", "ends in '.txt'"),
])
def test_machine_must_be_a_plain_model_file_name(tmp_path, name, phrase):
    path = write_csv(tmp_path / "r.csv", {**META, "machine": name})
    with pytest.raises(DataFormatError) as err:
        read_record(path)
    assert f"{path}: machine: {name!r}" in str(err.value) and phrase in str(err.value)


@pytest.mark.parametrize("name", ["paper_machine.toml", "paper_machine", "rig-B 2.toml"])
def test_plain_machine_names_are_kept(tmp_path, name):
    assert read_record(write_csv(tmp_path / "r.csv", {**META, "machine": name})).machine == name


def test_a_mat_file_with_an_out_of_range_type_code_is_refused_not_a_crash(tmp_path):
    # scipy's reader used such a code as an index into a C array and crashed the process (scipy PR #25349)
    c = {k: np.array(v) for k, v in channels().items()}
    path = tmp_path / "r.mat"
    scipy.io.savemat(path, {**c, "speed_hz": 75.0, "units": "um"})
    data = bytearray(path.read_bytes())
    at = data.index(b"x1\x00\x00") + 4
    data[at:at + 4] = (8).to_bytes(4, "little")
    path.write_bytes(bytes(data))
    with pytest.raises(DataFormatError, match="unknown data type code 8") as err:
        read_record(path)
    assert str(path) in str(err.value)


def test_mat_variables_a_record_cannot_hold_are_skipped_with_a_warning(tmp_path):
    import scipy.sparse

    c = {k: np.array(v) for k, v in channels().items()}
    scipy.io.savemat(tmp_path / "r.mat", {**c, "speed_hz": 75.0, "units": "um", "x_daq": {"gain": 2.0},
                                         "adjacency": scipy.sparse.eye(3, format="csc")}, do_compression=True)
    rec = read_record(tmp_path / "r.mat")
    assert rec.warnings == (f"{tmp_path / 'r.mat'}: variable 'adjacency' ignored; a MATLAB sparse array,"
                            " which a record cannot hold",)
    assert rec.displacement[0, 0, 3] == pytest.approx(channels()["x1"][3] * 1e-6)


def test_an_npz_that_unpacks_beyond_the_limit_is_refused_before_unpacking(tmp_path, monkeypatch):
    path = _npz(tmp_path / "r.npz")
    monkeypatch.setattr(records.record, "MAX_RECORD_BYTES", path.stat().st_size + 100)
    np.savez_compressed(path, **{k: np.zeros(N) for k in ("x1", "y1", "x2", "y2")}, pad=np.zeros(10**5))
    assert path.stat().st_size < records.MAX_RECORD_BYTES  # small on disk, 0.8 MB unpacked
    with pytest.raises(DataFormatError, match="unpacks to") as err:
        read_record(path)
    assert str(path) in str(err.value)


def test_a_temperature_key_points_to_the_oil_temperature(tmp_path):
    rec = read_record(write_csv(tmp_path / "r.csv", {**META, "temperature_c": "41"}))
    assert rec.oil_temperature_c is None and "did you mean 'oil_temperature_c'?" in rec.warnings[0]


def test_an_upload_named_longer_than_a_file_system_allows_is_read_under_its_name(tmp_path):
    """The bytes pass through a temporary file of the reader's own name; messages name the user's file."""
    from lubeviz.signals.records import write_record
    from tests.records import read_record_bytes, record_from_arrays

    t = np.arange(2000) / 2000.0
    rec = record_from_arrays(*(1e-5 * np.sin(2 * np.pi * 75.0 * t + p) for p in (0, 1, 2, 3)), speed_hz=75.0,
                             sample_rate_hz=2000.0)
    data = write_record(rec, tmp_path / "r.csv").read_bytes()
    name = "x" * 400 + ".csv"  # beyond the 255-byte limit of a file name
    assert read_record_bytes(data, name).source == name
    with pytest.raises(DataFormatError) as err:
        read_record_bytes(data.replace(b"units: m", b"units: furlong"), name)
    assert str(err.value).startswith(name + ": units") and "lubeviz-upload" not in str(err.value)


def test_a_record_of_three_planes_round_trips_with_its_nodes_and_probes(tmp_path):
    """SPEC §8: columns x1, y1, ..., xP, yP, `nodes: n1, ..., nP`, 2 or 2P probe angles; written and read back
    the same in every format, the rest readings per plane too."""
    rng = np.random.default_rng(3)
    t = np.arange(N) / RATE
    planes = [(a * np.cos(2 * np.pi * SPEED * t + p), a * np.sin(2 * np.pi * SPEED * t + p)) for a, p in
              ((20e-6, 0.1), (15e-6, 1.0), (8e-6, 2.0))]
    d = np.array(planes) + 1e-7 * rng.standard_normal((3, 2, N))
    angles = ((45.0, 135.0), (0.0, 90.0), (30.0, 120.0))
    rec = Record(SPEED, RATE, d, nodes=(7, 15, 23), probe_angles_deg=angles, rest_position=np.zeros((3, 2)))
    assert rec.n_planes == 3 and rec.xy().shape == (3, 2, N) and rec.static_offset.shape == (3, 2)
    for suffix in (".csv", ".npz", ".mat"):
        path = tmp_path / f"three{suffix}"
        write_record(rec, path)
        back = read_record(path)
        assert back.nodes == (7, 15, 23) and back.probe_angles_deg == angles
        assert np.allclose(back.displacement, rec.displacement, rtol=1e-12, atol=1e-15)
        assert np.allclose(back.static_offset, rec.static_offset, atol=1e-12)
    text = (tmp_path / "three.csv").read_text()
    assert "# nodes: 7, 15, 23" in text and "t,x1,y1,x2,y2,x3,y3" in text


def test_a_three_plane_file_names_what_is_missing(tmp_path):
    """A y3 column without its x3, and three planes without their nodes, are refused naming the field."""
    rec = rich_record()
    path = tmp_path / "r.csv"
    write_record(rec, path)
    lines = path.read_text().splitlines()
    head = next(i for i, ln in enumerate(lines) if not ln.startswith("#"))
    body = [ln + "," + ln.split(",")[1] for ln in lines[head + 1:]]
    path.write_text("\n".join(lines[:head] + [lines[head] + ",y3"] + body) + "\n")
    with pytest.raises(DataFormatError, match=r"x3: missing column; expected columns x1, y1, \.\.\., x3, y3"):
        read_record(path)
    both = lines[head].split(",")
    body = [ln + "," + ",".join(ln.split(",")[1:3]) for ln in lines[head + 1:]]
    kept = [ln for ln in lines[:head] if not ln.startswith(("# node1", "# node2", "# probe_angles_deg"))]
    path.write_text("\n".join(kept + [",".join(both + ["x3", "y3"])] + body) + "\n")
    with pytest.raises(DataFormatError, match="nodes: missing: the record has 3 planes"):
        read_record(path)
    path.write_text("\n".join(kept + ["# nodes: 6, 20", ",".join(both + ["x3", "y3"])] + body) + "\n")
    with pytest.raises(DataFormatError, match="nodes: 2 values for 3 planes"):
        read_record(path)
    path.write_text("\n".join(kept + ["# nodes: 6, 13, 20", ",".join(both + ["x3", "y3"])] + body) + "\n")
    assert read_record(path).nodes == (6, 13, 20)


def test_a_record_names_its_planes_or_is_read_with_its_machine(tmp_path):
    """No machine's nodes are assumed: a record that names none is refused unless read with a machine, whose
    planes (any count) then stand in (SPEC §6, §8)."""
    from lubeviz.model.machine import load_machine

    path = write_csv(tmp_path / "r.csv", META)
    with pytest.raises(DataFormatError, match=r"r\.csv: nodes: missing.*without a machine.*'nodes: n1, n2'"):
        records.read_record(path)
    assert records.read_record(path, **load_machine().record_defaults()).nodes == (6, 20)
    with pytest.raises(DataFormatError, match="record: nodes: missing"):
        Record(SPEED, RATE, np.full((2, 2, N), 1e-6) * np.arange(N))
    with pytest.raises(TypeError, match="nodes"):
        records.record_from_arrays(*np.ones((4, N)) * np.arange(N) * 1e-8, speed_hz=SPEED, sample_rate_hz=RATE)

    fan = load_machine(Path(__file__).parents[2] / "models" / "three_bearing_fan.toml")
    t = np.arange(4000) / 4000.0
    six = [1e-5 * np.cos(2 * np.pi * 24.75 * t + 0.3 * k) for k in range(6)]
    rec = records.record_from_arrays(*six, speed_hz=24.75, sample_rate_hz=4000.0, nodes=(7, 15, 23))
    back = records.read_record(write_record(rec, tmp_path / "fan.csv"))
    assert back.nodes == (7, 15, 23) and back.n_planes == 3
    text = (tmp_path / "fan.csv").read_text()
    bare = tmp_path / "bare.csv"  # the same record with its nodes line taken out: the fan's planes stand in
    bare.write_text("\n".join(line for line in text.splitlines() if not line.lower().startswith("# nodes")))
    with pytest.raises(DataFormatError, match="'nodes: n1, n2, n3'"):
        records.read_record(bare)
    assert records.read_record(bare, **fan.record_defaults()).nodes == (7, 15, 23)
    with pytest.raises(DataFormatError, match="nodes: missing: the record has 3 planes and the machine 2"):
        records.read_record(bare, **load_machine().record_defaults())
