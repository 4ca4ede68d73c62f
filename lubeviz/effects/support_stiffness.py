"""A constant support (a rolling-element bearing, a seal, a coupling's support) stiffer or softer than declared."""

from __future__ import annotations

import numpy as np
import param

from ..errors import InputError
from ..model.quantity import Quantity
from .base import Effect, as_array, register


@register
class SupportStiffness(Effect):
    """Constant support `support` has `factor` times its declared stiffness and damping. The support is the model
    file's [[supports]] entry (1..S): a rolling-element bearing worn loose or preloaded, a loose plummer block, a seal
    rubbed open.

    The support's change acts at its node (between the shaft and its pedestal when the file declares one): the
    machine's modes and its 1X response move as a film's change of flow moves them. On three or more supports it
    shares the weight otherwise as well: a softer support sags and sheds load onto the films, which then sit
    elsewhere in their bearings. Those load changes are taken with the films held where they sit at the declared
    statics (`static_load_change`), and the films then yield to them in the flows' load shift (`rotor.load_shift`),
    in size and lean.
    Changes the rotor stage (and the bearings' static loads).
    """

    effect_name = "support_stiffness"
    kind_words = "a support's stiffness"
    title_words = "the stiffness of {support}"
    stage = "rotor"
    continuous = ("factor",)
    placement = ("support",)
    neutral = {"factor": 1.0}
    step = {"factor": 1e-3}
    search = {"factor": (0.5,)}  # worn loose
    diagnose_free = ("factor",)
    separated_by = ("a vibration measurement on the support's housing, or records at several speeds (a support's "
                    "stiffness does not change with speed, a film's does)")

    support = param.Integer(1, bounds=(1, None), doc="Constant support whose stiffness differs (1..S, file order)")
    factor = Quantity(1.0, unit="", bounds=(0.05, 20.0),
                      doc="Its stiffness and damping over the declared (< 1: softer, a bearing worn loose)")
    statics = param.Parameter(None, precedence=-1,
                              doc="What the static loads' change needs of the machine (set when bound to a machine)")

    @property
    def index(self) -> int:
        return int(self.support) - 1

    def bind(self, machine) -> "SupportStiffness":
        supports = tuple(getattr(machine, "supports", ()))
        if not supports:
            raise InputError(f"effect {self.label()}: {machine.source or machine.name} declares no constant support "
                             "([[supports]]) to change")
        if self.support > len(supports):
            raise InputError(f"effect {self.label()}: support {self.support} of {len(supports)} "
                             f"([[supports]] 1..{len(supports)} of {machine.source or machine.name})")
        if self.statics is not None:
            return self
        return self.copy(statics=_SupportStatics(machine, self.index))

    def changes_support(self, j: int) -> bool:
        return j == self.index

    def support_change(self, j: int, omega: float, values: dict, shape):
        if j != self.index:
            return None
        st = self._bound()
        f = as_array(values, self, "factor", shape)
        return (f - 1.0)[..., None, None] * (st.K + 1j * omega * st.C)

    def static_load_change(self, values: dict, shape):
        st = self._bound()
        if not st.indeterminate:
            return None
        return st.loads(as_array(values, self, "factor", shape)) - st.W0

    def _bound(self) -> "_SupportStatics":
        if self.statics is None:
            raise InputError(f"effect {self.label()} is not bound to a machine (its support's stiffness)")
        return self.statics

    def placeable(self, rotor) -> bool:
        return int(self.support) <= len(rotor.supports)

    def placements(self, *, n_bearings: int, n_planes: int, n_supports: int = 0):
        return [self.copy(support=j) for j in range(1, n_supports + 1)]

    def demo(self, machine) -> "SupportStiffness":
        return self.bind(machine).shown(factor=0.5)

    def told(self, std: dict | None = None, machine=None) -> str:
        text = super().told(std, machine)
        st = self.statics
        if st is None and machine is not None:
            st = self.bind(machine).statics
        if st is None or not st.indeterminate:
            return text
        w = st.loads(np.asarray(float(self.factor)))
        each = ", ".join(f"bearing {k + 1} {np.linalg.norm(a):.0f} N (declared {np.linalg.norm(b):.0f} N)"
                         for k, (a, b) in enumerate(zip(w, st.W0)))
        return (f"{text} The bearings' static loads with the journals held where the declared statics put them: "
                f"{each} (the films then yield some of the change back).")


