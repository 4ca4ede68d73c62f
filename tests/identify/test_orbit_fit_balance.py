"""Identification with large orbits declared (issue 11): the linear chain plus the harmonic balance's
correction (`identify.fit.large_orbit`), on records from another path (`verification.orbit_record`: the 200 x 200
film, the 40-element rotor with another shaft damping, 6 harmonics and 28 points per revolution), and the
correction's parts. The same on the time integration's record (every harmonic): `test_orbit_fit.py`; the two
files run side by side under `pytest -n auto --dist loadfile`."""

import numpy as np
import pytest

from lubeviz.effects import parse_effect
from lubeviz.errors import InputError
from lubeviz.identify.batch import identify_record
from lubeviz.identify.forward.chain import ForwardChain
from lubeviz.identify.forward.measured import measure
from lubeviz.identify.fit.large_orbit import measured_scale, orbit_defect
from lubeviz.model.machine import DEFAULT_MACHINE
from lubeviz.verification import IndependentSpec
from lubeviz.verification.independent import make_record
from lubeviz.verification.orbit_record import make_orbit_records
from lubeviz.units import MLMIN_PER_M3S
from tests.identify.conftest import FIVE, LARGE_Q as Q, WEAKER_Q, inside

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def orbit_records():
    """Both records of this module, their balances (1.5 min each, then cached on disk) solved side by side."""
    return make_orbit_records([
        (IndependentSpec(speed_hz=75.0, q1_mlmin=Q[0], q2_mlmin=Q[1], seed=5), 1.0),
        (IndependentSpec(speed_hz=75.0, q1_mlmin=WEAKER_Q[0], q2_mlmin=WEAKER_Q[1], seed=5), 0.6)])


@pytest.fixture(scope="module")
def independent(orbit_records):
    return orbit_records[0]


@pytest.fixture(scope="module")
def weaker(orbit_records):
    """The same source at 0.6 x the machine's unbalance (2X 23 / 12 % of 1X, max eccentricity 0.23)."""
    return orbit_records[1]


def test_the_linear_fit_is_biased_and_flagged_the_large_orbit_fit_recovers_the_flows(machine, independent):
    """The plain linear fit: biased (-3.7 / -24.7 % measured) and flagged (chi2 ~1e4). With `large_orbit`
    declared the record is explained and the answer is within 5 % (measured -0.6 / -0.6 % with the first rounds
    on coarser films at Q_T-scaled flows, session 16; -2.7 / -2.8 % with the balance's exact slopes, session 15;
    -1.0 / -1.5 % with differenced slopes, session 14; -2.7 / -4.4 % while Q2's slope came from coarse films),
    not asserted at the 1 % of issue 11: Q2 lies above Q_T, in a flat chi2
    valley along which it trades against Q1, and the record itself supports no more: the 95 % intervals are
    [415, 471] for 460, [561, 646] for 600 (session 14: [379, 477], [564, 644]). They hold the truth
    since they carry the uncertainty of the correction's slope (`orbit_fit.SLOPE_UNCERTAINTY`); without it
    Q2's ended at 594-597, 0.5-1 % short (session 12, coarse slope), and the +- reported is never narrower.
    At 0.6 x the unbalance the answer is within 2 % (below)."""
    rec, truth = independent.record, independent.truth
    assert min(truth["ratio_2x"]) > 0.08  # a large orbit: a 2X the linear model lacks
    plain = identify_record(rec, machine).result
    plain_err = np.abs(plain.q * MLMIN_PER_M3S / np.array(Q) - 1)
    assert not plain.model_explains_data and plain_err.max() > 0.1
    r = identify_record(rec, machine, FIVE, effects=(parse_effect("large_orbit"),)).result
    err = np.abs(r.q * MLMIN_PER_M3S / np.array(Q) - 1)
    assert err.max() < 0.05
    assert r.model_explains_data  # the residual back to noise + model level
    assert inside(r.intervals[0], Q[0]) and inside(r.intervals[1], Q[1])
    for k in range(2):  # the +- shown claims no more than the intervals (which carry the slope's uncertainty)
        lo, hi = r.intervals[k]
        assert 1.96 * r.q_std[k] >= 0.999 * max(r.q[k] - lo, hi - r.q[k])
    assert r.effects["large_orbit"]["unbalance_scale"] == pytest.approx(1.0, abs=0.02)  # the declared unbalance
    info = r.effects["large_orbit"]
    assert info["converged"]
    # the balance's 2X at the answer against the source's (6 harmonics, finer film, other rotor): one orbit
    assert np.allclose(info["ratio_2x_model"], truth["ratio_2x"], rtol=0.15)


