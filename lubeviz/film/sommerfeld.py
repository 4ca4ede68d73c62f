"""What a non-mass-conserving film model says, for comparison with the p-theta model (teaching).

Full Sommerfeld: Reynolds' equation with the film full everywhere (theta = 1), negative pressures allowed.
Half Sommerfeld (Guembel): the same pressure with its negative part set to zero. Neither has a supply flow
among its inputs, so neither can represent a starved bearing: at a given journal position it gives the
same film whatever oil arrives, where the p-theta model's pressure zone shrinks as the supply falls.

The discrete equations are those of the p-theta model (`operator`) with every free cell held full: one
linear solve of the pattern system (`solver.PatternSystem`), at the same mesh, groove and feed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .feed import Feed, setup_problem
from .operator import FilmProblem, film_force
from .solver import Columns, PatternSystem, _whole


@dataclass(frozen=True)
class SommerfeldFilm:
    """Pressures (Pa) on the whole film, shape (n_axial, n_circ), and the film force [Fx, Fy] (N) of each."""

    full: np.ndarray  # full Sommerfeld (negative where the gap diverges)
    half: np.ndarray  # half Sommerfeld: max(full, 0)
    force_full: np.ndarray
    force_half: np.ndarray


def sommerfeld_film(bearing, omega: float, position) -> SommerfeldFilm:
    """Full and half Sommerfeld solutions at journal `position` (m): the groove held at ambient pressure
    (the classical model has no supply flow), or, without a groove, the plain bearing's feed line."""
    feed = Feed.flooded() if bearing.has_groove else Feed.plain()
    return sommerfeld_solution(setup_problem(bearing, omega, position, feed))


def sommerfeld_solution(problem: FilmProblem) -> SommerfeldFilm:
    """Full and half Sommerfeld solutions of `problem` with every free cell full (its feed as given)."""
    system = PatternSystem(problem, ~problem.fixed, Columns(problem))
    P, _ = system.fields(system.solve())
    half = np.maximum(P, 0.0)
    return SommerfeldFilm(full=_whole(problem, P) * problem.p_ref, half=_whole(problem, half) * problem.p_ref,
                          force_full=film_force(problem, P), force_half=film_force(problem, half))
