"""Sensitivity and maps (Sec. 3, Figs. 4-11): the features and the error functions over the flows.

- `flow_sweep`: Zf, Zb, fb and phi at two planes with Q1 = Q2 = Q (Figs. 4-6); phi unwrapped along Q.
- `feature_grid`: fb1, fb2, phi1, phi2 (or any of `ALL_FEATURES`) over a Q1 x Q2 grid (Fig. 7).
- `error_grid`: the paper's error functions (Eq. 11, the phi scale of paper mode, via
  `newton._paper_errors`), eps_T = sum |eps|, and the best mode's whitened cost when the reference is a
  `MeasuredFeatures` with its covariance (Figs. 9-11).
- `root_curves`: the zero contours of an error function (or any level of any field): the curves on
  which the unknown flows must lie (Figs. 9-11).
- `paper_figures`: Figs. 4-11 as plain data, in one call (`lubeviz figures` writes them to files).

Grid layout: every 2-D field is indexed [i_q2, j_q1] (rows follow Q2, columns Q1), the layout of
`contourpy`, matplotlib's `contour(x, y, z)` and HoloViews' `Image`/`QuadMesh`, so a field plots as is
with Q1 on the horizontal axis. Flows in m^3/s (SI) everywhere here; ml/min only at the edges.

Branch cuts: phi is defined modulo pi (SPEC §1) and the paper-mode eps_phi wraps its difference to
[-pi/2, pi/2), so an angle-valued field jumps by a whole period somewhere (where phi crosses the
branch, or phi_s - phi_m crosses +-pi/2). A contouring routine sees a sign change across that jump
and reports a "zero" that is not one. `root_curves` is told the field's period and masks the points
next to a jump larger than half a period (`branch_cut_mask`), so only true zeros remain. Near a point
where Zb = 0 (a circular orbit; seen outside the bearings) phi winds by pi around it: no unwrapping
removes that cut, so grids keep phi on its branch (-pi/2, pi/2] and the mask does the work.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from collections.abc import Mapping, Sequence

import contourpy
import numpy as np
from scipy.linalg import cholesky, solve_triangular

from ...errors import InputError
from ...progress import ProgressFn, silent
from ...rotor.directional import unwrap_orbit_angle
from ..forward.model import ALL_FEATURES, ANGULAR, PAPER_FEATURES, ForwardModel, feature_vector, wrap_difference
from ..forward.measured import MeasuredFeatures
from .newton import _bounds, _paper_errors, start_grid
from ..fit.settings import IdentificationSettings
from ...units import MLMIN_PER_M3S

# Sec. 3.1: the sweeps run from 50 to 150 % of the paper's Q_T = 546 ml/min.
PAPER_SWEEP_MLMIN = (273.0, 819.0)
# Sec. 3.2: the costly cases drawn in Fig. 9 (bearing centres) and Figs. 10-11 (outside the bearings).
# Fig. 10's caption says Q2 = 488.5 ml/min, which is not among the protocol's reference flows; the
# text's grid has 487.5, taken here.
FIG9_CASE_MLMIN = (448.5, 604.5)
FIG10_CASE_MLMIN = (604.5, 487.5)
FIG8_CASE_MLMIN = (409.5, 409.5)


# --- Figs. 4-6 -----------------------------------------------------------------------------------

@dataclass(frozen=True)
class FlowSweep:
    """Response with Q1 = Q2 = q (m^3/s), shape (n,); per plane (last axis, 2): Zf, Zb (m), fb, phi (rad).

    phi is unwrapped along the sweep (SPEC §1), starting on the branch (-pi/2, pi/2].
    """

    q: np.ndarray
    nodes: tuple[int, int]
    zf: np.ndarray
    zb: np.ndarray
    fb: np.ndarray
    phi: np.ndarray
    q_threshold: np.ndarray

    @property
    def forward_amplitude(self) -> np.ndarray:
        """|Zf| (m), Fig. 4a."""
        return np.abs(self.zf)

    @property
    def backward_amplitude(self) -> np.ndarray:
        """|Zb| (m), Fig. 4b."""
        return np.abs(self.zb)


def _axis(values, what: str, *, flows: bool = True) -> np.ndarray:
    a = np.asarray(values, dtype=float)
    if (a.ndim != 1 or a.size < 2 or not np.all(np.isfinite(a)) or np.any(np.diff(a) <= 0)
            or (flows and np.any(a <= 0))):
        expected = "positive, finite, strictly increasing flows (m^3/s)" if flows else "finite, strictly increasing values"
        raise InputError(f"{what}: expected at least 2 {expected}, got {np.array2string(a, threshold=6)}")
    return a


def flow_sweep(model: ForwardModel, flows) -> FlowSweep:
    """Zf, Zb, fb and phi at the model's two planes with both bearings at each of `flows` (m^3/s)."""
    q = _axis(flows, "sweep flows")
    r = model.response(q, q)
    zf, zb = r.zf, r.zb
    with np.errstate(divide="ignore"):
        fb = np.abs(zf) / np.abs(zb)
    phi = unwrap_orbit_angle(feature_vector(r.x, r.y, ("phi1", "phi2")), axis=0)
    return FlowSweep(q=q, nodes=tuple(model.nodes), zf=zf, zb=zb, fb=fb, phi=phi,
                     q_threshold=model.q_threshold.copy())


