"""Campbell diagram, critical speeds and instability threshold (lubeviz.rotor.stability).

Expected values come from outside the code under test: the analytic rigid rotor on cross-coupled
bearings, the pinned-pinned rotor's synchronous eigenproblem solved directly, the film model's own cold
equilibrium, and the paper's statement that 75 Hz lies between the first critical speed and the
instability threshold.
"""

import math

import numpy as np
import pytest
import scipy.linalg

from lubeviz.errors import InputError
from lubeviz.film.equilibrium import find_equilibrium, flooded_threshold
from lubeviz.film.feed import Feed
from lubeviz.rotor import (
    RigidDisc,
    TimoshenkoBeam,
    assemble,
    directional_components,
    isotropic,
    node_dofs,
    rotor_from_machine,
)
from lubeviz.rotor.stability import (
    Supply,
    film_coefficients_over_speed,
    machine_stability,
    stability_map,
)
from lubeviz.rotor.statics import bearing_static_loads
from lubeviz.units import MLMIN_PER_M3S

HZ = 2.0 * math.pi
K_RIGID = 1e6  # N/m per bearing


def rigid_rotor(disc_diameter=None):
    """A symmetric, practically rigid rotor (E x 1000) between bearings at nodes 1 and 5, no shaft damping.

    Its cylindrical mode decouples from the conical one (symmetry) and feels no gyroscopic moment, so on
    two bearings K = [[k, q], [-q, k]], C = c I it obeys, with z = x + i y (SPEC §1: f = -K q - C q'),
        m z'' + 2 c z' + 2 (k - i q) z = 0:
    undamped frequency w_n = sqrt(2 k / m); the forward root loses its damping when q = c w_n.
    """
    beams = [TimoshenkoBeam(k, 0.25, 0.1, 2.1e14, 0.3, 7850.0) for k in range(1, 5)]
    discs = [RigidDisc.annular(3, 0.03, disc_diameter, 0.1, 7850.0)] if disc_diameter else []
    return assemble(beams, discs, bearing_nodes=[1, 5])


def cross_coupled(k, q, c):
    return [(np.array([[k, q], [-q, k]]), c * np.eye(2))] * 2


def cylindrical_roots(m, k, q, c):
    """Roots of m s^2 + 2 c s + 2 (k - i q) = 0: (forward, backward), forward with Im > 0."""
    r = np.roots([m, 2 * c, 2 * (k - 1j * q)])
    return r[np.argmax(r.imag)], r[np.argmin(r.imag)]


def test_instability_threshold_matches_rigid_rotor_analytic():
    rotor = rigid_rotor()
    m = rotor.mass
    w_n = math.sqrt(2 * K_RIGID / m)
    c = 0.05 * m * w_n  # 5 % damping of the cylindrical mode
    a = c * w_n / (2 * math.pi * 60.0)  # cross coupling q = a Omega: threshold c w_n / a = 60 Hz
    speeds = HZ * np.arange(30.0, 90.1, 2.5)
    res = stability_map(rotor, speeds, lambda w: cross_coupled(K_RIGID, a * w, c))
    u = res.unstable_mode
    assert u is not None and u.whirl == "forward"
    assert u.speed == pytest.approx(c * w_n / a, rel=2e-3)  # linear interpolation over 2.5 Hz steps
    assert u.frequency == pytest.approx(w_n, rel=2e-3)  # it whirls at w_n at the threshold
    # Consistent with every root, not only the tracked modes.
    assert np.all(res.stable[speeds < u.speed]) and not np.any(res.stable[speeds > u.speed])


