"""Film equilibria of the independent source, solved directly on a fine mesh and cached on disk.

The identification reads K, C from tables of the 100 x 100 mesh (groove refinement 4, sub-cell
tangent), interpolated in the supply. Here each bearing is solved at its exact supply, speed, load,
viscosity and clearance on `FINE_MESH` = 200 x 200 with groove refinement 1 (the paper's uniform
mesh, at twice its resolution), and K, C are the fixed-pattern tangent (the exact small-amplitude
derivative of that discrete film): a different mesh, a different groove discretization and a
different linearization. Measured (2 cores, 75 Hz, 545 ml/min): 1.8 s per bearing at 200 x 200
against 0.45 s at 100 x 100 refinement 4 and 2.3 s at 200 x 200 refinement 4.

Cache: `<lubeviz cache_dir()>/independent/<sha256>.npz`, the key a sha256 of every input (the
bearing's parameters including mesh, load, speed, supply, coefficient method, format version and a
hash of the film package's code, `film_code_version()`: its statements, not its docstrings). A file
is used only if its stored key equals the key asked for, and its arrays have the right shapes and are
finite; anything else is deleted with a warning and solved again. Files are written atomically
(temporary file + os.replace).
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import json
import math
import os
import tempfile
import warnings
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..code_key import feed_code
from ..errors import ConvergenceError
from ..film.equilibrium import find_equilibrium, flooded_threshold
from ..film.feed import Feed
from ..identify.tables.cache import cache_dir
from ..model.bearing import Bearing
from ..units import MLMIN_PER_M3S

FORMAT_VERSION = 1
FINE_MESH = (200, 200)
GROOVE_REFINEMENT = 1
COEFFICIENTS = "fixed-pattern"


class StaleIndependentCacheWarning(UserWarning):
    """A cached independent equilibrium could not be trusted and was solved again."""


@dataclass(frozen=True)
class FilmPoint:
    """One bearing's equilibrium: position [eX, eY] (m), K (N/m), C (N s/m), side leakage (m^3/s)."""

    position: np.ndarray
    K: np.ndarray
    C: np.ndarray
    side_leakage: float
    cached: bool


def fine_bearing(bearing: Bearing, **changes) -> Bearing:
    """The bearing on the independent source's mesh, with physical `changes` (viscosity, clearance)."""
    return bearing.copy(n_circumferential=FINE_MESH[0], n_axial=FINE_MESH[1],
                        groove_refinement=GROOVE_REFINEMENT, **changes)


@functools.lru_cache(maxsize=1)
def film_code_version() -> str:
    """sha256 of the film package's source (`lubeviz/film/*.py`): an edit there invalidates the cache.

    Only the film code: the load enters the key as numbers, so the rotor and identification modules
    (which `lubeviz.identify.tables.cache.solver_version` also hashes, and which change often) do not."""
    return code_version("film")


@functools.lru_cache(maxsize=8)
def code_version(*packages: str) -> str:
    """sha256 of the code of these sub-packages of lubeviz (e.g. "film", "rotor"), in the order given: their
    statements, not their docstrings or comments (`code_key`)."""
    root = Path(__file__).resolve().parents[1]
    h = hashlib.sha256()
    for name in packages:
        package = root / name
        feed_code(h, package, sorted(package.rglob("*.py")))
    return h.hexdigest()


def _key(kind: str, bearing: Bearing, omega: float, load, q_supply: float | None) -> str:
    inputs = {"format": FORMAT_VERSION, "kind": kind, "film_code": film_code_version(),
              "bearing": {k: getattr(bearing, k) for k in sorted(bearing.param) if k not in ("name", "node")},
              "omega": float(omega), "load": [float(f"{float(w):.12g}") for w in load],
              "q_supply": None if q_supply is None else float(q_supply), "coefficients": COEFFICIENTS}
    text = json.dumps(inputs, sort_keys=True, separators=(",", ":"), allow_nan=False, default=_plain)
    return hashlib.sha256(text.encode()).hexdigest()


