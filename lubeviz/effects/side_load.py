"""A static load on the shaft that the model file does not declare: a belt, a gear, a radial hydraulic force or a
misaligned coupling."""

from __future__ import annotations

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


@register
class SideLoad(Effect):
    """A static force of `force_n` and a couple of `moment_nm` act on the shaft at `node`, besides its weight.

    A belt's pull, a gear's or an impeller's radial force, or a coupling laid out of line loads the shaft
    statically: each bearing then carries another static load than the model file's weight share, its film
    another Sommerfeld number (S ~ 1 / load), so its stiffness, damping, journal position and flooded threshold
    change although the oil and the bearing have not. A force shares out over the bearings by the lever rule
    (the shaft's statics), a couple moves load from one bearing to another. From one record's 1X this can
    look like a 1X force or a flow change; the static shaft position (the probes' DC gap) shows the journals
    moved, and records at several speeds tell it from a 1X force. The loads act along the weight (vertical:
    `force_n` > 0 presses down); a horizontal load turns the film's load line, which the tables do not hold.
    Changes the bearings stage. `node` None: midway between the outermost bearings (with two bearings a force
    and a couple at any node load them the same way: where it acts is not identifiable from them).
    """

    effect_name = "side_load"
    kind_words = "a static side load"
    stage = "bearings"
    static_load = True
    continuous = ("force_n", "moment_nm")
    placement = ("node",)
    neutral = {"force_n": 0.0, "moment_nm": 0.0}
    step = {"force_n": 1.0, "moment_nm": 1.0}
    diagnose_free = ("force_n", "moment_nm")
    separated_by = ("the static shaft position (the probes' DC gap: the journals sit elsewhere in their "
                    "bearings), or records at several speeds")

    node = param.Integer(None, allow_None=True, bounds=(1, None),
                         doc="Rotor node where the load acts; None: midway between the outermost bearings")
    force_n = Quantity(0.0, unit="N", bounds=(-1e6, 1e6), doc="Static force along the weight (N; > 0 presses down)")
    moment_nm = Quantity(0.0, unit="N m", bounds=(-1e6, 1e6),
                         doc="Static couple in the vertical plane (N m; > 0 loads the first bearing more)")
    shares = param.Array(None, allow_None=True, precedence=-1,
                         doc="(n_bearings, 2): each bearing's share of a unit force and of a unit couple at the node "
                             "(set when the effect is bound to a machine)")
    loads = param.Array(None, allow_None=True, precedence=-1, doc="The bearings' declared static loads (N)")
    indeterminate = param.Boolean(False, precedence=-1,
                                  doc="Whether the machine stands on 3+ supports (set when bound): the loads' change "
                                      "is then given with the journals held (`static_load_change`) and the films "
                                      "yield to it in the chain's load shift")

    def title(self) -> str:
        return ("a static side load (between the bearings)" if self.node is None
                else f"a static side load at node {self.node}")

    def bind(self, machine) -> "SideLoad":
        from ..rotor.assembly import rotor_from_machine
        from ..rotor.statics import bearing_static_loads, load_shares, moment_shares, statically_determinate

        rotor = rotor_from_machine(machine)
        node = self.node
        if node is None:
            z = rotor.node_z
            ends = [z[n - 1] for n in (min(rotor.bearing_nodes), max(rotor.bearing_nodes))]
            node = int(np.argmin(np.abs(z - 0.5 * sum(ends)))) + 1
        if not 1 <= node <= rotor.n_nodes:
            raise InputError(f"effect side_load: node {node} is not a node of the rotor (1..{rotor.n_nodes})")
        return self.copy(shares=np.stack([load_shares(rotor, node), moment_shares(rotor, node)], axis=-1),
                         loads=np.abs(bearing_static_loads(machine)[:, 1]),
                         indeterminate=not statically_determinate(machine, rotor))

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
        """(..., n_bearings) change of each bearing's static load (N, > 0: it carries more) at `values`."""
        shares, _ = self._bound()
        values = values or {}
        f = as_array(values, self, "force_n", shape)
        m = as_array(values, self, "moment_nm", shape)
        return f[..., None] * shares[:, 0] + m[..., None] * shares[:, 1]

    def bearing_change(self, k: int, values: dict, shape) -> dict:
        """Two supports: bearing `k`'s load x a factor (the lever rule's share of the force and couple). On 3+
        supports nothing here: the loads change through `static_load_change`."""
        _, loads = self._bound()
        if self.indeterminate:
            return {}
        factor = 1.0 + self.load_changes(values, shape)[..., k] / loads[k]
        return {"load_factor": np.clip(factor, *LOAD_FACTOR_RANGE)}

    def static_load_change(self, values: dict, shape):
        """On 3+ supports, (..., N, 2): each film's load changed by its share of the force and couple with the
        journals held (`load_shares`, `moment_shares`: the shaft pinned at them, the constant supports elastic);
        the chain's load shift then lets the films yield, so the loads' size and lean follow (one mechanism with a
        support's stiffness, `Effect.static_load_change`). None on two supports (the load factor there)."""
        if not self.indeterminate:
            return None
        change = self.load_changes(values, shape)  # > 0: the bearing carries more, along the weight (-Y)
        out = np.zeros(change.shape + (2,))
        out[..., 1] = -change
        return out

    def at_limit(self) -> list[int]:
        """The bearings (1-based) whose load change at the current values reaches past LOAD_FACTOR_RANGE, where the
        load factor is held to it (two supports). On 3+ supports the loads are not held there (the films' Sommerfeld
        numbers are held on the tables' grid, `ForwardChain._within_grid`): none (it told a fan's bearing at x0.37
        of its load that the fit had stopped at x0.5, session 56)."""
        if self.indeterminate:
            return []
        _, loads = self._bound()
        factor = 1.0 + self.load_changes() / loads
        return [k + 1 for k, f in enumerate(factor) if not LOAD_FACTOR_RANGE[0] <= f <= LOAD_FACTOR_RANGE[1]]

    def told(self, std: dict | None = None, machine=None) -> str:
        text = super().told(std, machine).replace(" at node None", "")
        if self.shares is None and machine is not None:
            self = self.bind(machine)
        if self.shares is None:
            return text
        _, loads = self._bound()
        new = loads + self.load_changes()
        each = ", ".join(f"bearing {k + 1} {w:.0f} N (declared {w0:.0f} N)" for k, (w, w0) in enumerate(zip(new, loads)))
        limit = self.at_limit()
        past = (f" The load of bearing(s) {', '.join(map(str, limit))} reaches past x{LOAD_FACTOR_RANGE[0]:g}-"
                f"{LOAD_FACTOR_RANGE[1]:g} of the declared, the range the film's tables hold: the fit stopped "
                "there.") if limit else ""
        return f"{text} The bearings' static loads: {each}.{past}"
