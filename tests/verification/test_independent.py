"""The independent record source: close to the model but not the model; effects act as declared; seeded.

Runs integrate 6 s and keep 5 (total_s=6): at 75 Hz the slowest mode has decayed to ~4e-6 by then.
Film equilibria are cached under $LUBEVIZ_CACHE_DIR (or the user cache dir); a cold run solves ~8
bearing equilibria on the 200 x 200 mesh (~2 s each).
"""

import math

import numpy as np
import pytest

from lubeviz.errors import InputError
from lubeviz.rotor.film_bearings import machine_response
from lubeviz.signals.features import record_features
from lubeviz.verification import (IndependentSpec, clean_corpus, make_record, make_set, max_growth_rate, parse_effect,
                                  steady_truth, write_record_csv)
from lubeviz.units import MLMIN_PER_M3S
from tests.records import read_record

SPEED = 75.0
Q = 545.0  # ml/min, ~Q_T at 75 Hz
FAST = dict(total_s=6.0, duration_s=5.0)


def spec(*effects, **kw):
    base = dict(speed_hz=SPEED, q1_mlmin=Q, q2_mlmin=Q, snr_db=None, effects=effects, **FAST)
    base.update(kw)
    return IndependentSpec(**base)


@pytest.fixture(scope="module")
def base():
    return make_record(spec())


def _fb_phi(rec):
    f = record_features(rec.record, harmonics=1)
    return np.array([p.fb for p in f.planes]), np.array([p.phi for p in f.planes])


def _angle_diff(a, b):
    """a - b for orbit angles (defined modulo pi), in (-pi/2, pi/2]."""
    return (np.asarray(a) - np.asarray(b) + 0.5 * np.pi) % np.pi - 0.5 * np.pi


# --- (a) close to the model, but not identical --------------------------------------------------

@pytest.mark.parametrize("q", [400.0, 545.0, 800.0])
def test_close_to_model_but_not_identical(machine, q):
    rec = make_record(spec(q1_mlmin=q, q2_mlmin=q, total_s=15.0))  # starved: a slow whirl mode
    model, _ = machine_response(machine, (q / MLMIN_PER_M3S, q / MLMIN_PER_M3S), 2 * math.pi * SPEED, nodes=(6, 20))
    t = rec.truth
    dfb = t["fb"] / model.fb - 1.0
    dphi = np.degrees(_angle_diff(t["phi_rad"], model.phi))
    dzf = np.abs(t["zf"]) / np.abs(model.zf) - 1.0
    print(f"\n{SPEED} Hz, Q = {q} ml/min: dfb = {100 * dfb} %, dphi = {dphi} deg, d|Zf| = {100 * dzf} %")
    assert np.all(np.abs(dfb) < 0.03) and np.all(np.abs(dphi) < 2.0) and np.all(np.abs(dzf) < 0.05)
    assert np.max(np.abs(dfb)) > 1e-4 or np.max(np.abs(dphi)) > 1e-3  # another path, not the model
    # the integrated record carries the same features as the source's own steady state
    fb, phi = _fb_phi(rec)
    np.testing.assert_allclose(fb, t["fb"], rtol=2e-3)
    np.testing.assert_allclose(_angle_diff(phi, t["phi_rad"]), 0.0, atol=2e-3)


def test_start_up_transient_has_decayed(base):
    assert base.truth["max_growth_rate"] < 0.0
    assert base.truth["transient_factor"] < 1e-3
    assert base.truth["transient_residual"] < 2e-3  # Newmark period error ~2e-4 plus what is left


# --- (b) each effect acts as declared --------------------------------------------------------------

def test_probe_gain_scales_that_channel_only():
    a = make_record(spec(snr_db=12.0, seed=3))
    b = make_record(spec("probe_gain:channel=x1,gain=1.1", snr_db=12.0, seed=3))
    da, db = a.record.displacement, b.record.displacement
    np.testing.assert_allclose(db[0, 0], 1.1 * da[0, 0], rtol=1e-12, atol=0)  # the noise scales with it
    np.testing.assert_array_equal(db[0, 1], da[0, 1])
    np.testing.assert_array_equal(db[1], da[1])


