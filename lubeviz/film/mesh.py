"""Finite-volume mesh of the unwrapped film (paper Fig. 1b) and the groove/feed cells on it.

Coordinates: alpha in [0, 2 pi) measured from +Y in the direction of rotation (Eq. 1), z along the
bearing from one edge (z = 0) to the other (z = L). Cells are indexed [j, i] with i around the
circumference (the direction of the Couette flow) and j along the axis.

Symmetry: with an axially centred groove and an aligned journal the film is symmetric about the
mid-plane, so by default only the half 0 <= z <= L/2 is solved, with a zero-flux face at L/2. The
discrete solution is identical to the full-domain one (tested); the linear solves are ~2x cheaper.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError

MIN_GROOVE_CELLS = 2  # cells the groove must span in each direction to be resolved


@dataclass(frozen=True)
class FilmMesh:
    """Cell-centred mesh of the film; `half` = only 0 <= z <= L/2 is meshed."""

    n_circ: int
    n_axial: int  # cells over the full length L (even when `half`)
    radius: float
    length: float
    alpha_offset: float = 0.0  # alpha of the west face of cell i = 0 (rad)
    half: bool = True

    def __post_init__(self):
        if self.n_circ < 8:
            raise InputError(f"mesh has {self.n_circ} circumferential cells; expected at least 8")
        if self.n_axial < 2:
            raise InputError(f"mesh has {self.n_axial} axial cells; expected at least 2")
        if self.half and self.n_axial % 2:
            raise InputError(
                f"a half-domain mesh needs an even number of axial cells, got {self.n_axial}"
            )

    @property
    def d_alpha(self) -> float:
        return 2.0 * math.pi / self.n_circ

    @property
    def dz(self) -> float:
        return self.length / self.n_axial

    @property
    def nz(self) -> int:
        """Axial cells actually solved."""
        return self.n_axial // 2 if self.half else self.n_axial

    @property
    def shape(self) -> tuple[int, int]:
        return (self.nz, self.n_circ)

    @property
    def alpha(self) -> np.ndarray:
        """Cell-centre angles (rad), shape (n_circ,)."""
        return self.alpha_offset + (np.arange(self.n_circ) + 0.5) * self.d_alpha

    @property
    def alpha_east(self) -> np.ndarray:
        """Angles of the east (downstream) faces, shape (n_circ,)."""
        return self.alpha_offset + (np.arange(self.n_circ) + 1.0) * self.d_alpha

    @property
    def z(self) -> np.ndarray:
        """Cell-centre axial positions (m), shape (nz,)."""
        return (np.arange(self.nz) + 0.5) * self.dz

    @property
    def cell_area(self) -> float:
        return self.radius * self.d_alpha * self.dz

    @property
    def mirror_factor(self) -> float:
        """What integrals over the solved cells must be multiplied by to cover the whole film."""
        return 2.0 if self.half else 1.0


def angle_mask(mesh: FilmMesh, centre: float, arc: float) -> np.ndarray:
    """Cells whose centre angle lies within +-arc/2 of `centre`, shape (n_circ,)."""
    d = np.angle(np.exp(1j * (mesh.alpha - centre)))  # wrapped to (-pi, pi]
    return np.abs(d) <= 0.5 * arc * (1.0 + 1e-9)


def groove_cells(mesh: FilmMesh, angle: float, groove_length: float, groove_width: float) -> np.ndarray:
    """Boolean (nz, n_circ) mask of the cells inside an axially centred groove.

    A cell belongs to the groove when its centre lies inside it. Raises InputError when the mesh is
    too coarse to resolve the groove (fewer than MIN_GROOVE_CELLS cells across either dimension).
    """
    in_arc = angle_mask(mesh, angle, groove_length / mesh.radius)
    in_width = np.abs(mesh.z - 0.5 * mesh.length) <= 0.5 * groove_width * (1.0 + 1e-9)
    n_arc = int(in_arc.sum())
    n_width = int(np.count_nonzero(np.abs(
        (np.arange(mesh.n_axial) + 0.5) * mesh.dz - 0.5 * mesh.length) <= 0.5 * groove_width * (1.0 + 1e-9)))
    if n_arc < MIN_GROOVE_CELLS or n_width < MIN_GROOVE_CELLS:
        raise InputError(
            f"mesh {mesh.n_circ}x{mesh.n_axial} is too coarse to resolve the groove "
            f"({groove_length * 1e3:g} mm x {groove_width * 1e3:g} mm spans {n_arc} x {n_width} cells); "
            f"expected at least {MIN_GROOVE_CELLS} cells across each groove dimension"
        )
    return in_width[:, None] & in_arc[None, :]


def groove_aligned_offset(n_circ: int, radius: float, angle: float, groove_length: float) -> float:
    """Mesh offset that centres the groove on the mesh and best matches its length.

    The groove spans a whole number of cells either way; of the two symmetric placements (groove
    centre on a cell face or on a cell centre) this picks the one whose covered arc is closest to the
    true groove length, so the discrete groove is symmetric and as long as the real one.
    """
    d_alpha = 2.0 * math.pi / n_circ
    arc = groove_length / radius
    best = None
    for shift in (0.0, 0.5):  # groove centre on a face, or on a centre
        offset = angle - shift * d_alpha
        m = FilmMesh(n_circ, 2, radius, 1.0, offset, half=False)
        covered = angle_mask(m, angle, arc).sum() * d_alpha
        err = abs(covered - arc)
        if best is None or err < best[0] - 1e-12:
            best = (err, offset)
    return best[1]
