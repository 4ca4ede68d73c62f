"""Gravity statics of the rotor: weight, bearing reactions, static deflection (SPEC §2, Eq. 8 with F = weight).

Gravity acts along -Y (SPEC §1). The consistent nodal weight is F_g = -g M u_y, u_y the unit rigid
translation along Y: the Timoshenko shape functions reproduce a rigid translation exactly and carry no
rotation with it, so this equals the integral of N^T rho A g over each element plus the disc weights.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from .assembly import Rotor, as_bearings, bearing_matrices
from .elements import DOF_PER_NODE, THETA_X, X, Y, node_dofs


def _check_gravity(gravity: float) -> float:
    if not (np.isfinite(gravity) and gravity > 0.0):
        raise InputError(f"gravity = {gravity!r} m/s^2; expected a positive number")
    return float(gravity)


def gravity_load(rotor: Rotor, gravity: float = 9.81) -> np.ndarray:
    """Consistent nodal load vector of the rotor's weight (N, N*m), along -Y."""
    u = np.zeros(rotor.n_dof)
    u[Y::DOF_PER_NODE] = 1.0
    return -_check_gravity(gravity) * (rotor.M @ u)


def weight(rotor: Rotor, gravity: float = 9.81) -> float:
    """Total weight (N) of shaft and discs."""
    return _check_gravity(gravity) * rotor.mass


@dataclass(frozen=True)
class Reactions:
    """Vertical support reactions (N, along +Y) at `nodes`, the rotor as a beam on simple supports."""

    nodes: tuple[int, ...]
    forces: np.ndarray
    weight: float


def simple_support_reactions(rotor: Rotor, gravity: float = 9.81, nodes=None) -> Reactions:
    """Reactions of the rotor pinned (x = y = 0) at the bearing nodes, under its own weight.
    With two supports this is statically determinate: the reactions depend on the mass distribution
    only. Solved on the FE model (x, y fixed at the supports, rotations free), so it also handles a
    bearing placed on a stubby element or more than two supports.
    """
    nodes = tuple(rotor.bearing_nodes if nodes is None else nodes)
    fy = support_reactions(rotor, gravity_load(rotor, gravity), nodes)[:, 1]
    return Reactions(nodes=nodes, forces=fy, weight=weight(rotor, gravity))


def support_reactions(rotor: Rotor, F: np.ndarray, nodes) -> np.ndarray:
    """(n_supports, 2) forces (N, X and Y) the supports at `nodes` exert on the rotor pinned there (x = y = 0,
    rotations free) under the static load `F` (all DOFs, N and N m): with two supports the lever rule, with more
    the shaft's stiffness shares it."""
    nodes = tuple(nodes)
    if len(nodes) < 2:
        raise InputError(f"support nodes {list(nodes)}: need at least two supports for a static solution")
    fixed = np.array([node_dofs(rotor.check_node(n, "support node"))[[X, Y]] for n in nodes]).ravel()
    free = np.setdiff1d(np.arange(rotor.n_dof), fixed)
    q = np.zeros(rotor.n_dof)
    q[free] = np.linalg.solve(rotor.K[np.ix_(free, free)], F[free])
    r = rotor.K @ q - F  # support forces on the rotor
    return r[fixed].reshape(len(nodes), 2)


def load_shares(rotor: Rotor, node: int, nodes=None) -> np.ndarray:
    """The share of a static force at `node` each support at `nodes` (default the bearings) carries: (n,), summing
    to 1; negative where the force lifts the shaft off that support (a force outboard of the others)."""
    nodes = tuple(rotor.bearing_nodes if nodes is None else nodes)
    F = np.zeros(rotor.n_dof)
    F[node_dofs(rotor.check_node(node, "load node"))[Y]] = -1.0
    return support_reactions(rotor, F, nodes)[:, 1]


def moment_shares(rotor: Rotor, node: int, nodes=None) -> np.ndarray:
    """The change of each support's load (N, along the weight) under a unit couple (1 N m) in the vertical plane at
    `node`, summing to 0; its sign chosen so that the first support's is >= 0 (a couple that loads the first
    bearing more is positive)."""
    nodes = tuple(rotor.bearing_nodes if nodes is None else nodes)
    F = np.zeros(rotor.n_dof)
    F[node_dofs(rotor.check_node(node, "load node"))[THETA_X]] = 1.0
    r = support_reactions(rotor, F, nodes)[:, 1]
    return r if r[0] >= 0 else -r


@dataclass(frozen=True)
class StaticDeflection:
    """Static deflection under gravity on linear bearings: q (all DOFs, m and rad), per-node x, y,
    and the bearing forces on the journal (N, rows per bearing, (X, Y)), f = -K q (SPEC §1)."""

    q: np.ndarray
    x: np.ndarray
    y: np.ndarray
    bearing_nodes: tuple[int, ...]
    bearing_forces: np.ndarray


def static_deflection(rotor: Rotor, bearings, gravity: float = 9.81) -> StaticDeflection:
    """Solve (K_shaft + K_bearings) q = F_g for given bearing (K, C) pairs or LinearBearing objects."""
    bearings = as_bearings(rotor, bearings)
    for b in bearings:
        if b.stiffness.shape != (2, 2):
            raise InputError(f"bearing at node {b.node}: static deflection needs one 2x2 stiffness, "
                             f"got shape {b.stiffness.shape}")
    K, _ = bearing_matrices(rotor, bearings)
    try:
        q = np.linalg.solve(K, gravity_load(rotor, gravity))
    except np.linalg.LinAlgError:
        raise InputError("the bearings do not restrain the rotor (singular stiffness): "
                         "give non-zero bearing stiffness at two or more nodes") from None
    forces = np.array([-b.stiffness @ q[b.dofs()] for b in bearings])
    return StaticDeflection(q=q, x=q[X::DOF_PER_NODE].copy(), y=q[Y::DOF_PER_NODE].copy(),
                            bearing_nodes=tuple(b.node for b in bearings), bearing_forces=forces)


def bearing_static_loads(machine) -> np.ndarray:
    """Static load on each bearing's journal, [[Wx, Wy], ...] (N): the rotor's weight share, downwards.

    The journal presses on its film with the support reaction of the pinned rotor, so the film must
    carry -load; this is the load the film model's equilibrium uses.
    """
    from .assembly import rotor_from_machine

    rotor = rotor_from_machine(machine)
    reactions = simple_support_reactions(rotor, machine.gravity, nodes=[b.node for b in machine.bearings])
    return np.array([[0.0, -f] for f in reactions.forces])
