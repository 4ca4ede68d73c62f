"""Static shaft position and sets of records (SPEC §6): the static offset is the mean reading minus
the rest reading resolved along the probes, its standard error sees slow noise, the journal's
position is checked against its clearance, and the records of one set are checked together."""

import dataclasses
import math

import numpy as np
import pytest
import scipy.signal

from lubeviz.errors import DataFormatError, InputError
from lubeviz.signals import record_features
from lubeviz.signals.records import (
    check_set,
    group_records,
    journal_static_position,
    write_record,
)
from tests.records import read_record, read_set, record_from_arrays

SPEED = 75.0
RATE = 3000.0  # 40 samples per revolution
N = 1200  # 30 whole revolutions
C = 120e-6  # the paper's radial clearance


def probe_readings(xy, angles):
    """What probes at `angles` (deg from +X) read of a motion (x, y): s = x cos a + y sin a."""
    x, y = xy
    return [x * math.cos(math.radians(a)) + y * math.sin(math.radians(a)) for a in angles]


def orbit(n=N, rate=RATE):
    """Elliptical 1X orbits (x, y) of the two planes in metres, zero mean over whole revolutions."""
    w = 2 * math.pi * SPEED * np.arange(n) / rate
    return [(20e-6 * np.cos(w), 12e-6 * np.sin(w + 0.4)), (9e-6 * np.cos(w + 1.0), 7e-6 * np.sin(w - 0.2))]


ANGLES = ((45.0, 135.0), (30.0, 120.0))
OFFSET = np.array([[12e-6, 55e-6], [-8e-6, 70e-6]])  # journal lifted and pushed off its rest point
REST_UM = np.array([[1100.0, 950.0], [1210.5, 1002.25]])  # gap readings at rest, µm


def static_csv(path, *, offset=OFFSET, rest_um=REST_UM, meta_changes=None, angles=ANGLES):
    """A `static: absolute` CSV in µm built by hand: rest reading + offset + orbit, along each probe."""
    cols = {}
    for k, (x, y) in enumerate(orbit()):
        for a, (name, reading) in enumerate(zip((f"x{k + 1}", f"y{k + 1}"),
                                                probe_readings((x + offset[k, 0], y + offset[k, 1]),
                                                               angles[k]))):
            cols[name] = rest_um[k, a] + reading * 1e6
    meta = {"speed_hz": SPEED, "sample_rate_hz": RATE, "units": "um",
            "probe_angles_deg": ", ".join(str(a) for pair in angles for a in pair),
            "static": "absolute", "rest_position": ", ".join(repr(float(v)) for v in rest_um.ravel())}
    meta.update(meta_changes or {})
    lines = [f"# {k}: {v}" for k, v in meta.items() if v is not None]
    lines.append(",".join(cols))
    lines += [",".join(repr(float(v)) for v in row) for row in zip(*cols.values())]
    path.write_text("\n".join(lines) + "\n")
    return path


# --- the static offset ------------------------------------------------------------------------

def test_static_offset_is_mean_minus_rest_resolved_along_the_probes(tmp_path):
    rec = read_record(static_csv(tmp_path / "s.csv"))
    assert rec.is_static
    np.testing.assert_allclose(rec.rest_position, REST_UM * 1e-6, rtol=1e-15)
    np.testing.assert_allclose(rec.static_offset, OFFSET, rtol=0, atol=1e-12)
    # whole revolutions, whole samples per revolution: the plain mean of each column, by hand
    for k in range(2):
        a, b = np.radians(ANGLES[k])
        mean_a, mean_b = rec.displacement[k].mean(axis=1) - REST_UM[k] * 1e-6
        x, y = np.linalg.solve([[math.cos(a), math.sin(a)], [math.cos(b), math.sin(b)]], [mean_a, mean_b])
        np.testing.assert_allclose(rec.static_offset[k], [x, y], rtol=0, atol=1e-13)
    assert np.all(rec.static_offset_std < 1e-12)  # a noise-free record knows its mean exactly


