"""Test records made along another path than the identification's model (issue 11, item 5).

`make_record(IndependentSpec(...))` builds one measured record (SPEC §6) of the machine with
supply flows Q1, Q2 (or Q1..QN for a machine of N fluid-film bearings, SPEC §8) and optional effects, and
returns it with the truth it was made from. How the path differs from the identification's model (a list
also in `lubeviz.verification`):

| stage    | identification's model                         | this source                                        |
|----------|------------------------------------------------|----------------------------------------------------|
| film     | 100 x 100, groove refinement 4, sub-cell K, C, | 200 x 200, groove refinement 1, fixed-pattern K, C, |
|          | tables interpolated in the supply             | solved directly at the exact supply (equilibria.py) |
| rotor    | 20 Timoshenko elements, beta = 2e-5 s          | every element split in two (40), beta = 3e-5 s      |
| response | steady complex solve                           | Newmark integration from rest (newmark.py), 15 s at |
|          |                                                | 1e-4 s, last 5 s kept, noise at 12 dB (seeded)      |
| effects  | lubeviz.effects                                | declared and applied here (effects.py)              |

Node numbers (record planes, effect nodes) are the machine's own (paper 1..21); on the split rotor
node n is node 2n - 1. The machine's constant-coefficient supports (SPEC §8 [[supports]]) are in the split
rotor's K and C at their node (the shaft damping is beta times the shaft's own stiffness only).

Static loads on the films. Two fluid-film bearings and no other support (statically determinate): the
reactions of the split rotor pinned at the bearing centres under its weight (and any `side_load`), whatever
the films. Otherwise (3+ bearings, or bearings and supports) the coupled equilibrium of the split rotor on
its supports and on each film, solved here (`static_equilibrium`): every film on the fine mesh at its actual
supply (starved or not) and the record's speed, under its full load vector (a horizontal part included),
each bearing centre at its offset (dX, dY); Newton on the films' reactions with each film's K (the shaft
condensed on the journals), until the shaft pinned where the films hold the journals carries its loads with
exactly the films' forces (relative residual < `STATIC_TOLERANCE`). Not `lubeviz.rotor.statics.
coupled_statics` (flooded films on the model's mesh at the operating speed, the model's rotor).

Static position (`static=True`, SPEC §6 `static: absolute`): each probe reads
    s = gain * (GAP + u(theta + rotation) . (p_static + d(t)))
with u(a) = (cos a, sin a), GAP = 1 mm, p_static the shaft's static position at the plane, d(t) the
dynamic motion; the rest reading is gain * (GAP + u . p_rest). p_static solves the shaft's static
bending under gravity with each journal held at its film equilibrium (so at a bearing centre it is
that equilibrium, relative to the bearing centre); p_rest likewise with the journals at (0, -c_true).
With bearing offsets the journals are held at offset + position and a plane reads relative to the centre
of the bearing whose housing carries its probes (the nearest along the shaft, as the model takes it).
Probes on a pedestal ride the housing, which sags equally at rest and running: not modelled in the
DC. With `static=False` the readings carry the dynamic motion only.

Start-up transient. `truth["transient_residual"]` is the largest distance of the kept samples from
the steady state, relative to the steady 1X (its floor, ~8e-4, is the trapezoidal rule's own error
on the 1X line); a warning is raised above 1 %. `truth["transient_factor"]` is the bound |z|^n_skip
of the slowest discrete mode. With the default 15 s (10 s skipped) the paper's machine at 75 Hz and
Q_T leaves ~1e-54 of the transient. The slowest mode is the oil-whirl mode near 0.65 X: it decays at
12 1/s at 75 Hz and Q_T, but only at 0.2 1/s at 75 Hz and 300 ml/min (not gone after the 10 s skipped), and
part of the 50-100 Hz x 30-180 % Q_T range is unstable (90 Hz at 0.5 and 1.5 Q_T; in the model too),
where `make_record` raises (`max_growth_rate` tells beforehand). The fast option total_s = 6,
duration_s = 5 (1 s skipped) suits well-damped points (75 Hz near Q_T: e^-12); check the residual.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import time
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import scipy.linalg

from ..errors import ConvergenceError, InputError, LubevizError
from ..model.machine import DEFAULT_MACHINE, load_machine
from ..rotor.assembly import Rotor, assemble
from ..rotor.elements import DOF_PER_NODE, RigidDisc, TimoshenkoBeam
from ..rotor.statics import gravity_load, simple_support_reactions
from ..signals.noise import add_noise
from ..signals.records import Record, record_from_arrays, write_record
from . import equilibria
from .effects import channel_index, normalize_effects
from .newmark import amplification, integrate_harmonic
from ..units import MLMIN_PER_M3S

SHAFT_DAMPING_BETA = 3e-5  # s; the model's is 2e-5
GAP = 1.0e-3  # m, the probes' DC gap reading with the shaft at the bearing centre
TRANSIENT_TOLERANCE = 1e-2  # warn when the transient left exceeds 1 % of the steady 1X
X_Y = ((0.0, 90.0), (0.0, 90.0))  # two planes' probes along X and Y (per plane: `XY`)
XY = (0.0, 90.0)
MAX_RECORD_PLANES = 12  # as a record (lubeviz.signals.records.MAX_PLANES)


def fine_node(node: int) -> int:
    """The split rotor's node of machine node `node` (each element split in two)."""
    return 2 * int(node) - 1


