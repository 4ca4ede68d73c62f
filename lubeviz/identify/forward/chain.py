"""The forward chain: named parameters -> what the probes read, with the effects of a real machine.

One chain with fixed, named stages (STYLE "the effect library and the fit"):

    bearings  each bearing's K, C and journal position at its supply flow, from its coefficient table;
              bearings-stage effects change the bearing first (viscosity, clearance)
    rotor     Eq. 8 at the record's speed; rotor-stage effects add forcing (a second unbalance, a bow)
              or put a support in series with a bearing (pedestals)
    probes    the planes' displacements as the probes resolve them (probe rotation, probe gain)
    features  the invariants of an unbalance of unknown size and phase (fb, phi per plane, Zf2/Zf1)
              and, when the record holds it, the static journal position per plane

The parameters are a named vector: `q1` ... `qN` (m^3/s, one per fluid-film bearing in the model file's order),
then every free continuous parameter of every
effect (`viscosity.factor`, `pedestals.stiffness_n_m`, ...). Evaluations are batched over any leading
shape, so a Jacobian by central differences, a start grid or a whole Q1 x Q2 map is one call.
Any number of bearings N and measurement planes P (SPEC §8): nothing below counts to two.

The rotor solve is the rank-2N Woodbury update of `lubeviz.identify.forward.model` generalized: with D0 the
dynamic stiffness at reference bearings, factorized once, and the forcing a linear combination of fixed
shapes (main unbalance, effect shapes) with complex weights,

    x0 = sum_j w_j D0^-1 F_j,   c = (I + dB W)^-1 dB x0_U,   x_out = x0_out - Z_out c,   x_U = x0_U - W c,

where dB = blockdiag(B_k - B0_k) and B_k the bearing's dynamic stiffness (in series with its pedestal
when there is one). Tests check every path against a direct solve of the assembled system.
"""

from __future__ import annotations

import functools
import hashlib
import math
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple, Sequence

import numpy as np

from ...errors import InputError
from ...progress import ProgressFn, silent
from ...rotor.assembly import bearing_matrices, film_dofs, probe_housings, rotor_from_machine
from ...rotor.elements import X, Y, node_dofs
from ...rotor.response import dynamic_stiffness, machine_unbalance, unbalance_force
from ...rotor import load_shift
from ...rotor.statics import bearing_static_loads
from .model import feature_plane, feature_vector, is_static
from .shifted import packed_stacks, shifted_states
from ..tables.supply import DEFAULT_SPAN, CoefficientTable
from ...units import MLMIN_PER_M3S



def flow_names(n_bearings: int) -> tuple[str, ...]:
    """The flows' names in a parameter vector: q1 ... qN, one per fluid-film bearing in file order (SPEC §8)."""
    return tuple(f"q{k}" for k in range(1, n_bearings + 1))


# --- bearings stage ------------------------------------------------------------------------------

_HELD_KEY = ("slices",)  # a views store's entry for the slices its sources loaded (`BearingSource.share_views`)
_TURN_KEY = ("turn",)  # its entry for the bearing's turn error (`BearingSource.turn_error`)


class _HeldSlices:
    """A bearing's dimensionless table with the slices loaded so far and their `SliceStack`, shared by the sources
    of one bearing, load and speed (a session's pages, a budget's chains), under a lock."""

    def __init__(self):
        self.table = None
        self.stack = None
        self.lock = threading.Lock()


class BearingSource:
    """One bearing's K, C and journal position at one speed, for any supply flow, viscosity and clearance.

    The declared bearing is served by its coefficient table (`lubeviz.identify.tables.cache`); a bearing with
    another viscosity or clearance by the table of that bearing, which the dimensionless (S, Q/Q_T)
    tables give without a film solve when they cover it. Flows are clipped to the table's span
    (`tables.supply.DEFAULT_SPAN` x that bearing's own Q_T; `ForwardChain.past_tables` finds an answer there).
    """

    def __init__(self, machine, index: int, omega: float, table: CoefficientTable | None = None, *,
                 load=None, progress: ProgressFn = silent, frame=None):
        self.bearing = machine.bearings[index]
        self.index = index
        self.omega = float(omega)
        self.load = bearing_static_loads(machine)[index] if load is None else np.asarray(load, dtype=float)
        self.progress = progress
        self._held = _HeldSlices()  # the slices loaded so far and their stack (shared by `share_views`)
        self._views: dict = {_HELD_KEY: self._held}
        from ..tables.cache import film_frame

        # the bearing seen from the frame where its load is vertical, that load, the map back (None: vertical);
        # `frame`: those of a source of the same bearing and load (`ForwardChain.with_effects`)
        self._seen, self._seen_load, self._turn = film_frame(self.bearing, self.load) if frame is None else frame
        if table is not None:
            self._views[self._key(1.0, self.bearing.clearance)] = table

    @staticmethod
    def _key(factor: float, clearance: float, load_factor: float = 1.0, lean: float = 0.0):
        """A view's key: a turn of the load (`lean`) leaves the table as it is (`evaluate` turns the states)."""
        return (round(float(factor), 12), round(float(clearance), 15), round(float(load_factor), 12))

    def view(self, factor: float = 1.0, clearance: float | None = None, load_factor: float = 1.0, lean: float = 0.0,
             *, progress: ProgressFn | None = None) -> CoefficientTable:
        """The coefficient table of this bearing with viscosity x `factor`, radial clearance `clearance` (m) and
        static load x `load_factor` (`BearingChange`); `progress` reports a table build when one is needed
        (default: the source's own callback). A load turned by `lean` has the same table (a rigid turn, `_turned`:
        its Q_T and its flows' range are the film's own), so `lean` only completes a `BearingChange`."""
        clearance = self.bearing.clearance if clearance is None else float(clearance)
        key = self._key(factor, clearance, load_factor)
        if key not in self._views:
            bearing = self.bearing
            changed = key != self._key(1.0, self.bearing.clearance)
            load = self.load * float(load_factor)
            view = None
            if changed and self._table is not None:  # from the slices in memory: ~0.6 ms, not ~2 ms
                from ..tables.cache import turned_table
                from ..tables.scaled import scaled_view

                view = scaled_view(self._table, self._seen, self._seen_load * float(load_factor), self.omega,
                                   float(factor), clearance, index=self.index)
                if view is not None and self._turn is not None:
                    view = turned_table(view, self._turn)
            if view is None:
                from ..tables.cache import bearing_view, turned_table

                if not changed:
                    view = bearing_view(bearing, load, self.omega,
                                        progress=self.progress if progress is None else progress)
                else:  # in the declared load's frame: a scaled load's lean differs in its last bits, not its frame
                    seen = self._seen.copy(viscosity=self._seen.viscosity * float(factor), clearance=clearance)
                    seen_load = self._seen_load * float(load_factor)
                    view = bearing_view(seen, seen_load, self.omega,
                                        progress=self.progress if progress is None else progress)
                    if self._turn is not None:
                        view = turned_table(view, self._turn)
                    self._remember_slices(seen, seen_load)
            self._views.setdefault(key, view)
        return self._views[key]

    def _remember_slices(self, seen, seen_load) -> None:
        """Keep the slices the view of `seen` (this bearing in its load's frame, changed, under the vertical load
        `seen_load`) was made from, for `scaled.scaled_view` and the `SliceStack`."""
        from ..tables import cache

        try:
            table = cache.loaded_table(seen, seen_load, self.omega)
        except InputError:
            return
        self._hold(table)

    def _hold(self, table) -> bool:
        """Add `table`'s slices to the ones held (its geometry's; another geometry's replace them); whether any was
        new."""
        with self._held.lock:
            held = self._held.table
            if held is None or held.geometry != table.geometry:
                self._held.table = table
                return bool(table.slices)
            added = set(table.slices) - set(held.slices)
            held.slices.update(table.slices)
            return bool(added)

    @property
    def _table(self):
        """The geometry's dimensionless table with the slices loaded so far (for changed views), or None."""
        return self._held.table

    def share_views(self, store: dict) -> None:
        """Keep this bearing's views in `store` (a dict shared with other sources of the same bearing, load
        and speed), adding the ones it already has; and the slices they loaded (a budget's or a diagnosis's
        chains then find them loaded, and stacked, by the first)."""
        for k, v in self._views.items():
            if k != _HELD_KEY:
                store.setdefault(k, v)
        self._views = store
        self._held = store.setdefault(_HELD_KEY, self._held)

    @property
    def nominal(self) -> CoefficientTable:
        return self.view()

    def evaluate(self, q, factor=1.0, clearance=None, load_factor=1.0, lean=0.0):
        """K, C (... 2, 2) and journal position (..., 2) at flows q (m^3/s) with the given bearing changes
        (`BearingChange`: each a number or an array of the batch's shape), the film turned by `lean` (rad) when its
        load leans that much further than its table's (`_turned`: a horizontal side load on two supports). The
        declared bearing from its view; a changed one straight from the slices in memory (`scaled.SliceStack`: a fit
        with the oil or the loads free asks for another bearing at every evaluation and every Jacobian column), or
        from its own view when they do not hold it yet (which loads or builds them)."""
        state = self._evaluate(q, factor, clearance, load_factor)
        return state if np.ndim(lean) == 0 and lean == 0.0 else _turned(state, lean)

    def _evaluate(self, q, factor, clearance, load_factor):
        q = np.asarray(q, dtype=float)
        declared = self.bearing.clearance
        if np.ndim(factor) == 0 and np.ndim(clearance) == 0 and np.ndim(load_factor) == 0:  # one bearing for all
            c0 = declared if clearance is None else float(clearance)
            if self._key(factor, c0, load_factor) == self._key(1.0, declared):
                t = self.view()
                v = t._values(np.clip(q, t.q_min, t.q_max))
                return v[..., 0:4].reshape(q.shape + (2, 2)), v[..., 4:8].reshape(q.shape + (2, 2)), v[..., 8:10]
        f, c, lf = (np.broadcast_to(np.asarray(a, dtype=float), q.shape).ravel()
                    for a in (factor, declared if clearance is None else clearance, load_factor))
        qf = q.ravel()
        out = np.empty(qf.shape + (10,))
        same = (np.round(f, 12) == 1.0) & (np.round(c, 15) == round(declared, 15)) & (np.round(lf, 12) == 1.0)
        if same.any():
            t = self.view()
            out[same] = t._values(np.clip(qf[same], t.q_min, t.q_max))
        rest = np.flatnonzero(~same)
        stack = self._slice_stack() if rest.size else None
        if stack is not None:
            v, served = stack.values(qf[rest], f[rest], c[rest], lf[rest])
            if self._turn is not None:
                v = v @ self._turn.T
            out[rest[served]] = v[served]
            rest = rest[~served]
        if rest.size:
            changes = np.stack([f[rest], c[rest], lf[rest]], axis=1)
            uniq, inverse = np.unique(changes, axis=0, return_inverse=True)
            for j, change in enumerate(uniq):
                sel = rest[inverse.ravel() == j]
                t = self.view(*change)
                out[sel] = t._values(np.clip(qf[sel], t.q_min, t.q_max))
        out = out.reshape(q.shape + (10,))
        return out[..., 0:4].reshape(q.shape + (2, 2)), out[..., 4:8].reshape(q.shape + (2, 2)), out[..., 8:10]

    def turn_error(self):
        """What the rigid turn of this bearing's film leaves out (`forward.turn.TurnError`), measured on its film in
        its load's frame at the declared load and speed (once, then kept in memory and on disk)."""
        if self._views.get(_TURN_KEY) is None:
            from .turn import turn_error

            self._views[_TURN_KEY] = turn_error(self._seen, self.omega, self._seen_load, self.nominal.q_threshold,
                                                progress=self.progress)
        return self._views[_TURN_KEY]

    def turn_error_at(self, omega: float):
        """The turn's error measured as `turn_error` does but at rotational speed `omega` (rad/s; its Q_T the film's
        own there, solved only when the measurement is not kept): the size a budget carries on two supports, measured
        once at the machine's operating speed rather than at every record's (`budget.turn_errors`)."""
        if math.isclose(float(omega), self.omega, rel_tol=1e-12):
            return self.turn_error()
        key = _TURN_KEY + (round(float(omega), 9),)
        if self._views.get(key) is None:
            from .turn import turn_error

            self._views[key] = turn_error(self._seen, float(omega), self._seen_load, None, progress=self.progress)
        return self._views[key]

    def flow_ratio(self, q, factor=1.0, clearance=None, load_factor=1.0) -> np.ndarray:
        """Each flow q (m^3/s) over the Q_T of this bearing with the given changes (`BearingChange`'s fields, each a
        number or an array of q's shape): from the slices in memory where they serve, else from the changed bearing's
        own view."""
        q = np.asarray(q, dtype=float)
        f, c, lf = (np.broadcast_to(np.asarray(a, dtype=float), q.shape).ravel()
                    for a in (factor, self.bearing.clearance if clearance is None else clearance, load_factor))
        qf = q.ravel()
        out = np.full(qf.shape, np.nan)
        stack = self._slice_stack()
        if stack is not None:
            v, served = stack.values(qf, f, c, lf, ratio=True)
            out[served] = v[served, 10]
        for i in np.flatnonzero(np.isnan(out)):
            out[i] = qf[i] / self.view(f[i], c[i], lf[i]).q_threshold
        return out.reshape(q.shape)

    def _slice_stack(self):
        """The `SliceStack` of the slices this bearing's views have loaded (the declared bearing's, first)."""
        if self._held.table is None:
            self._remember_slices(self._seen, self._seen_load)
        held = self._held
        with held.lock:
            if held.table is None:
                return None
            if held.stack is None or not held.stack.covers(held.table):
                from ..tables.scaled import SliceStack

                try:
                    held.stack = SliceStack(held.table, self._seen, self._seen_load, self.omega)
                except InputError:
                    return None
            return held.stack