def test_first_critical_is_the_forward_mode_crossing_1x():
    rotor = rigid_rotor()
    m = rotor.mass
    w_n = math.sqrt(2 * K_RIGID / m)
    c, q = 0.05 * m * w_n, 0.02 * K_RIGID  # q < c w_n: stable at every speed
    forward, _ = cylindrical_roots(m, K_RIGID, q, c)
    speeds = HZ * np.arange(10.0, 60.1, 5.0)
    res = stability_map(rotor, speeds, lambda w: cross_coupled(K_RIGID, q, c))
    # The cylindrical frequencies do not depend on speed, so the crossing is where the forward one lies
    # (to the 1e-5 by which the stiffened shaft is not quite rigid); the backward mode crosses 1X at the
    # same speed (equal frequencies here) and is not listed.
    assert res.first_critical_speed == pytest.approx(forward.imag, rel=1e-4)
    assert res.critical_speeds[0].damping_ratio == pytest.approx(-forward.real / abs(forward), rel=1e-3)
    assert all(cs.whirl == "forward" for cs in res.critical_speeds)  # the next one is the forward conical mode
    assert sum(abs(cs.speed - forward.imag) < 1e-3 * forward.imag for cs in res.critical_speeds) == 1
    assert res.instability_threshold is None and np.all(res.stable)


def test_tracking_follows_modes_through_a_frequency_crossing():
    # A heavy disc: the backward conical mode falls with speed and crosses the (constant) cylindrical pair.
    rotor = rigid_rotor(disc_diameter=0.7)
    m = rotor.mass
    w_n = math.sqrt(2 * K_RIGID / m)
    c, q = 0.05 * m * w_n, 0.02 * K_RIGID
    forward, backward = cylindrical_roots(m, K_RIGID, q, c)
    speeds = np.linspace(0.0, 2000.0, 41)[1:]
    res = stability_map(rotor, speeds, lambda w: cross_coupled(K_RIGID, q, c), n_modes=4)
    wd = res.damped_frequencies
    # The cylindrical modes keep one column each over the whole sweep, at their analytic frequencies...
    cyl = [t for t in range(wd.shape[1]) if np.all(np.abs(wd[:, t] - forward.imag) < 1e-4 * forward.imag)
           or np.all(np.abs(wd[:, t] + backward.imag) < 1e-4 * forward.imag)]
    assert len(cyl) == 2
    # ... while some other mode passes from above them to below them (the crossing happened).
    others = [t for t in range(wd.shape[1]) if t not in cyl and not np.isnan(wd[0, t]) and not np.isnan(wd[-1, t])]
    assert any(wd[0, t] > forward.imag > wd[-1, t] for t in others)


def pinned_pinned_forward_critical(rotor):
    """Lowest forward synchronous critical speed with x, y held at the bearing nodes (rotations free).

    With q = Re(Q e^{i Omega t}) at the critical speed, (K - Omega^2 (M - i G)) Q = 0: a generalized
    eigenproblem in Omega^2, solved here directly on the constrained matrices.
    """
    fixed = np.concatenate([node_dofs(n)[:2] for n in rotor.bearing_nodes])
    free = np.setdiff1d(np.arange(rotor.n_dof), fixed)
    ix = np.ix_(free, free)
    lam, vec = scipy.linalg.eig(rotor.K[ix], rotor.M[ix] - 1j * rotor.G[ix])
    full = np.zeros((rotor.n_dof, vec.shape[1]), complex)
    full[free] = vec
    zf, zb = directional_components(full[0::4], full[1::4])
    orbit = np.abs(zf) + np.abs(zb)
    node = np.argmax(orbit, axis=0)
    cols = np.arange(orbit.shape[1])
    forward = np.abs(zf[node, cols]) > np.abs(zb[node, cols])
    ok = (np.abs(lam.imag) < 1e-8 * np.abs(lam)) & (lam.real > 0) & forward
    return float(np.sqrt(lam.real[ok].min()))


def test_first_critical_approaches_pinned_pinned_on_stiff_bearings(machine):
    rotor = rotor_from_machine(machine)
    target = pinned_pinned_forward_critical(rotor)  # 58.69 Hz; the backward one is 57.42 Hz
    speeds = HZ * np.arange(40.0, 80.1, 2.0)
    errors = []
    for k in (1e10, 1e11, 1e12):
        res = stability_map(rotor, speeds, lambda w, k=k: [isotropic(k)] * 2)
        errors.append(abs(res.first_critical_speed - target) / target)
    assert errors[0] > errors[1] > errors[2]
    assert errors[1] < 5e-4 and errors[2] < 1e-4