@dataclass(frozen=True)
class IndependentSpec:
    """What to record: speed (Hz), supply flows (ml/min), planes, probes, effects, noise, seed.

    Flows: `q1_mlmin`, `q2_mlmin` for a machine of two fluid-film bearings, or `q_mlmin` = every fluid-film
    bearing's flow in the model file's order (any machine, SPEC §8; one of the two forms). Given for a
    two-bearing machine, `q_mlmin` is folded into `q1_mlmin`, `q2_mlmin` (one spec, one form: equal specs
    and the same cached keys either way); for any other count `q1_mlmin`, `q2_mlmin` are None.
    `flows_mlmin` is every bearing's flow in either case. `nodes`: the record's planes (2 or more, each a node
    of the machine; None: the machine's measurement planes, SPEC §8). `probe_angles_deg`: one (a, b) pair per
    plane (None: the machine's declared probes at those of its planes, X and Y elsewhere).
    `effects`: (name, {params}) pairs or 'NAME:key=value,...' strings (SPEC §7 names, see
    `lubeviz.verification.effects`; `bearing = both` means every fluid-film bearing). `snr_db=None`: no
    noise. `static`: keep the DC gap (SPEC §6 `static: absolute`). `total_s` is integrated from rest, the
    last `duration_s` kept. `machine`: a model file (default the paper's machine).
    """

    speed_hz: float
    q1_mlmin: float | None = None
    q2_mlmin: float | None = None
    nodes: tuple[int, ...] | None = None
    probe_angles_deg: tuple[tuple[float, float], ...] | None = None
    effects: tuple = ()
    snr_db: float | None = 12.0
    duration_s: float = 5.0
    total_s: float = 15.0
    static: bool = False
    seed: int = 0
    sample_rate_hz: float = 1.0e4
    machine: str | None = None
    q_mlmin: tuple | None = None

    def __post_init__(self):
        put = functools.partial(object.__setattr__, self)
        for name in ("speed_hz", None, "duration_s", "total_s", "sample_rate_hz"):
            if name is None:  # the flows, in their old place among the numbers
                self._flows(put)
                continue
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float, np.floating, np.integer)) \
                    or not (math.isfinite(v) and v > 0):
                raise InputError(f"IndependentSpec.{name} = {v!r}; expected a positive number")
            put(name, float(v))
        if self.duration_s > self.total_s:
            raise InputError(f"duration_s = {self.duration_s} s is longer than total_s = {self.total_s} s")
        if self.snr_db is not None:
            if not math.isfinite(float(self.snr_db)):
                raise InputError(f"IndependentSpec.snr_db = {self.snr_db!r}; expected a finite number or None")
            put("snr_db", float(self.snr_db))
        planes = {p.node: tuple(float(a) for a in p.probe_angles_deg)
                  for p in _machine(self.machine).measurement_planes}
        nodes = tuple(planes) if self.nodes is None else tuple(self.nodes)
        if not 2 <= len(nodes) <= MAX_RECORD_PLANES or len(set(nodes)) != len(nodes):
            raise InputError(f"IndependentSpec.nodes = {self.nodes!r}; expected 2 to {MAX_RECORD_PLANES} different "
                             "node numbers, one per plane")
        put("nodes", tuple(int(n) for n in nodes))
        given = self.probe_angles_deg
        if given is None:
            given = tuple(planes.get(n, XY) for n in self.nodes)
        try:
            angles = tuple(tuple(float(a) for a in pair) for pair in given)
        except (TypeError, ValueError):
            angles = ()
        if len(angles) != len(self.nodes) or any(len(p) != 2 for p in angles):
            raise InputError(f"IndependentSpec.probe_angles_deg = {self.probe_angles_deg!r}; expected "
                             f"{len(self.nodes)} (angle_a, angle_b) pairs in degrees, one per plane")
        put("probe_angles_deg", angles)
        put("effects", normalize_effects(self.effects))
        put("static", bool(self.static))
        put("seed", int(self.seed))

    def _flows(self, put) -> None:
        """Check the flows against the machine's fluid-film bearings and store them in their one form."""

        def positive(name, v):
            if isinstance(v, bool) or not isinstance(v, (int, float, np.floating, np.integer)) \
                    or not (math.isfinite(v) and v > 0):
                raise InputError(f"IndependentSpec.{name} = {v!r}; expected a positive number")
            return float(v)

        n = len(_machine(self.machine).bearings)
        where = f"the machine {self.machine or DEFAULT_MACHINE} has {n} fluid-film bearing(s)"
        if self.q_mlmin is None:
            if n != 2:
                raise InputError(f"IndependentSpec.q_mlmin: {where}; give q_mlmin = (Q1, ..., Q{n}) ml/min, each "
                                 "bearing's flow in file order (q1_mlmin, q2_mlmin are for two bearings)")
            for name in ("q1_mlmin", "q2_mlmin"):
                if getattr(self, name) is None:
                    raise InputError(f"IndependentSpec.{name} = None; expected a positive number (or give "
                                     "q_mlmin = (Q1, Q2))")
                put(name, positive(name, getattr(self, name)))
            return
        if self.q1_mlmin is not None or self.q2_mlmin is not None:
            raise InputError("IndependentSpec: q_mlmin with q1_mlmin/q2_mlmin; give the flows one way")
        if isinstance(self.q_mlmin, (str, bytes)) or not isinstance(self.q_mlmin, (Sequence, np.ndarray)):
            raise InputError(f"IndependentSpec.q_mlmin = {self.q_mlmin!r}; expected a sequence of {n} flows in ml/min")
        flows = tuple(positive(f"q_mlmin[{k}]", v) for k, v in enumerate(self.q_mlmin))
        if len(flows) != n:
            raise InputError(f"IndependentSpec.q_mlmin has {len(flows)} flow(s) ({list(flows)}); {where}: expected "
                             f"{n}, each bearing's flow in file order")
        if n == 2:  # the two-bearing form: one spec, one form
            put("q1_mlmin", flows[0])
            put("q2_mlmin", flows[1])
            put("q_mlmin", None)
        else:
            put("q_mlmin", flows)

    @property
    def flows_mlmin(self) -> tuple[float, ...]:
        """Every fluid-film bearing's supply flow (ml/min), in the model file's order."""
        return (self.q1_mlmin, self.q2_mlmin) if self.q_mlmin is None else tuple(self.q_mlmin)

    def flows_text(self) -> str:
        """'Q = (q1, q2, ...) ml/min' for messages."""
        return "Q = (" + ", ".join(f"{q:g}" for q in self.flows_mlmin) + ") ml/min"

    def effects_text(self) -> list[str]:
        """The effects in SPEC §7 'NAME:key=value' form."""
        return [name + ":" + ",".join(f"{k}={v}" for k, v in p.items()) for name, p in self.effects]


@dataclass(frozen=True)
class IndependentRecord:
    """A record made by the independent source and the truth behind it (flows, effects, positions)."""

    record: Record
    truth: dict = field(repr=False)
    spec: IndependentSpec | None = None


@functools.lru_cache(maxsize=4)
def _machine(path: str | None):
    return load_machine(None if path is None else Path(path))


def split_rotor(path: str | None = None, shaft_damping_beta: float = SHAFT_DAMPING_BETA, effects=()) -> Rotor:
    """The machine's rotor with every shaft element split into two equal halves (40 elements), its constant supports
    in K and C (`effects`: a `support_stiffness` changes one)."""
    factors = tuple((int(p["support"]), float(p["factor"])) for name, p in normalize_effects(effects)
                    if name == "support_stiffness")
    return _split_rotor(path, shaft_damping_beta, factors)


@functools.lru_cache(maxsize=4)
def _split_rotor(path: str | None, shaft_damping_beta: float, factors: tuple) -> Rotor:
    m = _machine(path)
    beams = []
    for e in m.elements:
        for _ in range(2):
            beams.append(TimoshenkoBeam(len(beams) + 1, 0.5 * e.length, e.diameter, m.young_modulus,
                                        m.poisson_ratio, m.density, inner_diameter=getattr(e, "inner_diameter", 0.0)))
    discs = [RigidDisc(fine_node(d.node), d.mass, d.diametral_inertia, d.polar_inertia)
             if getattr(d, "lumped", False) else
             RigidDisc.annular(fine_node(d.node), d.width, d.outer_diameter, d.bore_diameter, m.density)
             for d in m.discs]
    rotor = assemble(beams, discs, bearing_nodes=[fine_node(b.node) for b in m.bearings],
                     shaft_damping_beta=shaft_damping_beta)
    effects = tuple(("support_stiffness", {"support": j, "factor": f}) for j, f in factors)
    return _add_supports(rotor, _support_parts(m, effects, rotor))


def _support_parts(machine, effects=(), rotor: Rotor | None = None) -> list[tuple]:
    """(split-rotor node, K 2x2, C 2x2, pedestal or None) of each constant support (SPEC §8 [[supports]]), each
    `support_stiffness` effect's factor applied to its K and C."""
    supports = tuple(getattr(machine, "supports", ()))
    factors = [1.0] * len(supports)
    for name, p in normalize_effects(effects):
        if name == "support_stiffness":
            j = int(p["support"]) - 1
            if not 0 <= j < len(supports):
                raise InputError(f"effect support_stiffness: support {p['support']}; the machine has {len(supports)} "
                                 "constant support(s)")
            factors[j] *= float(p["factor"])
    out = []
    for k, (s, f) in enumerate(zip(supports, factors), start=1):
        node = fine_node(s.node)
        if rotor is not None:
            rotor.check_node(node, f"[[supports]] {k} node (split rotor)")
        stiffness, damping = np.asarray(s.stiffness, dtype=float), np.asarray(s.damping, dtype=float)
        if stiffness.shape != (2, 2) or damping.shape != (2, 2) \
                or not (np.all(np.isfinite(stiffness)) and np.all(np.isfinite(damping))):
            raise InputError(f"[[supports]] {k} ({s.name}): stiffness and damping must be finite 2x2 matrices")
        out.append((node, f * stiffness, f * damping, getattr(s, "pedestal", None)))
    return out


