"""Maps over two of a machine's supply flows, the others held: what the fit's chi^2 and the orbit features do
as the two move (the Maps page of a machine of any number of bearings, the Diagnose page's and the report's
maps). The paper's own maps (Figs. 7, 9-11, two bearings, its error functions) are `identify.paper.maps`.

chi^2 is the fit's own (`least_squares`): the measured features' noise and the model budget, whitened once at
the held point, so the map shows the valley the search walked down.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ...errors import InputError
from ..forward.model import angular_period


@dataclass(frozen=True)
class PairMap:
    """chi^2 and features over flows `pair` (0-based) on the grid qx (n,) x qy (m,), m^3/s; fields are
    indexed [i_x, j_y]. `held`: every parameter's value where the map is drawn (the other flows and the
    effects' parameters); `names`: the features of `features` (last axis)."""

    pair: tuple[int, int]
    qx: np.ndarray
    qy: np.ndarray
    held: np.ndarray
    chi2: np.ndarray | None
    names: tuple[str, ...]
    features: np.ndarray | None
    q_threshold: np.ndarray

    def feature(self, name: str) -> np.ndarray:
        if self.features is None or name not in self.names:
            raise InputError(f"feature {name!r} not in this map; it has {self.names}")
        return self.features[..., self.names.index(name)]

    def periods(self) -> dict:
        return {n: angular_period(n) for n in self.names}


def pair_grid(chain, pair: tuple[int, int], held, *, n: int = 41, lower: float = 0.25, upper: float = 2.0):
    """Parameter vectors over the box of flows `pair` (`lower`-`upper` x each bearing's Q_T, spaced evenly in
    the square root, as the search's grid), every other parameter at `held`: (qx, qy, points (n, n, n_params))."""
    ref = chain[0] if isinstance(chain, (list, tuple)) else chain
    i, j = (int(v) for v in pair)
    if not (0 <= i < ref.n_flows and 0 <= j < ref.n_flows and i != j):
        raise InputError(f"flows {pair}: expected two different flows among 0..{ref.n_flows - 1}")
    if int(n) != n or n < 2:
        raise InputError(f"grid points {n!r}: expected an integer >= 2")
    held = np.asarray(held, dtype=float)
    if held.shape != (ref.n_params,):
        raise InputError(f"held values of shape {held.shape}; expected ({ref.n_params},) {ref.names}")
    s = np.linspace(math.sqrt(lower), math.sqrt(upper), int(n)) ** 2
    qx, qy = s * ref.q_threshold[i], s * ref.q_threshold[j]
    pts = np.repeat(held[None, None, :], qx.size, axis=0).repeat(qy.size, axis=1)
    pts[..., i], pts[..., j] = np.meshgrid(qx, qy, indexing="ij")
    return qx, qy, pts


def chi2_grid(chain, measured, points, *, names: Sequence[str] | None = None, budget=None, at=None) -> np.ndarray:
    """The fit's chi^2 at each parameter vector of `points` (..., n_params): the measured features' noise and
    the model budget evaluated once at `at` (default the chain's start)."""
    from .least_squares import _Problem, feature_parts

    chains = list(chain) if isinstance(chain, (list, tuple)) else [chain]
    meas = list(measured) if isinstance(measured, (list, tuple)) else [measured]
    parts, noise = feature_parts(chains, meas, names)
    ref = chains[0]
    at = ref.start() if at is None else np.asarray(at, dtype=float)
    free = np.arange(ref.n_params)
    prob = _Problem(parts, np.eye(len(noise)), free)
    prob = _Problem(parts, prob.model_cov(at, budget, noise), free)
    return prob.cost_many(points)


def pair_map(chain, pair: tuple[int, int], held, *, measured=None, names: Sequence[str] | None = None,
             features: Sequence[str] = (), budget=None, n: int = 41, lower: float = 0.25,
             upper: float = 2.0) -> PairMap:
    """chi^2 against `measured` (when given) and the orbit `features` over the flows `pair`, every other
    parameter at `held` (e.g. a fit's values: the other bearings at their identified flows)."""
    ref = chain[0] if isinstance(chain, (list, tuple)) else chain
    qx, qy, pts = pair_grid(chain, pair, held, n=n, lower=lower, upper=upper)
    chi2 = None if measured is None else chi2_grid(chain, measured, pts, names=names, budget=budget)
    feats = tuple(features)
    values = ref.features(pts, feats) if feats else None
    return PairMap(pair=(int(pair[0]), int(pair[1])), qx=qx, qy=qy, held=np.asarray(held, dtype=float).copy(),
                   chi2=chi2, names=feats, features=values, q_threshold=ref.q_threshold.copy())