def test_journal_position_is_the_offset_from_the_bottom_of_the_bearing(tmp_path):
    rec = read_record(static_csv(tmp_path / "s.csv"))
    pos = journal_static_position(rec, (C, C))
    np.testing.assert_allclose(pos, [[12e-6, 55e-6 - C], [-8e-6, 70e-6 - C]], rtol=0, atol=1e-12)
    assert pos.shape == (2, 2)
    # at rest (zero offset) the journal is at (0, -c): on the clearance circle, accepted
    rest = read_record(static_csv(tmp_path / "rest.csv", offset=np.zeros((2, 2))))
    np.testing.assert_allclose(journal_static_position(rest, (C, 100e-6)), [[0, -C], [0, -100e-6]],
                               rtol=0, atol=1e-12)


@pytest.mark.parametrize("offset,plane", [
    (np.array([[0.0, 300e-6], [0.0, 60e-6]]), 1),  # 180 µm above the centre with c = 120 µm
    (np.array([[0.0, 60e-6], [150e-6, 0.0]]), 2),  # 192 µm from the centre
])
def test_journal_outside_its_clearance_is_refused_naming_file_plane_and_distance(tmp_path, offset, plane):
    path = static_csv(tmp_path / "far.csv", offset=offset)
    rec = read_record(path)
    with pytest.raises(DataFormatError) as err:
        journal_static_position(rec, (C, C))
    message = str(err.value)
    r = float(np.hypot(offset[plane - 1, 0], offset[plane - 1, 1] - C))
    assert str(path) in message and f"plane {plane}" in message
    assert f"{r * 1e6:.4g} µm" in message and "c = 120 µm" in message


def test_journal_position_needs_a_static_record_and_clearances(tmp_path):
    rec = read_record(static_csv(tmp_path / "s.csv"))
    plain = dataclasses.replace(rec, rest_position=None)
    assert plain.static_offset is None and plain.static_offset_std is None and not plain.is_static
    with pytest.raises(DataFormatError, match="no static shaft position"):
        journal_static_position(plain, (C, C))
    for bad in [(C,), (C, -C), (C, float("nan")), "abc"]:
        with pytest.raises(InputError, match="clearances"):
            journal_static_position(rec, bad)


def test_the_dc_gap_does_not_change_the_1x_features(tmp_path):
    static = read_record(static_csv(tmp_path / "s.csv"))
    dynamic = record_from_arrays(*[c for k in range(2) for c in probe_readings(orbit()[k], ANGLES[k])],
                                 speed_hz=SPEED, sample_rate_hz=RATE, probe_angles_deg=ANGLES)
    np.testing.assert_allclose(record_features(static).vector(), record_features(dynamic).vector(),
                               rtol=1e-7, atol=1e-12)


def _noisy_static_records(noise, count=120, n=6000):
    """Records whose every channel carries `noise(rng, n)`; the true offset is zero."""
    rng = np.random.default_rng(11)
    out = []
    w = 2 * math.pi * SPEED * np.arange(n) / RATE
    for _ in range(count):
        chans = [10e-6 * np.cos(w + p) + noise(rng, n) for p in (0.0, 1.0, 2.0, 3.0)]
        out.append(record_from_arrays(*chans, speed_hz=SPEED, sample_rate_hz=RATE, rest_position=[0, 0, 0, 0]))
    return out


def test_static_offset_std_matches_the_scatter_of_repeated_white_noise_records():
    sigma = 2e-6
    recs = _noisy_static_records(lambda rng, n: rng.normal(scale=sigma, size=n))
    scatter = np.std([r.static_offset for r in recs], axis=0, ddof=1)
    claimed = np.mean([r.static_offset_std for r in recs], axis=0)
    np.testing.assert_allclose(claimed, scatter, rtol=0.25)
    np.testing.assert_allclose(claimed, sigma / math.sqrt(6000), rtol=0.25)  # white: sigma / sqrt(n)


def test_static_offset_std_sees_low_frequency_noise_that_sigma_over_sqrt_n_misses():
    def slow(rng, n, rho=0.99):  # AR(1) noise, correlation time ~100 samples = 2.5 revolutions
        return scipy.signal.lfilter([1.0], [1.0, -rho], rng.normal(scale=2e-6, size=n))

    recs = _noisy_static_records(slow, count=80)
    scatter = np.std([r.static_offset for r in recs], axis=0, ddof=1)
    claimed = np.mean([r.static_offset_std for r in recs], axis=0)
    naive = np.mean([np.std(r.displacement, axis=2) for r in recs], axis=0) / math.sqrt(6000)
    assert np.all(scatter > 4 * naive.mean())  # the white-noise formula would claim far too little
    np.testing.assert_allclose(claimed, scatter, rtol=0.35)