def test_probe_rotation_rotates_the_resolved_orbit(base):
    angle = 10.0
    rot = make_record(spec(("probe_rotation", {"plane": 1, "angle_deg": angle})))
    a = math.radians(-angle)
    R = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    np.testing.assert_allclose(rot.record.xy()[0], R @ base.record.xy()[0], atol=1e-12 * 1e-3)
    np.testing.assert_array_equal(rot.record.xy()[1], base.record.xy()[1])
    (fb0, phi0), (fb1, phi1) = _fb_phi(base), _fb_phi(rot)
    np.testing.assert_allclose(fb1, fb0, rtol=1e-9)
    assert math.degrees(_angle_diff(phi1[0], phi0[0])) == pytest.approx(-angle, abs=1e-6)


def test_probe_angles_at_45_135_read_the_same_orbit(base):
    diag = make_record(spec(probe_angles_deg=((45.0, 135.0), (45.0, 135.0))))
    np.testing.assert_allclose(diag.record.xy(), base.record.xy(), atol=1e-15)


def test_second_unbalance_is_linear(base):
    zero = make_record(spec("unbalance2:node=13,ratio=0,phase_deg=40"))
    np.testing.assert_array_equal(zero.record.displacement, base.record.displacement)
    same = make_record(spec("unbalance2:node=13,ratio=1,phase_deg=0"))  # doubles the main unbalance
    np.testing.assert_allclose(same.record.displacement, 2.0 * base.record.displacement, rtol=1e-9, atol=1e-15)
    other = make_record(spec("unbalance2:node=10,ratio=0.5,phase_deg=90"))
    assert not np.allclose(other.record.displacement, base.record.displacement, rtol=1e-2)


def test_stiff_pedestals_change_nothing_soft_ones_do(base):
    stiff = make_record(spec("pedestals:mass_kg=1,stiffness_n_m=1e12,damping_ns_m=1e5"))
    fb0, phi0 = base.truth["fb"], base.truth["phi_rad"]
    np.testing.assert_allclose(stiff.truth["fb"], fb0, rtol=2e-3)
    np.testing.assert_allclose(_angle_diff(stiff.truth["phi_rad"], phi0), 0, atol=2e-3)
    soft = make_record(spec("pedestals:mass_kg=50,stiffness_n_m=3e8,damping_ns_m=2e4,bearing=1"))
    assert abs(soft.truth["fb"][0] / fb0[0] - 1) > 0.01
    fb, phi = _fb_phi(soft)  # the integrated relative motion agrees with the steady state
    np.testing.assert_allclose(fb, soft.truth["fb"], rtol=2e-3)


def test_bow_of_zero_changes_nothing_and_bow_is_linear(base):
    zero = make_record(spec("bow:node=13,amplitude_um=0,phase_deg=30"))
    np.testing.assert_array_equal(zero.record.displacement, base.record.displacement)
    d = [make_record(spec(f"bow:node=13,amplitude_um={a},phase_deg=30")).record.displacement
         - base.record.displacement for a in (5.0, 10.0)]
    assert np.max(np.abs(d[0])) > 1e-7  # 5 um of bow moves the journals by more than 0.1 um
    np.testing.assert_allclose(d[1], 2.0 * d[0], rtol=1e-8, atol=1e-15)


def test_seal_cross_coupling_changes_the_orbit(base):
    zero = make_record(spec("seal:node=13,kxy_n_m=0"))
    np.testing.assert_array_equal(zero.record.displacement, base.record.displacement)
    seal = make_record(spec("seal:node=13,kxy_n_m=2e6"))
    # a forward (destabilizing) cross-coupling: more forward whirl, a less damped whirl mode
    assert np.all(seal.truth["fb"] > 1.003 * base.truth["fb"])
    assert seal.truth["max_growth_rate"] > base.truth["max_growth_rate"]


def test_thicker_oil_lifts_the_journal(base):
    thick = make_record(spec("viscosity:factor=1.3,bearing=1"))
    e0, e1 = (np.hypot(*r.truth["journal_positions_m"].T) for r in (base, thick))
    assert e1[0] < 0.95 * e0[0]
    assert e1[1] == e0[1]
    assert thick.truth["viscosity_pa_s"][0] == pytest.approx(1.3 * base.truth["viscosity_pa_s"][0])


