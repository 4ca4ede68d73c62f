"""A static load on the shaft that the model file does not declare: a belt, a gear, a radial hydraulic force or a
misaligned coupling."""

from __future__ import annotations

import math

import numpy as np
import param

from ..errors import InputError
from ..model.quantity import Quantity
from .base import Effect, as_array, register

# The static load of a bearing may change to this range of its declared one: the dimensionless tables cover a
# film's Sommerfeld number over x0.5-2 of the declared (S ~ 1 / load); a fit that wants more stops at the edge
# and says so (`at_limit`).
LOAD_FACTOR_RANGE = (0.5, 2.0)
SEARCH_SHARE = 0.3  # a fit's global search also starts from couples that move this share of a bearing's load
# A load off the weight's line leans the films, each the table's film turned rigidly (its grooves held where the
# table has them): its fitted force and couple reach each as far as leans the most sensitive bearing's load this much
# (the turn costs up to 0.45 of |K| per radian flooded, `identify.forward.budget.TURN_ERROR_PER_RAD`; further, a
# horizontal force of half the rig's weight took up a seal and a second unbalance, the paper's loop, session 57)
LEAN_LIMIT_DEG = 8.0


@register
class SideLoad(Effect):
    """A static force of `force_n` and a couple of `moment_nm` act on the shaft at `node`, besides its weight.

    Both act along `angle_deg` from straight down towards +X (0: along the weight; 90: horizontal, towards +X).

    A belt's pull, a gear's or an impeller's radial force, or a coupling laid out of line loads the shaft
    statically: each bearing then carries another static load than the model file's weight share, its film
    another Sommerfeld number (S ~ 1 / load), so its stiffness, damping, journal position and flooded threshold
    change although the oil and the bearing have not. A force shares out over the bearings by the lever rule
    (the shaft's statics), a couple moves load from one bearing to another. From one record's 1X this can
    look like a 1X force or a flow change; the static shaft position (the probes' DC gap) shows the journals
    moved, and records at several speeds tell it from a 1X force. A load off the vertical also turns each film's
    load line: the film is turned with it (`identify.forward.chain._turned`, the grooves held where the table has
    them; tests/effects/test_side_load_direction.py measures what that costs). A diagnosis tries a load along the
    weight and one across it, whose direction it fits where the records can tell it (`placements`, `candidate`).
    Changes the bearings stage. `node` None: midway between the outermost bearings (with two bearings a force and a
    couple at any node load them the same way: where it acts is not identifiable from them).
    """

    effect_name = "side_load"
    kind_words = "a static side load"
    stage = "bearings"
    static_load = True
    continuous = ("force_n", "moment_nm", "angle_deg")
    placement = ("node",)
    neutral = {"force_n": 0.0, "moment_nm": 0.0}
    step = {"force_n": 1.0, "moment_nm": 1.0, "angle_deg": 0.05}
    diagnose_free = ("force_n", "moment_nm")
    separated_by = ("the static shaft position (the probes' DC gap: the journals sit elsewhere in their "
                    "bearings), or records at several speeds")

    node = param.Integer(None, allow_None=True, bounds=(1, None),
                         doc="Rotor node where the load acts; None: midway between the outermost bearings")
    angle_deg = Quantity(0.0, unit="deg", bounds=(-180.0, 180.0),
                         doc="Direction of the force and of the couple's plane, from straight down towards +X: 0 "
                             "along the weight, 90 horizontal towards +X")
    force_n = Quantity(0.0, unit="N", bounds=(-1e6, 1e6),
                       doc="Static force along `angle_deg` (N; > 0 presses down when vertical)")
    moment_nm = Quantity(0.0, unit="N m", bounds=(-1e6, 1e6),
                         doc="Static couple in the plane of `angle_deg` (N m; > 0 loads the first bearing more)")
    direction_fitted = param.Boolean(False, precedence=-1,
                                     doc="Whether a diagnosis fits the direction too (`candidate`): on records that hold "
                                         "the static shaft position or several speeds")
    vectors = param.Array(None, allow_None=True, precedence=-1,
                          doc="(2, n_bearings, 2, 2): each bearing's load change (X, Y; N) under a unit force and a "
                              "unit couple at the node, along the weight [0] and across it towards +X [1] (set when "
                              "the effect is bound to a machine; any direction is their mix)")
    loads = param.Array(None, allow_None=True, precedence=-1, doc="The bearings' declared static loads (N)")
    load_vectors = param.Array(None, allow_None=True, precedence=-1,
                               doc="The bearings' declared static loads (N, X and Y)")
    indeterminate = param.Boolean(False, precedence=-1,
                                  doc="Whether the machine stands on 3+ supports (set when bound): the loads' change "
                                      "is then given with the journals held (`static_load_change`) and the films "
                                      "yield to it in the chain's load shift")

    def __init__(self, **params):
        super().__init__(**params)
        # the direction is given (along the weight unless said): fitted only when released (`candidate`)
        self._free = tuple(p for p in self._free if p != "angle_deg")

    def title(self) -> str:
        where = "(between the bearings)" if self.node is None else f"at node {self.node}"
        if self.direction_fitted:
            return f"a static side load {where}, in a direction fitted"
        return f"a {self.direction_words()}static side load {where}"

    @property
    def direction_free(self) -> bool:
        return "angle_deg" in self.free

    @property
    def moves_weight_loads(self) -> bool:
        """Along the weight, or in a direction fitted: yes. Across it (90 deg, given): its part along the weight is
        nil to first order, so the loads along the weight are as unpinned beside it as beside any other effect."""
        return self.direction_fitted or self.direction_free or abs(float(self.angle_deg)) != 90.0

    def direction_words(self) -> str:
        """'' for a load along the weight, 'horizontal ' for one across it, else its angle."""
        a = float(self.angle_deg)
        if a == 0.0:
            return ""
        if abs(a) == 90.0:
            return "horizontal "
        return f"{a:g}°-from-down "

    def label(self) -> str:
        """'side_load[node=5]' along the weight (the label every earlier diagnosis gave it); with its direction
        fitted 'side_load[node=5,direction=fitted]', and a given other one with its angle."""
        if self.direction_fitted:
            return f"{self.effect_name}[node={self.node},direction=fitted]"
        if float(self.angle_deg) == 0.0:
            return f"{self.effect_name}[node={self.node}]"
        return f"{self.effect_name}[node={self.node},angle_deg={float(self.angle_deg):g}]"

    def placements(self, *, n_bearings: int, n_planes: int, n_supports: int = 0,
                   rich: bool = False) -> list["SideLoad"]:
        """Along the weight, and across it: a belt, a gear or a volute's radial force points anywhere (a load at 75 deg
        from down read as a pedestal under bearing 1 and the flows 11 % off, their interval missing them: the pump's
        loop, case 20, session 56). On `rich` records (the static shaft position, or several speeds) the second's
        direction is fitted from horizontal: a load at 68 deg read as a horizontal one took up its vertical part
        with Q1 3 % off, outside its interval (the paper's loop, case 10, session 57). On one record of the 1X alone
        it stays horizontal: fitted there, a direction left a degree of freedom, and a load of any direction took
        up two other faults at once, flows 26-30 % off (the same loop, cases 29 and 33). On a shaft held at three or
        more places the load's node is scanned as well, and one record of the 1X alone (6 features for 3 flows on the
        fan) cannot carry that: a horizontal load took the place of a turned probe with thinner oil, its interval
        missing Q1 (tests/diagnose/test_pairs.py, the fan loop's case 4): tried there on `rich` records only. A given
        direction stays as given."""
        if float(self.angle_deg) != 0.0 or (n_bearings + n_supports > 2 and not rich):
            return [self]
        return [self, self.copy(angle_deg=90.0, direction_fitted=bool(rich))]

    def candidate(self) -> "SideLoad":
        """As a diagnosis tries it: the force and the couple free, and the direction too where `direction_fitted`."""
        new = super().candidate()
        if self.direction_fitted:
            new._free = (*new._free, "angle_deg")
        return new

    def bind(self, machine) -> "SideLoad":
        vectors, declared, indeterminate = _bound_arrays(machine, self.node)
        return self.copy(vectors=vectors, load_vectors=declared, loads=np.linalg.norm(declared, axis=-1),
                         indeterminate=indeterminate)

    def bounds(self, pname: str) -> tuple[float, float]:
        """Off the weight's line, the force and the couple each within what leans the most sensitive bearing's load
        LEAN_LIMIT_DEG on its own (past that the rigid turn of the film is not the film); along it, the declared
        bounds (the load factor holds the size, `at_limit`)."""
        if pname == "angle_deg" and pname not in getattr(self, "_limits", {}):
            return (0.0, 180.0)  # a force at a + 180 deg is the force at a reversed
        if (pname in ("force_n", "moment_nm") and pname not in getattr(self, "_limits", {})
                and (float(self.angle_deg) != 0.0 or self.direction_free) and self.vectors is not None):
            w0 = self.load_vectors  # the reach of a load across the weight (the most leaning direction)
            across = np.stack([-w0[:, 1], w0[:, 0]], axis=-1) / self.loads[:, None]
            perp = np.abs(np.einsum("ki,ki->k", self.vectors[1][:, 0 if pname == "force_n" else 1], across))
            if np.any(perp > 0.0):
                reach = math.tan(math.radians(LEAN_LIMIT_DEG)) * float(np.min(self.loads[perp > 0] / perp[perp > 0]))
                return (-reach, reach)
        return super().bounds(pname)

    @property
    def shares(self) -> np.ndarray | None:
        """(n_bearings, 2): each bearing's share of a unit force and of a unit couple at the node along `angle_deg` (N
        per N and per N m, > 0: it carries more that way), None until bound."""
        if self.vectors is None:
            return None
        a = math.radians(float(self.angle_deg))
        return np.einsum("kjx,x->kj", self._unit(np.cos(a), np.sin(a)), np.array([math.sin(a), -math.cos(a)]))

    def _unit(self, c, s):
        """(..., n_bearings, 2, 2) the unit changes along the direction of cosine c and sine s (numbers or arrays)."""
        c, s = np.asarray(c, dtype=float), np.asarray(s, dtype=float)
        if c.ndim == 0 and s == 0.0 and c == 1.0:
            return self.vectors[0]
        return c[..., None, None, None] * self.vectors[0] + s[..., None, None, None] * self.vectors[1]

    def scan_nodes(self, rotor) -> tuple[int, ...]:
        """On a shaft held at three or more places, every node: there a force and a couple share out over the
        bearings otherwise at each node (a force between A and B, one between B and C and one at B load the fan's
        films in patterns no force and couple at one node make up: 32-38 % of each left over), so where the load
        acts is a place to find, as a second unbalance's is. On two supports () (a force and a couple at any node
        load them alike)."""
        from .bow import support_nodes

        return tuple(range(1, rotor.n_nodes + 1)) if len(support_nodes(rotor)) > 2 else ()

    def search_values(self, pname: str, machine) -> tuple[float, ...]:
        """The couple that moves SEARCH_SHARE of the most sensitive bearing's declared load, either way: a fit from no
        load at a node away from the true one ends in a poor basin there (a couple of 1252 N m at the fan's node 18:
        from none, chi2 338 and 1617 at nodes 17 and 19, and the record, which fits at chi2 0.2 at 18, was left
        unexplained: its loop case 168). The force needs none: it shares out by the lever rule."""
        if pname != "moment_nm":
            return ()
        bound = self if self.shares is not None else self.bind(machine)
        shares, loads = bound._bound()
        reach = SEARCH_SHARE * float(np.min(loads / np.maximum(np.abs(shares[:, 1]), 1e-300)))
        return (-reach, reach)

    def values(self) -> dict:
        v = super().values()
        if v["node"] is None:  # not given: "where it acts" is not a number to write back
            del v["node"]
        return v

    def _bound(self):
        if self.shares is None:
            raise InputError("effect side_load is not bound to a machine (its bearings' shares of the load)")
        return self.shares, self.loads

    def demo(self, machine) -> "SideLoad":
        """A coupling out of line that moves a tenth of the first bearing's load onto the others."""
        bound = self.bind(machine)
        shares, loads = bound._bound()
        return bound.shown(force_n=0.0, moment_nm=round(float(0.1 * loads[0] / shares[0, 1]), 1))

    def load_changes(self, values: dict | None = None, shape=()) -> np.ndarray:
        """(..., n_bearings) change of each bearing's static load along `angle_deg` (N, > 0: it carries more that
        way) at `values`."""
        shares, _ = self._bound()
        values = values or {}
        f = as_array(values, self, "force_n", shape)
        m = as_array(values, self, "moment_nm", shape)
        return f[..., None] * shares[:, 0] + m[..., None] * shares[:, 1]

    def load_vector_changes(self, values: dict | None = None, shape=()) -> np.ndarray:
        """(..., n_bearings, 2) change of each bearing's static load (N, X and Y; the weight's is -Y) at `values`."""
        self._bound()
        values = values or {}
        f = as_array(values, self, "force_n", shape)
        m = as_array(values, self, "moment_nm", shape)
        if "angle_deg" in values:
            a = np.radians(as_array(values, self, "angle_deg", shape))
            unit = self._unit(np.cos(a), np.sin(a))
        else:
            a = math.radians(float(self.angle_deg))
            unit = self._unit(math.cos(a), math.sin(a))
        return f[..., None, None] * unit[..., 0, :] + m[..., None, None] * unit[..., 1, :]

    def bearing_change(self, k: int, values: dict, shape) -> dict:
        """Two supports: bearing `k`'s load x a factor (the lever rule's share of the force and couple), and turned by
        its lean's change when the load is not along the weight. On 3+ supports nothing here: the loads change
        through `static_load_change`."""
        _, loads = self._bound()
        if self.indeterminate:
            return {}
        if float(self.angle_deg) == 0.0 and "angle_deg" not in values:  # along the weight: the size alone
            factor = 1.0 + self.load_changes(values, shape)[..., k] / loads[k]
            return {"load_factor": np.clip(factor, *LOAD_FACTOR_RANGE)}
        w0 = self.load_vectors[k]
        w = w0 + self.load_vector_changes(values, shape)[..., k, :]
        factor = np.linalg.norm(w, axis=-1) / loads[k]
        lean = np.arctan2(w[..., 0], -w[..., 1]) - np.arctan2(w0[0], -w0[1])
        return {"load_factor": np.clip(factor, *LOAD_FACTOR_RANGE), "lean": lean}

    def static_load_change(self, values: dict, shape):
        """On 3+ supports, (..., N, 2): each film's load changed by its share of the force and couple with the
        journals held (`_unit_changes`: the shaft pinned at them, the constant supports elastic); the chain's load
        shift then lets the films yield, so the loads' size and lean follow (one mechanism with a support's
        stiffness, `Effect.static_load_change`). None on two supports (the load factor and lean there)."""
        if not self.indeterminate:
            return None
        return self.load_vector_changes(values, shape)

    def at_limit(self) -> list[int]:
        """The bearings (1-based) whose load change at the current values reaches past LOAD_FACTOR_RANGE, where the
        load factor is held to it (two supports). On 3+ supports the loads are not held there (the films' Sommerfeld
        numbers are held on the tables' grid, `ForwardChain._within_grid`): none (it told a fan's bearing at x0.37
        of its load that the fit had stopped at x0.5, session 56)."""
        if self.indeterminate:
            return []
        _, loads = self._bound()
        factor = np.linalg.norm(self.load_vectors + self.load_vector_changes(), axis=-1) / loads
        return [k + 1 for k, f in enumerate(factor) if not LOAD_FACTOR_RANGE[0] <= f <= LOAD_FACTOR_RANGE[1]]

    def told(self, std: dict | None = None, machine=None) -> str:
        text = super().told(std, machine).replace(" at node None", "")
        if float(self.angle_deg) != 0.0 or "angle_deg" in (std or {}):
            s = (std or {}).get("angle_deg")
            spread = "" if s is None else f" +- {s:.2g}"
            text = text.rstrip(".") + f", pointing {float(self.angle_deg):.0f}{spread}° from straight down towards +X."
        if self.shares is None and machine is not None:
            self = self.bind(machine)
        if self.shares is None:
            return text
        _, loads = self._bound()
        new = self.load_vectors + self.load_vector_changes()
        each = ", ".join(f"bearing {k + 1} {_load_words(w)} (declared {_load_words(w0)})"
                         for k, (w, w0) in enumerate(zip(new, self.load_vectors)))
        limit = self.at_limit()
        past = (f" The load of bearing(s) {', '.join(map(str, limit))} reaches past x{LOAD_FACTOR_RANGE[0]:g}-"
                f"{LOAD_FACTOR_RANGE[1]:g} of the declared, the range the film's tables hold: the fit stopped "
                "there.") if limit else ""
        return f"{text} The bearings' static loads: {each}.{past}"


