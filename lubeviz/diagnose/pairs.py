"""Which pairs of effects a diagnosis fits: a linear screen over every pair of its single candidates.

Two effects at once can each fit the record poorly alone: a turned probe on plane 2 with bearing 2 worn to 161 um
(the paper's loop, case 45) leaves chi2 783 and 793 alone, 8th and 10th of the singles, and 1.6 for 6 dof
together. A pair search among the best few singles never tries it, and fitting every pair costs hundreds of fits.

Each single candidate's fit says how its effect moves the features: the secant from the plain fit to its own
optimum with the flows' part taken out (the direction at the size the record asked of it), and, for an effect
of several parameters, the further directions its Jacobian there adds (a 1X force's phase). With the flows'
Jacobian at the plain fit, the best a pair can do in that linear picture is one small least-squares problem: the
pairs are ranked by it, and the best few are fitted for real (`loop._try_pairs`). The screen only chooses what is
fitted; nothing is named from it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import LubevizError
from ..identify.fit.least_squares import feature_parts
from ..identify.forward.model import wrap_difference


@dataclass(frozen=True)
class _Directions:
    """What one record set's features do, whitened: the residual at the plain fit and the flows' Jacobian there."""

    sigma: np.ndarray
    residual: np.ndarray
    flows: np.ndarray
    features: np.ndarray  # the plain fit's model features (unwhitened)
    theta: np.ndarray  # the plain fit's flows (every flow, m^3/s)
    free_flows: np.ndarray


def _parts(chains, meas, names):
    """[(chain, feature names, measured values)] of each record, as a fit takes them."""
    return feature_parts(chains, meas, names)[0]


def _point(chain, values) -> tuple[np.ndarray, np.ndarray]:
    """A fit's `values` (its free parameters) as the chain's whole vector, and the free indices."""
    free = np.array([i for i in range(chain.n_params) if i not in chain.known_flows], dtype=int)
    theta = chain.start()
    theta[free] = values
    return theta, free


def _jacobian(chains, meas, names, values):
    """(features, Jacobian over the free parameters, names, free indices, the whole parameter vector, the measured
    features) stacked over the set's records at `values`."""
    theta, free = _point(chains[0], values)
    gs, Js, ns, fms = [], [], [], []
    for chain, use, fm in _parts(chains, meas, names):
        g, J = chain.jacobian(theta, use, free=free)
        gs.append(g)
        Js.append(J)
        ns += list(use)
        fms.append(fm)
    return np.concatenate(gs), np.concatenate(Js), tuple(ns), free, theta, np.concatenate(fms)


def _plain(chains, meas, names, before) -> _Directions:
    g, J, use, free, theta, fm = _jacobian(chains, meas, names, before.values)
    sigma = np.asarray(before.features_sigma, dtype=float)
    nq = chains[0].n_flows
    flows = np.array([j for j, i in enumerate(free) if i < nq], dtype=int)
    return _Directions(sigma=sigma, residual=wrap_difference(fm - g, use) / sigma, flows=J[:, flows] / sigma[:, None],
                       features=g, theta=theta[:nq], free_flows=free[flows])


def _columns(chains, meas, names, plain: _Directions, cand) -> np.ndarray | None:
    """The whitened directions a single candidate's effect adds (k columns for its k parameters), or None."""
    chains_c = [c.adding(*(e.candidate() for e in cand.effects)) for c in chains]
    try:
        g, J, use, free, theta, _fm = _jacobian(chains_c, meas, names, cand.fit.values)
    except LubevizError:
        return None
    nq = chains[0].n_flows
    dq = (theta[:nq] - plain.theta)[plain.free_flows]
    secant = wrap_difference(g - plain.features, use) / plain.sigma - plain.flows @ dq
    own = J[:, [j for j, i in enumerate(free) if i >= nq]] / plain.sigma[:, None]
    k = own.shape[1]
    norm = np.linalg.norm(secant)
    if k == 0:
        return None
    if norm < 1e-12:  # the fit stayed at no effect: the local directions alone
        return own
    cols = [secant / norm]
    if k > 1:  # the directions the other parameters add beside the secant (a force's phase)
        rest = own - np.outer(cols[0], cols[0] @ own)
        u, s, _ = np.linalg.svd(rest, full_matrices=False)
        cols += [u[:, i] for i in range(k - 1) if s[i] > 1e-9 * max(s[0], 1e-300)]
    return np.column_stack(cols)