# --- Fig. 7 --------------------------------------------------------------------------------------

@dataclass(frozen=True)
class FeatureGrid:
    """Features over the grid q1 (n1,) x q2 (n2,) (m^3/s); each field (n2, n1), indexed [i_q2, j_q1].

    Angles (phi1, phi2, arg_zf_ratio) stay on their branch; `periods[name]` is their period (rad),
    None for the others, for `root_curves` and `branch_cut_mask`.
    """

    q1: np.ndarray
    q2: np.ndarray
    nodes: tuple[int, int]
    names: tuple[str, ...]
    values: dict
    q_threshold: np.ndarray

    def __getitem__(self, name: str) -> np.ndarray:
        try:
            return self.values[name]
        except KeyError:
            raise InputError(f"feature {name!r} not in this grid; it has {self.names}") from None

    @property
    def periods(self) -> dict:
        return {n: ANGULAR.get(n) for n in self.names}

    def stack(self, names: Sequence[str] | None = None) -> np.ndarray:
        """Fields of `names` (default all) on the last axis: (n2, n1, len(names))."""
        return np.stack([self[n] for n in (self.names if names is None else names)], axis=-1)


def _names(names, allowed, what) -> tuple[str, ...]:
    names = tuple(names)
    bad = [n for n in names if n not in allowed]
    if bad or not names or len(set(names)) != len(names):
        raise InputError(f"{what} {names!r}: expected distinct names among {allowed}")
    return names


def feature_grid(model: ForwardModel, q1_axis, q2_axis, names: Sequence[str] = PAPER_FEATURES) -> FeatureGrid:
    """`names` over Q1 = q1_axis x Q2 = q2_axis (m^3/s), one batched evaluation of the forward model."""
    q1, q2 = _axis(q1_axis, "Q1 axis"), _axis(q2_axis, "Q2 axis")
    names = _names(names, ALL_FEATURES, "features")
    f = model.features(q1[None, :], q2[:, None], names)  # (n2, n1, k): rows follow Q2
    return FeatureGrid(q1=q1, q2=q2, nodes=tuple(model.nodes), names=names,
                       values={n: f[..., k] for k, n in enumerate(names)}, q_threshold=model.q_threshold.copy())