def _plain(value):
    """A bearing's further groove or its pedestal in a key: its fields (a one-groove bearing's key is unchanged)."""
    if dataclasses.is_dataclass(value):
        return dataclasses.asdict(value)
    raise TypeError(f"{type(value).__name__} in a cache key")


def _directory() -> Path:
    return cache_dir() / "independent"


_SHAPES = {"position": (2,), "K": (2, 2), "C": (2, 2), "side_leakage": ()}


def _load(path: Path, key: str, shapes: dict | None = None) -> dict | None:
    """The arrays of a cache file if its stored key is `key` and each array has its shape in `shapes` and is
    finite; else None (the file deleted, with a warning)."""
    shapes = _SHAPES if shapes is None else shapes
    if not path.exists():
        return None
    try:
        with np.load(path, allow_pickle=False) as f:
            data = {k: np.array(f[k]) for k in ("key", *shapes)}
        ok = str(data["key"]) == key and all(data[k].shape == s and np.all(np.isfinite(data[k]))
                                             for k, s in shapes.items())
    except (OSError, ValueError, KeyError, zipfile.BadZipFile, EOFError) as exc:
        ok, data = False, None
        reason = f"unreadable ({exc})"
    else:
        reason = "another key, a wrong shape or a non-finite value"
    if ok:
        return data
    warnings.warn(f"independent film cache {path}: {reason}; solving again", StaleIndependentCacheWarning,
                  stacklevel=3)
    path.unlink(missing_ok=True)
    return None


def _store(path: Path, key: str, arrays: dict) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-", suffix=".npz")
    try:
        with os.fdopen(fd, "wb") as f:
            np.savez(f, key=np.array(key), **arrays)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def film_point(bearing: Bearing, omega: float, load, q_supply: float, *, use_cache: bool = True) -> FilmPoint:
    """Equilibrium and fixed-pattern K, C of `bearing` (already on the fine mesh) at supply `q_supply`."""
    key = _key("equilibrium", bearing, omega, load, q_supply)
    path = _directory() / f"{key}.npz"
    data = _load(path, key) if use_cache else None
    if data is not None:
        return FilmPoint(position=data["position"], K=data["K"], C=data["C"],
                         side_leakage=float(data["side_leakage"]), cached=True)
    eq = find_equilibrium(bearing, omega, np.asarray(load, dtype=float), Feed.flow(q_supply),
                          coefficients=COEFFICIENTS)
    if not eq.converged:
        raise ConvergenceError(f"independent film: no equilibrium at {q_supply * MLMIN_PER_M3S:.1f} ml/min, "
                               f"{omega / 2 / math.pi:g} Hz: {eq.message}")
    arrays = {"position": np.asarray(eq.position, float), "K": np.asarray(eq.coefficients.K, float),
              "C": np.asarray(eq.coefficients.C, float), "side_leakage": np.float64(eq.film.side_leakage)}
    if not all(np.all(np.isfinite(a)) for a in arrays.values()):
        raise ConvergenceError(f"independent film: non-finite coefficients at {q_supply * MLMIN_PER_M3S:.1f} ml/min")
    if use_cache:
        _store(path, key, arrays)
    return FilmPoint(position=arrays["position"], K=arrays["K"], C=arrays["C"],
                     side_leakage=float(arrays["side_leakage"]), cached=False)


def threshold(bearing: Bearing, omega: float, load, *, use_cache: bool = True) -> float:
    """Q_T (m^3/s) of `bearing` as given (no mesh change): the flooded side leakage, cached likewise."""
    key = _key("threshold", bearing, omega, load, None)
    path = _directory() / f"{key}.npz"
    data = _load(path, key) if use_cache else None
    if data is not None:
        return float(data["side_leakage"])
    q, eq = flooded_threshold(bearing, omega, np.asarray(load, dtype=float))
    if not (eq.converged and math.isfinite(q) and q > 0):
        raise ConvergenceError(f"flooded threshold at {omega / 2 / math.pi:g} Hz: {eq.message}")
    if use_cache:
        _store(path, key, {"position": np.asarray(eq.position, float), "K": np.zeros((2, 2)),
                           "C": np.zeros((2, 2)), "side_leakage": np.float64(q)})
    return float(q)
