"""The model budget's structure (issue 15): which term scales with what, at the record's operating point."""

import numpy as np
import pytest

from lubeviz.identify.forward.budget import ModelBudget, model_sensitivity
from lubeviz.identify.forward.chain import ForwardChain
from lubeviz.identify.forward.model import ALL_FEATURES

PER_BEARING = 12  # K scale + 4 entries, C scale + 4 entries, viscosity, clearance


@pytest.fixture(scope="module")
def chain(machine):
    return ForwardChain(machine, 75.0, (6, 20))


def _mesh_columns(S, k):
    return S[:, PER_BEARING * k:PER_BEARING * k + 10]


def test_the_mesh_terms_of_a_flooded_bearing_scale_with_flooded_mesh_and_a_starved_one_s_do_not(chain):
    """Bearing 1 at 0.8 Q_T (starved), bearing 2 at 1.3 Q_T (flooded, past the 1.1 Q_T ramp): the mesh study
    moves C by 0.8 % starved and 0.14-0.35 % at and above Q_T, so only the flooded bearing's terms shrink."""
    theta = chain.q_threshold * np.array([0.8, 1.3])
    full = model_sensitivity(chain, theta, ALL_FEATURES, ModelBudget(flooded_mesh=1.0))
    half = model_sensitivity(chain, theta, ALL_FEATURES, ModelBudget(flooded_mesh=0.5))
    assert np.allclose(_mesh_columns(half, 0), _mesh_columns(full, 0), rtol=1e-9, atol=0)
    assert np.allclose(_mesh_columns(half, 1), 0.5 * _mesh_columns(full, 1), rtol=1e-6, atol=1e-15)
    assert np.abs(_mesh_columns(full, 1)).max() > 0
    # the shaft damping is not a film mesh term: unchanged
    beta = slice(2 * PER_BEARING, 2 * PER_BEARING + 2)
    assert np.allclose(half[:, beta], full[:, beta])


def test_the_flooded_scale_sets_in_smoothly_between_q_t_and_1_1_q_t(chain):
    ratios = []
    for r in (1.0, 1.01, 1.05, 1.08, 1.1):
        theta = chain.q_threshold * np.array([0.8, r])
        full = _mesh_columns(model_sensitivity(chain, theta, ALL_FEATURES, ModelBudget(flooded_mesh=1.0)), 1)
        half = _mesh_columns(model_sensitivity(chain, theta, ALL_FEATURES, ModelBudget(flooded_mesh=0.5)), 1)
        ratios.append(np.linalg.norm(half) / np.linalg.norm(full))
    assert ratios[0] == pytest.approx(1.0) and ratios[-1] == pytest.approx(0.5)
    assert all(a >= b for a, b in zip(ratios, ratios[1:]))  # monotone, no jump at Q_T
    assert ratios[1] > 0.98  # flat at Q_T: no kink added to the film's own


def test_no_budget_is_the_noise_alone(chain):
    S = model_sensitivity(chain, chain.q_threshold, ALL_FEATURES, ModelBudget.none())
    assert not np.any(S)


def test_with_large_orbits_the_flooded_bearing_keeps_the_full_mesh_terms(chain):
    """Along a large orbit the film cavitates and refills even above Q_T: no flooded reduction then."""
    from lubeviz.identify.forward.chain import ResponseDefect

    zero = np.zeros((2, 2), complex)
    d = ResponseDefect(x=np.zeros(2, complex), y=np.zeros(2, complex), static=np.zeros((2, 2)),
                       q0=chain.q_threshold.copy(), dx=zero, dy=zero, dstatic=np.zeros((2, 2, 2)))
    theta = chain.q_threshold * np.array([0.8, 1.3])
    big = chain.with_defect(d)
    full = model_sensitivity(big, theta, ALL_FEATURES, ModelBudget(flooded_mesh=1.0))
    half = model_sensitivity(big, theta, ALL_FEATURES, ModelBudget(flooded_mesh=0.5))
    assert np.allclose(_mesh_columns(half, 1), _mesh_columns(full, 1))


def test_the_supply_flow_term_moves_the_features_along_each_flow_s_own_direction(chain):
    """Two meshes map the same film to flows 0.3 % apart: the term is the flow's own derivative times s q, so it
    widens the flows' intervals and leaves the fit's chi2 alone (a direction the fit absorbs)."""
    from lubeviz.identify.forward.budget import n_terms

    theta = chain.q_threshold * np.array([0.8, 1.3])
    s = 0.003
    S = model_sensitivity(chain, theta, ALL_FEATURES, ModelBudget(supply_flow=s))
    none = model_sensitivity(chain, theta, ALL_FEATURES, ModelBudget(supply_flow=0.0))
    g, J = chain.jacobian(theta, ALL_FEATURES)
    cols = [j for j in range(n_terms(2, 2)) if np.any(S[:, j] != none[:, j])]
    assert cols == [2 * PER_BEARING + 2, 2 * PER_BEARING + 3]
    for k, j in enumerate(cols):
        assert np.allclose(S[:, j], s * theta[k] * J[:, k], rtol=1e-3, atol=1e-6 * np.abs(J[:, k]).max() * theta[k])