def test_static_reading_gives_back_the_journal_position_and_clearance(tmp_path):
    rec = make_record(spec("clearance:bearing=2,clearance_um=150", static=True, total_s=10.0))
    r, t = rec.record, rec.truth
    assert r.is_static
    np.testing.assert_allclose(r.rest_position, t["rest_readings_m"], rtol=1e-12)
    clear = np.array(t["clearance_m"])
    assert clear[1] == pytest.approx(150e-6)
    position = r.displacement.mean(axis=2) - r.rest_position + np.column_stack([np.zeros(2), -clear])
    np.testing.assert_allclose(position, t["journal_positions_m"], atol=5e-9)  # 1X averages out
    np.testing.assert_allclose(r.static_offset + np.column_stack([np.zeros(2), -clear]),
                               t["journal_positions_m"], atol=5e-9)
    path = write_record_csv(rec, tmp_path / "static.csv", units="um")
    text = path.read_text()
    assert "# static: absolute" in text and "# synthetic: independent" in text
    back = read_record(path)
    np.testing.assert_allclose(back.rest_position, r.rest_position, rtol=1e-12)
    assert back.warnings == ()


def test_effects_are_validated():
    with pytest.raises(InputError, match="allowed"):
        parse_effect("probe_gain:channel=x1,gian=1.1")
    with pytest.raises(InputError, match="unknown effect"):
        spec("wobble:amount=1")
    with pytest.raises(InputError, match="bearing centres"):
        make_record(spec("bow:node=3,amplitude_um=5"))
    # a machine's parts by number, whatever its count; the count is the machine's, checked where the record is made
    assert parse_effect("viscosity:factor=0.9,bearing=3")[1]["bearing"] == 3
    assert parse_effect("probe_gain:channel=Y3,gain=1.1")[1]["channel"] == "y3"
    for bad in ("viscosity:factor=0.9,bearing=0", "probe_rotation:plane=0,angle_deg=3",
                "probe_gain:channel=z1,gain=1.1", "probe_gain:channel=x0,gain=1.1"):
        with pytest.raises(InputError, match="bearing|plane|channel"):
            parse_effect(bad)
    with pytest.raises(InputError, match="2 fluid-film bearing"):
        make_record(spec("viscosity:factor=0.9,bearing=3"))
    with pytest.raises(InputError, match="2 plane"):
        make_record(spec("probe_gain:channel=x3,gain=1.1"))


# --- (c) determinism --------------------------------------------------------------------------------

def test_same_seed_same_record_other_seed_other_noise():
    a, b = (make_record(spec(snr_db=12.0, seed=7)) for _ in range(2))
    c = make_record(spec(snr_db=12.0, seed=8))
    assert a.record == b.record
    assert not np.array_equal(a.record.displacement, c.record.displacement)
    assert a.record.metadata["seed"] == "7" and a.record.metadata["synthetic"] == "independent"


def test_set_links_records_of_one_machine(tmp_path):
    recs = make_set([spec(speed_hz=70.0, seed=1), spec(speed_hz=80.0, seed=2)], "coast")
    assert [r.record.set_name for r in recs] == ["coast", "coast"]
    back = read_record(write_record_csv(recs[0], tmp_path / "a.csv"))
    assert back.set_name == "coast" and back.metadata["q1_mlmin"] == "545" and back.warnings == ()
    with pytest.raises(InputError, match="q1_mlmin differs"):
        make_set([spec(speed_hz=70.0), spec(speed_hz=80.0, q1_mlmin=500.0)], "bad")


def test_unstable_operating_point_gives_no_record():
    s = spec("seal:node=13,kxy_n_m=2e7")
    assert max_growth_rate(s) > 0.0
    assert steady_truth(s)["fb"].shape == (2,)  # the steady solution still exists mathematically
    with pytest.raises(InputError, match="unstable"):
        make_record(s)


def test_clean_corpus_draws_decaying_specs_in_range():
    specs = clean_corpus(2, np.random.default_rng(5), speed_step_hz=25.0)
    assert len(specs) == 2
    for s in specs:
        assert 50.0 <= s.speed_hz <= 100.0 and s.effects == ()
        assert s.nodes in ((6, 20), (5, 21))
        assert s.probe_angles_deg in (((0.0, 90.0), (0.0, 90.0)), ((45.0, 135.0), (45.0, 135.0)))
        assert max_growth_rate(s) < -0.5  # e^-5 left after the 10 s before the kept window
    again = clean_corpus(2, np.random.default_rng(5), speed_step_hz=25.0)
    assert again == specs


