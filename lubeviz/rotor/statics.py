"""Gravity statics of the rotor: weight, bearing reactions, static deflection (SPEC §2, Eq. 8 with F = weight).

Gravity acts along -Y (SPEC §1). The consistent nodal weight is F_g = -g M u_y, u_y the unit rigid
translation along Y: the Timoshenko shape functions reproduce a rigid translation exactly and carry no
rotation with it, so this equals the integral of N^T rho A g over each element plus the disc weights.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from .assembly import Rotor, as_bearings, bearing_matrices, film_dofs
from .elements import DOF_PER_NODE, THETA_X, X, Y, node_dofs


def _check_gravity(gravity: float) -> float:
    if not (np.isfinite(gravity) and gravity > 0.0):
        raise InputError(f"gravity = {gravity!r} m/s^2; expected a positive number")
    return float(gravity)


def gravity_load(rotor: Rotor, gravity: float = 9.81) -> np.ndarray:
    """Consistent nodal load vector of the rotor's weight (N, N*m), along -Y. A pedestal's housing carries its own
    weight straight to the ground: not in this load (its sag moves housing and journal alike)."""
    u = np.zeros(rotor.n_dof)
    u[Y:rotor.shaft_dofs:DOF_PER_NODE] = 1.0
    F = -_check_gravity(gravity) * (rotor.M @ u)
    F[rotor.shaft_dofs:] = 0.0
    return F


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


def support_reactions(rotor: Rotor, F: np.ndarray, nodes, positions=None) -> np.ndarray:
    """(n_supports, 2) forces (N, X and Y) the supports at `nodes` exert on the rotor pinned there (x, y held at
    `positions` (n, 2) m, default 0; rotations free) under the static load `F` (all DOFs, N and N m): with two
    supports the lever rule, with more (or with the rotor's own constant-coefficient supports) the shaft's
    stiffness shares it."""
    nodes = tuple(nodes)
    if len(nodes) < 2 and not rotor.supports:
        raise InputError(f"support nodes {list(nodes)}: need at least two supports for a static solution")
    fixed = np.array([node_dofs(rotor.check_node(n, "support node"))[[X, Y]] for n in nodes]).ravel()
    free = np.setdiff1d(np.arange(rotor.n_dof), fixed)
    q = np.zeros(rotor.n_dof)
    if positions is not None:
        q[fixed] = np.asarray(positions, dtype=float).ravel()
    q[free] = np.linalg.solve(rotor.K[np.ix_(free, free)], F[free] - rotor.K[np.ix_(free, fixed)] @ q[fixed])
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
    forces = []
    for b in bearings:  # over a pedestal the film is strained by the journal's motion relative to the housing
        i, h = film_dofs(rotor, b.node)
        forces.append(-b.stiffness @ (q[i] - (0.0 if h is None else q[h])))
    forces = np.array(forces)
    shaft = rotor.shaft_part(q)
    return StaticDeflection(q=q, x=shaft[X::DOF_PER_NODE].copy(), y=shaft[Y::DOF_PER_NODE].copy(),
                            bearing_nodes=tuple(b.node for b in bearings), bearing_forces=forces)


def bearing_static_loads(machine) -> np.ndarray:
    """Static load on each bearing's journal, [[Wx, Wy], ...] (N): the rotor's weight share, downwards.

    The journal presses on its film with the support reaction of the pinned rotor, so the film must
    carry -load; this is the load the film model's equilibrium uses. With 3+ supports it is the coupled
    equilibrium's (`coupled_statics`), sideways part included: offsets out of line lean it (the tables take a
    leaning load in the bearing's own frame, `identify.tables.cache.film_frame`).
    """
    from .assembly import rotor_from_machine

    rotor = rotor_from_machine(machine)
    if not statically_determinate(machine, rotor):  # 3+ supports: the films' compliance shares the weight
        return coupled_statics(machine).loads.copy()
    reactions = simple_support_reactions(rotor, machine.gravity, nodes=[b.node for b in machine.bearings])
    return np.array([[0.0, -f] for f in reactions.forces])


def statically_determinate(machine, rotor: Rotor | None = None) -> bool:
    """Two fluid-film bearings and no other support: the reactions are the lever rule's, whatever the films."""
    supports = rotor.supports if rotor is not None else getattr(machine, "supports", ())
    return len(machine.bearings) == 2 and not supports


@dataclass(frozen=True)
class CoupledStatics:
    """The static equilibrium of the shaft on its films and supports (SPEC §8, 3+ supports): each fluid-film
    bearing's load (N, [Wx, Wy] on the journal, its sideways part included), the journals' positions in their
    bearings (m), the constant supports' reactions (N), the iterations and the largest sideways load against the
    vertical one."""

    loads: np.ndarray  # (N, 2): the load on each film, sideways part included
    positions: np.ndarray  # (N, 2) journal positions from the bearing centres
    pinned_loads: np.ndarray  # (N, 2): the stiff-bearing limit (journals held at the bearing centres + offsets)
    support_forces: np.ndarray  # (n_supports, 2): force of each constant support on the shaft
    iterations: int
    horizontal_share: float


COUPLED_TOL = 1e-6  # the loads' relative change that ends the iteration
_COUPLED: dict = {}


def _statics_key(machine) -> str:
    import dataclasses as _dc
    import json

    def plain(v):
        if _dc.is_dataclass(v):
            return _dc.asdict(v)
        if hasattr(v, "param"):
            return {k: getattr(v, k) for k in sorted(v.param) if k != "name"}
        return str(v)

    parts = {"elements": [plain(e) if _dc.is_dataclass(e) else (e.length, e.diameter, getattr(e, "inner_diameter", 0.0))
                          for e in machine.elements],
             "discs": [plain(d) for d in machine.discs], "bearings": [plain(b) for b in machine.bearings],
             "supports": [plain(s) for s in getattr(machine, "supports", ())],
             "material": [machine.young_modulus, machine.poisson_ratio, machine.density],
             "gravity": machine.gravity, "speed": machine.operating_speed}
    return json.dumps(parts, sort_keys=True, default=plain)


OFFSET_STEPS = (0.0, 0.25, 0.5, 0.75, 1.0)  # the offsets' share at each step when rigid supports lift a journal off


def _lift_off(machine, R, where: str) -> None:
    """Refuse a start that pulls a journal up (R: the forces on the journals, +Y up). Only the start: a film can push
    its journal down, and the coupled answer may load one upwards (its tables turn with the load, `film_frame`)."""
    if np.all(R[:, 1] > 0.0):
        return
    bad = ", ".join(f"{k + 1} ({machine.bearings[k].name})" for k in np.flatnonzero(R[:, 1] <= 0.0))
    raise InputError(f"{machine.source or machine.name}: [[bearings]] {bad} would be lifted off: {where} the "
                     f"journals press down with {np.round(R[:, 1], 1).tolist()} N, and a film cannot pull a journal "
                     "down; check the bearings' offset_um (alignment) and the supports' nodes")


def _coupled_steps(machine, rotor, F, omega, dofs, housed, offsets, R, positions, max_iter: int):
    """Newton on the reactions R from the given start (`coupled_statics`): (R, positions, shaft displacement,
    iterations)."""
    from ..errors import ConvergenceError
    from ..film.equilibrium import find_equilibrium
    from ..film.feed import Feed

    positions = list(positions)
    for it in range(1, max_iter + 1):
        Kf = []
        for k, b in enumerate(machine.bearings):
            eq = find_equilibrium(b, omega, -R[k], Feed.flooded(), start=positions[k])
            if not eq.converged:
                raise ConvergenceError(f"coupled statics: bearing {k + 1}'s film found no equilibrium under "
                                       f"{np.round(-R[k], 1).tolist()} N ({eq.message})")
            positions[k] = eq.position
            Kf.append(np.asarray(eq.coefficients.K, dtype=float))
        A = rotor.K.copy()
        rhs = F.copy()
        for k in range(len(dofs)):
            h = housed[k]
            A[np.ix_(dofs[k], dofs[k])] += Kf[k]
            rhs[dofs[k]] += R[k] + Kf[k] @ (offsets[k] + positions[k])
            if h is not None:  # the film pushes the housing back as it pushes the journal
                A[np.ix_(h, h)] += Kf[k]
                A[np.ix_(dofs[k], h)] -= Kf[k]
                A[np.ix_(h, dofs[k])] -= Kf[k]
                rhs[h] -= R[k] + Kf[k] @ (offsets[k] + positions[k])
        u = np.linalg.solve(A, rhs)
        new = np.array([R[k] - Kf[k] @ (u[dofs[k]] - (0.0 if housed[k] is None else u[housed[k]]) - offsets[k]
                                        - positions[k]) for k in range(len(dofs))])
        change = np.max(np.abs(new - R)) / np.max(np.abs(new))
        R = new
        if change < COUPLED_TOL:
            return R, positions, u, it
    raise ConvergenceError(f"coupled statics: the loads still changed by {change:.1e} after {max_iter} steps")


def coupled_statics(machine, *, max_iter: int = 30) -> CoupledStatics:
    """The shaft's static equilibrium on its fluid films (flooded, at the machine's operating speed) and its
    constant supports, bearing offsets included (SPEC §8: a statically indeterminate machine).

    Newton on the bearings' reactions R (N, 2; the film force on each journal): each film's equilibrium under
    -R_k gives the journal's place p_k in its bearing and the film's static stiffness K_k (the linearized film
    force is R_k - K_k (u_k - d_k - p_k), d_k the bearing's offset); the shaft on those springs,
    (K + sum K_k) u = F_g + sum (R_k + K_k (d_k + p_k)) at the journals, gives the next R. At the answer the
    journals sit where their films put them under the loads they carry, and the shaft pinned there carries its
    weight with exactly those reactions. Stiff films: the pinned (Clapeyron) reactions. The films are taken
    flooded at the operating speed: starvation or another speed moves a journal by micrometres and the loads
    by what the shaft's stiffness makes of that (not carried in the loads). Memoized per machine."""
    from .assembly import rotor_from_machine

    key = _statics_key(machine)
    if key in _COUPLED:
        return _COUPLED[key]
    rotor = rotor_from_machine(machine)
    nodes = [b.node for b in machine.bearings]
    offsets = np.array([tuple(getattr(b, "offset", (0.0, 0.0))) for b in machine.bearings], dtype=float)
    F = gravity_load(rotor, machine.gravity)
    omega = 2.0 * np.pi * machine.operating_speed
    R = support_reactions(rotor, F, nodes, offsets)
    pinned = -R.copy()
    dofs = np.array([node_dofs(n)[[X, Y]] for n in nodes])
    housed = [film_dofs(rotor, n)[1] for n in nodes]  # a pedestal's DOFs under the film, or None
    positions = [None] * len(nodes)
    # On rigid supports a few micrometres of offset can lift a journal off that its film, far softer, still
    # loads: then the offsets are brought in by steps from the straight line, each step started from the last
    # (Newton from the rigid reactions would start from films pulled upwards by the full offsets).
    scales = (1.0,) if np.all(R[:, 1] > 0.0) else OFFSET_STEPS
    if scales is OFFSET_STEPS:
        R = support_reactions(rotor, F, nodes, 0.0 * offsets)
        _lift_off(machine, R, "on rigid supports in a straight line")
    for scale in scales:
        R, positions, u, it = _coupled_steps(machine, rotor, F, omega, dofs, housed, scale * offsets, R, positions,
                                             max_iter)
    full = -R
    support_forces = []
    for j, (n, k, _) in enumerate(rotor.supports):  # over a pedestal: the shaft's motion relative to the housing
        h = rotor.housing("support", j)
        rel = u[node_dofs(n)[[X, Y]]] - (0.0 if h is None else u[list(h.dofs)])
        support_forces.append(-(np.asarray(k) @ rel))
    support_forces = np.array(support_forces) if support_forces else np.zeros((0, 2))
    out = CoupledStatics(loads=full, positions=np.array(positions), pinned_loads=pinned,
                         support_forces=support_forces, iterations=it,
                         horizontal_share=float(np.max(np.abs(full[:, 0]) / np.abs(full[:, 1]))))
    _COUPLED[key] = out
    return out
