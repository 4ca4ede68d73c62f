"""On-disk cache of dimensionless coefficient tables (SPEC §5): film solves once per geometry, then loaded.

The numbers behind every `CoefficientTable` are slices of a dimensionless table (`dimensionless.py`):
one geometry, one Sommerfeld number, the ten dimensionless values over the supply ratio r. A slice
costs ~10 s at the paper's 100 x 100 mesh and is deterministic, so each is stored in the user's
cache directory (never inside the repository) as `<cache_dir>/slices/<key>.npz`, the key a sha256 of
every input that affects its numbers (`slice_inputs`). A file is trusted only if it proves it is
what the key says: its stored key and a sha256 of its arrays match, its shapes agree, every value is
finite, its ratios are the grid the key asks for and its S the key's node. Anything else (truncated
file, a bad zip, another key, NaN, tampered values) is reported with a `StaleCacheWarning`, deleted
and rebuilt. Only a regular file is opened: `os.lstat` refuses a FIFO (opening one would block for
ever), a socket, a device, a directory or a symlink under a slice's name before any open, and the
same warning says so (the name is removed, a directory left in place). Files are read with `allow_pickle=False` and written atomically (temporary file in the
same directory, then `os.replace`), so a crash or a concurrent writer never leaves a half-written
slice under a valid name.

The cache only saves time, so no cache failure loses an answer: a directory that cannot be written (read-only,
a path that is a file, a directory where a slice should be, a full disk) gives a `CacheStoreWarning` ("could
not store ... in <dir>: <reason>; rebuilt next time") and the slices just built are used from memory (and kept
there for this process, `_UNSTORED`); a build lock that cannot be taken is skipped with a `CacheWarning`.

A bearing's dimensional table (`bearing_view`, `cached_table`, `machine_tables`) is a view: its
Sommerfeld number picks the 4 slices around it (one on a node), those missing are built (in
parallel: a whole slice per worker process when there are at least as many slices as processes, else two
per slice, one per part r <= 1 and r > 1; forked from a single-threaded caller, spawned from a threaded one
such as the app, `_process_context`), and the view is scaled to the bearing's viscosity, clearance, load and
speed. So a change of viscosity, clearance, speed or load costs no film solve once its slices exist,
and bearings of one geometry (the paper's two) share them. Workers get plain values (the geometry
and S) and run `dimensionless.build_slice` or `build_slice_part`, the same code the serial path runs (a
part solves the slice's flooded equilibrium itself, deterministically), so parallel and serial slices are
identical. Progress: every worker reports each solved ratio through a
`multiprocessing.Manager` queue; the parent drains it while it waits and calls
`progress(done, total, label)` with the sum over the slices being built. If that callback raises
`Cancelled`, the workers are told to stop at their next ratio, pending work is cancelled, the pool is
shut down and `Cancelled` is re-raised; slices finished before that are kept (a build is resumable).

Builders of one geometry take turns (`_build_lock`: an exclusive `flock` on `<slices>/.build-<digest>.lock`,
POSIX only): a second process (another app session, a parallel test worker, a second `lubeviz` command)
that misses the same slices waits, reporting "waiting for another build", then loads what the first one
stored and builds only what is still missing, instead of solving the same films twice on the same cores.
A crashed builder's lock goes with its process.
"""

from __future__ import annotations

import dataclasses

import contextlib
import functools
import hashlib
import io
import json
import math
import multiprocessing
import os
import queue as queue_module
import stat
import tempfile
import threading
import time
import warnings
import zipfile
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from pathlib import Path

import numpy as np
import platformdirs

import lubeviz

from ...code_key import feed_code
from ...errors import ConvergenceError, InputError
from ...model.bearing import Bearing
from ...progress import Cancelled, ProgressFn, silent
from ...rotor.statics import bearing_static_loads
from . import dimensionless as _dimensionless
from .dimensionless import DimensionlessTable, Slice, geometry_values, sommerfeld_nodes, sommerfeld_number
from .supply import DEFAULT_POINTS, DEFAULT_SPAN, CoefficientTable

# Bump when the stored layout or the meaning of a stored array changes.
TABLE_FORMAT_VERSION = 2

# Modules whose source decides the numbers in a slice: the film model and its solvers, the
# equilibrium and coefficient method, the ratio grid and the reference point of a slice, and the
# rotor statics that give a view's load. Their code (without docstrings and comments, `code_key`) is
# hashed into the key (`solver_version`), so any edit to a statement invalidates every cached slice: a
# version constant that someone must remember to bump would be trusted after a change nobody bumped it for.
_SOLVER_MODULES = ("film", "identify/tables/supply.py", "identify/tables/dimensionless.py", "rotor/statics.py",
                   "rotor/assembly.py", "rotor/elements.py")

_LOAD_DIGITS = 12  # significant digits of the static load kept in a view's key (see `table_key`)

_ARRAYS = ("ratio", "values", "q_threshold", "sommerfeld", "seconds")


class CacheWarning(UserWarning):
    """The disk cache could not be used as intended; the answer is computed all the same."""


class StaleCacheWarning(CacheWarning):
    """A cached slice could not be trusted (corrupt, tampered, for other inputs, not a regular file) and is rebuilt."""


class CacheStoreWarning(CacheWarning):
    """Slices could not be written to the cache directory: they are used from memory and rebuilt next time."""