def _series(stiffness: np.ndarray, pedestal) -> np.ndarray:
    """The static stiffness of a support over its pedestal: (K^-1 + I / k_h)^-1."""
    return np.linalg.inv(np.linalg.inv(stiffness) + np.eye(2) / pedestal.stiffness)


def _add_supports(rotor: Rotor, parts) -> Rotor:
    """`rotor` with the constant supports `parts` (`_support_parts`; Lund's sign: the support's force on the shaft is
    -K x - C v) added to K and C at the split rotor's node, x and y; the shaft damping (beta K, already in C) stays the
    shaft's own. A support over a pedestal enters K with its static stiffness in series with the pedestal's, and not
    C: the dynamics build the housing (`_system`). `rotor.supports`: (node, static K, C) of each."""
    if not parts:
        return rotor
    K, C = rotor.K.copy(), rotor.C.copy()
    added = []
    for node, stiffness, damping, pedestal in parts:
        i = np.ix_(_xy(node), _xy(node))
        static = stiffness if pedestal is None else _series(stiffness, pedestal)
        K[i] += static
        if pedestal is None:
            C[i] += damping
        added.append((node, static, damping))
    return dataclasses.replace(rotor, K=K, C=C, supports=tuple(added))


def _determinate(machine) -> bool:
    """Two fluid-film bearings and no other support: the static loads are the lever rule's, whatever the films."""
    return len(machine.bearings) == 2 and not tuple(getattr(machine, "supports", ()))


def _offsets(machine) -> np.ndarray:
    """(N, 2) each bearing centre's offset (dX, dY) from the straight line, m (SPEC §8 offset_um)."""
    return np.array([tuple(getattr(b, "offset", (0.0, 0.0))) for b in machine.bearings], dtype=float).reshape(-1, 2)


def _misaligned(machine, effects):
    """`machine` with each `misalignment` effect's move added to its bearing's offset (the file's machine itself when
    there is none): the statics, the static shape and the readings then take the bearing where it is."""
    moves = [(p, _bearings_of(p, len(machine.bearings))) for name, p in effects if name == "misalignment"]
    if not moves:
        return machine
    bearings = list(machine.bearings)
    for p, ks in moves:
        for k in ks:
            dx, dy = tuple(getattr(bearings[k], "offset", (0.0, 0.0)))
            bearings[k] = bearings[k].copy(offset=(dx + 1e-6 * float(p["dx_um"]), dy + 1e-6 * float(p["dy_um"])))
    moved = load_machine(Path(machine.source)) if machine.source else load_machine()
    moved.bearings = bearings
    return moved


def _pedestals_as_found(machine, effects):
    """`machine` with each `pedestals` effect on a bearing whose model file declares a pedestal taken as that pedestal's
    stiffness (its mass and damping as declared): the statics (its sag under the film's load) and the dynamics then
    take the pedestal as it is. The file's machine itself when there is none; two such effects on one pedestal are
    refused."""
    bearings = list(machine.bearings)
    changed = set()
    for name, p in effects:
        if name != "pedestals":
            continue
        for k in _bearings_of(p, len(bearings)):
            if getattr(bearings[k], "pedestal", None) is None:
                continue
            if k in changed:
                raise InputError(f"effect pedestals: the pedestal of bearing {k + 1} is changed twice")
            changed.add(k)
            bearings[k] = bearings[k].copy(pedestal=dataclasses.replace(bearings[k].pedestal,
                                                                        stiffness=float(p["stiffness_n_m"])))
    if not changed:
        return machine
    found = load_machine(Path(machine.source)) if machine.source else load_machine()
    found.bearings = bearings
    return found


def _bearings_of(params, n: int) -> tuple[int, ...]:
    """0-based bearing indices an effect with a `bearing` parameter applies to: `both` is every one of the
    machine's n fluid-film bearings."""
    if params["bearing"] == "both":
        return tuple(range(n))
    k = int(params["bearing"]) - 1
    if not 0 <= k < n:
        raise InputError(f"effect bearing = {params['bearing']!r}; the machine has {n} fluid-film bearing(s)")
    return (k,)


def _plane_housing(rotor: Rotor, node: int) -> int:
    """The bearing (0-based) whose housing carries the probes of a plane at machine node `node`: the nearest
    along the shaft (the first of two as near)."""
    z = rotor.node_z
    at = z[fine_node(node) - 1]
    return int(np.argmin([abs(z[b - 1] - at) for b in rotor.bearing_nodes]))


def _check_machine(machine) -> None:
    """What this source does not build is refused here (today: nothing of SPEC §8; a pedestal under a fluid-film
    bearing or a constant support is a housing mass on its spring and damper, the film or support between the shaft
    and it)."""


def _sag_compliance(machine) -> np.ndarray:
    """(2N,) each journal's extra static compliance (m/N) from the pedestal its model file puts under its bearing: the
    housing yields by W / k along the load W the film carries (0 without a pedestal)."""
    h = np.zeros(2 * len(machine.bearings))
    for k, b in enumerate(machine.bearings):
        if getattr(b, "pedestal", None) is not None:
            h[2 * k:2 * k + 2] = 1.0 / b.pedestal.stiffness
    return h


def _xy(node: int) -> np.ndarray:
    """Global x, y DOFs of a split-rotor node."""
    return DOF_PER_NODE * (node - 1) + np.array([0, 1])


def _static_shape(rotor: Rotor, gravity: float, journal_positions, extra=None) -> np.ndarray:
    """Static shaft (all DOFs) under gravity (and the static force `extra`, all DOFs) with each journal's x, y held
    at the given position."""
    fixed = np.concatenate([_xy(b) for b in rotor.bearing_nodes])
    free = np.setdiff1d(np.arange(rotor.n_dof), fixed)
    q = np.zeros(rotor.n_dof)
    q[fixed] = np.ravel(journal_positions)
    F = gravity_load(rotor, gravity) - rotor.K[:, fixed] @ q[fixed]
    if extra is not None:
        F = F + extra
    q[free] = np.linalg.solve(rotor.K[np.ix_(free, free)], F[free])
    return q


