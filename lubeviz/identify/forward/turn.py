"""What a rigid turn of a film leaves out, measured on each bearing's own film, and the correction it gives.

A film whose static load leans off its table's line is the table's film turned with the load (`chain._turned`):
the grooves stay where the table has them. On a rigidly coupled train a starved bearing sinks a few micrometres and
turns its neighbours' loads by 10-15 deg; beside a supply groove the film is not round, so the turned film is not the
film at the turned load. Measured on the model's own mesh (session 68, docs/notes/any-machine.md "The rigid turn of
a film"), per radian of lean: the journal's position moves up to 0.29 c (two axial grooves at L/D 0.5, flooded),
0.12 c (one top groove) and 0.07 c (the paper's bearing); K and C up to 2 x their largest entry (two grooves) and
0.5-0.9 x (one groove). On the rehearsal train the position's error alone moved the loads beside its rigid coupling
by 2-4 %, and four of its first twelve clean records were flagged. Sizes that differ four-fold between groove
layouts are no constant: each bearing's are measured here, on its own film.

`turn_error` solves the film in its load's frame (`tables.cache.film_frame`) at the declared load and at that load
turned by each of TURN_LEANS_DEG, at TURN_RATIOS x the bearing's Q_T, on a mesh MESH_SHARE as fine each way: the
change of each of the table's ten values (the chain's correction, `forward.shifted.lean_corrected`, on 3+ supports)
and the largest change per radian (the model budget's sizes). ~55 film solves, the flows side by side on THREADS
threads, kept in memory and on disk (the user cache, keyed by the bearing, its load, the speed, the mesh share and
the film solver's code; a file that is not exactly that is measured again, never trusted).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import tempfile
import threading
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...progress import ProgressFn, silent

# The flows the turn is measured at, relative to the bearing's Q_T: the error changes fastest about Q_T, where the
# groove's pressure comes and goes, and levels off past 2 Q_T (session 68's study)
TURN_RATIOS = (0.5, 0.7, 0.85, 0.95, 1.0, 1.05, 1.15, 1.3, 1.6, 2.0, 3.0)
# The leans it is measured at (deg): the correction is linear between them and zero at none, and goes on past the
# outer ones with the slope between the last two. At the threshold the error is no smooth function of the lean: on
# the fan's bearing A at Q_T a turn of 1.6 deg leaves K 0.09 % off, while a parabola through +-8 deg put 0.53 %
# (session 68); the inner points hold a small lean's correction to its own size
TURN_LEANS_DEG = (-8.0, -3.0, 3.0, 8.0)
# What a point whose film does not converge is given (no correction there, and the budget's largest sizes measured
# on any bearing, session 68: two axial grooves at L/D 0.5): position 0.3 c, K 2.1, C 1.9 per radian
FALLBACK = (0.3, 2.1, 1.9)
FORMAT = 2
# The film mesh the turn is measured on, against the bearing's own: the change a turn makes is a property of the
# groove's place, which a coarser mesh resolves as well (0.144 / 0.260 c per radian on the rehearsal's motor bearing at
# 0.7 / 1.3 Q_T on 60 x 30 against 0.145 / 0.261 on its 100 x 50, at half the cost); never coarser than a groove needs
MESH_SHARE = 0.6
# The flows are measured side by side on this many threads (the film's LU and kernels release the GIL): on the fan's
# bearing A, 2 threads ran 1.4 x as fast as 1 on a loaded 2-core host (session 69)
THREADS = min(2, os.cpu_count() or 1)

_memo: dict = {}
_lock = threading.Lock()
_FIELDS = ("errors", "position", "stiffness", "damping")


@dataclass(frozen=True)
class TurnError:
    """A bearing's film turned with its load against the film solved at the turned load, in the frame where the
    declared load is vertical (`tables.cache.film_frame`), at flows `ratio` (x Q_T): at each of TURN_LEANS_DEG, the
    change of each of the table's ten values (K row-major, C, position) over its scale (K's, C's Frobenius norm, the
    clearance), `errors` (n, 4, 10); and the sizes the budget carries (`position` over the clearance, `stiffness` and
    `damping` over their largest entry, per radian: the largest of the leans'). Flows whose film did not converge have
    no correction (zeros) and the FALLBACK sizes."""

    ratio: np.ndarray
    errors: np.ndarray
    position: np.ndarray
    stiffness: np.ndarray
    damping: np.ndarray

    def at(self, q_over_qt: float) -> tuple[float, float, float]:
        """(position / c, K, C) per radian at a flow `q_over_qt` x Q_T, between the measured flows, held at
        the ends (below the lowest the film is shorter still, and further from the grooves)."""
        r = float(q_over_qt)
        return tuple(float(np.interp(r, self.ratio, v)) for v in (self.position, self.stiffness, self.damping))


def _rotation(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s], [s, c]])


def _values(eq, back: float) -> np.ndarray:
    """The ten table values of an equilibrium turned back by `back` (rad): R K R^T, R C R^T, R p with R = R(back)."""
    R = _rotation(back)
    K = R @ eq.coefficients.K @ R.T
    C = R @ eq.coefficients.C @ R.T
    return np.concatenate([K.ravel(), C.ravel(), R @ np.asarray(eq.position)])


def measuring_bearing(bearing):
    """`bearing` on the mesh the turn is measured on: MESH_SHARE of its own each way (`_measure` falls back to its own
    where a groove would span fewer than two cells)."""
    return bearing.copy(n_circumferential=max(8, int(round(MESH_SHARE * bearing.n_circumferential))),
                        n_axial=max(2, int(round(MESH_SHARE * bearing.n_axial))))


def _measure(bearing, omega: float, load, q_threshold: float, progress: ProgressFn = silent) -> TurnError:
    """The turn's error at TURN_RATIOS x `q_threshold`, `bearing` under the vertical `load` (its film frame), on the
    coarser mesh where its grooves allow it; `progress` after each flow."""
    from ...errors import InputError

    try:
        return _measure_on(measuring_bearing(bearing), omega, load, q_threshold, progress)
    except InputError:  # a groove too narrow for the coarser mesh
        return _measure_on(bearing, omega, load, q_threshold, progress)


def _measure_on(bearing, omega: float, load, q_threshold: float, progress: ProgressFn = silent) -> TurnError:
    """The flows' measurements side by side on THREADS threads (the film's LU and kernels release the GIL), the
    slowest (the highest flows) first; `progress` in the calling thread as each flow finishes. Each flow is measured
    alone, so the result is the same on any number of threads."""
    from concurrent.futures import FIRST_COMPLETED, ThreadPoolExecutor, wait

    load = np.asarray(load, dtype=float)
    n = len(TURN_RATIOS)
    errors = np.zeros((n, len(TURN_LEANS_DEG), 10))
    sizes = np.empty((3, n))
    order = sorted(range(n), key=lambda j: -TURN_RATIOS[j])
    progress(0, n, f"the film turned with its load, {n} flows")
    if THREADS <= 1:
        for done, j in enumerate(order, start=1):
            errors[j], sizes[:, j] = _one_flow(bearing, omega, load, TURN_RATIOS[j] * q_threshold)
            progress(done, n, f"the film turned with its load, {TURN_RATIOS[j]:g} Q_T")
        return TurnError(np.asarray(TURN_RATIOS, dtype=float), errors, *sizes)
    with ThreadPoolExecutor(THREADS, thread_name_prefix="lubeviz-turn") as pool:
        futures = {pool.submit(_one_flow, bearing, omega, load, TURN_RATIOS[j] * q_threshold): j for j in order}
        pending, done = set(futures), 0
        try:
            while pending:
                finished, pending = wait(pending, return_when=FIRST_COMPLETED)
                for f in finished:
                    j = futures[f]
                    errors[j], sizes[:, j] = f.result()
                    done += 1
                    progress(done, n, f"the film turned with its load, {TURN_RATIOS[j]:g} Q_T")
        except BaseException:  # a cancel (raised by progress) or a failure: the flows not started are dropped
            for f in pending:
                f.cancel()
            raise
    return TurnError(np.asarray(TURN_RATIOS, dtype=float), errors, *sizes)


def _one_flow(bearing, omega: float, load: np.ndarray, q: float) -> tuple[np.ndarray, np.ndarray]:
    """At supply flow q: each lean's change of the ten values over their scales (4, 10), and the three sizes per
    radian (position / c, K, C); zeros and FALLBACK where a film does not converge."""
    from ...film.equilibrium import find_equilibrium
    from ...film.feed import Feed

    leans = np.radians(TURN_LEANS_DEG)
    feed = Feed.flow(q)
    base = find_equilibrium(bearing, omega, load, feed)
    found = []
    for a in leans if base.converged else ():
        R = _rotation(a)
        eq = find_equilibrium(bearing, omega, R @ load, feed, start=R @ np.asarray(base.position))
        if not eq.converged:
            break
        found.append(_values(eq, -a) - _values(base, 0.0))
    if len(found) < leans.size:
        return np.zeros((leans.size, 10)), np.asarray(FALLBACK, dtype=float)
    K0, C0 = base.coefficients.K, base.coefficients.C
    scale = np.concatenate([np.full(4, np.linalg.norm(K0)), np.full(4, np.linalg.norm(C0)),
                            np.full(2, bearing.clearance)])
    e = np.array(found)
    per_rad = np.abs(e) / np.abs(leans)[:, None]
    return e / scale, np.array([np.max(np.hypot(per_rad[:, 8], per_rad[:, 9])) / bearing.clearance,
                                per_rad[:, 0:4].max() / np.abs(K0).max(), per_rad[:, 4:8].max() / np.abs(C0).max()])


def _key(bearing, omega: float, load, q_threshold: float | None) -> str:
    from ..tables.cache import _bearing_values, solver_version

    inputs = {"format": FORMAT, "bearing": _bearing_values(bearing), "omega": round(float(omega), 12),
              "load": [float(f"{v:.12g}") for v in np.asarray(load, dtype=float)],
              "q_threshold": None if q_threshold is None else float(f"{q_threshold:.12g}"),
              "ratios": list(TURN_RATIOS), "leans": list(TURN_LEANS_DEG), "mesh_share": MESH_SHARE,
              "solver": solver_version()}
    return hashlib.sha256(json.dumps(inputs, sort_keys=True).encode()).hexdigest()


def _path(key: str):
    from ..tables.cache import cache_dir

    return cache_dir() / "turns" / f"{key[:40]}.npz"


def _read(key: str) -> TurnError | None:
    """The stored measurement of `key`, or None when there is none or it is not exactly that (then it is measured
    again, with a warning: not a regular file, a file for other inputs, a truncated or edited one, values that are not
    finite or sizes below zero). Read as the slices are (`tables.cache._file_bytes`: no symlink, FIFO or oversized
    file is opened)."""
    import io
    import zipfile

    from ..tables.cache import _file_bytes, _Untrusted

    path = _path(key)
    try:
        content = _file_bytes(path)
        if content is None:
            return None
        with np.load(io.BytesIO(content), allow_pickle=False) as data:
            if str(data["key"]) != key:
                raise _Untrusted("for other inputs")
            arrays = [np.asarray(data[name], dtype=float) for name in _FIELDS]
    except (_Untrusted, OSError, EOFError, KeyError, ValueError, zipfile.BadZipFile) as exc:
        warnings.warn(f"turn error cache {path}: not used ({type(exc).__name__}: {exc}); measured again",
                      stacklevel=3)
        return None
    n = len(TURN_RATIOS)
    shapes = [(n, len(TURN_LEANS_DEG), 10), (n,), (n,), (n,)]
    if any(a.shape != shape or not np.all(np.isfinite(a)) for a, shape in zip(arrays, shapes)) or any(
            np.any(a < 0) for a in arrays[1:]):
        warnings.warn(f"turn error cache {path}: values out of shape or range; measured again", stacklevel=3)
        return None
    return TurnError(np.asarray(TURN_RATIOS, dtype=float), *arrays)


def _write(key: str, t: TurnError) -> None:
    """Atomically, as the slices are written: a temporary file in the same directory, fsync, then os.replace."""
    path = _path(key)
    tmp = None
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=".turn-", suffix=".npz.tmp", dir=path.parent)
        with os.fdopen(fd, "wb") as fh:
            np.savez(fh, key=np.array(key), **{name: getattr(t, name) for name in _FIELDS})
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except OSError as exc:  # kept in memory; measured again next time
        if tmp is not None:
            Path(tmp).unlink(missing_ok=True)
        warnings.warn(f"turn error cache {path.parent}: not written ({exc})", stacklevel=3)


def turn_error(bearing, omega: float, load, q_threshold: float | None, progress: ProgressFn = silent) -> TurnError:
    """The rigid-turn error of `bearing` (its own mesh and grooves) at rotational speed `omega` (rad/s) under its
    static `load` [Wx, Wy] (N) with flooded threshold `q_threshold` (m^3/s; None: the film's own there, solved only
    when the measurement is not kept): measured once (`progress` after each flow: 3-8 s a bearing), then kept."""
    key = _key(bearing, omega, load, q_threshold)
    with _lock:
        hit = _memo.get(key)
    if hit is not None:
        return hit
    t = _read(key)
    if t is None:
        if q_threshold is None:
            from ...film.equilibrium import flooded_threshold

            q_threshold, _ = flooded_threshold(bearing, omega, np.asarray(load, dtype=float))
        t = _measure(bearing, omega, load, q_threshold, progress)
        _write(key, t)
    with _lock:
        _memo[key] = t
    return t