def domain_axes(model: ForwardModel, points: int = 101, settings: IdentificationSettings | None = None
                ) -> tuple[np.ndarray, np.ndarray]:
    """Q1 and Q2 axes (m^3/s) spanning the identification's search domain (default 25-200 % Q_T),
    clipped to the flows the tables cover: the domain of the maps of Figs. 9-11."""
    if int(points) != points or points < 2:
        raise InputError(f"grid points {points!r}: expected an integer >= 2")
    lo, hi = _bounds(model, settings or IdentificationSettings.paper())
    return np.linspace(lo[0], hi[0], int(points)), np.linspace(lo[1], hi[1], int(points))


# --- Figs. 9-11: error functions ------------------------------------------------------------------

@dataclass(frozen=True)
class ErrorGrid:
    """Paper-mode error functions (Eq. 11) over q1 (n1,) x q2 (n2,) (m^3/s), fields (n2, n1) [i_q2, j_q1].

    eps[name]: eps of feature `name` (fb: relative; phi: wrapped difference over `phi_scale`, or over
    |phi_m| when the scale is 0, as `identify_paper` does); total: eps_T = sum |eps| (Sec. 2.3);
    periods[name]: the jump of eps[name] across a branch cut (pi / scale for phi, None for fb);
    cost: the best mode's cost |L^-1 (f_s - f_m)|^2 over `cost_names` (L L^T the measured covariance),
    None without a covariance.
    """

    q1: np.ndarray
    q2: np.ndarray
    nodes: tuple[int, int]
    names: tuple[str, ...]
    eps: dict
    total: np.ndarray
    reference: dict
    periods: dict
    phi_scale: float
    q_threshold: np.ndarray
    cost: np.ndarray | None = None
    cost_names: tuple[str, ...] = ()

    def roots(self, names: Sequence[str] | None = None) -> dict:
        """Root curves (zero contours, `root_curves`) of each error function: name -> list of (n, 2) arrays."""
        return {n: root_curves(self.q1, self.q2, self.eps[n], period=self.periods[n])
                for n in (self.names if names is None else names)}

    def lowest(self) -> np.ndarray:
        """(Q1, Q2) of the grid point with the lowest eps_T (m^3/s)."""
        return _argmin(self.q1, self.q2, self.total)

    def lowest_cost(self) -> np.ndarray | None:
        """(Q1, Q2) of the grid point with the lowest best-mode cost (m^3/s), None without a covariance."""
        return None if self.cost is None else _argmin(self.q1, self.q2, self.cost)


def _argmin(q1, q2, field) -> np.ndarray:
    i, j = np.unravel_index(np.nanargmin(field), field.shape)
    return np.array([q1[j], q2[i]])


def _reference_values(reference, names) -> np.ndarray:
    if isinstance(reference, MeasuredFeatures):
        missing = [n for n in names if n not in reference.names]
        if missing:
            raise InputError(f"the measured features lack {missing}; they have {reference.names}")
        return reference.subset(names).values
    if isinstance(reference, Mapping):
        try:
            return np.array([float(reference[n]) for n in names])
        except KeyError as exc:
            raise InputError(f"reference features lack {exc.args[0]!r}; expected {names}") from None
    values = np.asarray(reference, dtype=float)
    if values.shape != (len(names),):
        raise InputError(f"reference features of shape {values.shape}; expected {len(names)} values in the "
                         f"order {names}")
    return values