def test_film_cache_is_keyed_validated_and_rebuilt(tmp_path, monkeypatch, paper_bearing):
    from lubeviz.verification import equilibria

    monkeypatch.setenv("LUBEVIZ_CACHE_DIR", str(tmp_path))
    b = paper_bearing.copy(n_circumferential=60, n_axial=20, groove_refinement=1)  # small: a cache test
    args = (b, 2 * math.pi * 75.0, (0.0, -3272.8), 545.0 / MLMIN_PER_M3S)
    cold = equilibria.film_point(*args)
    warm = equilibria.film_point(*args)
    assert not cold.cached and warm.cached
    np.testing.assert_array_equal(warm.K, cold.K)
    other = equilibria.film_point(b, 2 * math.pi * 75.0, (0.0, -3272.8), 500.0 / MLMIN_PER_M3S)
    assert not other.cached  # another supply, another key
    files = sorted((tmp_path / "independent").glob("*.npz"))
    assert len(files) == 2
    for f in files:
        f.write_bytes(b"not a zip file")
    with pytest.warns(equilibria.StaleIndependentCacheWarning):
        again = equilibria.film_point(*args)
    assert not again.cached
    np.testing.assert_array_equal(again.K, cold.K)


def test_orbit_balance_cache_round_trips_is_keyed_and_rebuilt(tmp_path, monkeypatch):
    """The large-orbit records' balance (1.5 min each) is cached like the equilibria: the same harmonics back
    on a hit without solving, another key for other flows or another unbalance, a damaged file solved again."""
    from lubeviz.rotor.orbit_balance import OrbitBalance
    from lubeviz.verification import equilibria, orbit_record

    monkeypatch.setenv("LUBEVIZ_CACHE_DIR", str(tmp_path))
    rng = np.random.default_rng(3)
    h = orbit_record.HARMONICS + 1

    def c(*shape):
        return rng.normal(size=shape) + 1j * rng.normal(size=shape)

    solved = []

    def solve():
        ob = OrbitBalance(omega=2 * math.pi * 75.0, nodes=(11, 39), x=c(h, 2), y=c(h, 2), bearing_x=c(h, 2),
                          bearing_y=c(h, 2), linear_x=c(2), linear_y=c(2), iterations=7, film_solves=400,
                          residual=1e-8, max_eccentricity=0.28, seconds=200.0)
        solved.append(ob)
        return ob, {}

    spec = IndependentSpec(speed_hz=75.0, q1_mlmin=460.0, q2_mlmin=600.0, seed=5)
    cold, _ = orbit_record._cached_balance(spec, 1.0, solve)
    warm, extra = orbit_record._cached_balance(spec, 1.0, solve)
    assert len(solved) == 1 and extra == {}
    for name in ("x", "y", "bearing_x", "bearing_y", "linear_x", "linear_y"):
        np.testing.assert_array_equal(getattr(warm, name), getattr(cold, name))
    assert warm.iterations == 7 and warm.max_eccentricity == 0.28 and warm.nodes == cold.nodes
    assert warm.residual == 1e-8
    # the time integration's orbit is keyed apart and keeps its extra figure
    h_time = orbit_record.TIME_HARMONICS + 1
    timed = OrbitBalance(omega=2 * math.pi * 75.0, nodes=(11, 39), x=c(h_time, 2), y=c(h_time, 2),
                         bearing_x=c(h_time, 2), bearing_y=c(h_time, 2), linear_x=c(2), linear_y=c(2), iterations=0,
                         film_solves=9000, residual=0.004, max_eccentricity=0.28, seconds=240.0)
    orbit_record._cached_balance(spec, 1.0, lambda: (timed, {"half_order": 0.027}), "time")
    again, extra = orbit_record._cached_balance(spec, 1.0, solve, "time")
    assert extra == {"half_order": 0.027} and again.x.shape == (h_time, 2) and len(solved) == 1
    np.testing.assert_array_equal(again.x, timed.x)
    for f in (tmp_path / "independent").glob("orbit-*.npz"):
        if np.load(f)["x"].shape[0] == h_time:
            f.unlink()
    orbit_record._cached_balance(IndependentSpec(speed_hz=75.0, q1_mlmin=460.0, q2_mlmin=601.0, seed=5), 1.0, solve)
    orbit_record._cached_balance(spec, 0.6, solve)
    orbit_record._cached_balance(IndependentSpec(speed_hz=75.0, q1_mlmin=460.0, q2_mlmin=600.0, seed=9), 1.0, solve)
    assert len(solved) == 3  # flows and unbalance are keys; the seed (noise, after the balance) is not
    files = sorted((tmp_path / "independent").glob("orbit-*.npz"))
    assert len(files) == 3
    for f in files:
        f.write_bytes(b"not a zip file")
    with pytest.warns(equilibria.StaleIndependentCacheWarning):
        orbit_record._cached_balance(spec, 1.0, solve)
    assert len(solved) == 4