class _SupportStatics:
    """How the films' static loads follow support j's stiffness factor f, the films held where the declared statics
    put them (`rotor.statics.coupled_statics`; stiff films as `side_load`'s shares).

    With the journals held (a film over a pedestal: held to its housing), the shaft's DOFs left are u = T u_r. The
    support's change dK = (f - 1) K_j acts on its relative motion P^T u (P: +1 at its node, -1 at its pedestal). The
    declared state has P^T u0 = r0 = -K_j^-1 R0 (R0 its force on the shaft). With A = T^T K T, B = T^T P, G = A^-1 B,
    H = B^T G (Woodbury, rank 2): v = (I + dK H)^-1 dK r0, du = -T G v, and the held journals' forces change by
    df = (K du + P dK (r0 + P^T du)) at their DOFs; each film's load by -df."""

    def __init__(self, machine, j: int):
        from ..rotor.assembly import film_dofs, rotor_from_machine
        from ..rotor.elements import X, Y, node_dofs
        from ..rotor.statics import coupled_statics, statically_determinate

        rotor = rotor_from_machine(machine)
        node, K, C = rotor.supports[j]
        self.K, self.C = np.asarray(K, dtype=float), np.asarray(C, dtype=float)
        self.indeterminate = not statically_determinate(machine, rotor)
        n = rotor.n_dof
        if not self.indeterminate:
            return
        cs = coupled_statics(machine)
        self.W0 = np.asarray(cs.loads, dtype=float)
        r0 = -np.linalg.solve(self.K, cs.support_forces[j])
        P = np.zeros((n, 2))
        P[node_dofs(node)[[X, Y]], [0, 1]] = 1.0
        h = rotor.housing("support", j)
        if h is not None:
            P[list(h.dofs), [0, 1]] = -1.0
        # the journals held: dropped (on the ground) or tied to their housing's DOFs
        tied = {}
        journals = []
        for b in rotor.bearing_nodes:
            jd, hd = film_dofs(rotor, b)
            journals.extend(int(d) for d in jd)
            if hd is not None:
                tied.update({int(a): int(c) for a, c in zip(jd, hd)})
        held = set(journals)
        kept = [d for d in range(n) if d not in held]
        T = np.zeros((n, len(kept)))
        T[kept, np.arange(len(kept))] = 1.0
        col = {d: i for i, d in enumerate(kept)}
        for a, c in tied.items():
            T[a, col[c]] = 1.0
        Kr = rotor.K
        A = T.T @ Kr @ T
        G = np.linalg.solve(A, T.T @ P)
        self.H = P.T @ T @ G
        jr = np.array(journals)
        self._J1 = (Kr @ T @ G)[jr]  # (2N, 2): the held journals' force per unit v
        self._Pj = P[jr]
        self.r0 = r0

    def loads(self, f) -> np.ndarray:
        """(..., N, 2) the films' static loads (N, as `coupled_statics`'s) with the support's stiffness x f (...)."""
        f = np.asarray(f, dtype=float)
        dK = (f - 1.0)[..., None, None] * self.K
        v = np.linalg.solve(np.eye(2) + dK @ self.H, (dK @ self.r0)[..., None])[..., 0]
        rel = self.r0 - np.einsum("ij,...j->...i", self.H, v)
        df = -np.einsum("ij,...j->...i", self._J1, v) + np.einsum("ij,...j->...i", self._Pj,
                                                                 np.einsum("...ij,...j->...i", dK, rel))
        return self.W0 - df.reshape(f.shape + self.W0.shape)