# --- where ---------------------------------------------------------------------------------------

def _forbidden_roots() -> list[Path]:
    """The installed package, and the repository around it when lubeviz runs from a checkout."""
    package = Path(lubeviz.__file__).resolve().parent
    roots = [package]
    if (package.parent / "pyproject.toml").exists() or (package.parent / ".git").exists():
        roots.append(package.parent)
    return roots


def _check_directory(path: Path, origin: str) -> Path:
    path = Path(path).expanduser().resolve()
    for root in _forbidden_roots():
        if path == root or root in path.parents:
            raise InputError(f"cache directory {path} ({origin}) is inside the lubeviz source tree {root}; "
                             "expected a user cache directory outside the repository")
    return path


def cache_dir() -> Path:
    """Root of lubeviz's cache: $LUBEVIZ_CACHE_DIR, else the platform's user cache dir + /lubeviz.

    On Linux the latter is $XDG_CACHE_HOME/lubeviz, else ~/.cache/lubeviz (via platformdirs). A
    directory inside the lubeviz source tree or its repository is refused with an InputError.
    """
    env = os.environ.get("LUBEVIZ_CACHE_DIR", "")
    if env:
        return _check_directory(Path(env), "$LUBEVIZ_CACHE_DIR")
    return _check_directory(platformdirs.user_cache_path("lubeviz", appauthor=False), "user cache directory")


def _slices_dir(directory) -> Path:
    root = cache_dir() if directory is None else _check_directory(Path(directory), "directory argument")
    return root / "slices"


# --- keys ----------------------------------------------------------------------------------------

@functools.lru_cache(maxsize=1)
def solver_version() -> str:
    """sha256 of the code of the modules that compute a table (`_SOLVER_MODULES`): their statements, not their
    docstrings or comments (`code_key`)."""
    package = Path(lubeviz.__file__).resolve().parent
    h = hashlib.sha256()
    for entry in _SOLVER_MODULES:
        path = package / entry
        feed_code(h, package, sorted(path.rglob("*.py")) if path.is_dir() else [path])
    return h.hexdigest()


def _omega(machine, omega) -> float:
    omega = 2.0 * math.pi * machine.operating_speed if omega is None else float(omega)
    return _check_omega(omega)


def _check_omega(omega) -> float:
    omega = float(omega)
    if not (math.isfinite(omega) and omega > 0.0):
        raise InputError(f"shaft speed {omega!r} rad/s; expected a positive number")
    return omega


def _check_bearing(machine, bearing: int) -> int:
    if not (isinstance(bearing, (int, np.integer)) and 0 <= bearing < len(machine.bearings)):
        raise InputError(f"bearing index {bearing!r}; the machine has {len(machine.bearings)} bearings")
    return int(bearing)


def _bearing_values(b: Bearing) -> dict:
    """Every parameter of a Bearing except its display name: geometry, oil, groove(s), mesh, node, supply (JSON-ready:
    a further groove or a pedestal as its fields)."""
    def plain(v):
        if dataclasses.is_dataclass(v):
            return dataclasses.asdict(v)
        if isinstance(v, list):
            return [plain(x) for x in v]
        return v

    return {k: plain(getattr(b, k)) for k in sorted(b.param) if k != "name"}


def _grid(span, points) -> dict:
    lo, hi = (float(v) for v in span)
    return {"span": [lo, hi], "points": int(points)}


def slice_inputs(geometry: dict, sommerfeld: float, *, span=DEFAULT_SPAN, points: int = DEFAULT_POINTS) -> dict:
    """What a slice's key hashes (JSON-ready; also stored in the file, for reading).

    - the geometry (`dimensionless.geometry_values`: radius, length, groove angle, groove length / R,
      groove width / L, the mesh) and the slice's S (the exact node value);
    - the ratio grid (span, points) and the reference operating point the slice is solved at;
    - the code: `TABLE_FORMAT_VERSION`, `lubeviz.__version__` and `solver_version()`.
    Not in it: viscosity, clearance, load, speed (they only choose S and scale the view), the rotor."""
    return {
        "format": TABLE_FORMAT_VERSION,
        "lubeviz": lubeviz.__version__,
        "solver": solver_version(),
        "geometry": dict(geometry),
        "sommerfeld": float(sommerfeld),
        "reference": [_dimensionless.REF_VISCOSITY, _dimensionless.REF_CLEARANCE_RATIO, _dimensionless.REF_OMEGA],
        **_grid(span, points),
    }


def slice_key(geometry: dict, sommerfeld: float, *, span=DEFAULT_SPAN, points: int = DEFAULT_POINTS) -> str:
    return _digest(slice_inputs(geometry, sommerfeld, span=span, points=points))


def key_inputs(machine, bearing: int, omega: float | None = None, *, span=DEFAULT_SPAN,
               points: int = DEFAULT_POINTS, load=None) -> dict:
    """The inputs `table_key` hashes, as a JSON-ready dict."""
    bearing = _check_bearing(machine, bearing)
    load = bearing_static_loads(machine)[bearing] if load is None else load
    return _view_inputs(machine.bearings[bearing], load, _omega(machine, omega), span, points)