def test_record_from_arrays_builds_a_static_record_from_the_dynamic_part():
    rng = np.random.default_rng(4)
    chans = [c + rng.normal(scale=1e-6, size=N) for k in range(2) for c in probe_readings(orbit()[k], ANGLES[k])]
    rec = record_from_arrays(*chans, speed_hz=SPEED, sample_rate_hz=RATE, probe_angles_deg=ANGLES,
                             static_offset=OFFSET, rest_position=REST_UM * 1e-6)
    np.testing.assert_allclose(rec.static_offset, OFFSET, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(rec.rest_position, REST_UM * 1e-6)
    # in µm, both given in the record's units; the rest defaults to zero readings
    um = record_from_arrays(*[c * 1e6 for c in chans], speed_hz=SPEED, sample_rate_hz=RATE, units="um",
                            probe_angles_deg=ANGLES, static_offset=OFFSET * 1e6)
    np.testing.assert_allclose(um.static_offset, OFFSET, rtol=0, atol=1e-15)
    assert np.array_equal(um.rest_position, np.zeros((2, 2)))
    np.testing.assert_allclose(um.static_offset_std, rec.static_offset_std, rtol=1e-6)


@pytest.mark.parametrize("suffix", [".csv", ".npz", ".mat"])
def test_static_records_round_trip_exactly(tmp_path, suffix):
    rec = dataclasses.replace(read_record(static_csv(tmp_path / "s.csv")), set_name="coast-down 3",
                              source=None)
    path = write_record(rec, tmp_path / f"back{suffix}")
    back = read_record(path)
    assert back == rec and back.warnings == ()
    assert np.array_equal(back.rest_position, rec.rest_position)
    assert np.array_equal(back.static_offset, rec.static_offset)
    assert np.array_equal(back.static_offset_std, rec.static_offset_std)
    assert back.set_name == "coast-down 3"
    in_um = read_record(write_record(rec, tmp_path / f"um{suffix}", units="um"))
    np.testing.assert_allclose(in_um.static_offset, rec.static_offset, rtol=0, atol=1e-15)


@pytest.mark.parametrize("changes,field,phrase", [
    ({"rest_position": None}, "rest_position", "missing"),
    ({"static": None}, "static", "missing"),
    ({"static": "relative"}, "static", "'relative'"),
    ({"static": ""}, "static", "empty"),
    ({"rest_position": "1100, 950, 1210"}, "rest_position", "3 values"),
    ({"rest_position": "1100, 950, 1210, 1002, 7"}, "rest_position", "5 values"),
    ({"rest_position": "1100, nan, 1210, 1002"}, "rest_position", "not finite"),
    ({"rest_position": "1100, 950, gap, 1002"}, "rest_position", "'gap' is not a number"),
    ({"rest_position": "1100e9, 950, 1210, 1002"}, "rest_position", "check the 'units'"),
])
def test_inconsistent_static_metadata_is_refused(tmp_path, changes, field, phrase):
    path = static_csv(tmp_path / "bad.csv", meta_changes=changes)
    with pytest.raises(DataFormatError) as err:
        read_record(path)
    message = str(err.value)
    assert str(path) in message and field in message and phrase in message


def test_static_spelled_in_capitals_is_the_same_convention(tmp_path):
    a = read_record(static_csv(tmp_path / "a.csv"))
    b = read_record(static_csv(tmp_path / "b.csv", meta_changes={"static": "Absolute"}))
    assert a == b


# --- sets ---------------------------------------------------------------------------------------

def set_record(speed, *, set_name="coast", machine="paper_machine.toml", nodes=(6, 20),
               angles=((0.0, 90.0), (0.0, 90.0)), source=None):
    n = int(round(12 * 4000 / speed))
    w = 2 * math.pi * speed * np.arange(n) / 4000.0
    return record_from_arrays(*(a * np.cos(w + a) for a in (1e-5, 2e-5, 3e-5, 4e-5)), speed_hz=speed,
                              sample_rate_hz=4000.0, machine=machine, nodes=nodes, probe_angles_deg=angles,
                              set_name=set_name, source=source)


def test_a_set_is_read_sorted_by_speed(tmp_path):
    paths = [write_record(set_record(s), tmp_path / f"r{s:g}.csv") for s in (90.0, 60.0, 75.0)]
    recs = read_set(paths)
    assert [r.speed_hz for r in recs] == [60.0, 75.0, 90.0]
    assert {r.set_name for r in recs} == {"coast"}
    assert [r.source for r in recs] == [str(tmp_path / f"r{s}.csv") for s in ("60", "75", "90")]


@pytest.mark.parametrize("changes,phrase", [
    ({"set_name": "other"}, "set: 'other' disagrees with 'coast'"),
    ({"machine": "other.toml"}, "machine: 'other.toml' disagrees"),
    ({"machine": None}, "machine: None disagrees"),
    ({"nodes": (5, 21)}, "nodes (node1, node2): (5, 21) disagrees with (6, 20)"),
    ({"angles": ((45.0, 135.0), (0.0, 90.0))}, "probe_angles_deg"),
    ({"set_name": None}, "no '# set: NAME' line"),
])
def test_records_of_a_set_that_disagree_are_refused_naming_both_files(tmp_path, changes, phrase):
    good = write_record(set_record(60.0), tmp_path / "good.csv")
    bad = write_record(set_record(75.0, **changes), tmp_path / "bad.csv")
    with pytest.raises(DataFormatError) as err:
        read_set([good, bad])
    message = str(err.value)
    assert phrase in message and str(bad) in message
    if changes.get("set_name", "coast") is not None:
        assert str(good) in message


def test_two_records_of_a_set_at_one_speed_are_refused():
    a, b = set_record(75.0, source="a.csv"), set_record(75.05, source="b.csv")  # 0.07 % apart
    with pytest.raises(DataFormatError, match=r"b\.csv: speed_hz: 75\.05 Hz is the speed of a\.csv"):
        check_set([b, a])
    assert [r.source for r in check_set([set_record(75.2, source="c.csv"), a])] == ["a.csv", "c.csv"]


def test_a_set_needs_two_records(tmp_path):
    one = write_record(set_record(75.0), tmp_path / "one.csv")
    with pytest.raises(DataFormatError, match=r"one\.csv: set: a set needs at least 2 records"):
        read_set([one])
    with pytest.raises(DataFormatError, match="at least 2 records"):
        check_set([])


def test_group_records_groups_by_set_keeping_input_order():
    a1, b1, lone, a2, lone2, b2 = (set_record(s, set_name=n, source=f"{i}.csv") for i, (s, n) in enumerate(
        [(60.0, "A"), (60.0, "B"), (70.0, None), (80.0, "A"), (70.0, None), (50.0, "B")]))
    groups = group_records([a1, b1, lone, a2, lone2, b2])
    assert [[r.source for r in g] for g in groups] == [["0.csv", "3.csv"], ["1.csv", "5.csv"], ["2.csv"],
                                                       ["4.csv"]]
    assert group_records([]) == []


def test_record_fields_given_as_metadata_act_as_in_a_file():
    chans = [c for k in range(2) for c in probe_readings(orbit()[k], ANGLES[k])]
    rest = REST_UM.ravel() * 1e-6
    shifted = [c + r for c, r in zip(chans, rest)]
    rec = record_from_arrays(*shifted, speed_hz=SPEED, sample_rate_hz=RATE, probe_angles_deg=ANGLES,
                             metadata={"set": "A", "static": "absolute",
                                       "rest_position": ", ".join(repr(float(v)) for v in rest), "seed": "3"})
    assert rec.set_name == "A" and rec.is_static and dict(rec.metadata) == {"seed": "3"}
    np.testing.assert_allclose(rec.static_offset, 0.0, atol=1e-15)
    with pytest.raises(DataFormatError, match="'set'.*also given as an argument"):
        record_from_arrays(*chans, speed_hz=SPEED, sample_rate_hz=RATE, set_name="A", metadata={"set": "B"})