def test_the_diagnosis_names_large_orbits_at_a_smaller_unbalance_and_reads_its_size(machine, weaker):
    """Issue 12 on the large_orbit effect, at 0.6 x the declared unbalance (480 / 520 ml/min, just below
    Q_T): the plain model is flagged (chi2 ~2400, flows -3 / -7 %), the record's 2X line brings in the
    large-orbit candidate, which explains the record and is named, with the unbalance's size read from the
    record's 1X (0.59 measured). Before the size was read the balance ran at the declared unbalance, an orbit
    1.7 times too large, and this record was left "unexplained" (chi2 47-62). Flows after: -1.2 / -0.9 %
    measured (issue 12 asks 1 %; the bound here is 2 %), and the intervals hold them."""
    from lubeviz.diagnose import diagnose
    from lubeviz.diagnose.inputs import diagnosis_inputs

    q_true = np.array(WEAKER_Q)
    inputs = diagnosis_inputs([weaker.record], machine)
    d = diagnose(inputs.chains, inputs.measured, lines=inputs.lines)
    assert not d.before.explained
    assert np.abs(d.before.values[:2] * MLMIN_PER_M3S / q_true - 1).max() > 0.05
    assert d.added is not None and d.added.label == "large_orbit" and not d.ambiguous
    assert d.explained
    assert d.added.unbalance_scale == pytest.approx(0.6, rel=0.05)
    err = np.abs(d.final.values[:2] * MLMIN_PER_M3S / q_true - 1)
    assert err.max() < 0.02
    assert all(inside(d.final.intervals[n], q_true[k]) for k, n in enumerate(("q1", "q2")))
    assert "2X" in d.verdict and "film" in d.verdict and "x the declared unbalance" in d.verdict
    # a diagnosis tries the 5-harmonic balance and says where the finer flows come from
    assert "5-harmonic" in d.verdict and "identify --effect large_orbit" in d.verdict


def test_the_correction_s_own_error_is_within_its_budget_term(machine):
    """ModelBudget.orbit_defect (3 % of the correction's size, per entry): the correction with the model's 5
    harmonics and 24 points against 6 and 36 on the same films (measured 1.3 %; 3 and 16 gave 9 %)."""
    from lubeviz.identify.forward.budget import ModelBudget

    chain = ForwardChain(machine, 75.0, (6, 20))
    q = np.array(Q) / MLMIN_PER_M3S
    a, orbit = orbit_defect(chain, q, slope=False)
    # the finer balance's Newton starts from the coarser orbit (its harmonics padded) instead of the linear one: the
    # same orbit (the two corrections 6e-8 of its size apart, measured), 9 s instead of 21 s (measured)
    b, _ = orbit_defect(chain, q, slope=False, harmonics=6, points=36, start=orbit)
    size = np.linalg.norm(np.concatenate([b.x, b.y]))
    diff = np.abs(np.concatenate([a.x - b.x, a.y - b.y]))
    assert diff.max() <= ModelBudget().orbit_defect * size
    assert diff.max() > 0.002 * size  # the term is not empty: the truncation is seen


def test_large_orbits_with_an_effect_on_the_machine_are_refused(machine):
    from lubeviz.identify.fit.large_orbit import check_orbit_chain

    chain = ForwardChain(machine, 75.0, (6, 20), (parse_effect("viscosity:factor=0.8"),))
    with pytest.raises(InputError, match="probe effects only"):
        check_orbit_chain(chain)


