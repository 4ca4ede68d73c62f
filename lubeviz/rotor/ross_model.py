"""The same rotor in ROSS (petrobras/ross, PyPI `ross-rotordynamics`): an independent implementation to
cross-check against (tests/rotor/test_ross_crosscheck.py) and to time against (lubeviz.bench.rotor).

Optional: ROSS is imported only when one of these functions is called, and a missing or broken ROSS
raises `RossUnavailable` with the install hint. Checked with ross-rotordynamics 2.3.0 (the newest for
Python < 3.12; 3.x needs Python >= 3.12) with plotly < 6 (ROSS 2.3 fails at import with plotly 6).

Correspondence. Same shaft: Timoshenko with rotary inertia and gyroscopic terms, ROSS's default
`shear_method_calc="cowper"`, which for a solid section is 6(1+nu)/(7+6nu) like ours; same annular discs
(`DiskElement.from_geometry`: Ip = m (Do^2 + Di^2)/8, Id = Ip/2 + m w^2/12); same shaft damping (ROSS
ShaftElement `beta`: C = beta K); the same bearing coefficients (ROSS `kxy` is K[0][1], entered with a
+ sign, SPEC §1). ROSS 2.x carries six DOFs per node (x, y, z, alpha, beta, theta), nodes from 0, SI;
its lateral (x, y, alpha, beta) are our (x, y, theta_x, theta_y). Axial and torsional modes are told
apart by their mode shapes.
"""

from __future__ import annotations

import contextlib
import os
import sys
import warnings

import numpy as np

from ..errors import LubevizError

INSTALL_HINT = 'pip install -e ".[test]" (ross-rotordynamics 2.3.0 with plotly < 6)'
LATERAL = (0, 1, 3, 4)  # x, y, alpha, beta among ROSS's six DOFs per node


class RossUnavailable(LubevizError, ImportError):
    """ROSS is not installed, or fails at import."""


@contextlib.contextmanager
def _stdout_to_stderr():
    """ROSS imports ccp, whose CoolProp prints a REFPROP notice on file descriptor 1 (C level): send it to
    stderr so that `--json` output on stdout stays one JSON object."""
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        os.dup2(2, 1)
        yield
    finally:
        sys.stdout.flush()
        os.dup2(saved, 1)
        os.close(saved)


def import_ross():
    """The `ross` module, or RossUnavailable naming the reason and the install command."""
    if "ross" in sys.modules:
        return sys.modules["ross"]
    try:
        with _stdout_to_stderr(), warnings.catch_warnings():
            warnings.filterwarnings("ignore", message=r"(?s).*REFPROP", category=UserWarning)
            import ross
    except Exception as exc:  # ImportError, or ROSS failing inside its import (e.g. plotly >= 6 with ROSS 2.3)
        raise RossUnavailable(f"ROSS is not importable ({type(exc).__name__}: {exc}); install it with "
                              f"{INSTALL_HINT}") from exc
    return ross


def ross_rotor(machine, bearings, *, shaft_damping_beta: float | None = None):
    """ROSS `Rotor` of a `Machine` on linear bearings: one (K, C) pair (2x2, SPEC §1) per machine bearing."""
    rs = import_ross()
    bearings = list(bearings)
    if len(bearings) != len(machine.bearings):
        raise LubevizError(f"got {len(bearings)} (K, C) pairs for {len(machine.bearings)} bearings")
    beta = machine.shaft_damping_beta if shaft_damping_beta is None else shaft_damping_beta
    steel = rs.Material(name="lubeviz_steel", rho=machine.density, E=machine.young_modulus,
                        Poisson=machine.poisson_ratio)
    shaft = [rs.ShaftElement(L=e.length, idl=getattr(e, "inner_diameter", 0.0), odl=e.diameter, material=steel,
                             shear_effects=True, rotary_inertia=True, gyroscopic=True, shear_method_calc="cowper",
                             beta=beta)
             for e in machine.elements]
    discs = [rs.DiskElement(n=d.node - 1, m=d.mass, Id=d.diametral_inertia, Ip=d.polar_inertia)
             if getattr(d, "lumped", False) else
             rs.DiskElement.from_geometry(n=d.node - 1, material=steel, width=d.width, i_d=d.bore_diameter,
                                          o_d=d.outer_diameter) for d in machine.discs]
    brgs = []
    for b, (K, C) in zip(machine.bearings, bearings):
        K, C = np.asarray(K, dtype=float), np.asarray(C, dtype=float)
        brgs.append(rs.BearingElement(n=b.node - 1, kxx=K[0, 0], kxy=K[0, 1], kyx=K[1, 0], kyy=K[1, 1],
                                      cxx=C[0, 0], cxy=C[0, 1], cyx=C[1, 0], cyy=C[1, 1]))
    for sup in getattr(machine, "supports", ()):  # constant-coefficient supports (SPEC §8): ROSS bearings too
        K, C = np.asarray(sup.stiffness, dtype=float), np.asarray(sup.damping, dtype=float)
        brgs.append(rs.BearingElement(n=sup.node - 1, kxx=K[0, 0], kxy=K[0, 1], kyx=K[1, 0], kyy=K[1, 1],
                                      cxx=C[0, 0], cxy=C[0, 1], cyx=C[1, 0], cyy=C[1, 1]))
    return rs.Rotor(shaft, discs, brgs)


def ross_lateral_eigenvalues(rotor, omega: float, *, max_damping_ratio: float = 0.99) -> np.ndarray:
    """ROSS's damped lateral eigenvalues at speed omega (rad/s), Im > 0, ascending Im; like modal_analysis.

    Full dense eigen-solution (`sparse=False`); modes with less than 99 % of their shape in lateral DOFs
    (axial, torsional) are dropped, and so are nearly real pairs (zeta >= max_damping_ratio).
    """
    modal = rotor.run_modal(speed=omega, num_modes=2 * rotor.ndof, sparse=False)
    lam = np.asarray(modal.evalues)
    vec = np.asarray(modal.evectors)[: rotor.ndof]
    lateral = np.zeros(rotor.ndof, bool)
    for k in LATERAL:
        lateral[k::rotor.number_dof] = True
    frac = np.linalg.norm(vec[lateral], axis=0) / np.linalg.norm(vec, axis=0)
    zeta = -lam.real / np.abs(lam)
    lam = lam[(lam.imag > 0) & (frac > 0.99) & (zeta < max_damping_ratio)]
    return lam[np.argsort(lam.imag)]


def ross_unbalance_response(rotor, omega: float, unbalance, nodes) -> tuple[np.ndarray, np.ndarray]:
    """Complex x, y amplitudes (m) at `nodes` (paper numbering) for one `Unbalance`, from ROSS.

    Same phasor convention as `unbalance_response` (x(t) = Re(x e^{i Omega t})), checked by the tests.
    """
    resp = rotor.run_unbalance_response(node=unbalance.node - 1, unbalance_magnitude=unbalance.moment,
                                        unbalance_phase=unbalance.phase, frequency=[omega])
    q = np.asarray(resp.forced_resp)[:, 0]
    idx = rotor.number_dof * (np.asarray(nodes) - 1)
    return q[idx], q[idx + 1]