def _load_words(w) -> str:
    """'812 N' for a load along the weight, '812 N leaning 12° towards +X' otherwise."""
    lean = float(np.degrees(np.arctan2(w[0], -w[1])))
    size = f"{float(np.hypot(*w)):.0f} N"
    return size if abs(lean) < 0.5 else f"{size} leaning {abs(lean):.0f}° towards {'+X' if lean > 0 else '-X'}"


_BOUND: dict = {}  # (machine's statics key, node) -> `_bound_arrays`: a diagnosis binds ~70 side loads of one machine
BOUND_KEPT = 256


def _bound_arrays(machine, node):
    """(unit changes along the weight and across it (2, n, 2, 2), the declared loads (n, 2), on 3+ supports) of a side
    load at `node` (None: midway between the outermost bearings), kept by the machine's content
    (`rotor.statics._statics_key`): each costs a rotor assembly and eight static solves (0.77 s of a fan's
    diagnosis, session 57)."""
    from ..rotor.assembly import rotor_from_machine
    from ..rotor.statics import _statics_key, bearing_static_loads, statically_determinate

    key = (_statics_key(machine), node)
    hit = _BOUND.get(key)
    if hit is not None:
        return hit
    rotor = rotor_from_machine(machine)
    if node is None:
        z = rotor.node_z
        ends = [z[n - 1] for n in (min(rotor.bearing_nodes), max(rotor.bearing_nodes))]
        node = int(np.argmin(np.abs(z - 0.5 * sum(ends)))) + 1
    if not 1 <= node <= rotor.n_nodes:
        raise InputError(f"effect side_load: node {node} is not a node of the rotor (1..{rotor.n_nodes})")
    out = (np.stack([_unit_changes(rotor, node, a) for a in (0.0, 90.0)]), bearing_static_loads(machine),
           not statically_determinate(machine, rotor))
    for a in out[:2]:
        a.flags.writeable = False
    if len(_BOUND) >= BOUND_KEPT:
        _BOUND.pop(next(iter(_BOUND)))
    _BOUND[key] = out
    return out


