"""Global matrices of Eq. 8: M q'' + (C + Omega G) q' + K q = F.

`Rotor` holds the shaft-and-disc matrices (M, K_shaft, G, C_shaft = beta K_shaft, stiffness-
proportional as the paper says below Eq. 8) and the bearing nodes; the bearing K and C are added per
operating point by `bearing_matrices`, because they change with speed and oil supply.

Dense numpy arrays on purpose. Measured once for the paper's rotor (84 DOF; numpy 2.4, scipy 1.17,
2 cores): assembling takes ~0.8 ms; one complex steady solve of (-Omega^2 M + i Omega (C + Omega G) + K) Q = F
takes ~60 us with `numpy.linalg.solve` on the dense matrix against ~120 us with scipy.sparse `spsolve`
(SuperLU) on a CSC copy, plus ~60 us to make that copy (944 non-zeros). Sparse would only pay off for
meshes of many hundreds of nodes.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from ..errors import InputError
from .elements import DOF_PER_NODE, LinearBearing, RigidDisc, TimoshenkoBeam, coefficient_matrix, node_dofs


@dataclass(frozen=True)
class Housing:
    """A pedestal (SPEC §8): the housing of fluid-film bearing or constant support `index` (0-based; `part` says
    which), a point mass on an isotropic spring and damper to ground, under shaft node `node`. Its x and y are the
    rotor's DOFs `dofs`, after the shaft's; the bearing or support acts between the shaft and it."""

    part: str  # "bearing" | "support"
    index: int
    node: int
    mass: float
    stiffness: float
    damping: float
    dofs: tuple[int, int]


@dataclass(frozen=True)
class Rotor:
    """Assembled shaft + discs, without bearings. Nodes are numbered from 1 (paper numbering).

    M, K, G (multiplies Omega), C are dense (n_dof, n_dof): K the shaft's and C its damping beta*K_shaft, each
    plus the constant-coefficient `supports` (rolling-element bearings, seals: (node, K 2x2, C 2x2), SPEC §8),
    which are part of the rotor as the fluid films are not; `node_z` are the axial node positions (m) from node
    1; `bearing_nodes` the fluid-film bearings, in order. `housings`: the pedestals (`Housing`), two DOFs each
    after the shaft's `shaft_dofs`; a film or support over one acts between the shaft and it.
    """

    n_nodes: int
    node_z: np.ndarray
    M: np.ndarray
    K: np.ndarray
    G: np.ndarray
    C: np.ndarray
    bearing_nodes: tuple[int, ...]
    shaft_damping_beta: float
    beams: tuple[TimoshenkoBeam, ...] = field(repr=False)
    discs: tuple[RigidDisc, ...] = field(repr=False)
    supports: tuple = ()  # (node, K (2, 2), C (2, 2)) of each constant-coefficient support, in K and C above
    housings: tuple = ()  # Housing of each pedestal, its DOFs after the shaft's

    @property
    def n_dof(self) -> int:
        return self.shaft_dofs + 2 * len(self.housings)

    @property
    def shaft_dofs(self) -> int:
        """The shaft's DOFs (x, y, theta_x, theta_y of each node), first in every vector; the housings' follow."""
        return DOF_PER_NODE * self.n_nodes

    @property
    def mass(self) -> float:
        """Shaft and discs' mass (kg): the kinetic energy of a unit rigid translation (exact for consistent mass);
        the pedestals' housings are not the rotor's."""
        u = np.zeros(self.n_dof)
        u[0:self.shaft_dofs:DOF_PER_NODE] = 1.0
        return float(u @ self.M @ u)

    def housing(self, part: str, index: int) -> "Housing | None":
        """The pedestal under fluid-film bearing (`part` "bearing") or constant support ("support") `index`
        (0-based), or None."""
        return next((h for h in self.housings if h.part == part and h.index == index), None)

    def bearing_housing(self, node: int) -> "Housing | None":
        """The pedestal under the fluid-film bearing at shaft `node`, or None."""
        if node not in self.bearing_nodes:
            return None
        return self.housing("bearing", self.bearing_nodes.index(node))

    def require_films_on_ground(self, what: str) -> None:
        """Raise InputError when a fluid-film bearing sits on a pedestal: `what` solves the films against the
        ground (its nonlinear film forces act between journal and ground)."""
        on = [h.index + 1 for h in self.housings if h.part == "bearing"]
        if on:
            raise InputError(f"{what} takes each film between its journal and the ground; bearing(s) {on} of this "
                             "machine sit on pedestals (SPEC §8 pedestal_* keys): not taken by this path yet. The "
                             "linear analyses (identify, diagnose, simulate --method steady, modes, stability) take "
                             "them")

    def shaft_part(self, q: np.ndarray) -> np.ndarray:
        """The shaft's DOFs of `q` (last axis; a mode shape or a response), the housings' dropped."""
        return q[..., :self.shaft_dofs]

    def check_node(self, node: int, what: str = "node") -> int:
        if not (isinstance(node, (int, np.integer)) and 1 <= node <= self.n_nodes):
            raise InputError(f"{what} {node!r} is not a rotor node; expected an integer in 1..{self.n_nodes}")
        return int(node)


def assemble(beams: Sequence[TimoshenkoBeam], discs: Sequence[RigidDisc] = (), *,
             bearing_nodes: Sequence[int] = (), shaft_damping_beta: float = 0.0) -> Rotor:
    """Assemble the global M, K, G and C_shaft = beta K of Eq. 8 from consecutive shaft elements."""
    beams, discs = tuple(beams), tuple(discs)
    if not beams:
        raise InputError("a rotor needs at least one shaft element")
    for k, b in enumerate(beams, start=1):
        if b.node != k:
            raise InputError(f"shaft element #{k} starts at node {b.node}; expected node {k} "
                             "(elements must run consecutively from node 1)")
    if not (np.isfinite(shaft_damping_beta) and shaft_damping_beta >= 0.0):
        raise InputError(f"shaft damping beta = {shaft_damping_beta!r} s; expected a non-negative number")
    n_nodes = len(beams) + 1
    n = DOF_PER_NODE * n_nodes
    M, K, G = np.zeros((n, n)), np.zeros((n, n)), np.zeros((n, n))
    for el in beams + discs:
        if not 1 <= el.node <= n_nodes:
            raise InputError(f"{type(el).__name__} at node {el.node}; expected a node in 1..{n_nodes}")
        idx = np.ix_(el.dofs(), el.dofs())
        M[idx] += el.M()
        K[idx] += el.K()
        G[idx] += el.G()
    rotor = Rotor(n_nodes=n_nodes, node_z=np.concatenate([[0.0], np.cumsum([b.length for b in beams])]),
                  M=M, K=K, G=G, C=shaft_damping_beta * K, bearing_nodes=tuple(int(b) for b in bearing_nodes),
                  shaft_damping_beta=float(shaft_damping_beta), beams=beams, discs=discs)
    for b in rotor.bearing_nodes:
        rotor.check_node(b, "bearing node")
    return rotor


def rotor_from_machine(machine, *, shaft_damping_beta: float | None = None, shear: bool = True) -> Rotor:
    """The rotor of a `lubeviz.model.machine.Machine` (Timoshenko shaft with Cowper's kappa, hollow where declared;
    discs by geometry or lumped). A machine whose file declares parts the numerics do not take yet is refused."""
    if hasattr(machine, "require_modelled"):
        machine.require_modelled("the rotor model")
    beams = [TimoshenkoBeam(k, e.length, e.diameter, machine.young_modulus, machine.poisson_ratio,
                            machine.density, shear=shear, inner_diameter=getattr(e, "inner_diameter", 0.0))
             for k, e in enumerate(machine.elements, start=1)]
    discs = [machine_disc(d, machine.density) for d in machine.discs]
    beta = machine.shaft_damping_beta if shaft_damping_beta is None else shaft_damping_beta
    rotor = assemble(beams, discs, bearing_nodes=[b.node for b in machine.bearings], shaft_damping_beta=beta)
    housings = [("bearing", k, b.node, b.pedestal) for k, b in enumerate(machine.bearings)
                if getattr(b, "pedestal", None) is not None]
    supports = list(getattr(machine, "supports", ()))
    housings += [("support", k, s.node, s.pedestal) for k, s in enumerate(supports)
                 if getattr(s, "pedestal", None) is not None]
    if housings:
        rotor = with_housings(rotor, [(part, k, node, (p.mass, p.stiffness, p.damping))
                                      for part, k, node, p in housings])
    supports = [(s.node, s.stiffness, s.damping) for s in supports]
    return with_supports(rotor, supports) if supports else rotor


def with_housings(rotor: Rotor, housings) -> Rotor:
    """`rotor` with pedestals: each (part "bearing" | "support", index 0-based, node, (mass kg, stiffness N/m,
    damping N s/m)) a point mass on an isotropic spring and damper to ground, two DOFs appended after the rotor's
    (declare them before the supports that stand on them, `with_supports`)."""
    import dataclasses

    if rotor.supports:
        raise InputError("pedestals go in before the constant supports (with_housings, then with_supports)")
    n0 = rotor.n_dof
    out = list(rotor.housings)
    for part, index, node, (m, k, c) in housings:
        if part not in ("bearing", "support"):
            raise InputError(f"pedestal under {part!r}; expected 'bearing' or 'support'")
        node = rotor.check_node(int(node), "pedestal node")
        if not (np.isfinite(m) and m > 0 and np.isfinite(k) and k > 0 and np.isfinite(c) and c >= 0):
            raise InputError(f"pedestal under {part} {index + 1}: mass {m!r} kg and stiffness {k!r} N/m must be "
                             f"positive, damping {c!r} N s/m non-negative")
        start = rotor.shaft_dofs + 2 * len(out)
        out.append(Housing(part, int(index), node, float(m), float(k), float(c), (start, start + 1)))
    n = rotor.shaft_dofs + 2 * len(out)
    grown = []
    for A in (rotor.M, rotor.K, rotor.G, rotor.C):
        B = np.zeros((n, n))
        B[:n0, :n0] = A
        grown.append(B)
    M, K, G, C = grown
    for h in out[len(rotor.housings):]:
        i = list(h.dofs)
        M[i, i] += h.mass
        K[i, i] += h.stiffness
        C[i, i] += h.damping
    return dataclasses.replace(rotor, M=M, K=K, G=G, C=C, housings=tuple(out))


def film_dofs(rotor: Rotor, node: int) -> tuple[np.ndarray, np.ndarray | None]:
    """(the journal's x, y DOFs at `node`, its housing's or None): what a bearing there acts between."""
    h = rotor.bearing_housing(node)
    return node_dofs(node)[:2], (None if h is None else np.array(h.dofs))


def probe_housings(rotor: Rotor, nodes) -> list:
    """For each measurement node, the DOFs (x, y) of the pedestal its probes ride on, or None: probes are mounted on
    the housing of the nearest fluid-film bearing along the shaft (the first of two as near), and over a pedestal
    read the shaft relative to it (the `pedestals` effect's rule too)."""
    out = []
    if not rotor.bearing_nodes:
        return [None] * len(nodes)
    z = rotor.node_z
    for n in nodes:
        k = int(np.argmin([abs(z[b - 1] - z[int(n) - 1]) for b in rotor.bearing_nodes]))
        h = rotor.housing("bearing", k)
        out.append(None if h is None else np.array(h.dofs))
    return out


def _add_between(A, i, h, block):
    """Add the 2x2 `block` (leading stack allowed) of a part acting between DOFs i and its housing's h (or ground)."""
    A[..., i[:, None], i[None, :]] += block
    if h is not None:
        A[..., h[:, None], h[None, :]] += block
        A[..., i[:, None], h[None, :]] -= block
        A[..., h[:, None], i[None, :]] -= block


def with_supports(rotor: Rotor, supports) -> Rotor:
    """`rotor` with constant-coefficient supports (node, K 2x2 N/m, C 2x2 N s/m; Lund's sign: the support's force
    on the shaft is -K x - C v) added to its K and C at the node's x, y (the shaft damping stays beta K_shaft);
    support j (0-based, in the order of all supports) over its pedestal (`rotor.housing("support", j)`) acts between
    the shaft and the housing."""
    import dataclasses

    K, C = rotor.K.copy(), rotor.C.copy()
    out = []
    for node, k, c in supports:
        node = rotor.check_node(int(node), "support node")
        k, c = np.asarray(k, dtype=float), np.asarray(c, dtype=float)
        if k.shape != (2, 2) or c.shape != (2, 2) or not (np.all(np.isfinite(k)) and np.all(np.isfinite(c))):
            raise InputError(f"support at node {node}: stiffness and damping must be finite 2x2 matrices")
        h = rotor.housing("support", len(rotor.supports) + len(out))
        h = None if h is None else np.array(h.dofs)
        _add_between(K, node_dofs(node)[:2], h, k)
        _add_between(C, node_dofs(node)[:2], h, c)
        out.append((node, k, c))
    return dataclasses.replace(rotor, K=K, C=C, supports=rotor.supports + tuple(out))


def machine_disc(disc, density: float) -> RigidDisc:
    """A model file's disc as a rigid disc: lumped (its mass and inertias) or annular from its geometry."""
    if getattr(disc, "lumped", False):
        return RigidDisc(disc.node, disc.mass, disc.diametral_inertia, disc.polar_inertia)
    return RigidDisc.annular(disc.node, disc.width, disc.outer_diameter, disc.bore_diameter, density)


def as_bearings(rotor: Rotor, bearings) -> tuple[LinearBearing, ...]:
    """Normalize bearing input: LinearBearing objects, or one (K, C) pair per `rotor.bearing_nodes`."""
    bearings = list(bearings)
    if all(isinstance(b, LinearBearing) for b in bearings):
        out = tuple(bearings)
    else:
        if len(bearings) != len(rotor.bearing_nodes):
            raise InputError(f"got {len(bearings)} bearing (K, C) pairs; the rotor has "
                             f"{len(rotor.bearing_nodes)} bearing nodes {list(rotor.bearing_nodes)}")
        out = []
        for node, pair in zip(rotor.bearing_nodes, bearings):
            if isinstance(pair, LinearBearing) or len(pair) != 2:
                raise InputError(f"bearing at node {node}: expected a (K, C) pair, got {pair!r}")
            out.append(LinearBearing(node, pair[0], pair[1]))
        out = tuple(out)
    for b in out:
        rotor.check_node(b.node, "bearing node")
    return out


def bearing_matrices(rotor: Rotor, bearings) -> tuple[np.ndarray, np.ndarray]:
    """Global K_total = K_shaft + K_bearings and C_total = C_shaft + C_bearings (SPEC §1: + sign); a bearing over
    a pedestal acts between its journal and the housing.

    `bearings`: LinearBearing objects or one (K, C) pair per bearing node; coefficients may carry a
    leading stack dimension (e.g. one 2x2 per speed), in which case the result is stacked likewise.
    """
    bearings = as_bearings(rotor, bearings)
    stack = np.broadcast_shapes(*(b.stiffness.shape[:-2] for b in bearings),
                                *(b.damping.shape[:-2] for b in bearings))
    K = np.broadcast_to(rotor.K, stack + rotor.K.shape).copy()
    C = np.broadcast_to(rotor.C, stack + rotor.C.shape).copy()
    for b in bearings:
        i, h = film_dofs(rotor, b.node)
        _add_between(K, i, h, coefficient_matrix(b.stiffness, "K"))
        _add_between(C, i, h, coefficient_matrix(b.damping, "C"))
    return K, C


def isotropic(k: float, c: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """(K, C) of an isotropic bearing without cross coupling: K = k I, C = c I."""
    return k * np.eye(2), c * np.eye(2)
