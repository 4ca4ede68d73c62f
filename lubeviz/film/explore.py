"""What a bearing looks like at one supply flow: the fields and figures a person wants to see.

`supply_frame` finds the static equilibrium at a supply flow and keeps only what a view needs (the
pressure and oil-fraction fields on the whole film, the journal position, the eight coefficients and
the derived quantities of `derived.summarize`), not the solver's factorizations, so that a whole sweep
of frames stays small in memory. `supply_frames` walks a list of flows warm-started from neighbour to
neighbour, reporting progress, and may be cancelled between two flows (progress.Cancelled).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ConvergenceError
from ..model.bearing import Bearing
from ..progress import ProgressFn, silent
from .derived import FilmSummary, summarize
from .equilibrium import Equilibrium, find_equilibrium
from .feed import Feed
from .sommerfeld import sommerfeld_film
from ..units import MLMIN_PER_M3S


@dataclass(frozen=True)
class SupplyFrame:
    """One bearing at equilibrium under its load at supply flow `q` (SI; angles in rad).

    Fields are on the whole film, shape (n_axial, n_circ): rows from z = 0 to z = L, columns at the
    cell-centre angles `alpha` (from +Y in the direction of rotation, Eq. 1).
    """

    q: float  # supply flow (m^3/s); inf for a flooded groove
    position: np.ndarray  # [eX, eY] (m)
    K: np.ndarray  # (2, 2) N/m, Lund's sign (SPEC §1)
    C: np.ndarray  # (2, 2) N s/m
    pressure: np.ndarray  # (n_axial, n_circ) Pa
    theta: np.ndarray  # (n_axial, n_circ) oil fraction
    alpha: np.ndarray  # (n_circ,) rad, cell centres
    d_alpha: np.ndarray  # (n_circ,) rad, column widths (narrower where the mesh is refined at the groove)
    z: np.ndarray  # (n_axial,) m
    groove: np.ndarray  # (n_axial, n_circ) bool: cells of the supply groove
    film_thickness: np.ndarray  # (n_circ,) m, h(alpha) of Eq. 1
    summary: FilmSummary
    clearance: float
    half_sommerfeld: np.ndarray  # (n_circ,) Pa: the half-Sommerfeld mid-plane pressure at the same position


    @property
    def eccentricity_ratio(self) -> float:
        return self.summary.eccentricity_ratio

    def on_uniform_grid(self, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(alpha, values) with every column repeated so all have the narrowest column's width: the
        field as an image on a uniform grid (each refined column shown at its own width)."""
        counts = np.maximum(np.rint(self.d_alpha / self.d_alpha.min()).astype(int), 1)
        start = self.alpha[0] - 0.5 * self.d_alpha[0]
        width = 2.0 * np.pi / counts.sum()
        alpha = start + (np.arange(counts.sum()) + 0.5) * width
        return alpha, np.repeat(values, counts, axis=-1)

    def mid_plane(self) -> tuple[np.ndarray, np.ndarray]:
        """Pressure (Pa) and oil fraction along the circumference at the axial row nearest z = L/2."""
        row = self.pressure.shape[0] // 2
        return self.pressure[row], self.theta[row]


def frame_from_equilibrium(eq: Equilibrium) -> SupplyFrame:
    """Keep what a view needs from an equilibrium (drops the solver's factorizations)."""
    sol = eq.film
    pr = sol.problem
    m = pr.mesh
    groove = pr.groove
    if m.half:  # the solved half is mirrored about z = L/2 (see FilmSolution.pressure_field)
        groove = np.concatenate([groove, groove[::-1]], axis=0)
    z = (np.arange(m.n_axial) + 0.5) * m.dz
    q = eq.feed.q_supply if eq.feed.q_supply is not None else math.inf
    return SupplyFrame(
        q=float(q), position=np.array(eq.position, dtype=float),
        K=np.array(eq.coefficients.K), C=np.array(eq.coefficients.C),
        pressure=sol.pressure_field(), theta=sol.theta_field(), alpha=np.array(m.alpha),
        d_alpha=np.array(m.d_alpha), z=z,
        groove=np.array(groove, dtype=bool), film_thickness=np.array(pr.H[0] * pr.clearance),
        summary=summarize(sol, eq.position), clearance=float(pr.clearance),
        half_sommerfeld=_half_sommerfeld_mid_plane(eq))


def _half_sommerfeld_mid_plane(eq: Equilibrium) -> np.ndarray:
    """What a model without a supply flow says at this journal position (film.sommerfeld), mid-plane row."""
    film = sommerfeld_film(eq.bearing, eq.omega, eq.position)
    return film.half[film.half.shape[0] // 2].copy()


def supply_frame(bearing: Bearing, omega: float, load, q_supply: float | None, *,
                 warm: Equilibrium | None = None) -> tuple[SupplyFrame, Equilibrium]:
    """The frame at supply flow `q_supply` (m^3/s; None: flooded groove) and its equilibrium (for warm starts).

    Raises ConvergenceError naming the flow when the equilibrium is not found.
    """
    feed = Feed.flooded() if q_supply is None else Feed.flow(float(q_supply))
    eq = find_equilibrium(bearing, omega, load, feed,
                          start=None if warm is None else warm.position,
                          warm=None if warm is None else warm.film)
    if not eq.converged:
        what = "flooded groove" if q_supply is None else f"supply {q_supply * MLMIN_PER_M3S:.4g} ml/min"
        raise ConvergenceError(f"equilibrium at {what}: {eq.message}")
    return frame_from_equilibrium(eq), eq


def supply_frames(bearing: Bearing, omega: float, load, flows, *, progress: ProgressFn = silent,
                  order=None) -> dict[float, SupplyFrame]:
    """Frames at every flow of `flows` (m^3/s), warm-started in `order` (default: ascending).

    The progress callback may raise progress.Cancelled between two flows; the frames found so far are
    lost with it (a caller that wants them passes flows in smaller batches).
    """
    flows = [float(q) for q in flows]
    seq = sorted(flows) if order is None else [flows[k] for k in order]
    out: dict[float, SupplyFrame] = {}
    prev = None
    for n, q in enumerate(seq):
        frame, prev = supply_frame(bearing, omega, load, q, warm=prev)
        out[q] = frame
        progress(n + 1, len(seq), f"{q * MLMIN_PER_M3S:.0f} ml/min")
    return out
