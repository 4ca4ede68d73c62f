"""Mesh convergence of the equilibrium and coefficients (issue: film model, mesh study)."""

from __future__ import annotations

import numpy as np

from ..model.bearing import Bearing
from .equilibrium import find_equilibrium
from .feed import Feed
from ..units import MLMIN_PER_M3S


def mesh_study(bearing: Bearing, omega: float, load, feeds: dict[str, Feed],
               meshes=((50, 50), (100, 100), (200, 200))) -> list[dict]:
    """Equilibrium and coefficients of `bearing` for each feed on each mesh (rows of plain numbers)."""
    rows = []
    for name, feed in feeds.items():
        for n_circ, n_axial in meshes:
            b = bearing.copy(n_circumferential=n_circ, n_axial=n_axial)
            eq = find_equilibrium(b, omega, load, feed)
            rows.append({
                "feed": name, "mesh": f"{n_circ}x{n_axial}", "converged": eq.converged,
                "eccentricity_ratio": eq.eccentricity_ratio, "attitude_deg": float(np.degrees(eq.attitude_angle)),
                "side_leakage_mlmin": eq.film.side_leakage * MLMIN_PER_M3S,
                "K": eq.coefficients.K.tolist(), "C": eq.coefficients.C.tolist(), "seconds": eq.seconds,
            })
    return rows
