"""How oil enters the film, and setting up a film problem for a `Bearing`.

Three feeds (SPEC §3, §7):
- `Feed.flow(q)`: the supply flow q (m^3/s) is prescribed, a source q/Ng in each groove volume (Eq. 4).
  Below the flooded threshold the film upstream of the load is incomplete (starved); above it the
  groove pressurizes. Several axial grooves sharing one supply (SPEC §8) are one set of groove volumes:
  each groove gets the supply in proportion to its area (equal grooves share it equally, as from one
  gallery through equal orifices into grooves near ambient pressure).
- `Feed.flooded()`: the groove(s) held full at ambient pressure (p = 0, theta = 1); the supply is
  whatever the film draws. Its side leakage is the flooded threshold Q_T.
- `Feed.plain()`: no groove; a plain 360-degree bearing fed at ambient pressure along the line of
  maximum film thickness, as Raimondi & Boyd (1958) assume.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..model.bearing import Bearing
from .mesh import FilmMesh, groove_aligned_offset, groove_cells, refined_split
from .operator import FilmProblem, build_problem, max_film_angle
from ..units import MLMIN_PER_M3S


@dataclass(frozen=True)
class Feed:
    kind: str  # "flow" | "flooded" | "plain"
    q_supply: float = 0.0  # m^3/s, for "flow"

    @staticmethod
    def flow(q_supply: float) -> "Feed":
        q = float(q_supply)
        if not math.isfinite(q) or q <= 0.0:
            raise InputError(f"supply flow {q_supply!r} m^3/s is not a positive finite number")
        return Feed("flow", q)

    @staticmethod
    def flooded() -> "Feed":
        return Feed("flooded")

    @staticmethod
    def plain() -> "Feed":
        return Feed("plain")

    def describe(self) -> str:
        if self.kind == "flow":
            return f"supply {self.q_supply * MLMIN_PER_M3S:.4g} ml/min"
        return {"flooded": "flooded groove", "plain": "plain bearing (no groove)"}[self.kind]


def check_operating(bearing: Bearing, omega: float, position, velocity=(0.0, 0.0)) -> None:
    """Raise InputError for a speed, position or velocity the film model cannot take."""
    if not (math.isfinite(omega) and omega > 0.0):
        raise InputError(f"shaft speed {omega!r} rad/s is not positive; expected a running shaft (Omega > 0)")
    e_x, e_y = (float(v) for v in position)
    if not (math.isfinite(e_x) and math.isfinite(e_y)):
        raise InputError(f"journal position {position!r} is not finite")
    eps = math.hypot(e_x, e_y) / bearing.clearance
    if eps >= 1.0:
        raise InputError(f"eccentricity ratio {eps:.4g} >= 1: the journal would touch the bearing; expected < 1")
    if not all(math.isfinite(float(v)) for v in velocity):
        raise InputError(f"journal velocity {velocity!r} is not finite")


def make_mesh(bearing: Bearing, *, half: bool = True, alpha_offset: float | None = None) -> FilmMesh:
    """The bearing's mesh, placed so the first groove is centred on it (see groove_aligned_offset), with every
    groove's columns and their neighbours split into `bearing.groove_refinement` sub-columns
    (mesh.refined_split). A bearing without a groove gets a uniform mesh. (One mesh object per geometry: the
    films of a bearing share it and its arrays.)"""
    grooves = tuple((float(g.angle), float(g.length)) for g in _grooves(bearing))
    return _mesh(bearing.n_circumferential, bearing.n_axial, bearing.radius, bearing.length, bool(bearing.has_groove),
                 grooves, bearing.groove_refinement, bool(half), None if alpha_offset is None else float(alpha_offset))


def _grooves(bearing) -> tuple:
    """The bearing's axial grooves (SPEC §8: one or more sharing the supply)."""
    return tuple(getattr(bearing, "grooves", ())) or ()


@functools.lru_cache(maxsize=64)
def _mesh(n, n_axial, radius, length, has_groove, grooves, refinement, half, alpha_offset):
    if not has_groove:
        return FilmMesh(n, n_axial, radius, length, 0.0 if alpha_offset is None else alpha_offset, half=half)
    if alpha_offset is None:
        alpha_offset = groove_aligned_offset(n, radius, *grooves[0])
    split = refined_split(n, radius, alpha_offset, [a for a, _ in grooves], [b for _, b in grooves], refinement)
    return FilmMesh(n if split is None else sum(split), n_axial, radius, length, alpha_offset, half=half, split=split)


@functools.lru_cache(maxsize=64)
def _groove(mesh: FilmMesh, grooves: tuple) -> np.ndarray:
    """The cells of every groove (`mesh.groove_cells` of each, (angle, length, width)), kept read-only for the
    films that share the mesh."""
    g = np.zeros(mesh.shape, dtype=bool)
    for angle, length, width in grooves:
        g |= groove_cells(mesh, angle, length, width)
    g.flags.writeable = False
    return g


def setup_problem(bearing: Bearing, omega: float, position, feed: Feed, *, velocity=(0.0, 0.0),
                  mesh: FilmMesh | None = None) -> FilmProblem:
    """Build the nondimensional film problem of `bearing` at journal `position` (m), `velocity` (m/s)."""
    check_operating(bearing, omega, position, velocity)
    if feed.kind == "plain":
        if mesh is None:
            # Put a cell centre on the line of maximum film thickness: the feed line (uniform mesh).
            d_alpha = 2.0 * math.pi / bearing.n_circumferential
            mesh = FilmMesh(bearing.n_circumferential, bearing.n_axial, bearing.radius, bearing.length,
                            max_film_angle(*position) - 0.5 * d_alpha)
        gap = np.abs(np.angle(np.exp(1j * (mesh.alpha - max_film_angle(*position)))))
        line = gap == gap.min()  # the cell column on the line of maximum film thickness
        fixed = np.broadcast_to(line, mesh.shape).copy()
        return build_problem(mesh, clearance=bearing.clearance, viscosity=bearing.viscosity, omega=omega,
                             position=position, velocity=velocity, groove=fixed, fixed=fixed)
    if not bearing.has_groove:
        raise InputError(f"{feed.describe()} needs a groove, but the bearing has none; use the plain feed")
    mesh = make_mesh(bearing) if mesh is None else mesh
    groove = _groove(mesh, tuple((float(g.angle), float(g.length), float(g.width)) for g in _grooves(bearing)))
    if feed.kind == "flooded":
        return build_problem(mesh, clearance=bearing.clearance, viscosity=bearing.viscosity, omega=omega,
                             position=position, velocity=velocity, groove=groove, fixed=groove)
    if feed.kind == "flow":
        return build_problem(mesh, clearance=bearing.clearance, viscosity=bearing.viscosity, omega=omega,
                             position=position, velocity=velocity, groove=groove, q_supply=feed.q_supply)
    raise InputError(f"unknown feed kind {feed.kind!r}; expected 'flow', 'flooded' or 'plain'")