def _lean_corrected(src: BearingSource, state, q, change, lean):
    """A bearing's (K, C, position) from its table (`BearingSource.evaluate`, in the machine's frame at its table's
    lean) corrected for what the rigid turn by `lean` (rad, the batch's shape) leaves out, as the compiled loop
    corrects it (`forward.shifted.lean_corrected`, in the table's own frame), before the turn itself (`_turned`)."""
    from .shifted import lean_corrected_rows, turn_arrays

    K, C, pos = state
    lean = np.asarray(lean, dtype=float)
    if not np.any(lean != 0.0):
        return state
    shape = np.shape(pos)[:-1]
    rows = np.empty(shape + (11,))
    rows[..., 0:4], rows[..., 4:8], rows[..., 8:10] = K.reshape(shape + (4,)), C.reshape(shape + (4,)), pos
    back = src._turn  # the machine's frame from the table's: rows_machine = rows_table @ back.T
    if back is not None:
        rows[..., 0:10] = rows[..., 0:10] @ back
    rows[..., 10] = src.flow_ratio(q, change.viscosity_factor, change.clearance, change.load_factor)
    clearance = np.broadcast_to(np.asarray(src.bearing.clearance if change.clearance is None else change.clearance,
                                           dtype=float), shape)
    ratio, errors, count = turn_arrays((src.turn_error(),))
    flat = np.ascontiguousarray(rows.reshape(-1, 11))
    lean_corrected_rows(flat, np.ascontiguousarray(np.broadcast_to(lean, shape).ravel()),
                        np.ascontiguousarray(clearance.ravel()), ratio[0], errors[0], int(count[0]))
    v = flat[:, 0:10] if back is None else flat[:, 0:10] @ back.T
    v = v.reshape(shape + (10,))
    return v[..., 0:4].reshape(shape + (2, 2)), v[..., 4:8].reshape(shape + (2, 2)), v[..., 8:10]


def _sagged(positions, stiffness, loads, sags):
    """The journals' positions (..., N, 2) and the films' static stiffnesses (..., N, 2, 2) that `LoadShift.shifted`
    takes, for housings that yield `sags` (..., N) m/N more than the rotor's declared pedestals (a softer pedestal
    than its model file's, `Effect.housing_sag`), at the loads `loads` (..., N, 2) of this Newton step.

    A housing yields along its film's load, H W (H = 1 / its stiffness), so the journal sits H W from where the film
    alone puts it. The load shift holds the declared H in the shaft's stiffness (`LoadShift.k_s`); the change dH
    adds dH W: with the films' positions p(W) the equilibrium is W - W0 + k_s (p(W) - p0 + dH W) = 0. At the step's
    loads W this is the shift's own equation with each journal moved by dH W and each film's compliance K^-1 grown
    by dH (the extra sag is in series with the film): one Newton step of it, exact where the films are linear
    (`tests/rotor/test_declared_pedestals.py`, against the statics of the machine declaring the new pedestal)."""
    sags = np.asarray(sags, dtype=float)
    eye = np.eye(2)
    compliance = np.linalg.inv(stiffness) + sags[..., None, None] * eye
    return positions + sags[..., None] * loads, np.linalg.inv(compliance)


def _lean(loads) -> np.ndarray:
    """Each load's lean from the vertical (rad, `film_frame`'s beta) of loads (..., 2)."""
    loads = np.asarray(loads, dtype=float)
    return np.arctan2(loads[..., 0], -loads[..., 1])


def _turned(state, angle):
    """A bearing's (K, C, position) turned by `angle` (rad, a number or the batch's shape) about its centre: the
    film whose load leans `angle` further than its table's (the shifted loads lean as the journals move; on the fan
    a starved bearing B at two thirds of the rated speed turns bearing A's load 3 deg, which turns its orbit 2.7 deg).
    Rigid: the grooves stay where the table has them. Beside a groove a flooded film is not round, and that leaves
    up to 0.3 c of the position and 2 x K per radian of lean (session 68, `forward.turn`): on 3+ supports the film is
    corrected for it first (`_lean_corrected`); on two (a side load's lean) the budget carries it."""
    K, C, pos = state
    angle = np.asarray(angle, dtype=float)
    if not np.any(np.abs(angle) > 1e-9):
        return state
    c, s = np.cos(angle), np.sin(angle)
    r = np.stack([np.stack([c, -s], axis=-1), np.stack([s, c], axis=-1)], axis=-2)
    rt = np.swapaxes(r, -1, -2)
    return r @ K @ rt, r @ C @ rt, np.einsum("...ij,...j->...i", r, pos)