def _held_journals(rotor: Rotor, F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(R0, S): the journals' force on the shaft (2N,) held at x (2N,) under the static load F (all DOFs) is
    R0 + S x, the split rotor (its supports in K) condensed on the journals' x, y."""
    fixed = np.concatenate([_xy(b) for b in rotor.bearing_nodes])
    free = np.setdiff1d(np.arange(rotor.n_dof), fixed)
    K = rotor.K
    solved = np.linalg.solve(K[np.ix_(free, free)], np.column_stack([F[free], K[np.ix_(free, fixed)]]))
    return (K[np.ix_(fixed, free)] @ solved[:, 0] - F[fixed],
            K[np.ix_(fixed, fixed)] - K[np.ix_(fixed, free)] @ solved[:, 1:])


def _rest_sag(rotor: Rotor, gravity: float, rest, extra, H) -> np.ndarray:
    """(N, 2) each pedestal's sag (m) at rest, each journal on its bearing at `rest` (N, 2) from the straight line
    plus the sag: with R(g) = R0 + S g the journals' force on the shaft held at g, g = rest - H R solves
    (I + S H) R = R0 + S rest. Zero without pedestals (H = 0)."""
    h = np.ravel(H)
    if not np.any(h):
        return np.zeros_like(np.asarray(rest, float))
    R0, S = _held_journals(rotor, gravity_load(rotor, gravity) + (0.0 if extra is None else extra))
    R = np.linalg.solve(np.eye(h.size) + S * h[None, :], R0 + S @ np.ravel(rest))
    return (-h * R).reshape(-1, 2)


def _pinned_reactions(rotor: Rotor, F: np.ndarray) -> np.ndarray:
    """(n_bearings, 2) forces the journals, pinned at the bearing centres, exert on the rotor under the static
    force F (all DOFs)."""
    fixed = np.concatenate([_xy(b) for b in rotor.bearing_nodes])
    free = np.setdiff1d(np.arange(rotor.n_dof), fixed)
    q = np.zeros(rotor.n_dof)
    q[free] = np.linalg.solve(rotor.K[np.ix_(free, free)], F[free])
    return (rotor.K @ q - F)[fixed].reshape(-1, 2)


def _side_force(spec, rotor: Rotor) -> np.ndarray | None:
    """The static force (all DOFs of the finer rotor) of the spec's `side_load` effects, or None."""
    loads = [p for name, p in spec.effects if name == "side_load"]
    if not loads:
        return None
    F = np.zeros(rotor.n_dof)
    for p in loads:
        n = rotor.check_node(fine_node(p["node"]), "side_load node")
        a = math.radians(p["angle_deg"])
        F[_xy(n)] += p["force_n"] * np.array([math.sin(a), -math.cos(a)])
        if p["moment_nm"]:  # two opposite vertical forces, the node and its neighbour
            m = n + 1 if n < rotor.n_nodes else n - 1
            couple = np.zeros(rotor.n_dof)
            d = abs(rotor.node_z[m - 1] - rotor.node_z[n - 1])
            couple[_xy(n)[1]], couple[_xy(m)[1]] = -1.0 / d, 1.0 / d
            sign = 1.0 if _pinned_reactions(rotor, couple)[0, 1] >= 0 else -1.0  # > 0 loads bearing 1 more
            F += sign * p["moment_nm"] * couple
    return F


def _bow_shape(rotor: Rotor, node: int, ends: tuple[int, int] = (0, 0)) -> tuple[np.ndarray, np.ndarray]:
    """s(z) = sin(pi (z - z1)/(z2 - z1)) between the machine's nodes `ends` ((0, 0): the outermost bearing
    centres; 0 outside) and its slope."""
    z = rotor.node_z
    if ends[0]:
        z1, z2 = (z[fine_node(n) - 1] for n in ends)
    else:
        zb = [z[b - 1] for b in rotor.bearing_nodes]
        z1, z2 = min(zb), max(zb)
    inside = (z >= z1) & (z <= z2)
    arg = math.pi * (z - z1) / (z2 - z1)
    s = np.where(inside, np.sin(arg), 0.0)
    ds = np.where(inside, math.pi / (z2 - z1) * np.cos(arg), 0.0)
    ref = s[fine_node(node) - 1]
    if not abs(ref) > 1e-9:
        raise InputError(f"effect bow: node {node} is not between the bearing centres; the bow "
                         "(zero at and outside the bearings) cannot be scaled there")
    return s / ref, ds / ref


@dataclass
class _Build:
    """The linear system of one record: matrices, force, DOFs of the probes' shaft and housings."""

    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    F: np.ndarray
    housing: dict  # bearing index -> global (x, y) DOFs of its pedestal


def _system(spec: IndependentSpec, rotor: Rotor, machine, omega: float, films) -> _Build:
    peds = {k: {"mass_kg": b.pedestal.mass, "stiffness_n_m": b.pedestal.stiffness,
                "damping_ns_m": b.pedestal.damping}
            for k, b in enumerate(machine.bearings) if getattr(b, "pedestal", None) is not None}
    declared = set(peds)  # (an effect on one of these is already in `machine`: `_pedestals_as_found`)
    for name, p in spec.effects:
        if name == "pedestals":
            for k in _bearings_of(p, len(rotor.bearing_nodes)):
                if k in declared:
                    continue
                if k in peds:
                    raise InputError(f"effect pedestals: bearing {k + 1} is given a pedestal twice")
                peds[k] = p
    n_r = rotor.n_dof
    n = n_r + 2 * len(peds)
    M, K, C = (np.zeros((n, n)) for _ in range(3))
    M[:n_r, :n_r] = rotor.M
    K[:n_r, :n_r] = rotor.K
    C[:n_r, :n_r] = rotor.C + omega * rotor.G  # shaft damping beta K + gyroscopic
    housing = {}
    for j, k in enumerate(sorted(peds)):
        h = n_r + 2 * j + np.array([0, 1])
        housing[k] = h
        p = peds[k]
        M[h, h] += p["mass_kg"]
        K[h, h] += p["stiffness_n_m"]
        C[h, h] += p["damping_ns_m"]
    # a constant support over a pedestal: out of the shaft's K (its static series stiffness, `_add_supports`), and
    # between the shaft and its own housing instead
    parts = [part for part in _support_parts(machine, spec.effects) if part[3] is not None]
    if parts:
        grown = n + 2 * len(parts)
        M, K, C = (np.pad(A, ((0, grown - n), (0, grown - n))) for A in (M, K, C))
        for i, (node, stiffness, damping, ped) in enumerate(parts):
            j, h = _xy(node), n + 2 * i + np.array([0, 1])
            K[np.ix_(j, j)] -= _series(stiffness, ped)
            M[h, h] += ped.mass
            K[h, h] += ped.stiffness
            C[h, h] += ped.damping
            for a, c, sign in ((j, j, 1.0), (j, h, -1.0), (h, j, -1.0), (h, h, 1.0)):
                K[np.ix_(a, c)] += sign * stiffness
                C[np.ix_(a, c)] += sign * damping
        n = grown
    for k, (b, film) in enumerate(zip(rotor.bearing_nodes, films)):
        j = _xy(b)
        # SPEC §1: the film's K, C enter with + sign, acting on the journal's motion relative to
        # its housing (the ground without a pedestal).
        pairs = [(j, j, 1.0)]
        if k in housing:
            h = housing[k]
            pairs += [(j, h, -1.0), (h, j, -1.0), (h, h, 1.0)]
        for a, c, sign in pairs:
            K[np.ix_(a, c)] += sign * film.K
            C[np.ix_(a, c)] += sign * film.C
    # Eq. 9: the unbalance turns with the shaft, f = Re(m Omega^2 e^{i p} (1, -i) e^{i Omega t}).
    F = np.zeros(n, dtype=complex)
    main = machine.unbalance_moment * omega**2 * np.exp(1j * machine.unbalance_phase)

    def add_unbalance(node, amp):
        i = _xy(fine_node(node))
        F[i[0]] += amp
        F[i[1]] += -1j * amp

    add_unbalance(machine.unbalance_node, main)
    for u in getattr(machine, "other_unbalances", ()):  # the model file's further unbalances (SPEC §8)
        add_unbalance(u.node, u.moment * omega**2 * np.exp(1j * u.phase))
    for name, p in spec.effects:
        if name == "unbalance2":
            rotor.check_node(fine_node(p["node"]), "unbalance2 node")
            add_unbalance(p["node"], p["ratio"] * main * np.exp(1j * math.radians(p["phase_deg"])))
        elif name == "seal":
            i = _xy(rotor.check_node(fine_node(p["node"]), "seal node"))
            K[i[0], i[1]] += p["kxy_n_m"]
            K[i[1], i[0]] -= p["kxy_n_m"]
            K[i[0], i[0]] += p.get("kxx_n_m", 0.0)
            K[i[1], i[1]] += p.get("kxx_n_m", 0.0)
        elif name == "bow":
            rotor.check_node(fine_node(p["node"]), "bow node")
            for end in (p.get("from_node", 0), p.get("to_node", 0)):
                if end:
                    rotor.check_node(fine_node(end), "bow span end")
            s, ds = _bow_shape(rotor, p["node"], (p.get("from_node", 0), p.get("to_node", 0)))
            a = 1e-6 * p["amplitude_um"] * np.exp(1j * (machine.unbalance_phase + math.radians(p["phase_deg"])))
            qb = np.zeros(rotor.n_dof, dtype=complex)
            qb[0::DOF_PER_NODE] = a * s  # x = Re(a s e^{i Omega t})
            qb[1::DOF_PER_NODE] = -1j * a * s  # y = Re(-i a s e^{i Omega t}): turning with the shaft
            qb[3::DOF_PER_NODE] = a * ds  # theta_y = dx/dz
            qb[2::DOF_PER_NODE] = 1j * a * ds  # theta_x = -dy/dz
            F[:n_r] += rotor.K @ qb  # K_shaft (q - q_bow): the bow's rotating force
    return _Build(M=M, C=C, K=K, F=F, housing=housing)


STATIC_TOLERANCE = 1e-8  # the coupled statics' residual (the films' forces against the pinned shaft's reactions)
STATIC_FLOOR = 1e-6  # ... or below this once it stops halving: the films' own tolerance (1e-9 of the load, times
# the shaft's stiffness over the film's) can hold it above STATIC_TOLERANCE on a stiff shaft
STATIC_MAX_ITER = 30
# Each step's loads are taken to 1e-7 of the largest (the same decimal place for both components), then solved: a
# film under a load is cached under that load's digits, and the Newton steps' last bits are the host's (another
# CPU's BLAS moved the fan's loads by ~1e-13, and 12 digits of each load in the key sent every film of a
# three-support machine to be solved again, session 60; on a third host with its own fresh install the films came
# out ~1e-11 apart, and at 9 digits a step's load still crossed a rounding edge in about one statics in six, session
# 66). A film moves by no more than its load's own relative change (5e-15 for 3e-15, measured on the fan's bearing
# A), so the residual ends near 1e-7 and the loop stops below STATIC_FLOOR once it no longer halves.
STATIC_DIGITS = 7


def _snapped(loads: np.ndarray) -> np.ndarray:
    """Each bearing's load (N, 2) rounded to STATIC_DIGITS significant digits of its larger component, at one decimal
    place for both (a near-zero component is not rounded to its own digits); -0.0 made 0.0."""
    out = np.array(loads, dtype=float)
    for w in out:
        size = float(np.max(np.abs(w)))
        if size > 0.0 and math.isfinite(size):
            place = STATIC_DIGITS - 1 - math.floor(math.log10(size))
            w[:] = [round(float(v), place) + 0.0 for v in w]
    return out


@dataclass(frozen=True)
class StaticEquilibrium:
    """The static equilibrium of the split rotor on its films (and supports): `loads` (N, 2) what each film
    carries, [Wx, Wy] N (the film's force on its journal is -W), `positions` (N, 2) the journals' positions from
    their bearing centres (m), `films` each bearing's `equilibria.FilmPoint` under its load, `support_forces`
    (n_supports, 2) each constant support's force on the shaft (N), `iterations` (0: the determinate lever rule),
    `residual` the largest difference between a film's force and the reaction of the shaft pinned where the films
    hold the journals, relative to the largest load (0 when determinate)."""

    loads: np.ndarray
    positions: np.ndarray
    films: tuple
    support_forces: np.ndarray
    iterations: int
    residual: float
    determinate: bool


def _bearing_changes(effects, machine) -> list[dict]:
    """Each bearing's viscosity and clearance with the effects' changes."""
    n = len(machine.bearings)
    changes = [{"viscosity": b.viscosity, "clearance": b.clearance} for b in machine.bearings]
    for name, p in effects:
        for k in _bearings_of(p, n) if name in ("viscosity", "clearance") else ():
            if name == "viscosity":
                changes[k]["viscosity"] *= p["factor"]
            else:
                changes[k]["clearance"] = 1e-6 * p["clearance_um"]
    return changes


def _film_bearings(machine, changes, mesh=None) -> list:
    """The bearings on the independent source's fine mesh (`mesh` = (n_circumferential, n_axial): another one,
    groove refinement still 1, e.g. a coarser one for a quick check of the statics)."""
    if mesh is None:
        return [equilibria.fine_bearing(b, **ch) for b, ch in zip(machine.bearings, changes)]
    n_c, n_a = (int(v) for v in mesh)
    return [b.copy(n_circumferential=n_c, n_axial=n_a, groove_refinement=equilibria.GROOVE_REFINEMENT, **ch)
            for b, ch in zip(machine.bearings, changes)]


def _support_forces(rotor: Rotor, q: np.ndarray) -> np.ndarray:
    """(n_supports, 2) each constant support's force on the shaft, -K x, under the static shape q."""
    return np.array([-(k @ q[_xy(node)]) for node, k, _ in rotor.supports]).reshape(-1, 2)


def _statics(machine, rotor: Rotor, omega: float, bearings, flows, side, use_cache: bool) -> StaticEquilibrium:
    """The films' static loads and equilibria: the lever rule when determinate (today's path, unchanged), else the
    coupled equilibrium (`_coupled_statics`)."""
    if _determinate(machine):
        reactions = simple_support_reactions(rotor, machine.gravity).forces
        loads = np.stack([np.zeros_like(reactions), -reactions], axis=-1)  # what each film carries (N)
        if side is not None:
            loads = loads - _pinned_reactions(rotor, side)
        films = [equilibria.film_point(b, omega, tuple(w), q, use_cache=use_cache)
                 for b, w, q in zip(bearings, loads, flows)]
        return StaticEquilibrium(loads=loads, positions=np.array([f.position for f in films]), films=tuple(films),
                                 support_forces=np.zeros((0, 2)), iterations=0, residual=0.0, determinate=True)
    return _coupled_statics(machine, rotor, omega, bearings, flows, side, use_cache)


def _coupled_statics(machine, rotor: Rotor, omega: float, bearings, flows, side, use_cache: bool) -> StaticEquilibrium:
    """The statically indeterminate shaft on its films and supports (SPEC §8), on this source's own terms.

    The split rotor (its supports in K) condensed on the journals' x, y: held at x, the journals take the
    reactions R(x) = R0 + S x (the force of the journals on the shaft; R0 the reactions pinned at the straight
    line under gravity and any side load). Each film under the load W_k = -R_k (its full vector) puts its journal
    at p_k from its bearing centre d_k (the offset), with stiffness K_k. Newton on R: the residual
    r = R - R(d + p(R)), dr/dR = I + S K^-1, so with p' = p + dp, dp = (S + K)^-1 r, the next R = R - K dp.
    Starts from the stiff-film limit (journals at the bearing centres); ends when |r| < STATIC_TOLERANCE |R| (or
    below STATIC_FLOOR once it stops halving). Each step solves every film (fine mesh, actual supply, cached on
    disk); the answer's films are those solved at the loads returned."""
    n = len(bearings)
    F = gravity_load(rotor, machine.gravity)
    R0, S = _held_journals(rotor, F if side is None else F + side)
    d = _offsets(machine).ravel()
    H = _sag_compliance(machine)  # a pedestal's housing sags by -H R: the journal's place on the ground moves with it
    R = np.linalg.solve(np.eye(2 * n) + S * H[None, :], R0 + S @ d)  # stiff films: journals at the bearing centres
    scale = float(np.max(np.abs(R)))
    residual = math.inf
    for it in range(1, STATIC_MAX_ITER + 1):
        loads = _snapped(-R.reshape(n, 2))
        R = -loads.ravel()
        try:
            films = [equilibria.film_point(b, omega, tuple(w), q, use_cache=use_cache)
                     for b, w, q in zip(bearings, loads, flows)]
        except ConvergenceError as exc:
            raise ConvergenceError(f"independent statics, step {it}: loads {np.round(loads, 1).tolist()} N: {exc}") \
                from None
        p = np.concatenate([f.position for f in films])
        r = R - (R0 + S @ (d + p - H * R))
        last, residual = residual, float(np.max(np.abs(r)) / max(float(np.max(np.abs(R))), 1e-12 * scale))
        if residual < STATIC_TOLERANCE or (residual < STATIC_FLOOR and residual > 0.5 * last):
            break
        # each film in series with its housing's spring: stiffness (K^-1 + H)^-1, the journal at p - H R
        Kf = np.linalg.inv(scipy.linalg.block_diag(*[np.linalg.inv(f.K) for f in films]) + np.diag(H))
        dp = np.linalg.solve(S + Kf, r)
        R = R - Kf @ dp
    else:
        raise ConvergenceError(f"independent statics: the films' forces still differ from the shaft's reactions by "
                               f"{residual:.1e} (relative) after {STATIC_MAX_ITER} steps")
    positions = p.reshape(n, 2)
    sag = (H * loads.ravel()).reshape(n, 2)  # each pedestal's housing, sagging under its film's load
    q = _static_shape(rotor, machine.gravity, positions + _offsets(machine) + sag, side)
    return StaticEquilibrium(loads=loads, positions=positions, films=tuple(films),
                             support_forces=_support_forces(rotor, q), iterations=it, residual=residual,
                             determinate=False)


def static_equilibrium(machine: str | None = None, speed_hz: float | None = None, q_mlmin=None, *, effects=(),
                       mesh=None, use_cache: bool = True) -> StaticEquilibrium:
    """The independent source's static equilibrium of `machine` (a model file, default the paper's) at `speed_hz`
    (default its operating speed) and supply flows `q_mlmin` (every fluid-film bearing's, file order), with
    the effects that change it (viscosity, clearance, side_load, misalignment). `mesh` (n_circumferential,
    n_axial): the films on another mesh than the fine one (a quick check; records always use the fine mesh).
    What `make_record` uses for the same spec (with mesh=None)."""
    m = _machine(machine)
    _check_machine(m)
    rotor = split_rotor(machine)
    speed = m.operating_speed if speed_hz is None else float(speed_hz)
    if q_mlmin is None or isinstance(q_mlmin, (str, bytes)) or not isinstance(q_mlmin, (Sequence, np.ndarray)):
        raise InputError(f"static_equilibrium: q_mlmin = {q_mlmin!r}; expected every fluid-film bearing's flow "
                         "(ml/min) in file order")
    spec = IndependentSpec(speed_hz=speed, q_mlmin=tuple(q_mlmin), effects=effects, machine=machine)
    m = _pedestals_as_found(_misaligned(m, spec.effects), spec.effects)
    rotor = split_rotor(machine, effects=spec.effects)
    omega = 2.0 * math.pi * spec.speed_hz
    bearings = _film_bearings(m, _bearing_changes(spec.effects, m), mesh)
    flows = tuple(q / MLMIN_PER_M3S for q in spec.flows_mlmin)
    return _statics(m, rotor, omega, bearings, flows, _side_force(spec, rotor), use_cache)


def _films(spec: IndependentSpec, machine, rotor: Rotor, omega: float, use_cache: bool):
    """Each bearing on the fine mesh with the effects' viscosity/clearance, solved at its supply under its static
    load (`_statics`)."""
    changes = _bearing_changes(spec.effects, machine)
    flows = tuple(q / MLMIN_PER_M3S for q in spec.flows_mlmin)
    statics = _statics(machine, rotor, omega, _film_bearings(machine, changes), flows, _side_force(spec, rotor),
                       use_cache)
    return list(statics.films), changes, statics


def _probes(spec: IndependentSpec):
    """Actual probe angles (rad, declared + rotation) and gains, (plane, probe)."""
    n = len(spec.probe_angles_deg)
    rot = [0.0] * n
    gain = np.ones((n, 2))
    for name, p in spec.effects:
        if name == "probe_rotation":
            if p["plane"] > n:
                raise InputError(f"effect probe_rotation: plane {p['plane']}; the record has {n} plane(s)")
            rot[p["plane"] - 1] += p["angle_deg"]
        elif name == "probe_gain":
            i = channel_index(p["channel"])
            if i // 2 >= n:
                raise InputError(f"effect probe_gain: channel {p['channel']}; the record has {n} plane(s)")
            gain[i // 2, i % 2] *= p["gain"]
    angles = np.radians([[a + rot[k] for a in spec.probe_angles_deg[k]] for k in range(n)])
    return angles, gain


def _resolve(readings, declared_deg):
    """x, y from the readings of a probe pair at its declared angles (as Record.xy does)."""
    (a, b) = np.radians(declared_deg)
    A = np.array([[math.cos(a), math.sin(a)], [math.cos(b), math.sin(b)]])
    return np.linalg.solve(A, readings)


def _prepare(spec: IndependentSpec, use_cache: bool):
    """Films, the linear system and its eigenvalues (first-order form) of one spec."""
    machine = _pedestals_as_found(_misaligned(_machine(spec.machine), spec.effects), spec.effects)
    _check_machine(machine)
    rotor = split_rotor(spec.machine, effects=spec.effects)
    for node in spec.nodes:
        rotor.check_node(fine_node(node), "record node")
    omega = 2.0 * math.pi * spec.speed_hz
    films, changes, statics = _films(spec, machine, rotor, omega, use_cache)
    sys = _system(spec, rotor, machine, omega, films)
    n = len(sys.M)
    lam = scipy.linalg.eigvals(np.block([[np.zeros((n, n)), np.eye(n)],
                                         [-np.linalg.solve(sys.M, sys.K), -np.linalg.solve(sys.M, sys.C)]]))
    return machine, rotor, omega, films, changes, statics, sys, lam


def max_growth_rate(spec: IndependentSpec, *, use_cache: bool = True) -> float:
    """Largest real part (1/s) of the source's modes for `spec`: < 0 stable; -1/(its value) the slowest
    decay time. Costs the film equilibria (cached) and one eigenvalue problem, no integration."""
    return float(_prepare(spec, use_cache)[-1].real.max())


def _truth(spec: IndependentSpec, prepared) -> dict:
    """Everything about `spec` that needs no time integration: films, static readings, steady 1X."""
    machine, rotor, omega, films, changes, statics, sys, lam = prepared
    shaft = [_xy(fine_node(n)) for n in spec.nodes]
    housing = [_plane_housing(rotor, n) for n in spec.nodes]  # the bearing whose housing carries each plane's probes
    ref = [sys.housing.get(k) for k in housing]
    Qs = np.linalg.solve(sys.K - omega**2 * sys.M + 1j * omega * sys.C, sys.F)  # steady state, all DOFs
    D = np.array([Qs[s] - (Qs[r] if r is not None else 0.0) for s, r in zip(shaft, ref)])  # (plane, xy)

    # static positions at the planes, running and at rest: the shaft held at each journal's place (its bearing
    # centre's offset + its position there), read from the centre of the bearing that carries the probes
    pos = np.array([f.position for f in films])
    clear = [ch["clearance"] for ch in changes]
    offsets = _offsets(machine)
    side = _side_force(spec, rotor)
    # a pedestal's housing sags along the load its film carries, and its probes sag with it
    H = _sag_compliance(machine).reshape(-1, 2)
    sag_run = H * np.asarray(statics.loads, float)
    rest = np.array([(0.0, -c) for c in clear]) + offsets
    sag_rest = _rest_sag(rotor, machine.gravity, rest, side, H)
    q_run = _static_shape(rotor, machine.gravity, pos + offsets + sag_run, side)
    p_run = q_run[np.array(shaft)] - offsets[housing] - sag_run[housing]
    p_rest = _static_shape(rotor, machine.gravity, rest + sag_rest, side)[np.array(shaft)] - offsets[housing] \
        - sag_rest[housing]

    angles, gain = _probes(spec)
    u = np.stack([np.cos(angles), np.sin(angles)], axis=-1)  # (plane, probe, xy): where each probe points
    steady = gain * np.einsum("kpj,kj->kp", u, D)
    xy = np.array([_resolve(steady[k], pair) for k, pair in enumerate(spec.probe_angles_deg)])  # as the probes say
    zf, zb = 0.5 * (xy[:, 0] + 1j * xy[:, 1]), np.conj(0.5 * (xy[:, 0] - 1j * xy[:, 1]))
    phi = 0.5 * (np.angle(zf) + np.angle(zb))
    phi = phi - np.pi * np.round(phi / np.pi)
    phi = np.where(phi <= -0.5 * np.pi, phi + np.pi, phi)
    return {
        "speed_hz": spec.speed_hz, "q1_mlmin": spec.q1_mlmin, "q2_mlmin": spec.q2_mlmin,
        "q_mlmin": list(spec.flows_mlmin),
        "effects": [(name, dict(p)) for name, p in spec.effects],
        "journal_positions_m": pos, "static_positions_m": p_run, "rest_positions_m": p_rest,
        "static_readings_m": gain * (GAP + np.einsum("kpj,kj->kp", u, p_run)),
        "rest_readings_m": gain * (GAP + np.einsum("kpj,kj->kp", u, p_rest)), "gap_m": GAP,
        "clearance_m": clear, "viscosity_pa_s": [ch["viscosity"] for ch in changes],
        "bearing_loads_n": -np.asarray(statics.loads, float)[:, 1],
        "bearing_load_vectors_n": np.asarray(statics.loads, float), "support_forces_n": statics.support_forces,
        "static_iterations": statics.iterations, "static_residual": statics.residual,
        "plane_bearings": housing,
        "K": np.array([f.K for f in films]), "C": np.array([f.C for f in films]),
        "side_leakage_mlmin": [f.side_leakage * MLMIN_PER_M3S for f in films],
        "steady_xy_m": xy, "steady_true_xy_m": D, "zf": zf, "zb": zb, "fb": np.abs(zf) / np.abs(zb),
        "phi_rad": phi, "max_growth_rate": float(lam.real.max()),
        "film_cached": [f.cached for f in films],
        "_probe_directions": u, "_gain": gain, "_shaft": shaft, "_ref": ref, "_Qs": Qs,
    }


def steady_truth(spec: IndependentSpec, *, use_cache: bool = True) -> dict:
    """The truth `make_record` returns, without integrating: film equilibria, K, C, static and rest
    readings, and the steady 1X (x, y as the declared probes resolve them, zf, zb, fb, phi) of the
    source. Also for unstable operating points (`max_growth_rate` >= 0), where no record exists."""
    truth = _truth(spec, _prepare(spec, use_cache))
    return {k: v for k, v in truth.items() if not k.startswith("_")}


def make_record(spec: IndependentSpec, *, set_name: str | None = None, use_cache: bool = True) -> IndependentRecord:
    """One record of the independent source (see the module docstring) and its truth."""
    t_start = time.perf_counter()
    prepared = _prepare(spec, use_cache)
    lam, sys, omega = prepared[-1], prepared[-2], prepared[2]
    t_film = time.perf_counter()
    if lam.real.max() >= 0.0:
        raise InputError(f"the machine is unstable at {spec.speed_hz:g} Hz with {spec.flows_text()} "
                         f"and effects {spec.effects_text()} (a mode grows at "
                         f"{lam.real.max():.3g} 1/s): no steady record exists")
    truth = _truth(spec, prepared)
    shaft, ref, Qs = truth.pop("_shaft"), truth.pop("_ref"), truth.pop("_Qs")
    u, gain = truth.pop("_probe_directions"), truth.pop("_gain")
    dt = 1.0 / spec.sample_rate_hz
    n_steps = int(round(spec.total_s * spec.sample_rate_hz)) + 1
    n_keep = int(round(spec.duration_s * spec.sample_rate_hz))
    keep_from = n_steps - n_keep

    # outputs: shaft x, y at each plane, and the housing of the plane's bearing when it has a pedestal
    out = np.concatenate(shaft + [r for r in ref if r is not None])
    q = integrate_harmonic(sys.M, sys.C, sys.K, sys.F, omega, dt, n_steps, keep_from, out)
    t_int = time.perf_counter()
    # what is left of the start-up transient: distance from the steady state, relative to its size
    steady_out = (Qs[out][:, None] * np.exp(1j * omega * dt * np.arange(keep_from, n_steps))).real
    residual = float(np.max(np.abs(q - steady_out)) / np.max(np.abs(steady_out)))
    if residual > TRANSIENT_TOLERANCE:
        warnings.warn(f"independent record at {spec.speed_hz:g} Hz, {spec.flows_text()}: the start-up transient is "
                      f"still {100 * residual:.2g} % of the steady 1X in the "
                      f"kept window (slowest mode decays at {-lam.real.max():.3g} 1/s); lengthen total_s",
                      stacklevel=2)
    n_planes = len(spec.nodes)
    d = q[:2 * n_planes].reshape(n_planes, 2, -1)
    row = 2 * n_planes
    for k in range(n_planes):
        if ref[k] is not None:  # probes on a pedestal read the shaft relative to its housing
            d[k] -= q[row:row + 2]
            row += 2

    readings = gain[..., None] * np.einsum("kpj,kjn->kpn", u, d)
    if spec.static:
        readings = readings + truth["static_readings_m"][..., None]
    if spec.snr_db is not None:
        readings = add_noise(readings, spec.snr_db, np.random.default_rng(spec.seed))

    flows = {"q1_mlmin": f"{spec.q1_mlmin:.10g}", "q2_mlmin": f"{spec.q2_mlmin:.10g}"} if spec.q_mlmin is None else \
        {"truth_q_mlmin": ", ".join(f"{q:.10g}" for q in spec.flows_mlmin)}  # N flows: no record key holds them
    meta = {**flows, "seed": str(spec.seed),
            "snr_db": "none" if spec.snr_db is None else f"{spec.snr_db:g}", "synthetic": "independent"}
    if spec.effects:
        meta["effects"] = "; ".join(spec.effects_text())
    record = record_from_arrays(*readings.reshape(2 * n_planes, -1), speed_hz=spec.speed_hz,
                                sample_rate_hz=spec.sample_rate_hz, units="m", nodes=spec.nodes,
                                probe_angles_deg=spec.probe_angles_deg, t0=keep_from * dt,
                                machine=Path(spec.machine or DEFAULT_MACHINE).name, metadata=meta,
                                rest_position=truth["rest_readings_m"] if spec.static else None,
                                set_name=set_name, source=f"independent({spec.speed_hz:g} Hz, seed {spec.seed})")
    truth.update({"transient_factor": float(amplification(lam, dt).max() ** keep_from),
                  "transient_residual": residual,
                  "seconds": {"film": t_film - t_start, "integration": t_int - t_film,
                              "total": time.perf_counter() - t_start}})
    return IndependentRecord(record=record, truth=truth, spec=spec)


def make_set(specs: Sequence[IndependentSpec], set_name: str, *, use_cache: bool = True) -> list[IndependentRecord]:
    """Records of one machine, supply and condition at several speeds, linked by `set: set_name`."""
    specs = list(specs)
    if not specs:
        raise InputError("make_set needs at least one IndependentSpec")
    if not isinstance(set_name, str) or not set_name.strip() or set_name.strip() != set_name \
            or "\n" in set_name:
        raise InputError(f"set name {set_name!r}; expected one line of text without surrounding spaces")
    same = ("q1_mlmin", "q2_mlmin", "q_mlmin", "effects", "machine")
    first = specs[0]
    for s in specs[1:]:
        for f in same:
            if getattr(s, f) != getattr(first, f):
                raise InputError(f"set {set_name!r}: {f} differs between records ({getattr(first, f)!r} vs "
                                 f"{getattr(s, f)!r}); a set is one machine, supply and condition")
    speeds = [s.speed_hz for s in specs]
    if len(set(speeds)) != len(speeds):
        raise InputError(f"set {set_name!r}: speeds {speeds} repeat; expected one record per speed")
    return [make_record(s, set_name=set_name, use_cache=use_cache) for s in specs]


def write_record_csv(rec: IndependentRecord | Record, path, *, units: str = "m") -> Path:
    """Write the record as a SPEC §6 CSV: q1/q2_mlmin, seed, snr_db, `synthetic: independent`,
    `effects`, and `set:`, `static: absolute`, `rest_position:` (in `units`) when the record has them."""
    record = rec.record if isinstance(rec, IndependentRecord) else rec
    if Path(path).suffix.lower() != ".csv":
        raise InputError(f"{path}: write_record_csv writes .csv files; use lubeviz.signals.records.write_record "
                         "for .npz or .mat")
    return write_record(record, path, units=units)


def thresholds_mlmin(speed_hz: float, machine: str | None = None) -> np.ndarray:
    """Q_T (ml/min) of each bearing at `speed_hz`: `flooded_thresholds`' computation, cached on disk."""
    from ..rotor.statics import bearing_static_loads

    m = _machine(machine)
    loads = bearing_static_loads(m)
    omega = 2.0 * math.pi * float(speed_hz)
    return np.array([equilibria.threshold(b, omega, w) * MLMIN_PER_M3S for b, w in zip(m.bearings, loads)])


def corpus_speeds(machine, step_hz: float = 2.5) -> np.ndarray:
    """The speeds a corpus draws from: 2/3 to 4/3 of the machine's operating speed (the paper's 50-100 Hz), within
    its declared range (speed_min_hz, speed_max_hz), on a `step_hz` grid."""
    lo = max(machine.speed_min, 2.0 * machine.operating_speed / 3.0)
    hi = min(machine.speed_max, 4.0 * machine.operating_speed / 3.0)
    return np.arange(lo, hi + 1e-9, step_hz)


def _decays(spec) -> bool:
    """Whether the draw's slowest mode decays by e^-5 before the kept window; a draw whose films the source cannot
    solve (a nearly unloaded bearing's cavitation pattern that does not settle) counts as not, and is drawn again."""
    try:
        return max_growth_rate(spec) < -5.0 / (spec.total_s - spec.duration_s)
    except LubevizError:
        return False


def clean_corpus(n: int, rng: np.random.Generator, *, machine: str | None = None, speed_step_hz: float = 2.5,
                 require_decay: bool = True, max_draws: int = 50, **spec_options) -> list[IndependentSpec]:
    """`n` effect-free specs for rate benchmarks.

    Each draw: a speed of `corpus_speeds` (the paper's 50-100 Hz on a `speed_step_hz` grid; Q_T is solved once per
    grid speed and cached), each flow uniform in 30-180 % of that bearing's Q_T at that speed (`thresholds_mlmin`,
    the model's `flooded_thresholds` computation; every fluid-film bearing of the machine; a bearing whose supply
    the model file declares `known` is fed its `supply_mlmin`, a `flooded` one 120-180 % of its Q_T), the
    machine's planes or its `outside_nodes` (the paper's bearing centres 6, 20 or outside them 5, 21; of a machine
    with more than two planes, all of them or, half the time, two drawn), the planes' probes or the other of X/Y
    and (45, 135), one seed. `spec_options` go to every IndependentSpec (e.g. total_s=6.0).

    Part of that range is unstable or barely stable (the oil-whirl mode near 0.65 X: e.g. 90 Hz at
    0.5 Q_T grows; 75 Hz at 0.55 Q_T decays at only 0.2 1/s), where no steady record exists. With
    `require_decay` (default) a draw is kept only if its slowest mode decays by e^-5 before the kept
    window (growth rate < -5/(total_s - duration_s)); otherwise the flows are drawn again (at most
    `max_draws` times per spec). This costs the film equilibria of every draw (cached on disk, and
    reused by `make_record`), and it biases the corpus away from the instability, as a real test
    campaign would be.
    """
    if not isinstance(rng, np.random.Generator):
        raise InputError("clean_corpus needs a numpy.random.Generator (e.g. np.random.default_rng(1))")
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 0:
        raise InputError(f"n = {n!r}; expected a non-negative integer")
    m = _machine(machine)
    grid = corpus_speeds(m, speed_step_hz)
    planes = (tuple(m.center_nodes), tuple(m.outside_nodes) or tuple(m.center_nodes))
    declared = tuple(tuple(float(a) for a in p.probe_angles_deg) for p in m.measurement_planes)
    if len(declared) != len(planes[0]):
        declared = (XY,) * len(planes[0])
    other = ((45.0, 135.0),) * len(declared) if all(a == XY for a in declared) else (XY,) * len(declared)
    probes = (declared, other)
    specs = []
    while len(specs) < int(n):
        if grid.size == 0:
            raise InputError("clean_corpus: no speed of the grid has a decaying operating point")
        speed = float(rng.choice(grid))
        qt = thresholds_mlmin(speed, machine)
        nodes = planes[int(rng.integers(2))]
        angles = probes[int(rng.integers(2))]
        seed = int(rng.integers(0, 2**31 - 1))
        if len(nodes) < 2:
            raise InputError(f"clean_corpus: the machine {m.source or m.name} has {len(nodes)} measurement "
                             "plane(s); a record holds two at least ([[planes]])")
        if len(nodes) > 2 and rng.random() < 0.5:  # every plane, or (a pair out of service) two of them, in order
            pick = sorted(int(i) for i in rng.choice(len(nodes), size=2, replace=False))
            angles = tuple(angles[i] for i in pick) if len(angles) == len(nodes) else angles
            nodes = tuple(nodes[i] for i in pick)
        for _attempt in range(max_draws):
            frac = rng.uniform(0.3, 1.8, size=len(qt))
            if len(qt) == 2 and all(b.supply == "unknown" for b in m.bearings):  # the paper's draws, unchanged
                flows = dict(q1_mlmin=float(frac[0] * qt[0]), q2_mlmin=float(frac[1] * qt[1]))
            else:
                q = [float(b.supply_flow * MLMIN_PER_M3S) if b.supply == "known" else
                     float((1.2 + 0.4 * (f - 0.3)) * t) if b.supply == "flooded" else float(f * t)
                     for b, f, t in zip(m.bearings, frac, qt)]
                flows = dict(q_mlmin=tuple(q))
            s = IndependentSpec(speed_hz=speed, **flows, nodes=nodes, probe_angles_deg=angles, seed=seed,
                                machine=machine, **spec_options)
            if not require_decay or _decays(s):
                specs.append(s)
                break
        else:  # above the instability threshold (the paper machine's is ~100 Hz): leave this speed out
            grid = grid[grid != speed]
    return specs


__all__ = ["GAP", "SHAFT_DAMPING_BETA", "STATIC_TOLERANCE", "IndependentRecord", "IndependentSpec", "StaticEquilibrium",
           "clean_corpus", "fine_node", "make_record", "make_set", "max_growth_rate", "split_rotor",
           "static_equilibrium", "steady_truth", "thresholds_mlmin", "write_record_csv"]