def test_over_a_set_the_mesh_terms_correlate_by_the_stated_factor_and_the_rest_is_common(machine):
    from lubeviz.identify.forward.budget import mesh_columns, set_covariance

    chains = [ForwardChain(machine, f, (6, 20)) for f in (60.0, 80.0)]
    blocks = [model_sensitivity(c, c.q_threshold, ALL_FEATURES, ModelBudget()) for c in chains]
    n = len(ALL_FEATURES)
    stacked = np.concatenate(blocks)
    assert np.allclose(set_covariance(blocks, 1.0, 2, 2), stacked @ stacked.T)
    mesh = mesh_columns(2, 2)
    zero = set_covariance(blocks, 0.0, 2, 2)
    assert np.allclose(zero[:n, n:], blocks[0][:, ~mesh] @ blocks[1][:, ~mesh].T)  # across records: common terms
    for i, b in enumerate(blocks):  # each record alone: its whole budget, whatever the correlation
        sl = slice(i * n, (i + 1) * n)
        for rho in (0.0, 0.85, 1.0):
            assert np.allclose(set_covariance(blocks, rho, 2, 2)[sl, sl], b @ b.T)
    mixed = set_covariance(blocks, 0.85, 2, 2)
    assert np.allclose(mixed, 0.85 * set_covariance(blocks, 1.0, 2, 2) + 0.15 * zero)
    assert np.linalg.eigvalsh(mixed).min() > -1e-12 * np.abs(mixed).max()


def test_the_shaft_damping_is_carried_from_none_to_several_times_as_two_one_sided_columns(machine, chain):
    """The range is a 95 % range; each column is the change to beta at its 1-sigma point (half-way), from a rotor
    assembled with that damping."""
    theta = chain.q_threshold * np.array([0.9, 1.1])
    budget = ModelBudget(shaft_damping_low=0.0, shaft_damping_high=4.0)
    S = model_sensitivity(chain, theta, ALL_FEATURES, budget)
    beta = machine.shaft_damping_beta
    mid = chain.features(theta, ALL_FEATURES)
    for j, factor, sign in ((0, 2.5, 1.0), (1, 0.5, -1.0)):
        other = ForwardChain(machine, 75.0, (6, 20), shaft_damping_beta=beta * factor)
        expect = sign * (other.features(theta, ALL_FEATURES) - mid) / np.sqrt(2.0)
        assert np.allclose(S[:, 2 * PER_BEARING + j], expect, rtol=1e-6, atol=1e-12)
    flat = model_sensitivity(chain, theta, ALL_FEATURES, ModelBudget(shaft_damping_low=1.0, shaft_damping_high=1.0))
    assert not np.any(flat[:, 2 * PER_BEARING:2 * PER_BEARING + 2])


def test_a_candidate_s_shaft_damping_columns_on_three_supports_are_those_of_a_chain_built_afresh():
    """A diagnosis's candidates are made from one chain (`with_effects`) and share the rotors of the other shaft
    damping it built (`ForwardChain.damped_rotor`, `with_rotor`: the statics, which do not see damping, shared too).
    On the fan (three films and a roller, its loads following the flows) with a bow in the first wheel's span, the
    columns equal those of chains assembled from scratch with that damping and that effect."""
    from lubeviz.effects import Bow
    from lubeviz.model.machine import load_machine

    fan = load_machine("models/three_bearing_fan.toml")
    base = ForwardChain(fan, 24.75)
    bow = Bow(span=2, amplitude_um=20.0, phase_deg=40.0)
    cand = base.adding(bow)
    theta = cand.start()
    theta[:3] = base.q_threshold * np.array([0.8, 1.2, 1.5])
    budget = ModelBudget(shaft_damping_low=0.0, shaft_damping_high=4.0)
    names = ALL_FEATURES  # planes 1 and 2 (A, B)
    S = model_sensitivity(cand, theta, names, budget)
    assert cand.damped_rotor(fan.shaft_damping_beta * 2.5) is base.damped_rotor(fan.shaft_damping_beta * 2.5)
    mid = cand.features(theta, names)
    col = 12 * 3
    for j, factor, sign in ((0, 2.5, 1.0), (1, 0.5, -1.0)):
        other = ForwardChain(fan, 24.75, None, (bow,), shaft_damping_beta=fan.shaft_damping_beta * factor)
        expect = sign * (other.features(theta, names) - mid) / np.sqrt(2.0)
        assert np.abs(expect).max() > 0
        np.testing.assert_allclose(S[:, col + j], expect, rtol=1e-6, atol=1e-12 * np.abs(expect).max())