def _unit_changes(rotor, node: int, angle_deg: float) -> np.ndarray:
    """(n_bearings, 2, 2): each bearing's static load change (X, Y; N) under a unit force along `angle_deg` (from
    down towards +X) at `node`, and under a unit couple in that plane there, with the shaft pinned at the bearings
    (`rotor.statics.support_reactions`: the lever rule on two supports, the shaft's stiffness and the constant
    supports' on more). The couple's sign: > 0 loads the first bearing more along the direction (a couple about X
    and one about Y each so signed, then mixed as the direction is, so a turned couple stays in its plane whatever
    the rotor's sign of theta_y)."""
    from ..rotor.elements import THETA_X, THETA_Y, X, Y, node_dofs
    from ..rotor.statics import support_reactions

    a = np.radians(angle_deg)
    d = np.array([np.sin(a), -np.cos(a)])
    dofs = node_dofs(node)
    nodes = tuple(rotor.bearing_nodes)

    def loads(F):  # the bearings' load change: minus the supports' reaction on the shaft
        return -support_reactions(rotor, F, nodes)

    force = np.zeros(rotor.n_dof)
    force[dofs[[X, Y]]] = d
    couple = np.zeros((rotor.n_dof, 2))
    for j, (dof, along) in enumerate(((THETA_X, np.array([0.0, -1.0])), (THETA_Y, np.array([1.0, 0.0])))):
        F = np.zeros(rotor.n_dof)
        F[dofs[dof]] = 1.0
        sign = 1.0 if loads(F)[0] @ along >= 0 else -1.0
        couple[:, j] = sign * F
    turned = np.cos(a) * couple[:, 0] + np.sin(a) * couple[:, 1]
    return np.stack([loads(force), loads(turned)], axis=1)