def _reference_solve(rotor, omega: float, B0, rhs) -> np.ndarray:
    """D0^-1 rhs, D0 the rotor's dynamic stiffness at omega on the films' reference coefficients B0: its LU factors
    kept with the rotor (a diagnosis makes ~200 chains of one rotor, speed and films; each solved the whole rotor,
    3.5 s of the fan's diagnosis, session 45). getrf and getrs, as `np.linalg.solve`."""
    from scipy.linalg import lu_factor, lu_solve

    key = (float(omega), np.concatenate([np.asarray(b, dtype=complex).ravel() for b in B0]).tobytes())
    kept = rotor.__dict__.setdefault("_reference_factors", {})
    lu = kept.get(key)
    if lu is None:
        Kt, Ct = bearing_matrices(rotor, [(b.real, b.imag / omega) for b in B0])
        lu = lu_factor(dynamic_stiffness(rotor, omega, Kt, Ct), check_finite=False)
        if len(kept) >= 8:
            kept.pop(next(iter(kept)))
        kept[key] = lu
    return lu_solve(lu, rhs, check_finite=False)


class _StatesMemo:
    """The load shift's states (`forward.shifted.shifted_states`' five arrays) of the last SIZE batches of at least
    POINTS points, every point served, by their inputs' bytes; shared by the chains of one machine, speed, rotor and
    loads (`with_effects`, `with_rotor`). A diagnosis searches the same flow lattice with ~30 candidates whose
    effects leave the bearings as declared (a probe's gain or angle, a second unbalance, a bow, a pedestal): their
    films are the plain chain's, point for point (~2/3 of a lattice point's cost). A point served by its slices has
    the same values whatever other slices are loaded since, so a remembered batch is the batch computed again;
    each get hands out copies."""

    SIZE = 8
    POINTS = 256

    def __init__(self):
        self._store: dict = {}
        self._lock = threading.Lock()

    @staticmethod
    def key(*arrays) -> bytes:
        h = hashlib.blake2b(digest_size=20)
        for a in arrays:
            if a is None:
                h.update(b"-")
            else:
                a = np.ascontiguousarray(a, dtype=float)
                h.update(repr(a.shape).encode())
                h.update(a.tobytes())
        return h.digest()

    def get(self, key):
        with self._lock:
            hit = self._store.pop(key, None)
            if hit is None:
                return None
            self._store[key] = hit  # the most recent last
        return tuple(a.copy() for a in hit)

    def put(self, key, value) -> None:
        with self._lock:
            self._store.pop(key, None)
            while len(self._store) >= self.SIZE:
                self._store.pop(next(iter(self._store)))
            self._store[key] = tuple(a.copy() for a in value)


def _repeated(value, shape):
    """`value` of one point (an array, or a `BearingChange` of numbers) as the same for every point of a batch of
    `shape` (a fresh array each; a float, or None, stays as it is: the batch's own evaluation gives those)."""
    if isinstance(value, BearingChange):
        return BearingChange(*(_repeated(v, shape) for v in value))
    if value is None or isinstance(value, float):
        return value
    value = np.asarray(value)
    return np.broadcast_to(value, tuple(shape) + value.shape).copy()


class BearingChange(NamedTuple):
    """What the bearings-stage effects change of one bearing: its oil's viscosity (x `viscosity_factor`), its
    radial clearance (m), the static load it carries (x `load_factor`) and that load's turn from the declared one's
    line (`lean`, rad, from straight down towards +X: a horizontal side load on two supports; on 3+ supports the
    load shift turns the films); numbers, or arrays of a batch's shape. `BearingSource.view(*change)` and
    `.evaluate(q, *change)` take it as it is."""

    viscosity_factor: object
    clearance: object
    load_factor: object = 1.0
    lean: object = 0.0

    def as_floats(self) -> "BearingChange":
        return BearingChange(*(float(v) for v in self))


def bearing_changes(effects, k: int, declared_clearance: float, values=lambda e: {}, shape=()) -> BearingChange:
    """The `BearingChange` of bearing k (0-based) after the `effects` (the bearings stage's, and any other's that
    moves the static loads: a support stiffer than declared): viscosity and load factors multiply, the last
    clearance given wins. `values(effect)` gives trial values of its free parameters (default: none, i.e. the
    effects' own values)."""
    factor, clearance, load, lean = 1.0, declared_clearance, 1.0, 0.0
    for e in effects:
        change = e.bearing_change(k, values(e), shape)
        if change:
            factor = factor * change.get("viscosity_factor", 1.0)
            clearance = change.get("clearance", clearance)
            load = load * change.get("load_factor", 1.0)
            lean = lean + change.get("lean", 0.0)
    return BearingChange(factor, clearance, load, lean)


def _rows(a, shape, tail) -> np.ndarray:
    """`a` broadcast to `shape` + `tail`, as rows (-1,) + `tail` (numpy's broadcast_to only when `a` is smaller: it
    costs ~7 us a call)."""
    a = np.asarray(a, dtype=float)
    full = tuple(shape) + tuple(tail)
    return (a if a.shape == full else np.broadcast_to(a, full)).reshape((-1,) + tuple(tail))


@functools.lru_cache(maxsize=256)
def _feature_split(names: tuple) -> tuple:
    """(the 1X invariants among feature `names`, their indices in `names`, ((name, its index, 0-based plane, 0 for x
    or 1 for y), ...) of the static positions among them): a fit asks for the same names thousands of times. The
    indices are a list, as numpy indexes with them (a tuple would index several axes); never changed by a caller."""
    dynamic = tuple((i, n) for i, n in enumerate(names) if not is_static(n))
    static = tuple((n, i, feature_plane(n)[1] - 1, 0 if n[1] == "x" else 1) for i, n in enumerate(names)
                   if is_static(n))
    return tuple(n for _, n in dynamic), [i for i, _ in dynamic], static


# --- the chain -----------------------------------------------------------------------------------

@dataclass(frozen=True)
class ResponseDefect:
    """A correction of the chain's response at its P planes, in the probes' X/Y frame before the probe
    stage, affine in the N flows (every fluid-film bearing's, a known supply's among them): at flows q it adds
    x + dx (q - q0) to the 1X amplitudes x, y (P planes, complex) and static + dstatic (q - q0) to the static
    offsets (plane, [x, y]), m.

    The large-orbit identification (`identify.fit.large_orbit`) sets it to the harmonic balance's orbit minus its
    own linear orbit near the last flows q0, with its slope in the flows (a defect correction): the linear
    chain stays the fast model the fit differentiates, and the correction carries what the film's
    nonlinearity adds, slope included, so the fit's intervals see the nonlinear model's sensitivity."""

    x: np.ndarray  # (P,) complex
    y: np.ndarray
    static: np.ndarray  # (P, 2)
    q0: np.ndarray  # (N,) m^3/s
    dx: np.ndarray  # (P planes, N flows) complex, per m^3/s
    dy: np.ndarray
    dstatic: np.ndarray  # (P, 2, N flows)
    # the correction's change with the unbalance's scale at q0 ((x, y, static) per unit of scale), when solved:
    # the large-orbit fit folds it into dx, dy, dstatic through the scale the record implies at each flow
    dscale: tuple | None = None
    # the correction's curvature in the flows at q0, when solved: (P planes, N, N flows) complex for x, y and
    # (P, 2, N, N) for the static offsets; at q it adds 1/2 (q - q0)^T H (q - q0)
    hx: np.ndarray | None = None
    hy: np.ndarray | None = None
    hstatic: np.ndarray | None = None

    @classmethod
    def constant(cls, x, y, static, q0) -> "ResponseDefect":
        x, q0 = np.asarray(x), np.asarray(q0, dtype=float)
        planes, flows = x.size, q0.size
        return cls(x, np.asarray(y), np.asarray(static), q0, np.zeros((planes, flows), complex),
                   np.zeros((planes, flows), complex), np.zeros((planes, 2, flows)))

    @property
    def shape(self) -> tuple[int, int]:
        """(planes, flows) the correction is for."""
        return int(np.size(self.x)), int(np.size(self.q0))

    def at(self, q) -> tuple[np.ndarray, np.ndarray]:
        """(d (..., P planes, 2 [x, y]) complex, static (..., P, 2)) at flows q (..., N)."""
        dq = np.asarray(q, dtype=float) - self.q0
        x = self.x + np.einsum("pk,...k->...p", self.dx, dq)
        y = self.y + np.einsum("pk,...k->...p", self.dy, dq)
        static = self.static + np.einsum("pjk,...k->...pj", self.dstatic, dq)
        if self.hx is not None:
            x = x + 0.5 * np.einsum("pkl,...k,...l->...p", self.hx, dq, dq)
            y = y + 0.5 * np.einsum("pkl,...k,...l->...p", self.hy, dq, dq)
            static = static + 0.5 * np.einsum("pjkl,...k,...l->...pj", self.hstatic, dq, dq)
        return np.stack([x, y], axis=-1), static


@dataclass(frozen=True)
class ChainOutput:
    """What the probes read: 1X amplitudes x, y (..., P planes) and the static offsets (..., P, 2) or None (no plane
    at a bearing's centre; a plane elsewhere has zeros)."""

    x: np.ndarray
    y: np.ndarray
    static: np.ndarray | None


def load_slices(sources, wanted: dict) -> bool:
    """The slices queries of each source k's film frame at Sommerfeld numbers `wanted[k]` need, loaded (or built,
    with the first source's progress) for every source at once, so the missing ones of every geometry share one pool
    (`tables.cache.geometry_tables`); whether any was added. An S off the grid adds nothing for that source."""
    from ..tables import cache

    ks = [k for k in sorted(wanted) if wanted[k]]
    if not ks:
        return False
    tables = cache.geometry_tables([(sources[k]._seen, np.asarray(wanted[k], dtype=float)) for k in ks],
                                   progress=sources[ks[0]].progress, off_grid="skip")
    added = [sources[k]._hold(t) for k, t in zip(ks, tables) if t is not None]
    return any(added)