def test_warm_started_sweep_matches_cold_equilibria(machine):
    speeds = HZ * np.array([60.0, 75.0])
    coef = film_coefficients_over_speed(machine, speeds, Supply.threshold_fraction(0.8))
    b, load = machine.bearings[1], bearing_static_loads(machine)[1]
    q_t, _ = flooded_threshold(b, speeds[0], load)
    cold = find_equilibrium(b, speeds[0], load, Feed.flow(0.8 * q_t))
    assert coef.q_threshold[0, 1] == pytest.approx(q_t, rel=1e-8)
    np.testing.assert_allclose(coef.position[0, 1], cold.position, rtol=1e-6)
    np.testing.assert_allclose(coef.K[0, 1], cold.coefficients.K, rtol=1e-5, atol=1e-6 * np.abs(cold.coefficients.K).max())
    np.testing.assert_allclose(coef.C[0, 1], cold.coefficients.C, rtol=1e-5, atol=1e-6 * np.abs(cold.coefficients.C).max())


def test_supply_rules(machine):
    speeds = HZ * np.array([40.0, 100.0])
    fixed = film_coefficients_over_speed(machine, speeds, Supply.flow(546 / MLMIN_PER_M3S))
    assert np.all(fixed.q_supply == 546 / MLMIN_PER_M3S)
    frac = film_coefficients_over_speed(machine, speeds, Supply.threshold_fraction((0.6, 0.9)))
    np.testing.assert_allclose(frac.q_supply, frac.q_threshold * [0.6, 0.9], rtol=1e-12)
    with pytest.raises(InputError, match="3 values for 2 bearings"):
        film_coefficients_over_speed(machine, speeds, Supply.threshold_fraction((0.5, 0.6, 0.7)))


def test_starvation_moves_the_journal_off_centre(machine):
    # Less oil than the flooded threshold leaves a shorter film, which must sit more eccentric to carry
    # the same load; what starvation does to the threshold is measured (BENCHMARKS), not asserted.
    speeds = HZ * np.array([30.0, 110.0])
    ecc = [film_coefficients_over_speed(machine, speeds, Supply.threshold_fraction(f)).eccentricity_ratio
           for f in (0.5, 0.75, 1.0)]
    assert np.all(ecc[0] > ecc[1]) and np.all(ecc[1] > ecc[2])


def test_speed_too_low_for_the_film_is_refused(machine):
    with pytest.raises(InputError, match=r"bearing 1 at 0\.3 Hz.*cannot carry the load"):
        film_coefficients_over_speed(machine, [HZ * 0.3])
    # The limit is an eccentricity ratio, adjustable; never a NaN coefficient.
    coef = film_coefficients_over_speed(machine, [HZ * 0.3], max_eccentricity=0.97)
    assert np.all(np.isfinite(coef.K)) and np.all(coef.eccentricity_ratio > 0.9)


def test_paper_operating_speed_lies_between_first_critical_and_threshold(machine):
    speeds = HZ * np.arange(20.0, 140.1, 10.0)
    steps = []
    res = machine_stability(machine, speeds, progress=lambda d, t, label: steps.append((d, t)))
    assert steps[-1] == (2 * speeds.size, 2 * speeds.size) and [d for d, _ in steps] == sorted(d for d, _ in steps)
    op = HZ * machine.operating_speed
    assert res.first_critical_speed < op < res.instability_threshold  # paper, Sec. 3
    u = res.modes.unstable_mode
    # Oil whip: the unstable mode whirls forward, below half the running speed (a film's mean
    # circumferential velocity is at most half the journal's).
    assert u.whirl == "forward" and u.frequency < 0.5 * u.speed
