"""Cross-check against ROSS (petrobras/ross, PyPI `ross-rotordynamics`), an independent implementation.

Same shaft (Timoshenko, Cowper's kappa: ROSS's default `shear_method_calc="cowper"` reduces to
6(1+nu)/(7+6nu) for a solid section), same annular discs (ROSS `DiskElement.from_geometry`: Ip = m (Do^2 +
Di^2)/8, Id = Ip/2 + m w^2/12), same shaft damping (ROSS ShaftElement `beta`: C = beta K) and the same
bearing coefficients (ROSS `kxy` is K[0][1], entered with + sign, like ours). ROSS 2.x carries six DOFs
per node (x, y, z, alpha, beta, theta), nodes from 0, SI units; its lateral (x, y, alpha, beta) are our
(x, y, theta_x, theta_y). Axial and torsional modes are dropped by their mode shapes.

Run it in a separate environment, never in the project's venv (ROSS brings its own dependency chain;
ROSS 2.3.0 fails at import with plotly >= 6, hence the pin):
    python3 -m venv /tmp/rossenv
    /tmp/rossenv/bin/pip install -e . ross-rotordynamics "plotly<6" pytest
    /tmp/rossenv/bin/pytest -m ross tests/rotor
Checked with ross-rotordynamics 2.3.0 (numpy 2.4.6, scipy 1.17.1): frequencies and responses agree to ~1e-11.
"""

import math

import numpy as np
import pytest

from lubeviz.rotor import machine_unbalance, modal_analysis, rotor_from_machine, unbalance_response

try:
    import ross as rs
except Exception as exc:  # ImportError, or ROSS failing at import time (e.g. plotly >= 6 with ROSS 2.3)
    pytest.skip(f"ROSS is not importable ({type(exc).__name__}: {exc}); install ross-rotordynamics "
                "in a separate environment to run this cross-check", allow_module_level=True)

pytestmark = pytest.mark.ross

OMEGA = 2 * math.pi * 75.0
BEARING_CASES = {
    "isotropic": [(np.diag([1.5e8, 1.5e8]), np.diag([8e5, 8e5]))] * 2,
    "cross_coupled": [(np.array([[1.2e8, 0.6e8], [-1.5e8, 2.5e8]]), np.array([[3.0e5, 0.4e5], [0.4e5, 6.0e5]])),
                      (np.array([[0.9e8, 0.5e8], [-1.1e8, 2.0e8]]), np.array([[2.5e5, 0.3e5], [0.3e5, 5.0e5]]))],
}
NODES = (5, 6, 20, 21)


def _ross_rotor(machine, bearings):
    steel = rs.Material(name="lubeviz_steel", rho=machine.density, E=machine.young_modulus,
                        Poisson=machine.poisson_ratio)
    shaft = [rs.ShaftElement(L=e.length, idl=0.0, odl=e.diameter, material=steel, shear_effects=True,
                             rotary_inertia=True, gyroscopic=True, shear_method_calc="cowper",
                             beta=machine.shaft_damping_beta)
             for e in machine.elements]
    discs = [rs.DiskElement.from_geometry(n=d.node - 1, material=steel, width=d.width, i_d=d.bore_diameter,
                                          o_d=d.outer_diameter) for d in machine.discs]
    brgs = [rs.BearingElement(n=b.node - 1, kxx=K[0, 0], kxy=K[0, 1], kyx=K[1, 0], kyy=K[1, 1],
                              cxx=C[0, 0], cxy=C[0, 1], cyx=C[1, 0], cyy=C[1, 1])
            for b, (K, C) in zip(machine.bearings, bearings)]
    return rs.Rotor(shaft, discs, brgs)


def _ross_lateral_modes(rotor, omega):
    modal = rotor.run_modal(speed=omega, num_modes=2 * rotor.ndof, sparse=False)
    lam = np.asarray(modal.evalues)
    vec = np.asarray(modal.evectors)[: rotor.ndof]
    nd = rotor.number_dof
    lateral = np.zeros(rotor.ndof, bool)
    for k in (0, 1, 3, 4):
        lateral[k::nd] = True
    frac = np.linalg.norm(vec[lateral], axis=0) / np.linalg.norm(vec, axis=0)
    zeta = -lam.real / np.abs(lam)
    keep = (lam.imag > 0) & (frac > 0.99) & (zeta < 0.99)
    lam = lam[keep]
    return lam[np.argsort(lam.imag)]


@pytest.mark.parametrize("case", sorted(BEARING_CASES))
def test_natural_frequencies_match_ross(machine, case):
    bearings = BEARING_CASES[case]
    ours = modal_analysis(rotor_from_machine(machine), OMEGA, bearings, n_modes=8)
    theirs = _ross_lateral_modes(_ross_rotor(machine, bearings), OMEGA)[:8]
    np.testing.assert_allclose(ours.damped_frequencies, theirs.imag, rtol=5e-3)
    np.testing.assert_allclose(ours.natural_frequencies, np.abs(theirs), rtol=5e-3)


@pytest.mark.parametrize("case", sorted(BEARING_CASES))
def test_unbalance_response_matches_ross(machine, case):
    bearings = BEARING_CASES[case]
    u = machine_unbalance(machine)[0]
    ours = unbalance_response(rotor_from_machine(machine), OMEGA, [u], bearings, nodes=NODES)
    ross_rotor = _ross_rotor(machine, bearings)
    resp = ross_rotor.run_unbalance_response(node=u.node - 1, unbalance_magnitude=u.moment,
                                             unbalance_phase=u.phase, frequency=[OMEGA])
    q = np.asarray(resp.forced_resp)[:, 0]
    nd = ross_rotor.number_dof
    for k, node in enumerate(NODES):
        for mine, dof in ((ours.x[k], 0), (ours.y[k], 1)):
            theirs = q[nd * (node - 1) + dof]
            assert abs(mine) == pytest.approx(abs(theirs), rel=1e-2), (node, dof)
            assert abs(math.degrees(np.angle(mine / theirs))) < 1.0, (node, dof)