def error_grid(grid: FeatureGrid | ForwardModel, reference, settings: IdentificationSettings | None = None, *,
               q1_axis=None, q2_axis=None, names: Sequence[str] = PAPER_FEATURES) -> ErrorGrid:
    """eps of each paper feature (Eq. 11), eps_T, and the best-mode cost, against `reference`.

    `grid`: a `FeatureGrid` holding the features needed, or a `ForwardModel` with `q1_axis`, `q2_axis`.
    `reference`: the measured features, as `MeasuredFeatures` (adds the best-mode cost over the features of
    `settings.features` it holds), a mapping name -> value, or values in the order of `names`.
    `settings`: the phi scale of paper mode (default `IdentificationSettings.paper()`).
    """
    settings = settings or IdentificationSettings.paper()
    names = _names(names, PAPER_FEATURES, "error functions")
    fm = _reference_values(reference, names)
    if not np.all(np.isfinite(fm)) or np.any(fm[[not n.startswith("phi") for n in names]] == 0):
        raise InputError(f"reference features {dict(zip(names, fm.tolist()))}: expected finite values, fb non-zero")
    cost_names: tuple[str, ...] = ()
    if isinstance(reference, MeasuredFeatures):
        cost_names = tuple(n for n in settings.features if n in reference.names)
    if isinstance(grid, ForwardModel):
        if q1_axis is None or q2_axis is None:
            raise InputError("error_grid on a ForwardModel needs q1_axis and q2_axis (m^3/s)")
        wanted = names + tuple(n for n in cost_names if n not in names)
        grid = feature_grid(grid, q1_axis, q2_axis, wanted)
    elif not isinstance(grid, FeatureGrid):
        raise InputError(f"error_grid needs a FeatureGrid or a ForwardModel, got {type(grid).__name__}")
    eps_stack = _paper_errors(grid.stack(names), fm, names, settings)  # Eq. 11, paper mode's phi scale
    eps = {n: eps_stack[..., k] for k, n in enumerate(names)}
    periods = {}
    for k, n in enumerate(names):
        if n.startswith("phi"):
            scale = abs(fm[k]) if settings.phi_scale == 0 else settings.phi_scale
            periods[n] = math.pi / scale if scale > 0 else None
        else:
            periods[n] = None
    cost = None
    if len(cost_names) >= 2:
        missing = [n for n in cost_names if n not in grid.names]
        if missing:
            raise InputError(f"the best-mode cost needs {missing} in the grid; build it with "
                             f"feature_grid(..., names={cost_names!r}) or pass the ForwardModel")
        meas = reference.subset(cost_names)
        try:
            L = cholesky(meas.cov, lower=True)
        except np.linalg.LinAlgError:
            raise InputError("the measured features' covariance is not positive definite; "
                             "no best-mode cost without noise estimates") from None
        d = wrap_difference(grid.stack(cost_names) - meas.values, cost_names)
        w = solve_triangular(L, d.reshape(-1, len(cost_names)).T, lower=True)
        cost = np.sum(w**2, axis=0).reshape(d.shape[:-1])
    else:
        cost_names = ()
    return ErrorGrid(q1=grid.q1, q2=grid.q2, nodes=grid.nodes, names=names, eps=eps,
                     total=np.abs(eps_stack).sum(axis=-1), reference=dict(zip(names, fm.tolist())),
                     periods=periods, phi_scale=float(settings.phi_scale), q_threshold=grid.q_threshold.copy(),
                     cost=cost, cost_names=cost_names)


# --- root curves ---------------------------------------------------------------------------------

def branch_cut_mask(field, period: float | None = None) -> np.ndarray:
    """True at grid points that are not finite or, for a field with a `period`, next to a branch cut.

    A cut is where two 4-neighbours differ by more than half a period: a smooth field resolved by the
    grid never changes that much between neighbours, a wrapped one does across its cut.
    """
    z = np.asarray(field, dtype=float)
    mask = ~np.isfinite(z)
    if period is None:
        return mask
    if not (math.isfinite(period) and period > 0):
        raise InputError(f"period {period!r}: expected a positive number or None")
    half = 0.5 * period
    with np.errstate(invalid="ignore"):
        jump_q1 = np.abs(np.diff(z, axis=1)) > half  # between columns j and j+1
        jump_q2 = np.abs(np.diff(z, axis=0)) > half  # between rows i and i+1
    mask[:, :-1] |= jump_q1
    mask[:, 1:] |= jump_q1
    mask[:-1, :] |= jump_q2
    mask[1:, :] |= jump_q2
    return mask