def screen(chains, meas, names, before, singles, *, dof_min: int, skip=frozenset(), lead=None,
           gain_min: float = 0.0) -> list:
    """[(a, b, dof)]: the pairs of `singles` (fitted single candidates of different effects) that leave at least
    `dof_min` degrees of freedom, best first by the chi2 the linear picture leaves; pairs whose labels are in `skip`
    (frozensets) are left out. With `lead` (a fitted single candidate), only pairs (lead, b) of b in `singles` that
    lower the lead's own chi2 in that picture by at least `gain_min`."""
    if before is None or getattr(before, "features_sigma", None) is None:
        return []
    plain = _plain(chains, meas, names, before)
    n = plain.residual.size
    cols = [(c, _columns(chains, meas, names, plain, c)) for c in ([lead] if lead is not None else []) + list(singles)]
    cols = [(c, A) for c, A in cols if A is not None]
    if lead is not None and (not cols or cols[0][0] is not lead):
        return []
    ranked = []
    alone = _left(plain, cols[0][1]) if lead is not None else np.inf
    for i, (a, A) in enumerate(cols[:1] if lead is not None else cols):
        for b, B in cols[i + 1:]:
            if a.effect.effect_name == b.effect.effect_name or frozenset((a.label, b.label)) in skip:
                continue
            dof = n - (len(a.fit.values) + len(b.fit.values) - plain.flows.shape[1])  # less the pair's parameters
            if dof < dof_min:
                continue
            left = _left(plain, np.column_stack([A, B]))
            if lead is None or alone - left >= gain_min:
                ranked.append((left, a, b, dof))
    ranked.sort(key=lambda t: t[0])
    return [(a, b, dof) for _, a, b, dof in ranked]


def _left(plain: _Directions, A) -> float:
    """chi2 the linear picture leaves with the flows and the directions `A` free."""
    M = np.column_stack([plain.flows, A])
    x, *_ = np.linalg.lstsq(M, plain.residual, rcond=None)
    r = plain.residual - M @ x
    return float(r @ r)


def node_picture(chains, meas, names, before, effects) -> np.ndarray:
    """The chi2 the linear picture leaves (`_left`) with each one of `effects` free beside the flows (one effect at
    each node of a scan), from the plain fit `before`: the directions the effect adds at the plain answer with its
    own parameters at their start values, and the secant there from the plain features. inf where none can be taken
    (no feature sigma in `before`, a chain that fails there). A node scan fits the nodes this ranks best from their
    own starts (`scan.NodeSweep`): it only chooses what is fitted."""
    out = np.full(len(effects), np.inf)
    if before is None or getattr(before, "features_sigma", None) is None:
        return out
    try:
        plain = _plain(chains, meas, names, before)
        base, _ = _point(chains[0], before.values)
    except LubevizError:
        return out
    for k, e in enumerate(effects):
        chains_e = [c.adding(e.candidate()) for c in chains]
        theta = chains_e[0].start()
        theta[:base.size] = base  # the effect's parameters come after the chain's own
        own = np.arange(base.size, theta.size)
        if own.size == 0:
            continue
        parts = _parts(chains_e, meas, names)
        try:
            gs, Js = zip(*(chain.jacobian(theta, use, free=own) for chain, use, _fm in parts))
        except LubevizError:
            continue
        use = tuple(n for _, ns, _ in parts for n in ns)
        secant = wrap_difference(np.concatenate(gs) - plain.features, use) / plain.sigma
        cols = np.concatenate(Js) / plain.sigma[:, None]
        if np.linalg.norm(secant) > 1e-12:
            cols = np.column_stack([secant, cols])
        out[k] = _left(plain, cols)
    return out