class ForwardChain:
    """Named parameters -> probe readings and features at the measurement planes of `machine` at `speed_hz`
    (`nodes`, any number; None: the machine's measurement planes, SPEC §8, with their probe angles;
    `probe_angles_deg` None: those, or X and Y at every plane of given `nodes`)."""

    def __init__(self, machine, speed_hz: float, nodes: Sequence[int] | None = None, effects=(), *,
                 probe_angles_deg=None, tables: Sequence[CoefficientTable] | None = None,
                 rotor=None, shaft_damping_beta: float | None = None, loads=None, progress: ProgressFn = silent,
                 _like: "ForwardChain | None" = None):
        self.machine = machine
        self.speed_hz = float(speed_hz)
        if not (math.isfinite(self.speed_hz) and self.speed_hz > 0):
            raise InputError(f"speed {speed_hz!r} Hz; expected a positive number")
        self.omega = 2 * math.pi * self.speed_hz
        self.rotor = rotor_from_machine(machine, shaft_damping_beta=shaft_damping_beta) if rotor is None else rotor
        if nodes is None:
            planes = machine.measurement_planes
            nodes = [p.node for p in planes]
            if probe_angles_deg is None:
                probe_angles_deg = [p.probe_angles_deg for p in planes]
        self.nodes = tuple(self.rotor.check_node(int(n), "measurement node") for n in nodes)
        if not self.nodes or len(set(self.nodes)) != len(self.nodes):
            raise InputError(f"distinct measurement planes expected, got nodes {tuple(nodes)}")
        if probe_angles_deg is None:
            probe_angles_deg = [(0.0, 90.0)] * len(self.nodes)
        self.probe_angles_deg = tuple(tuple(float(a) for a in p) for p in probe_angles_deg)
        if len(self.probe_angles_deg) != len(self.nodes) or any(len(p) != 2 for p in self.probe_angles_deg):
            raise InputError(f"probe angles {probe_angles_deg!r}: expected two directions for each of the "
                             f"{len(self.nodes)} planes")
        for e in effects:
            if getattr(e, "stage", None) == "response":
                raise InputError(f"{e.label()} replaces the linear response (the film solved along the orbit): "
                                 "the linear chain cannot carry it; `identify` fits it through "
                                 "`identify.fit.large_orbit` (with probe effects only), `simulate` alone")
            if getattr(e, "stage", None) not in ("bearings", "rotor", "probes"):
                raise InputError(f"{e!r} is not an effect (no stage)")
        self.effects = tuple(e.bind(machine) for e in effects)
        for k in range(len(machine.bearings)):  # supports act in series with one film: one pedestal per bearing
            on_k = [e.label() for e in self.effects if e.applies(k) or e.changes_housing(k)]
            if len(on_k) > 1:
                raise InputError(f"bearing {k + 1} is given a pedestal twice ({', '.join(on_k)}); "
                                 "one pedestals effect per bearing")
            if any(e.applies(k) for e in self.effects) and self.rotor.housing("bearing", k) is not None:
                raise InputError(f"bearing {k + 1} stands on the pedestal its model file declares; {on_k[0]} would "
                                 "put a second one under it")
        if tables is None:
            from ..tables.cache import machine_tables

            tables = machine_tables(machine, self.omega, progress=progress)
        # the static loads on the films (`loads`: the machine's, already known to a chain this one is copied from;
        # a machine of 3+ supports solves its shaft on its films for them)
        tables = list(tables)
        if not tables or len(tables) != len(machine.bearings):
            raise InputError(f"one coefficient table per fluid-film bearing expected ({len(machine.bearings)}), "
                             f"got {len(tables)}")
        self.loads = bearing_static_loads(machine) if loads is None else np.asarray(loads, dtype=float)
        # `_like`: a chain of the same machine, speed, rotor and loads (`with_effects`), whose bearings' frames and
        # load shift this one shares (a diagnosis makes ~200 chains: ~2 ms each was theirs)
        frames = [None] * len(tables) if _like is None else [(s._seen, s._seen_load, s._turn) for s in _like.sources]
        self.sources = [BearingSource(machine, k, self.omega, t, load=self.loads[k], progress=progress, frame=fr)
                        for k, (t, fr) in enumerate(zip(tables, frames))]
        from ...rotor.load_shift import LoadShift
        from ...rotor.statics import statically_determinate

        self._shift = None
        self._packed = None  # the bearings' stacked slices for `forward.shifted` (`_compiled_states`)
        self._packed_held = None  # what the sources held when they were packed
        # the load shift's states of the last large batches (`_StatesMemo`), shared with every chain made from this
        self._states_memo = _StatesMemo() if _like is None else _like._states_memo
        if _like is not None:
            self._shift = _like._shift
        elif not statically_determinate(machine, self.rotor):  # 3+ supports: the loads follow the journals (flows)
            from ...rotor.statics import coupled_statics

            self._shift = LoadShift(self.rotor, [s.bearing.node for s in self.sources], self.loads,
                                    coupled_statics(machine).positions)
        self.q_threshold = np.array([s.nominal.q_threshold for s in self.sources])
        self.names = flow_names(len(self.sources)) + tuple(f"{self.prefix(e)}.{p}" for e in self.effects for p in e.free)
        self._slots = [(e, p) for e in self.effects for p in e.free]
        self._build_reference()
        self.evaluations = 0
        self.defect: ResponseDefect | None = None
        self.position_error: np.ndarray | None = None  # (`with_position_error`)
        self._damped_rotors: dict = {}  # shaft damping beta -> rotor (`damped_rotor`), shared with derived chains

    def with_defect(self, defect: ResponseDefect | None) -> "ForwardChain":
        """The same chain (tables, views, effects shared) with `defect` added to its response."""
        import copy

        if defect is not None and defect.shape != (self.n_planes, self.n_flows):
            raise InputError(f"large orbits: an orbit correction of {defect.shape[0]} plane(s) and "
                             f"{defect.shape[1]} flow(s) given to a chain of {self.n_planes} plane(s) and "
                             f"{self.n_flows} fluid-film bearing(s)")
        new = copy.copy(self)
        new.defect = defect
        new.__dict__.pop("_budget_chains", None)
        return new

    def with_position_error(self, error) -> "ForwardChain":
        """The same chain with each film's journal held `error` (..., N, 2; m, broadcast against the batch) further
        from its bearing's centre than the film puts it: what the static loads of 3+ supports do when the films'
        positions are that much off (the model budget's columns of the position's error, carried through the
        load shift; on two supports the loads do not follow the journals and nothing changes)."""
        import copy

        new = copy.copy(self)
        new.position_error = None if error is None else np.asarray(error, dtype=float)
        new.__dict__.pop("_budget_chains", None)
        return new

    def with_effects(self, effects) -> "ForwardChain":
        """The same machine, speed, planes and tables with other effects (tables and bearing views shared, and the
        rotors of other shaft damping the model budget built: `with_rotor`)."""
        new = ForwardChain(self.machine, self.speed_hz, self.nodes, effects, probe_angles_deg=self.probe_angles_deg,
                           tables=[s.nominal for s in self.sources], rotor=self.rotor, loads=self.loads,
                           progress=self.sources[0].progress, _like=self)
        for s_new, s_old in zip(new.sources, self.sources):
            s_new.share_views(s_old._views)
        new._damped_rotors = self._damped_rotors
        return new

    def damped_rotor(self, beta: float):
        """This chain's rotor with the shaft damping `beta` (s) instead (the model budget's), built once for a chain
        and every chain made from it by `with_effects`."""
        if beta == self.rotor.shaft_damping_beta:
            return self.rotor
        if beta not in self._damped_rotors:
            self._damped_rotors[beta] = rotor_from_machine(self.machine, shaft_damping_beta=beta)
        return self._damped_rotors[beta]

    def with_rotor(self, rotor) -> "ForwardChain":
        """The same chain (sources, effects, load shift, defect shared) on another `rotor` of the same shaft and
        supports: another shaft damping (the statics, which do not see damping, stay)."""
        import copy

        new = copy.copy(self)
        new.rotor = rotor
        new.__dict__.pop("_budget_chains", None)
        new._build_reference()
        return new

    def adding(self, *effects) -> "ForwardChain":
        """The same chain with `effects` added after its own (its declared effects stay)."""
        return self.with_effects(self.effects + tuple(effects))

    # --- parameters -------------------------------------------------------------------------------
    def prefix(self, effect) -> str:
        """What `effect`'s parameters are called after in the vector: its name, or its label when the chain
        holds it twice ('pedestals[bearing=1]')."""
        same = [e for e in self.effects if e.effect_name == effect.effect_name]
        return effect.effect_name if len(same) == 1 else effect.label()

    @property
    def n_params(self) -> int:
        return len(self.names)

    @property
    def known_flows(self) -> dict[int, float]:
        """{bearing (0-based): flow (m^3/s)} of the bearings whose supply the model file gives (SPEC §8
        `supply_mlmin`): held in a fit, within the tables' span (`tables.supply.DEFAULT_SPAN` x its Q_T; a flow
        beyond is held at the end, and the fit says so)."""
        lo, hi = DEFAULT_SPAN[0] * self.q_threshold, DEFAULT_SPAN[1] * self.q_threshold
        return {k: float(np.clip(b.supply_flow, lo[k], hi[k])) for k, b in enumerate(self.machine.bearings)
                if getattr(b, "supply", "unknown") == "known"}

    @property
    def flooded_bearings(self) -> tuple[int, ...]:
        """The bearings (0-based) fed above their Q_T by an amount nobody states (SPEC §8 `supply = "flooded"`):
        their flow is a nuisance between Q_T and the search's upper end, not an answer."""
        return tuple(k for k, b in enumerate(self.machine.bearings) if getattr(b, "supply", "unknown") == "flooded")

    def start(self) -> np.ndarray:
        """The parameter vector at Q_T (a known supply at its flow) and the effects' current values (their declared
        ones when None)."""
        q = self.q_threshold.copy()
        for k, v in self.known_flows.items():
            q[k] = v
        out = [*q]
        for e, p in self._slots:
            v = getattr(e, p)
            out.append(self._declared(e, p) if v is None else float(v))
        return np.array(out)

    def search_variants(self, start: np.ndarray, free) -> list[np.ndarray]:
        """`start` with one free effect parameter moved to each of its `Effect.search_values` (inside its bounds):
        where the global search over the flows also looks."""
        lo, hi = self.bounds()
        out = []
        for j, (e, p) in enumerate(self._slots):
            i = self.n_flows + j
            if i not in free:
                continue
            for v in e.search_values(p, self.machine):
                if lo[i] <= v <= hi[i] and not math.isclose(v, start[i], rel_tol=1e-9, abs_tol=1e-12):
                    out.append(start.copy())
                    out[-1][i] = v
        return out

    def _declared(self, effect, pname) -> float:
        return effect.declared(pname, self.machine)

    def bounds(self, lower: float = 0.25, upper: float = 2.0) -> tuple[np.ndarray, np.ndarray]:
        lo = list(lower * self.q_threshold)
        hi = list(upper * self.q_threshold)
        for k in self.flooded_bearings:  # fed above Q_T: the flow is only known to be more than Q_T
            lo[k] = max(lower, 1.0) * self.q_threshold[k]
        for e, p in self._slots:
            a, b = e.bounds(p)
            lo.append(a)
            hi.append(b)
        return np.array(lo), np.array(hi)

    def steps(self) -> np.ndarray:
        """Central-difference step of each parameter (flows: 1e-4 Q_T)."""
        return np.array(list(1e-4 * self.q_threshold) + [e.step.get(p, 1e-4) for e, p in self._slots])

    def _values(self, theta: np.ndarray, effect) -> dict:
        n = self.n_flows
        return {p: theta[..., n + j] for j, (e, p) in enumerate(self._slots) if e is effect}

    @property
    def n_flows(self) -> int:
        """The flows at the head of the parameter vector: one per fluid-film bearing."""
        return len(self.sources)

    @property
    def n_planes(self) -> int:
        return len(self.nodes)

    def plane_bearing(self, p: int) -> int | None:
        """The bearing (0-based) whose centre node plane `p` (0-based) sits at, or None."""
        nodes = self.rotor.bearing_nodes
        return nodes.index(self.nodes[p]) if self.nodes[p] in nodes else None

    def plane_housing(self, p: int) -> int:
        """The bearing (0-based) on whose housing plane `p`'s probes are mounted: the nearest along the shaft (the
        first of two as near). With a pedestal under it the probes read the shaft relative to that housing."""
        z = self.rotor.node_z
        at = z[self.nodes[p] - 1]
        return int(np.argmin([abs(z[n - 1] - at) for n in self.rotor.bearing_nodes]))

    @property
    def dynamic_features(self) -> tuple[str, ...]:
        """Every 1X invariant of this chain's planes (`model.plane_features`)."""
        from .model import plane_features

        return plane_features(self.n_planes)

    def bearing_changes(self, k: int, theta, shape=()) -> BearingChange:
        """The `BearingChange` of bearing k at parameters theta (`bearing_changes`)."""
        return bearing_changes(self.effects, k, self._declared_clearances[k], lambda e: self._values(theta, e), shape)

    @functools.cached_property
    def _declared_clearances(self) -> tuple[float, ...]:
        """Each bearing's declared clearance (m), read once (a param attribute costs a few microseconds a read,
        thousands of reads a fit)."""
        return tuple(float(src.bearing.clearance) for src in self.sources)

    def bearing_states(self, theta, shape=()) -> list:
        """[(BearingChange, (K, C, position))] of each bearing at parameters theta (batch `shape`). On 3+ supports
        the static loads follow the journals' positions (`rotor.load_shift.LoadShift`): each bearing is evaluated
        again at its shifted load, turned by that load's change of lean. A batch that is one point repeated (a
        broadcast view: the model budget's perturbations of the dynamic stiffness at one point) is evaluated once."""
        theta = np.asarray(theta)
        if shape and math.prod(shape) > 1 and theta.ndim == len(shape) + 1 and not any(theta.strides[:len(shape)]):
            return [(_repeated(change, shape), tuple(_repeated(a, shape) for a in state))
                    for change, state in self._states(theta[(0,) * len(shape)], ())[0]]
        return self._states(theta, shape)[0]

    def past_tables(self, theta) -> list[tuple[int, float, float, float]]:
        """The bearings whose flow at parameters theta (one point) lies past their own table's ends: (bearing k,
        flow (m^3/s), its Q_T as the effects change it, the end it is held at). The lookups hold such a flow at the
        table's end (`tables.scaled.value_at`, `BearingSource.evaluate`): an effect that moves Q_T (thicker oil, a
        worn bearing) can take a flow there inside the search box, and the answer then rests on the end's
        coefficients, not the flow's."""
        theta = np.asarray(theta, dtype=float)
        out = []
        for k, (change, _state) in enumerate(self.bearing_states(theta)):
            try:
                view = self.sources[k].view(*change.as_floats())
            except InputError:  # a Sommerfeld number off the grid: held at its end too (`_within_grid`)
                continue
            q = float(theta[k])
            if q < view.q_min * (1 - 1e-6) or q > view.q_max * (1 + 1e-6):
                out.append((k, q, float(view.q_threshold), view.q_min if q < view.q_min else view.q_max))
        return out

    def off_grid(self, theta) -> list[tuple[int, float, float]]:
        """The bearings whose film at parameters theta (one point) has a Sommerfeld number past the tables' grid:
        (bearing k, its S, the grid's end it is held at). The effects' viscosity and clearance and the static load
        (on 3+ supports the load the journals' positions shift it to, `static_loads`) set S; the lookups hold it at
        the grid's end (`_within_grid`, `_on_grid`), as they hold a flow at its table's."""
        from ..tables.dimensionless import sommerfeld_nodes

        theta = np.asarray(theta, dtype=float)
        grid = sommerfeld_nodes()
        loads = self.static_loads(theta) if self._shift is not None else None
        out = []
        for k in range(self.n_flows):
            # the shifted load against the declared one (what `load_factor` scales), or none moved
            moved = 1.0 if loads is None else float(np.linalg.norm(loads[k]) / np.linalg.norm(self.loads[k]))
            s = float(self._sommerfeld(k, self.bearing_changes(k, theta), moved))
            if s > grid[-1] * (1 + 1e-6) or s < grid[0] * (1 - 1e-6):
                out.append((k, float(s), float(grid[-1] if s > grid[-1] else grid[0])))
        return out

    def turned_loads(self, theta) -> list[tuple[int, float]]:
        """The bearings whose static load at parameters theta (one point) leans more than `budget.TURN_SAID_DEG` off
        its declared line: (bearing k, the turn in degrees, from straight down towards +X). Such a film is the
        table's turned rigidly (`_turned`), whose error the model budget carries per radian as measured up to 10 deg
        (`budget.TURN_ERROR_PER_RAD`); a load turned far past that, or reversed (a couple that lifts the fan's bearing
        A off its film: its loop's case 138), is not that film."""
        from .budget import TURN_SAID_DEG

        turns = np.degrees(self.film_turns(theta))
        return [(k, float(t)) for k, t in enumerate(turns) if abs(t) > TURN_SAID_DEG]

    def film_turns(self, theta) -> np.ndarray:
        """(N,) how far each film's load leans off its table's line at parameters theta (one point; rad, in
        [-pi, pi)): the journals' positions shift it on 3+ supports (`static_loads`), an effect's `lean` (a side
        load) on two. The film is the table's turned by it (`_turned`), on 3+ supports corrected first for what a
        rigid turn leaves out (`_lean_corrected`, `forward.turn`); the model budget carries the rest."""
        theta = np.asarray(theta, dtype=float)
        if self._shift is not None:
            turns = _lean(self.static_loads(theta)) - _lean(self.loads)
        else:
            turns = np.array([float(self.bearing_changes(k, theta).lean) for k in range(self.n_flows)])
        return (turns + np.pi) % (2 * np.pi) - np.pi

    def static_loads(self, theta) -> np.ndarray:
        """Each bearing's static load (..., N, 2), N, at parameters theta: the flooded statics' moved by the
        journals' positions at the flows (3+ supports; `LoadShift`), the declared ones otherwise."""
        theta = np.asarray(theta, dtype=float)
        if self._shift is None:
            return np.broadcast_to(self.loads, theta.shape[:-1] + self.loads.shape).copy()
        return self._states(theta, theta.shape[:-1])[1]

    def _states(self, theta, shape):
        """(`bearing_states`, the loads they were evaluated under or None on a statically determinate machine):
        `rotor.load_shift.STEPS` Newton steps of the shaft's equilibrium on its films from the flooded loads."""
        changes = [self.bearing_changes(k, theta, shape) for k in range(self.n_flows)]
        if self._shift is None:
            if self.load_targets(theta, shape) is not None:  # the hook's contract: 3+ supports only
                raise InputError(f"{', '.join(e.label() for e in self.effects)}: a static load change on a machine "
                                 "whose loads do not follow the journals (two supports); give it as a load factor")
            changes = self._on_grid(changes, shape)
            states = [src.evaluate(theta[..., k], *changes[k]) for k, src in enumerate(self.sources)]
            return list(zip(changes, states)), None
        offsets = self.bearing_offsets(theta, shape)
        target = self.load_targets(theta, shape)
        sags = self.housing_sags(theta, shape)
        if sags is None:  # (a housing that sags otherwise than declared: numpy's loop, `_sagged`)
            compiled = self._compiled_states(theta, changes, shape, offsets, target)
            if compiled is not None:
                return compiled
        return self._numpy_states(theta, changes, offsets, target, sags)

    def load_targets(self, theta, shape=()):
        """(..., N, 2) the films' static loads held where the flooded statics put them, the effects' changes
        (`Effect.static_load_change`) added, or None when no effect changes them (3+ supports)."""
        out = None
        for e in self.effects:
            d = e.static_load_change(self._values(theta, e), shape)
            if d is not None:
                out = (self.loads if out is None else out) + d
        return out

    def bearing_offsets(self, theta, shape=()):
        """(..., N, 2) how far each bearing's centre sits from its declared place at parameters theta (the
        bearings-stage effects' `bearing_offset`, m, and the budget's `position_error`), or None when nothing moves
        one."""
        out = None
        if self.position_error is not None:  # the model budget's (`with_position_error`)
            out = np.zeros(shape + (self.n_flows, 2))
            out += self.position_error
        for e in self.effects:
            if e.stage != "bearings":
                continue
            for k in range(self.n_flows):
                d = e.bearing_offset(k, self._values(theta, e), shape)
                if d is not None:
                    if out is None:
                        out = np.zeros(shape + (self.n_flows, 2))
                    out[..., k, :] += d
        return out

    def housing_sags(self, theta, shape=()):
        """(..., N) how much more each bearing's declared pedestal yields per newton of its static load than declared
        (m/N, the effects' `housing_sag`), or None when no effect changes one."""
        out = None
        for e in self.effects:
            if not any(e.changes_housing(k) for k in range(self.n_flows)):
                continue  # (most effects: no housing of theirs, no values to read)
            for k in range(self.n_flows):
                d = e.housing_sag(k, self._values(theta, e), shape)
                if d is not None:
                    if out is None:
                        out = np.zeros(shape + (self.n_flows,))
                    out[..., k] += d
        return out

    def _numpy_states(self, theta, changes, offsets=None, target=None, sags=None):
        """`_states` on 3+ supports in numpy: every bearing's table evaluated (which loads the slices it needs). A
        moved bearing (`offsets`) holds its journal that much away from the shaft's flooded line; a housing that
        sags otherwise than declared (`sags`) moves it by its sag's change under the load (`_sagged`)."""
        states = [src.evaluate(theta[..., k], *changes[k]) for k, src in enumerate(self.sources)]
        loads = None
        for _ in range(load_shift.STEPS):
            positions = np.stack([st[2] for st in states], axis=-2)
            stiffness = np.stack([st[0] for st in states], axis=-3)
            if offsets is not None:
                positions = positions + offsets
            if sags is not None:
                positions, stiffness = _sagged(positions, stiffness, self.loads if loads is None else loads, sags)
            loads = self._shift.shifted(positions, stiffness, loads, target)
            factors = self._within_grid(np.linalg.norm(loads, axis=-1) / np.linalg.norm(self.loads, axis=-1),
                                        changes)
            turns = _lean(loads) - _lean(self.loads)
            turns = (turns + np.pi) % (2 * np.pi) - np.pi
            moved = [c._replace(load_factor=c.load_factor * factors[..., k]) for k, c in enumerate(changes)]
            states = [_turned(_lean_corrected(src, src.evaluate(theta[..., k], *c), theta[..., k], c, turns[..., k]),
                              turns[..., k]) for k, (c, src) in enumerate(zip(moved, self.sources))]
        return list(zip(moved, states)), loads

    def _on_grid(self, changes, shape) -> list:
        """Two supports: each bearing's change with its load factor held where its film's Sommerfeld number stays on
        the tables' grid (`_within_grid`, as the load shift holds it on 3+ supports). A side load's couple with the
        oil and the speed took the pump's bearing to S 13.8 against the grid's top 13.4, and the diagnosis stopped
        with an error (its loop, session 52); at the top the journal sits near the centre and K and C hardly follow
        the load. A change that stays on the grid is left as it is, bit for bit."""
        if all(np.ndim(v) == 0 for ch in changes for v in ch if v is not None) and all(
                ch.viscosity_factor == 1.0 and ch.load_factor == 1.0 and (ch.clearance is None or ch.clearance == c0)
                for ch, c0 in zip(changes, self._declared_clearances)):
            return changes  # the declared bearings
        factors = self._within_grid(np.ones(tuple(shape) + (self.n_flows,)), changes)
        if np.all(factors == 1.0):
            return changes
        return [ch._replace(load_factor=ch.load_factor * factors[..., k]) for k, ch in enumerate(changes)]

    def _sommerfeld(self, k: int, change: BearingChange, factor=1.0):
        """Bearing k's film Sommerfeld number under `change` (its viscosity, clearance and load factor) with its load
        x `factor` more (a shifted load's)."""
        from ..tables.dimensionless import sommerfeld_number

        src = self.sources[k]
        c = src.bearing.clearance if change.clearance is None else change.clearance
        return sommerfeld_number(src._seen, src._seen_load, self.omega) * np.asarray(change.viscosity_factor) / (
            np.asarray(change.load_factor) * factor) * (src.bearing.clearance / np.asarray(c)) ** 2

    def _within_grid(self, factors, changes) -> np.ndarray:
        """The shifted loads' factors (..., N) with each film's Sommerfeld number held on the tables' grid
        (`forward.shifted`'s `_within_grid`, which the compiled loop applies the same way)."""
        from ..tables.dimensionless import sommerfeld_nodes

        grid = sommerfeld_nodes()
        top, bottom = grid[-1] * (1.0 - 1e-9), grid[0] * (1.0 + 1e-9)
        out = np.array(factors, dtype=float, copy=True)
        for k, ch in enumerate(changes):
            s = self._sommerfeld(k, ch, out[..., k])
            out[..., k] = np.where(s > top, out[..., k] * s / top, np.where(s < bottom, out[..., k] * s / bottom,
                                                                          out[..., k]))
        return out

    def _compiled_states(self, theta, changes, shape, offsets=None, target=None):
        """`_states` through `forward.shifted` (one compiled loop over the points). The slices a point misses (a
        load shifted beyond the four slices about the flooded one) are loaded, or built, for every bearing at once
        (`load_slices`: one pool for all their geometries) and the loop run again; a point still not served (a
        Sommerfeld number off the grid at the declared load, from an effect) goes through `_numpy_states`, whose
        views say why. None when a bearing has no slices in memory."""
        n = self.n_flows
        declared = self._declared_clearances

        size = math.prod(shape)

        def columns(i, default=None):  # field i of every bearing's change, (points, N)
            vals = [default[k] if default is not None and ch[i] is None else ch[i] for k, ch in enumerate(changes)]
            if all(isinstance(v, float) or np.ndim(v) == 0 for v in vals):  # one bearing for all points
                out = np.empty((size, n))  # (numpy's broadcast_to costs ~7 us a call)
                out[:] = vals
                return out
            cols = [np.broadcast_to(np.asarray(v, dtype=float), shape) for v in vals]
            return np.stack(cols, axis=-1).reshape(-1, n)

        q = theta[..., :n].reshape(-1, n)  # theta is (shape, params)
        reference = self._shift.reference if offsets is None else \
            (self._shift.reference - np.broadcast_to(offsets, shape + (n, 2))).reshape(-1, n, 2)
        f, c, lf = columns(0), columns(1, declared), columns(2)  # viscosity factor, clearance, load factor
        # the loop stops at a point's first bearing without its slices: one attempt per bearing and Newton step at
        # most (an attempt over a fan's lattice costs ~7 ms; the numpy path for the points left, ~1 ms a point)
        attempts = 1 + n * (1 + load_shift.STEPS)
        for attempt in range(attempts):
            packed = self._packed
            held = tuple((src._held, src._held.table, len(src._held.table.slices) if src._held.table else -1)
                         for src in self.sources)
            if packed is not None and self._packed_held == held:  # nothing loaded since: the same stacks
                stacks = packed.stacks
            else:
                stacks = [src._slice_stack() for src in self.sources]
            if any(st is None for st in stacks):
                return None
            if packed is None or any(a is not b for a, b in zip(packed.stacks, stacks)):
                from ..tables.cache import frame_lean

                # each table's frame (`film_frame`): the lean its slices were turned by
                angles = [0.0 if src._turn is None else frame_lean(src.load) for src in self.sources]
                packed = self._packed = packed_stacks(stacks, angles, [src.turn_error() for src in self.sources])
            self._packed_held = tuple((src._held, src._held.table, len(src._held.table.slices))
                                      for src in self.sources) if stacks is not packed.stacks else held
            rows = None if target is None else _rows(target, shape, (n, 2))
            key = _StatesMemo.key(q, f, c, lf, reference, rows) if size >= _StatesMemo.POINTS else None
            hit = None if key is None else self._states_memo.get(key)
            if hit is not None:
                out, factors, loads, served, missed = hit
                break
            out, factors, loads, served, missed = shifted_states(
                packed, q, f, c, lf, self._shift.k_s, reference, self._shift.loads, load_shift.STEPS, rows)
            if key is not None and served.all():
                self._states_memo.put(key, (out, factors, loads, served, missed))
            if served.all() or attempt == attempts - 1:
                break
            # the slices a point missed: loaded (or built) for each bearing at once, and the loop run again
            wanted = {}
            for k, s_missed in missed[~served]:
                if np.isfinite(s_missed):
                    wanted.setdefault(int(k), []).append(float(s_missed))
            if not load_slices(self.sources, wanted):
                break
        if not served.all():  # those points in numpy (a Sommerfeld number off the slices' grid: its views say why)
            bad = np.flatnonzero(~served)
            flat = np.broadcast_to(theta, shape + theta.shape[-1:]).reshape(-1, theta.shape[-1])[bad]
            sub = [ch._replace(**{name: np.broadcast_to(np.asarray(getattr(ch, name), dtype=float), shape).ravel()[bad]
                                  for name in ch._fields if getattr(ch, name) is not None}) for ch in changes]
            sub_off = None if offsets is None else np.broadcast_to(offsets, shape + (n, 2)).reshape(-1, n, 2)[bad]
            sub_target = None if target is None else np.broadcast_to(target, shape + (n, 2)).reshape(-1, n, 2)[bad]
            sub_states, sub_loads = self._numpy_states(flat, sub, sub_off, sub_target)
            for k, (ch, (K, C, pos)) in enumerate(sub_states):
                out[bad, k, 0:4], out[bad, k, 4:8], out[bad, k, 8:10] = K.reshape(-1, 4), C.reshape(-1, 4), pos
                factors[bad, k] = np.asarray(ch.load_factor, dtype=float) / sub[k].load_factor
            loads[bad] = sub_loads
        out = out.reshape(shape + (n, 10))
        factors = factors.reshape(shape + (n,))
        K, C = out[..., 0:4].reshape(shape + (n, 2, 2)), out[..., 4:8].reshape(shape + (n, 2, 2))
        states = [(ch._replace(load_factor=ch.load_factor * factors[..., k]), (K[..., k, :, :], C[..., k, :, :],
                                                                               out[..., k, 8:10]))
                  for k, ch in enumerate(changes)]
        return states, loads.reshape(shape + (n, 2))

    # --- reference solve --------------------------------------------------------------------------
    def _build_reference(self):
        rotor, omega = self.rotor, self.omega
        B0 = []
        for s, qt in zip(self.sources, self.q_threshold):
            K, C = s.nominal.coefficients(qt)
            B0.append(K + 1j * omega * C)
        self._B0 = B0
        shapes = [unbalance_force(rotor, omega, machine_unbalance(self.machine))]
        self._forcing = []  # (effect, first column, n columns)
        for e in self.effects:
            cols = e.forcing_shapes(rotor, omega, self.machine)
            if cols:
                self._forcing.append((e, len(shapes), len(cols)))
                shapes.extend(cols)
        # the rank update's pairs of DOFs: each film (journal; its declared pedestal's DOFs or None), then each
        # constant support an effect changes (`Effect.changes_support`: its node; its pedestal's or None), then each
        # declared pedestal an effect changes (`Effect.changes_housing`: its housing's DOFs, to ground)
        self._changed_supports = tuple(j for j in range(len(rotor.supports))
                                       if any(e.changes_support(j) for e in self.effects))
        self._changed_housings = tuple(k for k in range(len(rotor.bearing_nodes))
                                       if rotor.housing("bearing", k) is not None
                                       and any(e.changes_housing(k) for e in self.effects))
        pairs = [film_dofs(rotor, n) for n in rotor.bearing_nodes]
        for j in self._changed_supports:
            h = rotor.housing("support", j)
            pairs.append((node_dofs(rotor.supports[j][0])[[X, Y]], None if h is None else np.array(h.dofs)))
        for k in self._changed_housings:
            pairs.append((np.array(rotor.housing("bearing", k).dofs), None))
        self._U = np.concatenate([p for p, _ in pairs])
        self._eye_U = np.eye(self._U.size)
        out = np.concatenate([node_dofs(n)[[X, Y]] for n in self.nodes])
        nf = len(shapes)
        nu = self._U.size  # 2 (N + changed supports + changed declared pedestals)
        rhs = np.zeros((rotor.n_dof, nf + nu), dtype=complex)
        rhs[:, :nf] = np.stack(shapes, axis=1)
        rhs[self._U, nf + np.arange(nu)] = 1.0
        # a film (or support) over a declared pedestal acts between journal and housing: its unit loads push both,
        # and the journal's motion that strains it (x_U) is relative to the housing, as are the probes riding on it
        for k, (_, h) in enumerate(pairs):
            if h is not None:
                rhs[h, nf + 2 * k + np.arange(2)] = -1.0
        sol = _reference_solve(rotor, omega, B0, rhs)
        journal, read = sol[self._U], sol[out]
        for k, (_, h) in enumerate(pairs):
            if h is not None:
                journal[2 * k:2 * k + 2] -= sol[h]
        for p, h in enumerate(probe_housings(rotor, self.nodes)):
            if h is not None:
                read[2 * p:2 * p + 2] -= sol[h]
        self._x0_out, self._x0_U = read[:, :nf], journal[:, :nf]  # (2P, nf), (2N + 2S', nf)
        self._Z_out, self._W = read[:, nf:], journal[:, nf:]
        self._n_forcing = nf
        # a plane at a bearing's centre node reads that bearing's static position (SPEC §6)
        self._plane_bearing = tuple(self.plane_bearing(p) for p in range(self.n_planes))
        self._plane_housing = tuple(self.plane_housing(p) for p in range(self.n_planes))
        self.static_planes = tuple(p for p, k in enumerate(self._plane_bearing) if k is not None)

    # --- evaluation -------------------------------------------------------------------------------
    def output(self, theta, dB_extra=None) -> ChainOutput:
        """Probe readings for parameter vectors theta (..., n_params).

        `dB_extra` (..., 2N, 2N), optional: added to the bearings' dynamic stiffness (the model budget
        perturbs the coefficients with it)."""
        theta = np.asarray(theta, dtype=float)
        if theta.shape[-1] != self.n_params:
            raise InputError(f"parameter vector of length {theta.shape[-1]}; expected {self.n_params} {self.names}")
        shape = theta.shape[:-1]
        omega = self.omega
        # forcing weights (main unbalance: 1)
        w = np.zeros(shape + (self._n_forcing,), dtype=complex)
        w[..., 0] = 1.0
        for e, j0, n in self._forcing:
            w[..., j0:j0 + n] = e.forcing_weights(self._values(theta, e), shape)
        x0_out = np.einsum("ij,...j->...i", self._x0_out, w)
        x0_U = np.einsum("ij,...j->...i", self._x0_U, w)
        # bearings stage, then supports
        nb, npl = self.n_flows, self.n_planes
        nu = self._U.size
        dB = np.zeros(shape + (nu, nu), dtype=complex)
        housing = [None] * nb
        journal = np.zeros(shape + (nb, 2))
        for k, (change, (K, C, pos)) in enumerate(self.bearing_states(theta, shape)):
            clearance = change.clearance
            B = K + 1j * omega * C
            for e in self.effects:
                if e.applies(k):
                    r = e.support(k, B, omega, self._values(theta, e), shape)
                    if r is not None:
                        B, T = r
                        housing[k] = T if housing[k] is None else housing[k]
            dB[..., 2 * k:2 * k + 2, 2 * k:2 * k + 2] = B - self._B0[k]
            journal[..., k, 0] = pos[..., 0]
            journal[..., k, 1] = pos[..., 1] + clearance
        for i, j in enumerate(self._changed_supports):  # constant supports changed by an effect
            a = 2 * (nb + i)
            for e in self.effects:
                d = e.support_change(j, omega, self._values(theta, e), shape)
                if d is not None:
                    dB[..., a:a + 2, a:a + 2] += d
        for i, k in enumerate(self._changed_housings):  # declared pedestals changed by an effect
            a = 2 * (nb + len(self._changed_supports) + i)
            for e in self.effects:
                d = e.housing_change(k, omega, self._values(theta, e), shape)
                if d is not None:
                    dB[..., a:a + 2, a:a + 2] += d
        if dB_extra is not None:  # on the films' blocks
            extra = np.zeros(np.broadcast_shapes(dB.shape[:-2], np.shape(dB_extra)[:-2]) + (nu, nu), dtype=complex)
            extra[..., :2 * nb, :2 * nb] = dB_extra
            dB = dB + extra
        A = self._eye_U + dB @ self._W
        c = np.linalg.solve(A, (dB @ x0_U[..., None]))[..., 0]
        x_out = x0_out - np.einsum("ij,...j->...i", self._Z_out, c)
        x_U = x0_U - np.einsum("ij,...j->...i", self._W, c)
        d = x_out.reshape(shape + (npl, 2))  # (plane, [x, y])
        static = np.zeros(shape + (npl, 2))
        for p, k in enumerate(self._plane_bearing):
            if k is not None:
                static[..., p, :] = journal[..., k, :]
        for p, k in enumerate(self._plane_housing):
            if housing[k] is not None:  # probes on housing k read the shaft relative to it
                xh = np.einsum("...ij,...j->...i", housing[k], x_U[..., 2 * k:2 * k + 2])
                d = d.copy()
                d[..., p, :] = d[..., p, :] - xh
        if self.defect is not None:
            dd, ds = self.defect.at(theta[..., :nb])
            d, static = d + dd, static + ds
        # probes stage
        for k in range(npl):
            for e in self.effects:
                if e.stage == "probes":
                    M = e.probe_matrix(k, self.probe_angles_deg[k], self._values(theta, e), shape)
                    if M is not None:
                        d = d.copy()
                        static = static.copy()
                        d[..., k, :] = np.einsum("...ij,...j->...i", M, d[..., k, :])
                        static[..., k, :] = np.einsum("...ij,...j->...i", M, static[..., k, :])
        for e in self.effects:  # then the columns as the record holds them (a mixed-up measurement)
            if e.stage == "probes":
                d, static = e.rewire(d, static, self.probe_angles_deg)
        self.evaluations += math.prod(shape)
        return ChainOutput(x=d[..., 0], y=d[..., 1], static=static if self.static_planes else None)

    def features(self, theta, names: Sequence[str], dB_extra=None) -> np.ndarray:
        """Features (last axis, `names` order): the 1X invariants and the static offsets (m)."""
        out = self.output(theta, dB_extra)
        names = tuple(names)
        dyn, at, where = _feature_split(names)
        if not where:  # 1X invariants only
            return feature_vector(out.x, out.y, names)
        for n, _, k, _ in where:
            if k >= self.n_planes:
                raise InputError(f"feature {n}: the chain has {self.n_planes} planes")
            if out.static is None or k not in self.static_planes:
                raise InputError(f"feature {n}: plane {k + 1} (node {self.nodes[k]}) is not at a bearing "
                                 "centre, where the static position is measured")
        g = np.empty(out.x.shape[:-1] + (len(names),))
        if dyn:
            g[..., at] = feature_vector(out.x, out.y, dyn)
        for _, i, k, j in where:
            g[..., i] = out.static[..., k, j]
        return g

    def direct_output(self, theta) -> ChainOutput:
        """The same readings from a direct solve of the assembled system (no Woodbury): the check."""
        theta = np.asarray(theta, dtype=float)
        omega, rotor = self.omega, self.rotor
        F = unbalance_force(rotor, omega, machine_unbalance(self.machine))
        for e, j0, n in self._forcing:
            wts = e.forcing_weights(self._values(theta, e), ())
            for j, col in enumerate(e.forcing_shapes(rotor, omega, self.machine)):
                F = F + wts[..., j] * col
        n0, nb = rotor.n_dof, self.n_flows
        extra = [k for k in range(nb) if any(e.applies(k) for e in self.effects)]
        n = n0 + 2 * len(extra)
        D = np.zeros((n, n), dtype=complex)
        D[:n0, :n0] = dynamic_stiffness(rotor, omega, rotor.K, rotor.C)
        hdofs = {}
        journal = np.zeros((nb, 2))
        for j, k in enumerate(extra):
            hdofs[k] = n0 + 2 * j + np.arange(2)
        for k, (change, (K, C, pos)) in enumerate(self.bearing_states(theta, ())):
            clearance = float(change.clearance)
            B = K + 1j * omega * C
            jd, declared = film_dofs(rotor, rotor.bearing_nodes[k])
            other = hdofs.get(k)
            D[np.ix_(jd, jd)] += B
            if declared is not None:  # the model file's pedestal: in the rotor, the film acts against it
                D[np.ix_(declared, declared)] += B
                D[np.ix_(jd, declared)] -= B
                D[np.ix_(declared, jd)] -= B
            if other is not None:
                e = next(e for e in self.effects if e.applies(k))
                m, s, c = e.housing(self._values(theta, e))
                D[np.ix_(other, other)] += B + (s - omega**2 * m + 1j * omega * c) * np.eye(2)
                D[np.ix_(jd, other)] -= B
                D[np.ix_(other, jd)] -= B
            journal[k] = pos + np.array([0.0, clearance])
        for j in self._changed_supports:  # a constant support an effect changes, between its node and its pedestal
            d = sum(e.support_change(j, omega, self._values(theta, e), ()) for e in self.effects
                    if e.changes_support(j))
            sd = node_dofs(rotor.supports[j][0])[[X, Y]]
            D[np.ix_(sd, sd)] += d
            h = rotor.housing("support", j)
            if h is not None:
                hd = list(h.dofs)
                D[np.ix_(hd, hd)] += d
                D[np.ix_(sd, hd)] -= d
                D[np.ix_(hd, sd)] -= d
        for k in self._changed_housings:  # a declared pedestal an effect changes: its spring to ground
            hd = list(rotor.housing("bearing", k).dofs)
            D[np.ix_(hd, hd)] += sum(e.housing_change(k, omega, self._values(theta, e), ()) for e in self.effects
                                     if e.changes_housing(k))
        rhs = np.zeros(n, dtype=complex)
        rhs[:n0] = F
        q = np.linalg.solve(D, rhs)
        d = np.array([q[node_dofs(nd)[[X, Y]]] for nd in self.nodes])
        static = np.zeros((self.n_planes, 2))
        for p, k in enumerate(self._plane_bearing):
            if k is not None:
                static[p] = journal[k]
        for p, k in enumerate(self._plane_housing):
            if k in hdofs:
                d[p] = d[p] - q[hdofs[k]]
        for p, h in enumerate(probe_housings(rotor, self.nodes)):
            if h is not None:
                d[p] = d[p] - q[h]
        if self.defect is not None:
            dd, ds = self.defect.at(theta[:nb])
            d, static = d + dd, static + ds
        for k in range(self.n_planes):
            for e in self.effects:
                if e.stage == "probes":
                    M = e.probe_matrix(k, self.probe_angles_deg[k], self._values(theta, e), ())
                    if M is not None:
                        d[k] = M @ d[k]
                        static[k] = M @ static[k]
        for e in self.effects:
            if e.stage == "probes":
                d, static = e.rewire(d, static, self.probe_angles_deg)
        return ChainOutput(x=d[:, 0], y=d[:, 1], static=static)

    def jacobian(self, theta: np.ndarray, names: Sequence[str], *, free=None):
        """Features at theta and their Jacobian (n_features, n_free) by central differences (one batch)."""
        theta = np.asarray(theta, dtype=float)
        free = np.arange(self.n_params) if free is None else np.asarray(free)
        h = self.steps()[free]
        pts = np.repeat(theta[None, :], 2 * free.size + 1, axis=0)
        for j, (i, hj) in enumerate(zip(free, h)):
            pts[1 + 2 * j, i] += hj
            pts[2 + 2 * j, i] -= hj
        g = self.features(pts, names)
        from .model import wrap_difference

        J = wrap_difference(g[1::2] - g[2::2], names).T / (2 * h)
        return g[0], J