def _view_inputs(b: Bearing, load, omega: float, span, points) -> dict:
    return {
        "format": TABLE_FORMAT_VERSION,
        "lubeviz": lubeviz.__version__,
        "solver": solver_version(),
        "bearing": _bearing_values(b),
        "load_n": [float(f"{float(w):.{_LOAD_DIGITS}g}") for w in load],
        "omega_rad_s": float(omega),
        "sommerfeld_nodes": [_dimensionless.COARSE_STEP, _dimensionless.FINE_STEP, _dimensionless.FINE_BELOW,
                             *_dimensionless.S_RANGE],
        **_grid(span, points),
    }


def table_key(machine, bearing: int, omega: float | None = None, span=DEFAULT_SPAN,
              points: int = DEFAULT_POINTS) -> str:
    """sha256 (hex) of every input that decides the numbers of a bearing's view (`CoefficientTable.key`).

    In it: the bearing's parameters (`Bearing.param` except `name`; `node` since it decides the load),
    the static load on the journal (12 significant digits; it stands for the shaft, discs, density,
    gravity and the other bearing's position), the speed, the ratio grid and the S grid, and the code
    (format, package version, `solver_version()`). Not in it: the unbalance, measurement nodes, shaft
    damping, E and nu (none enter a static equilibrium or the film's linearization), labels, the
    machine file's bytes. Views are not stored; the slices under them are (`slice_inputs`)."""
    return _digest(key_inputs(machine, bearing, omega, span=span, points=points))


def _digest(inputs: dict) -> str:
    text = json.dumps(inputs, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode()).hexdigest()


# --- file format -----------------------------------------------------------------------------------

def _checksum(key: str, arrays: dict) -> str:
    h = hashlib.sha256(key.encode() + b"\0" + str(TABLE_FORMAT_VERSION).encode())
    for name in _ARRAYS:
        a = np.ascontiguousarray(arrays[name], dtype="<f8")
        h.update(name.encode() + b"\0" + str(a.shape).encode() + b"\0" + a.tobytes())
    return h.hexdigest()


def _slice_arrays(s: Slice) -> dict:
    return {"ratio": s.ratio, "values": s.values, "q_threshold": np.float64(s.q_threshold),
            "sommerfeld": np.float64(s.sommerfeld), "seconds": np.float64(s.seconds)}


def _write(path: Path, s: Slice, key: str, inputs: dict) -> None:
    """Write atomically: a temporary file in the same directory, fsync, then os.replace."""
    path.parent.mkdir(parents=True, exist_ok=True)
    arrays = {k: np.asarray(v, dtype="<f8") for k, v in _slice_arrays(s).items()}
    fd, tmp = tempfile.mkstemp(prefix=f".{path.stem[:16]}-", suffix=".npz.tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            np.savez(fh, **arrays, key=np.array(key), checksum=np.array(_checksum(key, arrays)),
                     format=np.array(TABLE_FORMAT_VERSION), inputs=np.array(json.dumps(inputs, sort_keys=True)))
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


class _Untrusted(Exception):
    """Why a cache file is not used (becomes the warning's text)."""


# Far above any slice (about 25 kB at 140 ratios): a larger file, or zip members claiming more, are not read.
_MAX_SLICE_BYTES = 64 << 20