@pytest.mark.parametrize("moment_scale, phase_deg", [(0.6, 40.0), (1.5, -120.0)])
def test_the_unbalance_s_size_is_read_from_the_record(machine, tmp_path, moment_scale, phase_deg):
    """The balance must run at the orbit the record shows (the features are invariants of the unbalance, the
    nonlinearity is not). A machine whose unbalance is `moment_scale` x the declared one, at another phase,
    recorded by the independent source (linear: 40-element rotor, 200 x 200 films, other shaft damping, 12 dB):
    the size read from its 1X at the true flows against the declared machine's chain is that scale, within 3 %
    (the two paths' 1X differ by about 1 % in size here); the phase does not enter."""
    text = DEFAULT_MACHINE.read_text()
    assert "moment_kg_m = 1.24e-2" in text and 'phase_deg = 0.0' in text
    model = tmp_path / "machine.toml"
    model.write_text(text.replace("moment_kg_m = 1.24e-2", f"moment_kg_m = {1.24e-2 * moment_scale!r}")
                     .replace('phase_deg = 0.0\n\n# Two', f'phase_deg = {phase_deg!r}\n\n# Two'))
    ind = make_record(IndependentSpec(speed_hz=75.0, q1_mlmin=450.0, q2_mlmin=520.0, seed=11, machine=str(model)))
    chain = ForwardChain(machine, 75.0, ind.record.nodes)
    q = np.array([450.0, 520.0]) / MLMIN_PER_M3S
    assert measured_scale(chain, measure(ind.record), q) == pytest.approx(moment_scale, rel=0.03)


def test_the_secant_curvature_is_exact_along_the_step_and_the_correction_carries_it():
    """Powell's symmetric secant update from two exact slopes of a quadratic correction: its curvature times
    the step is the slopes' change, it stays symmetric, and `ResponseDefect.at` then reproduces the quadratic
    along the step (a fit round's model of the correction between its balances)."""
    from lubeviz.identify.forward.chain import ResponseDefect
    from lubeviz.identify.fit.large_orbit import secant_curvature

    rng = np.random.default_rng(3)
    H = rng.normal(size=(2, 2, 2)) + 1j * rng.normal(size=(2, 2, 2))
    H = H + H.transpose(0, 2, 1)
    b = rng.normal(size=(2, 2)) + 1j * rng.normal(size=(2, 2))
    a = rng.normal(size=2) + 1j * rng.normal(size=2)
    Hs = rng.normal(size=(2, 2, 2, 2))
    Hs = Hs + Hs.transpose(0, 1, 3, 2)
    bs = rng.normal(size=(2, 2, 2))

    def value(q):
        return a + b @ q + 0.5 * np.einsum("pkl,k,l->p", H, q, q)

    def defect(q):
        return ResponseDefect(x=value(q), y=2 * value(q), static=np.einsum("pjk,k->pj", bs, q), q0=q,
                              dx=b + H @ q, dy=2 * (b + H @ q), dstatic=bs + Hs @ q)

    q0, q1 = np.array([1.0, 2.0]), np.array([1.4, 2.3])
    new = secant_curvature(defect(q0), defect(q1))
    s = q1 - q0
    np.testing.assert_allclose(new.hx @ s, H @ s, atol=1e-12)
    np.testing.assert_allclose(new.hstatic @ s, Hs @ s, atol=1e-12)
    np.testing.assert_allclose(new.hx, new.hx.transpose(0, 2, 1))
    for t in (-1.0, 0.5, 2.0):  # along the step the quadratic model is exact
        d, _ = new.at(q1 + t * s)
        np.testing.assert_allclose(d[:, 0], value(q1 + t * s), atol=1e-12)
    # across the step nothing is known from a first update: no curvature is invented there
    n = np.array([-s[1], s[0]])
    assert np.abs(np.einsum("pkl,k,l->p", new.hx, n, n)).max() < 1e-12
