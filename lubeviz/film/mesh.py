"""Finite-volume mesh of the unwrapped film (paper Fig. 1b) and the groove/feed cells on it.

Coordinates: alpha in [0, 2 pi) measured from +Y in the direction of rotation (Eq. 1), z along the
bearing from one edge (z = 0) to the other (z = L). Cells are indexed [j, i] with i around the
circumference (the direction of the Couette flow) and j along the axis.

Local refinement: the columns in and around the groove may be split into equal sub-columns (`split`),
so the circumferential spacing is non-uniform there (see `refined_split`). Why: just above Q_T the
groove pressurizes and its full-film zone spreads up- and downstream of it; on a uniform 100-column
mesh that zone grows one whole column (25 axial cells at once) at a time, and the coefficients follow
in a staircase of slope changes (BENCHMARKS "Smoothness in the supply flow": the uniform 100 columns
against the refined mesh; docs/notes/film-smoothness.md). Splitting those 14 columns by 4 makes the growth
as smooth as on a 400-column mesh for 42 % more cells instead of 300 %. The groove itself is decided on
the nominal columns (`angle_mask`), so the refinement does not change what the groove covers: Q_T and
the flooded film stay those of the uniform mesh.

Symmetry: with an axially centred groove and an aligned journal the film is symmetric about the
mid-plane, so by default only the half 0 <= z <= L/2 is solved, with a zero-flux face at L/2. The
discrete solution is identical to the full-domain one (tested); the linear solves are ~2x cheaper.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError

MIN_GROOVE_CELLS = 2  # cells the groove must span in each direction to be resolved


def _frozen_array(method):
    """A mesh's array property computed once and kept read-only (a mesh is immutable and shared between the
    films of a bearing: every film solve of a harmonic balance asks for these)."""
    def compute(self):
        a = np.asarray(method(self))
        a.flags.writeable = False
        return a

    compute.__name__, compute.__doc__ = method.__name__, method.__doc__
    return functools.cached_property(compute)


@dataclass(frozen=True)
class FilmMesh:
    """Cell-centred mesh of the film; `half` = only 0 <= z <= L/2 is meshed.

    Uniform around the circumference unless `split` is given: then nominal column k (of
    len(split) equal columns of 2 pi / len(split)) is divided into split[k] equal sub-columns, and
    `n_circ` = sum(split) is the number of columns solved.
    """

    n_circ: int  # columns solved
    n_axial: int  # cells over the full length L (even when `half`)
    radius: float
    length: float
    alpha_offset: float = 0.0  # alpha of the west face of cell i = 0 (rad)
    half: bool = True
    split: tuple[int, ...] | None = None  # sub-columns of each nominal column (None: uniform)

    def __post_init__(self):
        if self.split is not None:
            if any(int(k) < 1 for k in self.split) or sum(self.split) != self.n_circ:
                raise InputError(f"mesh split {self.split!r} must be positive integers summing to "
                                 f"n_circ = {self.n_circ}")
            if len(self.split) < 8:
                raise InputError(f"mesh has {len(self.split)} nominal circumferential cells; expected at least 8")
        if self.n_circ < 8:
            raise InputError(f"mesh has {self.n_circ} circumferential cells; expected at least 8")
        if self.n_axial < 2:
            raise InputError(f"mesh has {self.n_axial} axial cells; expected at least 2")
        if self.half and self.n_axial % 2:
            raise InputError(
                f"a half-domain mesh needs an even number of axial cells, got {self.n_axial}"
            )

    @property
    def n_nominal(self) -> int:
        """Columns of the mesh before refinement."""
        return self.n_circ if self.split is None else len(self.split)

    @_frozen_array
    def d_alpha(self) -> np.ndarray:
        """Angular width of each column (rad), shape (n_circ,)."""
        if self.split is None:
            return np.full(self.n_circ, 2.0 * math.pi / self.n_circ)
        split = np.asarray(self.split)
        return np.repeat(2.0 * math.pi / self.n_nominal / split, split)

    @_frozen_array
    def d_alpha_east(self) -> np.ndarray:
        """Angle from each cell centre to the next one downstream (rad), shape (n_circ,)."""
        w = self.d_alpha
        return 0.5 * (w + np.roll(w, -1))

    @_frozen_array
    def nominal_column(self) -> np.ndarray:
        """Index of the nominal column each column belongs to, shape (n_circ,)."""
        if self.split is None:
            return np.arange(self.n_circ)
        return np.repeat(np.arange(self.n_nominal), self.split)

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

    @_frozen_array
    def alpha(self) -> np.ndarray:
        """Cell-centre angles (rad), shape (n_circ,)."""
        w = self.d_alpha
        return self.alpha_offset + np.cumsum(w) - 0.5 * w

    @_frozen_array
    def alpha_east(self) -> np.ndarray:
        """Angles of the east (downstream) faces, shape (n_circ,)."""
        return self.alpha_offset + np.cumsum(self.d_alpha)

    @_frozen_array
    def z(self) -> np.ndarray:
        """Cell-centre axial positions (m), shape (nz,)."""
        return (np.arange(self.nz) + 0.5) * self.dz

    @_frozen_array
    def cell_area(self) -> np.ndarray:
        """Area of the cells of each column (m^2), shape (n_circ,)."""
        return self.radius * self.d_alpha * self.dz

    @property
    def mirror_factor(self) -> float:
        """What integrals over the solved cells must be multiplied by to cover the whole film."""
        return 2.0 if self.half else 1.0


def angle_mask(mesh: FilmMesh, centre: float, arc: float) -> np.ndarray:
    """Columns whose *nominal* column's centre angle lies within +-arc/2 of `centre`, shape (n_circ,).

    Decided on the nominal columns so that refining a column never changes what it covers: the
    sub-columns of a nominal column are all in or all out."""
    nominal = mesh.alpha_offset + (np.arange(mesh.n_nominal) + 0.5) * (2.0 * math.pi / mesh.n_nominal)
    d = np.angle(np.exp(1j * (nominal - centre)))  # wrapped to (-pi, pi]
    return (np.abs(d) <= 0.5 * arc * (1.0 + 1e-9))[mesh.nominal_column]


def groove_cells(mesh: FilmMesh, angle: float, groove_length: float, groove_width: float) -> np.ndarray:
    """Boolean (nz, n_circ) mask of the cells inside an axially centred groove.

    A cell belongs to the groove when its centre lies inside it. Raises InputError when the mesh is
    too coarse to resolve the groove (fewer than MIN_GROOVE_CELLS cells across either dimension).
    """
    in_arc = angle_mask(mesh, angle, groove_length / mesh.radius)
    in_width = np.abs(mesh.z - 0.5 * mesh.length) <= 0.5 * groove_width * (1.0 + 1e-9)
    n_arc = int(np.unique(mesh.nominal_column[in_arc]).size)
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


# Refined zone of `refined_split`, in nominal columns beyond the groove: the groove-fed full film
# reaches ~1 column upstream and ~3 downstream of the groove within Q_T .. Q_T + 60 ml/min on the
# paper's bearing (100 columns), where it grows fastest; a margin of 2 / 6 also covers its growth up
# to 150 % Q_T (measured against 1 / 3 by the local-cubic deviation over 15 ml/min:
# docs/notes/film-smoothness.md).
REFINE_UPSTREAM = 2
REFINE_DOWNSTREAM = 6


def refined_split(n_circ: int, radius: float, alpha_offset: float, angle, groove_length, factor: int,
                  ) -> tuple[int, ...] | None:
    """`split` for a nominal uniform mesh with each groove's columns and their neighbours (REFINE_UPSTREAM /
    REFINE_DOWNSTREAM) divided into `factor` sub-columns; None when factor is 1. `angle`, `groove_length`: one
    groove's, or sequences with one entry per groove (a bearing's several axial grooves)."""
    if factor <= 1:
        return None
    angles = np.atleast_1d(np.asarray(angle, dtype=float))
    lengths = np.broadcast_to(np.asarray(groove_length, dtype=float), angles.shape)
    nominal = FilmMesh(n_circ, 2, radius, 1.0, alpha_offset, half=False)
    split = np.ones(n_circ, int)
    refined = False
    for a, b in zip(angles, lengths):
        cols = np.flatnonzero(angle_mask(nominal, float(a), float(b) / radius))
        if cols.size == 0:
            continue
        # the groove's columns are contiguous modulo n_circ; find its upstream end
        in_groove = set(cols.tolist())
        first = next(c for c in cols if (c - 1) % n_circ not in in_groove)
        zone = [(first + k) % n_circ for k in range(-REFINE_UPSTREAM, cols.size + REFINE_DOWNSTREAM)]
        split[zone] = factor
        refined = True
    return tuple(int(k) for k in split) if refined else None