_FILE_KINDS = ((stat.S_ISDIR, "a directory"), (stat.S_ISLNK, "a symbolic link"), (stat.S_ISFIFO, "a FIFO"),
               (stat.S_ISSOCK, "a socket"), (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"))


def _kind(mode: int) -> str:
    return next((name for test, name in _FILE_KINDS if test(mode)), "not a regular file")


def _reason(exc: OSError) -> str:
    """An OSError as a short reason: its type and text, without a temporary file's name."""
    return f"{type(exc).__name__}: {exc.strerror}" if exc.strerror else f"{type(exc).__name__}: {exc}"


def _file_bytes(path: Path) -> bytes | None:
    """The bytes of the cache file `path`; None when there is none (or the directory above it is a file).
    Anything but a regular file is refused by `lstat` before it is opened (a FIFO would block the reader),
    and the open itself follows no symlink and does not block, in case the name was swapped meanwhile."""
    try:
        st = os.lstat(path)
    except (FileNotFoundError, NotADirectoryError):
        return None
    except OSError as exc:
        raise _Untrusted(f"cannot be examined ({_reason(exc)})") from None
    if not stat.S_ISREG(st.st_mode):
        raise _Untrusted(f"{_kind(st.st_mode)}, not a regular file; not opened")
    if st.st_size > _MAX_SLICE_BYTES:
        raise _Untrusted(f"{st.st_size} bytes, more than any slice ({_MAX_SLICE_BYTES})")
    flags = os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0)
    try:
        fd = os.open(path, flags)
    except FileNotFoundError:
        return None
    except OSError as exc:
        raise _Untrusted(f"unreadable ({_reason(exc)})") from None
    with os.fdopen(fd, "rb") as fh:
        mode = os.fstat(fh.fileno()).st_mode
        if not stat.S_ISREG(mode):  # replaced between lstat and open
            raise _Untrusted(f"{_kind(mode)}, not a regular file")
        try:
            content = fh.read(_MAX_SLICE_BYTES + 1)
        except OSError as exc:
            raise _Untrusted(f"unreadable ({_reason(exc)})") from None
    if len(content) > _MAX_SLICE_BYTES:  # grew since lstat
        raise _Untrusted(f"more than any slice ({_MAX_SLICE_BYTES} bytes)")
    return content


def _read(content: bytes, key: str, sommerfeld: float, span, points: int) -> Slice:
    """Load and validate one slice file's bytes; raises _Untrusted with the reason."""
    try:
        with np.load(io.BytesIO(content), allow_pickle=False) as z:
            if sum(info.file_size for info in z.zip.infolist()) > _MAX_SLICE_BYTES:
                raise _Untrusted(f"its members claim more than any slice ({_MAX_SLICE_BYTES} bytes)")
            data = {name: z[name] for name in z.files}
    except (OSError, ValueError, EOFError, MemoryError, zipfile.BadZipFile) as exc:
        raise _Untrusted(f"unreadable ({type(exc).__name__}: {exc})") from None
    needed = set(_ARRAYS) | {"key", "checksum", "format"}
    if not needed <= set(data):
        raise _Untrusted(f"missing arrays {sorted(needed - set(data))}")
    if data["format"].shape != () or int(data["format"]) != TABLE_FORMAT_VERSION:
        raise _Untrusted(f"format {data['format']!r}, expected {TABLE_FORMAT_VERSION}")
    if str(data["key"]) != key:
        raise _Untrusted(f"stored key {str(data['key'])[:12]}... differs from the expected {key[:12]}...")
    arrays = {}
    for name in _ARRAYS:
        if data[name].dtype.kind != "f":
            raise _Untrusted(f"array {name!r} has dtype {data[name].dtype}, expected float")
        arrays[name] = data[name].astype("<f8")
    if str(data["checksum"]) != _checksum(key, arrays):
        raise _Untrusted("checksum mismatch (the values were changed after writing)")
    n = arrays["ratio"].shape[0] if arrays["ratio"].ndim == 1 else -1
    shapes = {"ratio": (n,), "values": (n, 10), "q_threshold": (), "sommerfeld": (), "seconds": ()}
    bad = [f"{k} {arrays[k].shape} (expected {s})" for k, s in shapes.items() if arrays[k].shape != s]
    grid = _dimensionless.ratio_grid(span, points)
    if n != grid.size or bad:
        raise _Untrusted(f"inconsistent shapes for the {grid.size} supply ratios of {points} points over {span}: "
                         f"{', '.join(bad) or 'ratio'}")
    if not all(np.all(np.isfinite(a)) for a in arrays.values()):
        raise _Untrusted("non-finite values")
    if not np.array_equal(arrays["ratio"], grid):
        raise _Untrusted("supply ratios are not the grid of the key's span and points")
    if float(arrays["sommerfeld"]) != float(sommerfeld) or not float(arrays["q_threshold"]) > 0.0:
        raise _Untrusted("Sommerfeld number or flooded threshold differs from the key's")
    return Slice(sommerfeld=float(arrays["sommerfeld"]), q_threshold=float(arrays["q_threshold"]),
                 ratio=arrays["ratio"], values=arrays["values"], seconds=float(arrays["seconds"]))


# Slices already validated in this process, by key and the sha256 of the file's bytes: a view is
# made for every (viscosity, clearance) a fit tries, and unpacking and re-checking its four files each
# time would dominate. Any change to a file's bytes gives another digest, and a full validation.
_VALIDATED: dict = {}
_VALIDATED_MAX = 512


def _load_or_discard(path: Path, key: str, sommerfeld: float, span, points: int) -> Slice | None:
    """The cached slice if present and trustworthy; None (after warning and deleting) otherwise."""
    try:
        content = _file_bytes(path)
        if content is None:
            return None
        ident = (key, float(sommerfeld), tuple(span), int(points), hashlib.sha256(content).hexdigest())
        if ident in _VALIDATED:
            return _VALIDATED[ident]
        s = _read(content, key, sommerfeld, span, points)
        if len(_VALIDATED) >= _VALIDATED_MAX:
            _VALIDATED.clear()
        _VALIDATED[ident] = s
        return s
    except _Untrusted as why:
        warnings.warn(f"coefficient table cache {path}: {why}; {_discard(path)}rebuilding",
                      StaleCacheWarning, stacklevel=4)
        return None


def _discard(path: Path) -> str:
    """Delete an untrusted cache entry (the name only: a symlink's target is left alone); a directory is
    left in place. Returns the warning's words for what was done."""
    try:
        if stat.S_ISDIR(os.lstat(path).st_mode):
            return "left in place, "
        path.unlink(missing_ok=True)
    except OSError as exc:
        return f"could not delete it ({_reason(exc)}), "
    return "deleting it and "


# Slices built in this process that could not be stored (an unwritable cache directory), by key: the next
# view that needs them uses them instead of solving them again. Cleared when full (each is ~12 kB).
_UNSTORED: dict = {}
_UNSTORED_MAX = 256


def _keep_unstored(key: str, s: Slice) -> None:
    if len(_UNSTORED) >= _UNSTORED_MAX:
        _UNSTORED.clear()
    _UNSTORED[key] = s


# --- slices: load or build ---------------------------------------------------------------------------

def _build_one(geometry: dict, sommerfeld: float, span, points: int, progress: ProgressFn) -> Slice:
    try:
        return _dimensionless.build_slice(geometry, sommerfeld, span=span, points=points, progress=progress)
    except ConvergenceError as exc:
        raise ConvergenceError(f"dimensionless table slice at S = {sommerfeld:.4g}: {exc}") from exc


def geometry_table(bearing: Bearing, sommerfeld=None, *, span=DEFAULT_SPAN, points: int = DEFAULT_POINTS,
                   progress: ProgressFn = silent, directory=None, workers: int | None = None,
                   nodes: np.ndarray | None = None) -> DimensionlessTable:
    """The dimensionless table of `bearing`'s geometry with the slices that queries at S value(s)
    `sommerfeld` need (None: every slice, the full range) loaded from the cache or built and stored.

    `workers` defaults to min(2 x number missing, CPU count) (with fewer slices than workers each slice is
    solved in two parts, r <= 1 and r > 1, one job each); `workers=1` builds in this process. Progress counts
    solved ratios over the slices being built. `nodes`: the S grid (default `sommerfeld_nodes()`)."""
    return geometry_tables([(bearing, sommerfeld)], span=span, points=points, progress=progress, directory=directory,
                           workers=workers, nodes=nodes)[0]


def geometry_tables(requests, *, span=DEFAULT_SPAN, points: int = DEFAULT_POINTS, progress: ProgressFn = silent,
                    directory=None, workers: int | None = None, nodes: np.ndarray | None = None,
                    off_grid: str = "raise") -> list[DimensionlessTable | None]:
    """`geometry_table` for several (bearing, sommerfeld) requests at once: the slices missing over all of them are
    built in one pool, so the processes stay busy across geometries (a machine's bearings each lean their own way,
    and each lean is a geometry of its own: three rounds of five slices on two processes leave a process idle at the
    end of each). Requests of one geometry share one table. `off_grid`: "raise" (an S off the grid raises
    InputError) or "skip" (that request's table is None, the others are loaded)."""
    directory = _slices_dir(directory)
    nodes = sommerfeld_nodes() if nodes is None else np.asarray(nodes, dtype=float)
    plans: dict[str, _Plan] = {}
    out: list[_Plan | None] = []
    for bearing, sommerfeld in requests:
        geometry = geometry_values(bearing)
        plan = plans.get(_digest(geometry))
        if plan is None:
            plan = _Plan(geometry, nodes, span, points, directory)
        try:
            wanted = range(nodes.size) if sommerfeld is None else plan.table.needed(sommerfeld)
        except InputError:
            if off_grid != "skip":
                raise
            out.append(None)
            continue
        plans[_digest(geometry)] = plan
        plan.want(wanted)
        out.append(plan)
    todo = [plan for plan in plans.values() if plan.load()]
    if not todo:
        progress(1, 1, "tables from cache")
        return [None if plan is None else plan.table for plan in out]
    with contextlib.ExitStack() as stack:
        problems = {}
        for lock in sorted({_lock_path(directory, plan.geometry, span, points) for plan in todo}):
            problems[lock] = stack.enter_context(_build_lock(lock, progress))
        todo = [plan for plan in todo if plan.load()]  # what another builder stored while this one waited
        if not todo:
            progress(1, 1, "tables from cache (built by another process)")
            return [None if plan is None else plan.table for plan in out]
        try:
            _build_missing(todo, span, points, progress, workers)
        finally:
            unstored = [why for plan in todo for why in plan.unstored]
            if unstored:
                warnings.warn(f"could not store {len(unstored)} coefficient table slice(s) in {directory}: "
                              f"{unstored[0]}; they are used from memory and will be rebuilt next time",
                              CacheStoreWarning, stacklevel=3)
            for lock, problem in problems.items():
                if problem and not unstored:
                    warnings.warn(f"could not take the build lock {lock}: {problem}; built without waiting for "
                                  "other builders (at worst they solve the same slices twice)", CacheWarning,
                                  stacklevel=3)
    return [None if plan is None else plan.table for plan in out]


class _Plan:
    """One geometry's table in `geometry_tables`: the slices wanted, loaded from disk (or memory) where trusted,
    the ones still missing, and where each built one is stored."""

    def __init__(self, geometry: dict, nodes: np.ndarray, span, points: int, directory: Path):
        self.geometry, self.nodes, self.span, self.points, self.directory = geometry, nodes, span, points, directory
        self.table = DimensionlessTable(geometry=geometry, nodes=nodes, span=tuple(float(v) for v in span),
                                        points=int(points))
        self.keys: dict[int, str] = {}
        self.missing: list[int] = []
        self.unstored: list[str] = []  # why slices just built could not be written

    def want(self, indices) -> None:
        for i in indices:
            if i not in self.keys:
                self.keys[i] = slice_key(self.geometry, self.nodes[i], span=self.span, points=self.points)

    def path(self, i: int) -> Path:
        return self.directory / f"{self.keys[i]}.npz"

    def load(self) -> list[int]:
        """The trusted slices on disk (or kept in memory, unstored) into the table; the ones still missing."""
        for i in self.keys:
            if i in self.table.slices:
                continue
            s = _load_or_discard(self.path(i), self.keys[i], float(self.nodes[i]), self.span, self.points)
            s = _UNSTORED.get(self.keys[i]) if s is None else s
            if s is not None:
                self.table.slices[i] = s
        self.missing = [i for i in sorted(self.keys) if i not in self.table.slices]
        return self.missing

    def store(self, i: int, s: Slice) -> None:
        """The slice serves this table whether or not it can be written."""
        self.table.slices[i] = s
        try:
            _write(self.path(i), s, self.keys[i], slice_inputs(self.geometry, self.nodes[i], span=self.span,
                                                                 points=self.points))
        except OSError as exc:
            self.unstored.append(_reason(exc))
            _keep_unstored(self.keys[i], s)


def _lock_path(directory: Path, geometry: dict, span, points: int) -> Path:
    """The lock file that builders of this geometry's slices (on this ratio grid) take turns on."""
    name = _digest({"geometry": geometry, "span": [float(v) for v in span], "points": int(points)})
    return directory / f".build-{name[:24]}.lock"


@contextlib.contextmanager
def _build_lock(path: Path, progress: ProgressFn, poll_s: float = 0.2):
    """Hold an exclusive lock on `path` (created if absent) for the block: polls every `poll_s`, calling
    `progress` while it waits (so a `Cancelled` raised there ends the wait). Yields None when locked, else why
    not (a directory that cannot be written, a lock path that is not a regular file, no locks on this file
    system): the block then runs unlocked, as it does without `fcntl` (not POSIX). Concurrent builders then
    only duplicate work, never corrupt it (atomic writes)."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not POSIX
        yield "no file locks on this platform"
        return
    flags = os.O_RDWR | os.O_CREAT | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0) | os.O_CLOEXEC
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd = os.open(path, flags, 0o644)
    except OSError as exc:
        problem = _reason(exc)
    else:
        problem = None
    if problem is not None:
        yield problem
        return
    try:
        mode = os.fstat(fd).st_mode
        problem = None if stat.S_ISREG(mode) else f"{_kind(mode)}, not a regular file"
        waited = 0.0
        while problem is None:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                break
            except BlockingIOError:
                progress(0, 1, f"waiting for another build of these table slices ({waited:.0f} s)")
                time.sleep(poll_s)
                waited += poll_s
            except OSError as exc:  # e.g. ENOLCK: a file system without locks
                problem = _reason(exc)
        if problem is not None:
            yield problem
            return
        try:
            yield None
        finally:
            fcntl.flock(fd, fcntl.LOCK_UN)
    finally:
        os.close(fd)


def _build_missing(plans: list, span, points, progress, workers) -> None:
    """Build every plan's missing slices, handing each to its plan's `store` as it is done."""
    jobs = [(p, i) for p, plan in enumerate(plans) for i in plan.missing]
    # up to two jobs per slice (its parts r <= 1 and r > 1), so even one slice uses two processes
    workers = min(2 * len(jobs), os.cpu_count() or 1) if workers is None else int(workers)
    if workers < 1:
        raise InputError(f"workers = {workers}; expected at least 1")
    per = _dimensionless.ratio_grid(span, points).size  # a slice's equilibria
    total = per * len(jobs)

    if workers == 1:
        for j, (p, i) in enumerate(jobs):
            nodes = plans[p].nodes

            def offset(done, _total, label="", j=j, i=i, nodes=nodes):
                progress(j * per + done, total, f"S = {nodes[i]:.3g}: {label}")
            plans[p].store(i, _build_one(plans[p].geometry, float(nodes[i]), span, points, offset))
        return
    _build_parallel(plans, jobs, span, points, progress, workers, total)


def _view(table: DimensionlessTable, bearing: Bearing, load, omega: float, index: int, key: str,
          turn: np.ndarray | None = None) -> CoefficientTable:
    s = sommerfeld_number(bearing, load, omega)
    view = _dimensionless.dimensional_table(table.combination(s), bearing, load, omega, index=index, key=key)
    return view if turn is None else turned_table(view, turn)


# --- a leaning load ------------------------------------------------------------------------------------
# The dimensionless tables hold loads along -Y (their slices are keyed by the geometry, the load's direction is
# not in them). A load leaning by beta from -Y (an offset out of line, a shaft on 3+ supports) is the same film
# seen from a frame turned by beta: in it the load is vertical and every groove sits beta earlier (angles from +Y
# in the direction of rotation, SPEC §1). That bearing's table, turned back, is the leaning bearing's: K and C
# as R K' R^T, the position as R p'.
# A lean below LEAN_DEG is taken as vertical: it moves K and C by 2.3 % of the largest entry per degree (the fan's
# bearing A, direct solves at 0.5-1.7 Q_T; the position by 0.4 % of c), so 0.23 % at 0.1 deg, below the tables' own
# error against direct solves (0.5 %); each lean above it is a geometry of its own, with its own slices to build.
# The fan: bearing A leans -5.1 deg, C +1.1 deg, B -0.045 deg (taken as vertical).
LEAN_DEG = 0.1
# A lean is the angle of a load the statics computed, and its last bits are the host's: another CPU's BLAS and
# numpy kernels moved the rig's -0.0189 rad by 1.4e-14 (session 60, against the host the seeds were made on), and
# every turned slice's key with it: a fresh clone rebuilt two full tables (742 s of one test). The lean is taken to
# 1e-9 rad (a turn of 1e-9 moves K and C by about 1e-9 of the largest entry), so that its key is the same on any
# host but for the rare lean within 1e-14 of a rounding edge.
LEAN_DECIMALS = 9


def frame_lean(load) -> float:
    """The lean (rad, from -Y towards +X) of the frame `film_frame` turns a bearing under `load` [Wx, Wy] into:
    the load's own, to LEAN_DECIMALS."""
    return round(math.atan2(float(load[0]), -float(load[1])), LEAN_DECIMALS)


def film_frame(bearing: Bearing, load) -> tuple[Bearing, np.ndarray, np.ndarray | None]:
    """(the bearing as seen from the frame where `load` is vertical, that vertical load, the 10 x 10 map of a
    table's columns from that frame back: `values @ turn.T`, or None when the load is vertical already)."""
    load = np.asarray(load, dtype=float)
    if load.shape != (2,) or not np.all(np.isfinite(load)):
        raise InputError(f"bearing load {load!r}: expected two finite numbers [Wx, Wy] (N)")
    w = float(np.hypot(*load))
    if not w > 0.0:
        raise InputError(f"bearing load {load.tolist()} N: expected a non-zero load")
    beta = frame_lean(load)
    if abs(math.degrees(beta)) <= LEAN_DEG:
        return bearing, np.array([0.0, -w]), None
    from ...model.bearing import Groove

    def turned(angle: float) -> float:
        return math.remainder(angle - beta, 2.0 * math.pi)

    seen = bearing.copy(groove_angle=turned(bearing.groove_angle),
                        other_grooves=[Groove(turned(g.angle), g.length, g.width) for g in bearing.other_grooves])
    c, s_ = math.cos(beta), math.sin(beta)
    r = np.array([[c, -s_], [s_, c]])
    rr = np.kron(r, r)  # row-major vec(R K R^T) = (R kron R) vec(K)
    turn = np.zeros((10, 10))
    turn[0:4, 0:4], turn[4:8, 4:8], turn[8:10, 8:10] = rr, rr, r
    return seen, np.array([0.0, -w]), turn


def turned_table(table: CoefficientTable, turn: np.ndarray) -> CoefficientTable:
    """`table` (a bearing's in its load's frame, `film_frame`) in the machine's frame."""
    v = np.concatenate([table.K.reshape(-1, 4), table.C.reshape(-1, 4), table.position], axis=1) @ turn.T
    return CoefficientTable(bearing=table.bearing, omega=table.omega, q_threshold=table.q_threshold, q=table.q,
                            K=v[:, 0:4].reshape(-1, 2, 2), C=v[:, 4:8].reshape(-1, 2, 2), position=v[:, 8:10],
                            seconds=table.seconds, key=table.key)


def bearing_view(bearing: Bearing, load, omega: float, *, index: int = 0, span=DEFAULT_SPAN,
                 points: int = DEFAULT_POINTS, progress: ProgressFn = silent, directory=None,
                 workers: int | None = None) -> CoefficientTable:
    """The `CoefficientTable` (SI) of `bearing` under static `load` (N, [Wx, Wy]; leaning: `film_frame`) at
    `omega` (rad/s), from its geometry's dimensionless table (slices built only if missing). Use it for a
    bearing with changed viscosity or clearance, e.g. `bearing.copy(viscosity=0.7 * mu)`: no film solve
    when the slices around its Sommerfeld number exist. Raises InputError outside the table's S range."""
    omega = _check_omega(omega)
    key = _digest(_view_inputs(bearing, load, omega, span, points))
    seen, load, turn = film_frame(bearing, load)
    s = sommerfeld_number(seen, load, omega)
    table = geometry_table(seen, [s], span=span, points=points, progress=progress, directory=directory,
                           workers=workers)
    return _view(table, seen, load, omega, index, key, turn)


def loaded_table(bearing: Bearing, load, omega: float, *, span=DEFAULT_SPAN, points: int = DEFAULT_POINTS,
                 directory=None) -> DimensionlessTable:
    """`bearing`'s geometry table with the slices around its Sommerfeld number loaded from the cache (after a
    `bearing_view` of it, which built any that were missing); for `scaled.scaled_view`. `load` vertical (a leaning
    one: its `film_frame`'s bearing and load)."""
    s = sommerfeld_number(bearing, _dimensionless._check_load(load), _check_omega(omega))
    return geometry_table(bearing, [s], span=span, points=points, directory=directory)


def cached_table(machine, bearing: int, omega: float | None = None, *, span=DEFAULT_SPAN,
                 points: int = DEFAULT_POINTS, progress: ProgressFn = silent, directory=None) -> CoefficientTable:
    """The table of `machine.bearings[bearing]`: a view of the cached slices (missing ones built in this process)."""
    bearing = _check_bearing(machine, bearing)
    omega = _omega(machine, omega)
    load = bearing_static_loads(machine)[bearing]
    return bearing_view(machine.bearings[bearing], load, omega, index=bearing, span=span, points=points,
                        progress=progress, directory=directory, workers=1)


def machine_tables(machine, omega: float | None = None, *, span=DEFAULT_SPAN, points: int = DEFAULT_POINTS,
                   progress: ProgressFn = silent, directory=None, workers: int | None = None
                   ) -> tuple[CoefficientTable, ...]:
    """One table per bearing of `machine`, views of the cached slices; bearings of one geometry share
    them, and the slices missing for all bearings (every geometry's) are built together, in one pool."""
    omega = _omega(machine, omega)
    loads = bearing_static_loads(machine)
    n = len(machine.bearings)
    frames = [film_frame(b, w) for b, w in zip(machine.bearings, loads)]  # a leaning load: its own frame
    groups: dict[str, list[int]] = {}
    for k, (seen, _, _) in enumerate(frames):
        groups.setdefault(_digest(geometry_values(seen)), []).append(k)
    out: list[CoefficientTable | None] = [None] * n
    requests = [(frames[members[0]][0], [sommerfeld_number(frames[k][0], frames[k][1], omega) for k in members])
                for members in groups.values()]
    tables = geometry_tables(requests, span=span, points=points, progress=progress, directory=directory,
                             workers=workers)  # every geometry's missing slices in one pool
    for members, table in zip(groups.values(), tables):
        for k in members:
            key = _digest(_view_inputs(machine.bearings[k], loads[k], omega, span, points))
            out[k] = _view(table, *frames[k][:2], omega, k, key, frames[k][2])
    return tuple(out)


# --- parallel build ------------------------------------------------------------------------------------

def _build_worker(geometry: dict, sommerfeld: float, index, part: str, span, points: int,
                  messages, cancel) -> dict:
    """Worker process: one part of one slice from plain values; reports each ratio on `messages` under
    (`index`, `part`)."""
    def report(done, total, label=""):
        if cancel.is_set():
            raise Cancelled(f"slice {index}: cancelled")
        messages.put(((index, part), done, total, label))

    try:
        if part == WHOLE:
            return _dimensionless.build_slice(geometry, sommerfeld, span=span, points=points, progress=report)
        return _dimensionless.build_slice_part(geometry, sommerfeld, part, span=span, points=points, progress=report)
    except ConvergenceError as exc:
        raise ConvergenceError(f"dimensionless table slice at S = {sommerfeld:.4g}: {exc}") from exc


def _process_context():
    """fork when this process has one thread (fast start, and the caller's script is not re-imported);
    spawn otherwise, since forking a threaded process (the app's server) can deadlock on a held lock.
    Under spawn the caller's main module is imported again in each worker, so a script that calls
    `machine_tables` must guard its top level with `if __name__ == "__main__":`."""
    if threading.active_count() == 1 and "fork" in multiprocessing.get_all_start_methods():
        return multiprocessing.get_context("fork")
    return multiprocessing.get_context("spawn")


WHOLE = "whole"  # a job that solves a whole slice (both parts in one process, Q_T once)


def _build_parallel(plans: list, jobs: list, span, points, progress, workers, total) -> None:
    """`jobs` ((plan, slice index) pairs, `_build_missing`) on `workers` processes."""
    ctx = _process_context()
    # Whole slices when there are enough to keep every process busy (each part would solve the slice's
    # flooded equilibrium again); else each slice's two parts as two jobs, so even one slice uses two processes.
    if len(jobs) >= workers:
        parted = [(job, WHOLE) for job in jobs]
    else:
        parted = [(job, part) for job in jobs for part in _dimensionless.PARTS]
    done = {key: 0 for key in parted}
    parts: dict[tuple, dict] = {job: {} for job in jobs}

    def node(job) -> float:
        p, i = job
        return float(plans[p].nodes[i])

    with ctx.Manager() as manager:
        messages, cancel = manager.Queue(), manager.Event()
        pool = ProcessPoolExecutor(max_workers=workers, mp_context=ctx)
        futures = {}
        try:
            for job, part in parted:
                futures[pool.submit(_build_worker, plans[job[0]].geometry, node(job), job, part, tuple(span),
                                    points, messages, cancel)] = (job, part)
            progress(0, total, f"building {len(jobs)} table slices on {workers} processes")
            pending = set(futures)

            def drain():
                while True:
                    try:
                        key, d, _t, label = messages.get_nowait()
                    except queue_module.Empty:
                        return
                    done[key] = max(done[key], d)
                    progress(sum(done.values()), total, f"S = {node(key[0]):.3g}: {label}")

            def harvest(finished):
                for f in finished:
                    job, part = futures[f]
                    if part in parts[job]:
                        continue
                    parts[job][part] = f.result()
                    plan, i = plans[job[0]], job[1]
                    if part == WHOLE:
                        plan.store(i, parts[job][part])
                    elif len(parts[job]) == len(_dimensionless.PARTS):
                        plan.store(i, _dimensionless.join_slice(node(job), parts[job]["below"], parts[job]["above"],
                                                                span=span, points=points))

            while pending:
                finished, pending = wait(pending, timeout=0.1, return_when=FIRST_COMPLETED)
                harvest(finished)  # before progress, which may raise Cancelled: finished slices are kept
                drain()
            drain()
        except BaseException:
            cancel.set()
            for f in futures:
                f.cancel()
            pool.shutdown(wait=True, cancel_futures=True)
            # keep the slices whose two parts both finished (a cancelled build resumes from them)
            harvest([f for f in futures if f.done() and not f.cancelled() and f.exception() is None])
            raise
        pool.shutdown(wait=True)


def full_build(bearing: Bearing, *, progress: ProgressFn = silent, directory=None, workers: int | None = None,
               span=DEFAULT_SPAN, points: int = DEFAULT_POINTS) -> tuple[DimensionlessTable, float]:
    """Every slice of `bearing`'s geometry (the whole S range); returns the table and the seconds taken."""
    t0 = time.perf_counter()
    table = geometry_table(bearing, None, span=span, points=points, progress=progress, directory=directory,
                           workers=workers)
    return table, time.perf_counter() - t0