def root_curves(q1_axis, q2_axis, field, *, period: float | None = None, level: float = 0.0) -> list[np.ndarray]:
    """Polylines (each (n, 2): Q1, Q2 in the axes' units) on which `field` (n2, n1) equals `level`.

    Linear interpolation within each grid cell (contourpy). For an angle-valued field give its
    `period` (`ErrorGrid.periods`, `FeatureGrid.periods`): points next to its branch cut are masked, so
    the jump of a whole period there is not reported as a crossing.
    """
    q1, q2 = _axis(q1_axis, "Q1 axis", flows=False), _axis(q2_axis, "Q2 axis", flows=False)
    z = np.asarray(field, dtype=float)
    if z.shape != (q2.size, q1.size):
        raise InputError(f"field of shape {z.shape}; expected (len(q2_axis), len(q1_axis)) = {(q2.size, q1.size)}")
    if not math.isfinite(level):
        raise InputError(f"contour level {level!r}: expected a finite number")
    mask = branch_cut_mask(z, period)
    zm = np.ma.array(np.where(mask, 0.0, z), mask=mask)
    gen = contourpy.contour_generator(q1, q2, zm, name="serial", corner_mask=True,
                                      line_type=contourpy.LineType.Separate)
    return [np.asarray(line, dtype=float) for line in gen.lines(level) if len(line) >= 2]


# --- Figs. 4-11 as data ----------------------------------------------------------------------------

def _case_features(machine, model: ForwardModel, q_mlmin, snr_db: float, rng: np.random.Generator):
    """The paper's reference for one case (Sec. 3.2): film equilibria solved directly at the flows, the
    steady 1X response sampled 5 s at 10 kHz, 12 dB noise, features measured as from a file."""
    from ...rotor.film_bearings import film_bearings
    from ...signals.synthesize import synthesize_record
    from ..forward.measured import measure

    flows = tuple(q / MLMIN_PER_M3S for q in q_mlmin)
    rec = synthesize_record(machine, flows, nodes=model.nodes, snr_db=snr_db, rng=rng, method="steady",
                            bearings=film_bearings(machine, flows), rotor=model.rotor)
    return measure(rec, ALL_FEATURES)


def identification_map(model: ForwardModel, measured: MeasuredFeatures, settings: IdentificationSettings,
                       axes, *, identification=None, title: str = "") -> dict:
    """Error maps, root curves and the search paths of one identification from `measured` (Figs. 9-11).

    `identification`: a result already computed from `measured` (else `identify` is run with `settings`).
    """
    from .newton import identify

    ident = identify(model, measured, settings) if identification is None else identification
    eg = error_grid(model, measured, settings, q1_axis=axes[0], q2_axis=axes[1])
    path_total = [np.abs(_paper_errors(model.features(p[:, 0], p[:, 1], PAPER_FEATURES),
                                       measured.subset(PAPER_FEATURES).values, PAPER_FEATURES, settings)).sum(axis=-1)
                  for p in ident.paths]
    return {"title": title, "nodes": tuple(model.nodes),
            "q1": eg.q1, "q2": eg.q2, "q_threshold": eg.q_threshold, "eps": eg.eps, "eps_total": eg.total,
            "cost": eg.cost, "roots": eg.roots(), "reference_features": eg.reference, "phi_scale": eg.phi_scale,
            "paths": list(ident.paths), "paths_total_error": path_total,
            "starts": np.array([p[0] for p in ident.paths]), "q_identified": ident.q,
            "converged": ident.converged, "iterations": ident.iterations, "starts_tried": ident.starts_tried,
            "message": ident.message, "identification": ident, "start_grid": start_grid(model, settings)}


def _identification_map(machine, model, q_mlmin, axes, settings, snr_db, rng, title) -> dict:
    meas = _case_features(machine, model, q_mlmin, snr_db, rng)
    out = identification_map(model, meas, settings, axes, title=title)
    out["q_ref"] = np.array(q_mlmin) / MLMIN_PER_M3S
    del out["identification"]
    return out


