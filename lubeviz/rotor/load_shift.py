"""How the static loads of a statically indeterminate machine follow its supply flows.

On three or more supports each film's share of the weight depends on where its journal sits, and a starved film
lets its journal sink: the load moves to the other supports. `rotor.statics.coupled_statics` solves the loads with
every film flooded; the machine runs at its own flows. Measured on the fan's independent record at 0.9, 1.1, 0.9 of
Q_T: bearing A carries 1935 N against the flooded 2016 N (-4 %). With the loads held at the flooded ones the fit
explained that record (chi2 1.4 for 3 dof) with Q1 3.7 % high and Q2 1.9 % low, each outside its interval: the
flows took up the load's change (session 44).

Linearized about the flooded statics (`LoadShift`): the shaft, condensed to the journals (its constant supports
included), pushes back on a journal displacement du with df = K_s du; each film yields to a change of its load dW
by K_k^-1 dW, K_k its stiffness at its flow, and moves by dp_k(q) = p_k(q) - p_k(flooded) with its flow (the
identification's chain takes both from its tables, `film_bearings` from its film solves). With
df = -dW: (I + K_s K_f^-1) df = K_s dp, so dW = -(I + K_s K_f^-1)^-1 K_s dp. Each bearing's load then scales by
|W + dW| / |W| and its lean turns with W + dW. From the shifted loads the films are evaluated again and the same
solve, with the residual W - W0 + K_s (p(W) - p0) on its right, is a Newton step (`STEPS` of them). A statically
determinate machine (two bearings, no other support): K_s dp = 0, no shift.

A film over a pedestal yields by its housing's sag too, dW / k_h (the pedestal's stiffness k_h): with H = blockdiag
(I / k_h) the equilibrium is (I + K_s H) (W - W0) + K_s (dp + K_f^-1 dW) = 0, i.e. the same equations with the shaft's
stiffness seen through the pedestals, K_s' = (I + K_s H)^-1 K_s (`LoadShift.k_s`).
"""

from __future__ import annotations

import numpy as np

from .elements import X, Y, node_dofs


STEPS = 2  # Newton steps of the equilibrium from the flooded loads: one is the linearized statics, 2.4 % short on
# the fan's bearing A at 16.5 Hz with 0.76 of its Q_T (1482.9 N against the independent statics' 1519.0); two,
# within 0.05 % on every case measured (session 45)


class LoadShift:
    """Each bearing's static load as a function of where its journal sits and how stiff its film is there, about
    the flooded statics: `loads` (N, 2) and the journals' positions `reference` (N, 2) with every film flooded at the
    operating speed (`coupled_statics`; a record at another speed moves the journals too), the bearings at `nodes`
    of `rotor` (whose K holds its constant supports)."""

    def __init__(self, rotor, nodes, loads, reference):
        self.loads = np.asarray(loads, dtype=float)
        self.reference = np.asarray(reference, dtype=float)
        journals = np.concatenate([node_dofs(int(n))[[X, Y]] for n in nodes])
        others = np.setdiff1d(np.arange(rotor.n_dof), journals)
        K = rotor.K
        k_s = K[np.ix_(journals, journals)] - K[np.ix_(journals, others)] @ np.linalg.solve(
            K[np.ix_(others, others)], K[np.ix_(others, journals)])
        # the housings under the films (uncoupled from the shaft in rotor.K: a film is not in it) add their sag
        h = np.zeros(2 * len(nodes))
        for k, n in enumerate(nodes):
            housing = rotor.bearing_housing(int(n)) if hasattr(rotor, "bearing_housing") else None
            if housing is not None:
                h[2 * k:2 * k + 2] = 1.0 / housing.stiffness
        self.k_s = np.linalg.solve(np.eye(2 * len(nodes)) + k_s * h[None, :], k_s)

    def shifted(self, positions, stiffness, loads=None, target=None) -> np.ndarray:
        """The loads (..., N, 2) with the journals at `positions` (..., N, 2) in their bearings (m), each film of
        static stiffness `stiffness` (..., N, 2, 2) there (its K at its flow), the films carrying `loads`
        (..., N, 2; default the flooded ones). From the flooded loads this is the linearized statics; from loads
        already shifted once (the films evaluated again under them) it is a Newton step of the equilibrium
        W - W0 + K_s (p(W) - p0) = 0. `target` (..., N, 2): W0, the loads the films would carry held where the flooded
        statics put them (default the flooded loads; an effect that loads the shaft otherwise adds its change)."""
        dp = np.asarray(positions, dtype=float) - self.reference
        n = dp.shape[-2]
        base = self.loads if loads is None else np.asarray(loads, dtype=float)
        compliance = np.zeros(dp.shape[:-2] + (2 * n, 2 * n))
        inv = np.linalg.inv(np.asarray(stiffness, dtype=float))
        for k in range(n):
            compliance[..., 2 * k:2 * k + 2, 2 * k:2 * k + 2] = inv[..., k, :, :]
        a = np.eye(2 * n) + self.k_s @ compliance
        residual = np.einsum("ij,...j->...i", self.k_s, dp.reshape(dp.shape[:-2] + (2 * n,)))
        if loads is not None or target is not None:
            aim = self.loads if target is None else np.asarray(target, dtype=float)
            shape = np.broadcast_shapes(np.shape(base), np.shape(aim), dp.shape)
            residual = residual + np.broadcast_to(base - aim, shape).reshape(shape[:-2] + (2 * n,))
        dw = -np.linalg.solve(a, residual[..., None])[..., 0]
        return base + dw.reshape(dp.shape)  # (base broadcasts)
