"""Quantities an engineer reads off a film: eccentricity, attitude, film, pressure, flows, losses."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .solver import FilmSolution

THETA_FULL = 1.0 - 1e-9  # theta below this counts as incomplete film


@dataclass(frozen=True)
class FilmSummary:
    """Derived quantities of one film (SI: m, Pa, m^3/s, N*m, W; angles in rad)."""

    eccentricity_ratio: float
    position_angle: float  # journal centre direction, from -Y in the direction of rotation
    attitude_angle: float  # from the load line (-force) to the line of centres, in the direction of rotation
    min_film: float
    max_pressure: float
    cavitated_fraction: float  # film area with theta < 1 (ruptured or incomplete film)
    starved_fraction: float  # the part of it where the gap converges: incomplete film entering the load zone
    # (non-zero even when flooded if the film ruptures between the groove and the thickest film)
    groove_pressure: float  # mean pressure over the groove cells (0 when held flooded)
    friction_torque: float  # viscous torque resisting the journal's rotation
    power_loss: float
    side_leakage: float
    supply: float
    load: float  # magnitude of the film force


def position_angle(e_x: float, e_y: float) -> float:
    """Direction of the journal centre from -Y, in the direction of rotation (SPEC §7), in [0, 2 pi)."""
    return math.atan2(e_x, -e_y) % (2.0 * math.pi)


def attitude_from_force(position, force) -> float:
    """Classic attitude angle: from the load's line of action (-F) to the line of centres (rad)."""
    centre = math.atan2(position[1], position[0])
    load = math.atan2(-force[1], -force[0])
    return (centre - load + math.pi) % (2.0 * math.pi) - math.pi


def summarize(sol: FilmSolution, position) -> FilmSummary:
    """Derived quantities of a solved film at journal `position` (m)."""
    pr = sol.problem
    m = pr.mesh
    c, mu, om = pr.clearance, pr.viscosity, pr.omega
    U = om * m.radius
    area = np.broadcast_to(m.cell_area * m.mirror_factor, m.shape)  # per cell (refined columns are narrower)
    total = float(area.sum())
    incomplete = sol.theta < THETA_FULL
    converging = pr.H_e < np.roll(pr.H_e, 1, axis=1)
    p = sol.P * pr.p_ref
    h = pr.H * c
    # Shear on the journal: Couette mu U / h carried by the oil fraction (theta: oil streamers in the
    # cavitated zone, the JFO/Elrod assumption) plus the Poiseuille part (h / 2) dp/dx.
    spacing = m.d_alpha_east + np.roll(m.d_alpha_east, 1)  # from the west to the east neighbour's centre
    dpdx = (np.roll(p, -1, axis=1) - np.roll(p, 1, axis=1)) / (m.radius * spacing)
    shear = mu * U * sol.theta / h + 0.5 * h * dpdx
    torque = float((shear * area).sum() * m.radius)
    groove = pr.groove & ~pr.fixed
    e_x, e_y = position
    return FilmSummary(
        eccentricity_ratio=math.hypot(e_x, e_y) / c,
        position_angle=position_angle(e_x, e_y),
        attitude_angle=attitude_from_force(position, sol.force),
        min_film=c - math.hypot(e_x, e_y),
        max_pressure=float(p.max()),
        cavitated_fraction=float(area[incomplete].sum() / total),
        starved_fraction=float(area[incomplete & converging].sum() / total),
        groove_pressure=float(np.average(p[groove], weights=area[groove])) if groove.any() else 0.0,
        friction_torque=torque,
        power_loss=torque * om,
        side_leakage=sol.side_leakage,
        supply=sol.supply,
        load=float(np.hypot(*sol.force)),
    )