def simulate(chain: ForwardChain, theta, *, snr_db: float | None = 12.0, rng: np.random.Generator | None = None,
             duration_s: float = 5.0, sample_rate_hz: float = 1.0e4, metadata: dict | None = None):
    """A measured record (SPEC §6) of the chain at parameters `theta`: the steady 1X orbit sampled as the
    probes read it (declared probe angles), white noise at `snr_db` per channel (seeded `rng`).

    The CLI's `simulate --effect`, the app and the tests call this, so an effect shows up everywhere.
    """
    from ...signals.noise import add_noise
    from ...signals.records import Record
    from ...signals.synthesize import steady_signals

    if snr_db is not None and rng is None:
        raise InputError("a noisy record needs an explicit rng (numpy.random.Generator); pass snr_db=None "
                         "for a clean one")
    if not (duration_s > 0 and sample_rate_hz > 0):
        raise InputError(f"duration {duration_s!r} s and sample rate {sample_rate_hz!r} Hz; expected positive")
    out = chain.output(np.asarray(theta, dtype=float))
    n = int(round(duration_s * sample_rate_hz))
    t = np.arange(n) / sample_rate_hz
    xy = steady_signals(out.x, out.y, chain.omega, t)  # resolved X/Y displacement per plane
    probes = np.empty_like(xy)
    for k, (a, b) in enumerate(chain.probe_angles_deg):  # what each probe reads along its declared direction
        ua, ub = (np.array([math.cos(math.radians(v)), math.sin(math.radians(v))]) for v in (a, b))
        probes[k, 0] = ua[0] * xy[k, 0] + ua[1] * xy[k, 1]
        probes[k, 1] = ub[0] * xy[k, 0] + ub[1] * xy[k, 1]
    if snr_db is not None:
        probes = add_noise(probes, snr_db, rng)
    meta = {**{f"q{k + 1}_mlmin": f"{theta[k] * MLMIN_PER_M3S:.6g}" for k in range(chain.n_flows)},
            "snr_db": "none" if snr_db is None else f"{snr_db:g}", "synthetic": "lubeviz simulate"}
    meta.update(metadata or {})
    return Record(speed_hz=chain.speed_hz, sample_rate_hz=sample_rate_hz, displacement=probes, nodes=chain.nodes,
                  probe_angles_deg=chain.probe_angles_deg, t0=0.0,
                  machine=Path(chain.machine.source).name if chain.machine.source else None, metadata=meta)