def simulated_measurement(machine, model: ForwardModel, flows, *, snr_db: float = 12.0,
                          rng: np.random.Generator) -> MeasuredFeatures:
    """Features of a record simulated as the paper does (direct film solves, 5 s at 10 kHz, noise) at
    supply flows `flows` (m^3/s), at the model's nodes."""
    return _case_features(machine, model, tuple(q * MLMIN_PER_M3S for q in flows), snr_db, rng)


def paper_figures(machine, *, grid: int = 101, sweep_points: int | None = None, tables=None, seed: int = 2024,
                  snr_db: float = 12.0, settings: IdentificationSettings | None = None,
                  progress: ProgressFn = silent) -> dict:
    """The data of the paper's Figs. 4-11 (SI: m^3/s, m, rad, s): figure id ("fig4" ... "fig11") -> dict.

    - fig4-6: Q1 = Q2 = q over 273-819 ml/min (`sweep_points`, default `grid`): |Zf|, |Zb| ("forward",
      "backward"), "fb" and "phi" (unwrapped), each a dict node -> array, at the bearing centres and
      outside them (the machine's `center_nodes`, `outside_nodes`).
    - fig7: fb1, fb2, phi1, phi2 at the bearing centres over 273-819 ml/min in both flows, grid x grid,
      fields [i_q2, j_q1]; "q_threshold" for the paper's red lines.
    - fig8: x, y at the centre of bearing 1 over 0.2 s (15 revolutions) with Q1 = Q2 = 409.5 ml/min,
      "clean" and "noisy" (SNR `snr_db`, seeded by `seed`).
    - fig9: bearing centres, case 448.5 / 604.5 ml/min; fig10 and fig11: outside the bearings, case
      604.5 / 487.5 ml/min. Each: the maps of eps (Eq. 11) and eps_T over the search domain
      (`domain_axes`, grid x grid), their root curves, and one paper-mode identification of a noisy
      reference record (direct film solves, steady response, 5 s, `snr_db`): its "paths" in order of
      attempt (Fig. 11 numbers the starts), "q_identified". fig11 is fig10's computation with its own title
      (the paper draws the paths over fig10's map); the arrays are shared, not copied.
    Each figure carries "title" and "seconds" (the time spent on it). `tables`: the machine's coefficient
    tables (default `machine_tables(machine)`, from the cache, built if missing).
    """
    from ...signals.noise import add_noise
    from ...signals.synthesize import synthesize_record
    from ..tables.cache import machine_tables

    if int(grid) != grid or not 3 <= grid <= 2001:
        raise InputError(f"grid {grid!r}: expected an integer number of points per axis, 3 to 2001")
    grid = int(grid)
    sweep_points = grid if sweep_points is None else sweep_points
    if int(sweep_points) != sweep_points or sweep_points < 3:
        raise InputError(f"sweep points {sweep_points!r}: expected an integer >= 3")
    if not math.isfinite(snr_db):
        raise InputError(f"SNR {snr_db!r} dB: expected a finite number")
    settings = settings or IdentificationSettings.paper()
    steps = 6
    if tables is None:
        tables = machine_tables(machine, progress=progress)
    centre, outside = tuple(machine.center_nodes), tuple(machine.outside_nodes)
    models = {"center": ForwardModel(machine, tables, centre), "outside": ForwardModel(machine, tables, outside)}
    out: dict = {}

    t0 = time.perf_counter()
    q = np.linspace(*PAPER_SWEEP_MLMIN, int(sweep_points)) / MLMIN_PER_M3S
    sweeps = {loc: flow_sweep(m, q) for loc, m in models.items()}

    def per_node(attr):
        return {n: getattr(s, attr)[:, k] for s in sweeps.values() for k, n in enumerate(s.nodes)}

    t_sweep = (time.perf_counter() - t0) / 3  # the sweeps serve three figures
    nodes = {"center": centre, "outside": outside}
    out["fig4"] = {"title": "Forward and backward 1X amplitudes vs Q1 = Q2 (Fig. 4)", "q": q, "nodes": nodes,
                   "forward": per_node("forward_amplitude"), "backward": per_node("backward_amplitude"),
                   "q_threshold": models["center"].q_threshold, "seconds": t_sweep}
    out["fig5"] = {"title": "fb = |Zf|/|Zb| vs Q1 = Q2 (Fig. 5)", "q": q, "nodes": nodes, "fb": per_node("fb"),
                   "q_threshold": models["center"].q_threshold, "seconds": t_sweep}
    out["fig6"] = {"title": "Orbit angle phi vs Q1 = Q2, unwrapped along Q (Fig. 6)", "q": q, "nodes": nodes,
                   "phi": per_node("phi"), "q_threshold": models["center"].q_threshold, "seconds": t_sweep}
    progress(1, steps, "Figs. 4-6: sweeps")

    t0 = time.perf_counter()
    axis = np.linspace(*PAPER_SWEEP_MLMIN, grid) / MLMIN_PER_M3S
    fg = feature_grid(models["center"], axis, axis, PAPER_FEATURES)
    out["fig7"] = {"title": "fb and phi at the bearing centres over Q1 x Q2 (Fig. 7); fields [i_q2, j_q1]",
                   "nodes": centre, "q1": fg.q1, "q2": fg.q2, **{n: fg[n] for n in PAPER_FEATURES},
                   "q_threshold": fg.q_threshold, "seconds": time.perf_counter() - t0}
    progress(2, steps, "Fig. 7: feature maps")

    t0 = time.perf_counter()
    from ...rotor.film_bearings import film_bearings

    flows8 = tuple(v / MLMIN_PER_M3S for v in FIG8_CASE_MLMIN)
    clean = synthesize_record(machine, flows8, nodes=centre, snr_db=None, method="steady", duration_s=0.2,
                              bearings=film_bearings(machine, flows8), rotor=models["center"].rotor)
    noisy = add_noise(clean.displacement, snr_db, np.random.default_rng([seed, 8]))
    out["fig8"] = {"title": f"Displacement at the centre of bearing 1, Q1 = Q2 = {FIG8_CASE_MLMIN[0]} ml/min, "
                            f"with and without {snr_db:g} dB noise (Fig. 8)",
                   "node": centre[0], "flows": np.array(flows8), "snr_db": snr_db, "t": clean.t,
                   "clean": {"x": clean.displacement[0, 0], "y": clean.displacement[0, 1]},
                   "noisy": {"x": noisy[0, 0], "y": noisy[0, 1]}, "seconds": time.perf_counter() - t0}
    progress(3, steps, "Fig. 8: noisy record")

    for fid, loc, case, rng_key, step in (("fig9", "center", FIG9_CASE_MLMIN, 9, 4),
                                          ("fig10", "outside", FIG10_CASE_MLMIN, 10, 5)):
        t0 = time.perf_counter()
        m = models[loc]
        title = (f"eps_T and root curves of eps_fb1, eps_fb2, eps_phi1, eps_phi2 at nodes {m.nodes}, "
                 f"Q1ref = {case[0]}, Q2ref = {case[1]} ml/min, with the paper-mode search paths "
                 f"(Fig. {fid[3:]})")
        out[fid] = _identification_map(machine, m, case, domain_axes(m, grid, settings), settings, snr_db,
                                       np.random.default_rng([seed, rng_key]), title)
        out[fid]["seconds"] = time.perf_counter() - t0
        progress(step, steps, f"Fig. {fid[3:]}: error maps")
    out["fig11"] = dict(out["fig10"], seconds=0.0,  # the same search, drawn over fig10's map
                        title=f"Paper-mode search paths, starts numbered in order of attempt, at nodes {outside}, "
                              f"Q1ref = {FIG10_CASE_MLMIN[0]}, Q2ref = {FIG10_CASE_MLMIN[1]} ml/min (Fig. 11)")
    progress(steps, steps, "figures done")
    return out