def test_an_edit_to_the_benches_keeps_the_orbit_records_an_edit_to_their_code_does_not(monkeypatch):
    """The orbit records' key hashes the film, rotor and verification sources, not the benches (lubeviz/bench,
    outside them): a bench edit keeps nothing stored in them and must not throw away hours of time-integration
    records; an edit to the code that makes them must, and an edit to its wording must not."""
    import pathlib

    from lubeviz.verification import equilibria, orbit_record

    spec = IndependentSpec(speed_hz=75.0, q1_mlmin=460.0, q2_mlmin=600.0, seed=5)
    original = pathlib.Path.read_bytes

    def key_with_edit(name, folder=None, edit=b"\nAN_EDIT = 1\n"):
        def edited(path):
            data = original(path)
            hit = path.name == name and (folder is None or path.parent.name == folder)
            return data + edit if hit else data

        monkeypatch.setattr(pathlib.Path, "read_bytes", edited)
        equilibria.code_version.cache_clear()
        try:
            return orbit_record._balance_key(spec, 1.0, "time")
        finally:
            monkeypatch.setattr(pathlib.Path, "read_bytes", original)
            equilibria.code_version.cache_clear()

    before = orbit_record._balance_key(spec, 1.0, "time")
    assert key_with_edit("records.py", "bench") == before
    assert key_with_edit("orbit_record.py") != before
    assert key_with_edit("orbit_balance.py") != before  # the rotor's balance
    # wording is not code (`lubeviz.code_key`): a comment, or a docstring reworded, keeps the records
    assert key_with_edit("orbit_balance.py", edit=b"\n# a comment\n") == before
    doc = b'"""'
    reworded = original(pathlib.Path(orbit_record.__file__)).replace(doc, doc + b"Reworded. ", 1)
    assert key_with_edit("orbit_record.py", edit=b"") == before  # (the helper itself, unedited)
    monkeypatch.setattr(pathlib.Path, "read_bytes",
                        lambda path: reworded if path.name == "orbit_record.py" else original(path))
    equilibria.code_version.cache_clear()
    try:
        assert orbit_record._balance_key(spec, 1.0, "time") == before
    finally:
        monkeypatch.setattr(pathlib.Path, "read_bytes", original)
        equilibria.code_version.cache_clear()


def test_the_orbit_bench_counts_a_balance_that_does_not_settle_as_a_miss():
    """`bench_orbit`'s figures at one harmonic count (`orbit_summary`): an identification whose balance did not
    settle is a row with `failed`, counted in its own rate and as a miss of the 1 %, not the bench's end; the error
    and coverage figures are over the rows that finished."""
    from lubeviz.bench.records import orbit_summary

    def row(err, holds=(True, True)):
        return {"max_abs_error_pct": err, "holds": list(holds), "above_qt": [False, True], "explained": True,
                "truth_in_alt": False, "seconds": 100.0 + err, "sigma_pct": [2.0, 3.0 + err]}

    rows = [row(0.5), row(2.0, (True, False)), {"failed": "harmonic balance did not settle", "q_mlmin": [1, 2],
                                                 "unbalance_scale": 0.7}]
    s = orbit_summary(rows)
    assert s["records"] == 3 and (s["failed"]["k"], s["failed"]["n"]) == (1, 3)
    assert (s["within_1pct"]["k"], s["within_1pct"]["n"]) == (1, 3)
    assert s["error_pct_max"] == 2.0 and s["error_pct_median"] == 1.25
    assert (s["coverage_q2"]["k"], s["coverage_q2"]["n"]) == (1, 2)
    assert s["sigma_pct_median"] == 4.25 and s["fit_s_median"] == 101.25
    nothing = orbit_summary([rows[2]])
    assert nothing["failed"]["k"] == 1 and nothing["within_1pct"]["k"] == 0 and nothing["sigma_pct_median"] is None
    assert "time_round_coverage" not in s  # without time rounds no such figure
    # with time rounds, the coverage of their own intervals: a record counts when both flows are inside
    timed = [{**row(0.2), "time_round_covered": [True, True]}, {**row(0.3), "time_round_covered": [True, False]},
             rows[2]]
    t = orbit_summary(timed)["time_round_coverage"]
    assert (t["k"], t["n"]) == (1, 2)
