"""On-disk cache of coefficient tables (SPEC §5): built once per machine, speed and oil, then loaded.

A table costs a few seconds per bearing at the paper's 100 x 100 mesh and is deterministic, so it
is stored in the user's cache directory (never inside the repository) as
`<cache_dir>/tables/<key>.npz`, the key a sha256 of every input that affects the numbers
(`table_key`). A file is trusted only if it proves it is what the key says: its stored key and a
sha256 of its arrays match, its shapes agree, every value is finite and its flows are the grid the
key asks for. Anything else (truncated file, a bad zip, another key, NaN, tampered values) is
reported with a `StaleCacheWarning`, deleted and rebuilt. Files are read with `allow_pickle=False`
and written atomically (temporary file in the same directory, then `os.replace`), so a crash or a
concurrent writer never leaves a half-written table under a valid name.

`machine_tables` builds the missing tables of a machine in parallel, one worker process per bearing
(forked from a single-threaded caller, spawned from a threaded one such as the app: `_process_context`);
workers get plain values (the bearing's parameters, its load, the speed) and run
`tables.bearing_table`, the same code `build_table` runs, so parallel and serial tables are identical. Progress: every worker
reports each solved flow through a `multiprocessing.Manager` queue; the parent drains it while it
waits and calls `progress(done, total, label)` with the sum over the bearings being built. If that
callback raises `Cancelled`, the workers are told to stop at their next flow, pending work is
cancelled, the pool is shut down and `Cancelled` is re-raised; tables finished before that are kept.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import json
import math
import multiprocessing
import os
import queue as queue_module
import tempfile
import threading
import warnings
import zipfile
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from pathlib import Path

import numpy as np
import platformdirs

import lubeviz

from ..errors import InputError
from ..model.bearing import Bearing
from ..progress import Cancelled, ProgressFn, silent
from ..rotor.statics import bearing_static_loads
from . import tables as _tables
from .tables import DEFAULT_POINTS, DEFAULT_SPAN, CoefficientTable, table_flows

# Bump when the stored layout or the meaning of a stored array changes.
TABLE_FORMAT_VERSION = 1

# Modules whose source decides the numbers in a table: the film model and its solvers, the
# equilibrium and coefficient method, the table grid, and the rotor statics that give the load.
# Their source text is hashed into the key (`solver_version`), so any edit to them invalidates
# every cached table: a version constant that someone must remember to bump would be trusted
# after a change nobody bumped it for.
_SOLVER_MODULES = ("film", "identify/tables.py", "rotor/statics.py", "rotor/assembly.py", "rotor/elements.py")

_LOAD_DIGITS = 12  # significant digits of the static load kept in the key (see `table_key`)

_ARRAYS = ("q", "K", "C", "position", "q_threshold", "omega", "seconds")


class StaleCacheWarning(UserWarning):
    """A cached table could not be trusted (corrupt, tampered or for other inputs) and is rebuilt."""


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


def _tables_dir(directory) -> Path:
    root = cache_dir() if directory is None else _check_directory(Path(directory), "directory argument")
    return root / "tables"


# --- key -----------------------------------------------------------------------------------------

@functools.lru_cache(maxsize=1)
def solver_version() -> str:
    """sha256 of the source of the modules that compute a table (`_SOLVER_MODULES`)."""
    package = Path(lubeviz.__file__).resolve().parent
    h = hashlib.sha256()
    for entry in _SOLVER_MODULES:
        path = package / entry
        files = sorted(path.rglob("*.py")) if path.is_dir() else [path]
        for f in files:
            h.update(f.relative_to(package).as_posix().encode() + b"\0" + f.read_bytes() + b"\0")
    return h.hexdigest()


def _omega(machine, omega) -> float:
    omega = 2.0 * math.pi * machine.operating_speed if omega is None else float(omega)
    if not (math.isfinite(omega) and omega > 0.0):
        raise InputError(f"shaft speed {omega!r} rad/s; expected a positive number")
    return omega


def _check_bearing(machine, bearing: int) -> int:
    if not (isinstance(bearing, (int, np.integer)) and 0 <= bearing < len(machine.bearings)):
        raise InputError(f"bearing index {bearing!r}; the machine has {len(machine.bearings)} bearings")
    return int(bearing)


def _bearing_values(b: Bearing) -> dict:
    """Every parameter of a Bearing except its display name: geometry, oil, groove, mesh, node."""
    return {k: getattr(b, k) for k in sorted(b.param) if k != "name"}


def key_inputs(machine, bearing: int, omega: float | None = None, *, span=DEFAULT_SPAN,
               points: int = DEFAULT_POINTS, load=None) -> dict:
    """The inputs `table_key` hashes, as a JSON-ready dict (also stored in the file, for reading)."""
    bearing = _check_bearing(machine, bearing)
    load = bearing_static_loads(machine)[bearing] if load is None else load
    lo, hi = (float(v) for v in span)
    return {
        "format": TABLE_FORMAT_VERSION,
        "lubeviz": lubeviz.__version__,
        "solver": solver_version(),
        "bearing": _bearing_values(machine.bearings[bearing]),
        "load_n": [float(f"{float(w):.{_LOAD_DIGITS}g}") for w in load],
        "omega_rad_s": _omega(machine, omega),
        "span": [lo, hi],
        "points": int(points),
    }


def table_key(machine, bearing: int, omega: float | None = None, span=DEFAULT_SPAN,
              points: int = DEFAULT_POINTS) -> str:
    """sha256 (hex) of the canonical JSON of every input that decides the table's numbers.

    In the key, and why:
    - the bearing's parameters (`Bearing.param` except `name`): radius, length, clearance, viscosity,
      groove angle, length and width, and the mesh (n_circumferential, n_axial): the film model's
      inputs. `node` too: it places the bearing on the rotor and so decides its load.
    - the static load on the journal (N), computed from the rotor (`bearing_static_loads`): it is
      the only way the shaft elements, discs, density, gravity and the other bearing's position
      reach the table, so it stands for all of them exactly, and a change to any of them that moves
      the load changes the key. Kept to 12 significant digits so last-bit differences of the
      linear algebra between machines do not defeat the cache.
    - the speed omega (rad/s), the span and the number of points (the flow grid is a function of
      span, points and Q_T, and Q_T of the bearing, load and speed).
    - the code: `TABLE_FORMAT_VERSION` (file layout), `lubeviz.__version__`, and `solver_version()`,
      a hash of the source of the film solver, equilibrium/coefficient method, table grid and statics.
    Not in the key, and why:
    - the unbalance, the measurement nodes, shaft damping, Young's modulus and Poisson's ratio: the
      table is a static equilibrium plus a linearization of the film, with the load from a statically
      determinate support problem; none of these enter it.
    - the bearing's index in the machine and its display name: labels only.
    - the machine file's bytes: every value the table depends on is hashed above as the machine
      object holds it, which also covers a machine edited after loading; hashing the bytes would
      rebuild on a comment or an unbalance edit. The file's sha256 is stored in the table file as
      provenance.
    - numpy/scipy/numba versions: they change results at rounding level only.
    """
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


def _table_arrays(table: CoefficientTable) -> dict:
    return {"q": table.q, "K": table.K, "C": table.C, "position": table.position,
            "q_threshold": np.float64(table.q_threshold), "omega": np.float64(table.omega),
            "seconds": np.float64(table.seconds)}


def _write(path: Path, table: CoefficientTable, key: str, inputs: dict, source_sha256: str) -> None:
    """Write atomically: a temporary file in the same directory, fsync, then os.replace."""
    path.parent.mkdir(parents=True, exist_ok=True)
    arrays = {k: np.asarray(v, dtype="<f8") for k, v in _table_arrays(table).items()}
    fd, tmp = tempfile.mkstemp(prefix=f".{path.stem[:16]}-", suffix=".npz.tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            np.savez(fh, **arrays, key=np.array(key), checksum=np.array(_checksum(key, arrays)),
                     format=np.array(TABLE_FORMAT_VERSION), inputs=np.array(json.dumps(inputs, sort_keys=True)),
                     source_sha256=np.array(source_sha256))
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


class _Untrusted(Exception):
    """Why a cache file is not used (becomes the warning's text)."""


def _read(path: Path, key: str, bearing: int, span, points: int) -> CoefficientTable:
    """Load and validate one table file; raises _Untrusted with the reason."""
    try:
        with np.load(path, allow_pickle=False) as z:
            data = {name: z[name] for name in z.files}
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as exc:
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
    n = arrays["q"].shape[0] if arrays["q"].ndim == 1 else -1
    shapes = {"q": (n,), "K": (n, 2, 2), "C": (n, 2, 2), "position": (n, 2), "q_threshold": (),
              "omega": (), "seconds": ()}
    bad = [f"{k} {arrays[k].shape} (expected {s})" for k, s in shapes.items() if arrays[k].shape != s]
    if n != points or bad:
        raise _Untrusted(f"inconsistent shapes for {points} points: {', '.join(bad) or 'q'}")
    if not all(np.all(np.isfinite(a)) for a in arrays.values()):
        raise _Untrusted("non-finite values")
    q = arrays["q"]
    if np.any(np.diff(q) <= 0):
        raise _Untrusted("flows not strictly increasing")
    grid = table_flows(float(arrays["q_threshold"]), span, points)
    if not np.allclose(q, grid, rtol=1e-12, atol=0.0):
        raise _Untrusted("flows are not the table grid of the key's span and points")
    return CoefficientTable(bearing=bearing, omega=float(arrays["omega"]), q_threshold=float(arrays["q_threshold"]),
                            q=q, K=arrays["K"], C=arrays["C"], position=arrays["position"],
                            seconds=float(arrays["seconds"]), key=key)


def _source_sha256(machine) -> str:
    if not machine.source:
        return ""
    try:
        return hashlib.sha256(Path(machine.source).read_bytes()).hexdigest()
    except OSError:
        return ""


def _load_or_discard(path: Path, key: str, bearing: int, span, points: int) -> CoefficientTable | None:
    """The cached table if present and trustworthy; None (after warning and deleting) otherwise."""
    if not path.exists():
        return None
    try:
        return _read(path, key, bearing, span, points)
    except _Untrusted as why:
        warnings.warn(f"coefficient table cache {path}: {why}; deleting it and rebuilding",
                      StaleCacheWarning, stacklevel=3)
        path.unlink(missing_ok=True)
        return None


def _store(path: Path, table: CoefficientTable, key: str, inputs: dict, machine) -> CoefficientTable:
    _write(path, table, key, inputs, _source_sha256(machine))
    return dataclasses.replace(table, key=key)


# --- public --------------------------------------------------------------------------------------

def cached_table(machine, bearing: int, omega: float | None = None, *, span=DEFAULT_SPAN,
                 points: int = DEFAULT_POINTS, progress: ProgressFn = silent, directory=None) -> CoefficientTable:
    """The table of `machine.bearings[bearing]`: from the cache if valid, else built (in this process) and stored."""
    bearing = _check_bearing(machine, bearing)
    omega = _omega(machine, omega)
    inputs = key_inputs(machine, bearing, omega, span=span, points=points)
    key = _digest(inputs)
    path = _tables_dir(directory) / f"{key}.npz"
    table = _load_or_discard(path, key, bearing, span, points)
    if table is not None:
        progress(points, points, f"bearing {bearing + 1}: table from cache")
        return table
    table = _tables.build_table(machine, bearing, omega, span=span, points=points, progress=progress)
    return _store(path, table, key, inputs, machine)


def _build_worker(bearing_values: dict, load: list, omega: float, index: int, span, points: int,
                  messages, cancel) -> dict:
    """Worker process: one bearing's table from plain values; reports each flow on `messages`."""
    def report(done, total, label=""):
        if cancel.is_set():
            raise Cancelled(f"bearing {index + 1}: cancelled")
        messages.put((index, done, total, label))

    table = _tables.bearing_table(Bearing(**bearing_values), np.asarray(load), omega, index=index, span=span,
                                  points=points, progress=report)
    return _table_arrays(table)


def _from_arrays(arrays: dict, index: int) -> CoefficientTable:
    return CoefficientTable(bearing=index, omega=float(arrays["omega"]), q_threshold=float(arrays["q_threshold"]),
                            q=arrays["q"], K=arrays["K"], C=arrays["C"], position=arrays["position"],
                            seconds=float(arrays["seconds"]))


def machine_tables(machine, omega: float | None = None, *, span=DEFAULT_SPAN, points: int = DEFAULT_POINTS,
                   progress: ProgressFn = silent, directory=None, workers: int | None = None
                   ) -> tuple[CoefficientTable, ...]:
    """One table per bearing of `machine`: cached ones loaded, missing ones built in parallel and stored.

    `workers` defaults to min(number missing, CPU count); `workers=1` (or a single missing table)
    builds in this process without a pool. Progress counts solved flows over the tables being built.
    """
    omega = _omega(machine, omega)
    directory = _tables_dir(directory)
    loads = bearing_static_loads(machine)
    n = len(machine.bearings)
    inputs = [key_inputs(machine, k, omega, span=span, points=points, load=loads[k]) for k in range(n)]
    keys = [_digest(i) for i in inputs]
    paths = [directory / f"{key}.npz" for key in keys]
    out: list[CoefficientTable | None] = [_load_or_discard(paths[k], keys[k], k, span, points) for k in range(n)]
    missing = [k for k in range(n) if out[k] is None]
    if not missing:
        progress(1, 1, "tables from cache")
        return tuple(out)
    workers = min(len(missing), os.cpu_count() or 1) if workers is None else int(workers)
    if workers < 1:
        raise InputError(f"workers = {workers}; expected at least 1")
    total = points * len(missing)
    if workers == 1 or len(missing) == 1:
        for j, k in enumerate(missing):
            def offset(done, _total, label="", j=j, k=k):
                progress(j * points + done, total, f"bearing {k + 1}: {label}")
            table = _tables.build_table(machine, k, omega, span=span, points=points, progress=offset)
            out[k] = _store(paths[k], table, keys[k], inputs[k], machine)
        return tuple(out)
    out_missing = _build_parallel(machine, omega, missing, loads, span, points, progress, workers, total,
                                  lambda k, table: _store(paths[k], table, keys[k], inputs[k], machine))
    for k, table in out_missing.items():
        out[k] = table
    return tuple(out)


def _process_context():
    """fork when this process has one thread (fast start, and the caller's script is not re-imported);
    spawn otherwise, since forking a threaded process (the app's server) can deadlock on a held lock.
    Under spawn the caller's main module is imported again in each worker, so a script that calls
    `machine_tables` must guard its top level with `if __name__ == "__main__":`."""
    if threading.active_count() == 1 and "fork" in multiprocessing.get_all_start_methods():
        return multiprocessing.get_context("fork")
    return multiprocessing.get_context("spawn")


def _build_parallel(machine, omega, missing, loads, span, points, progress, workers, total, store) -> dict:
    ctx = _process_context()
    done = {k: 0 for k in missing}
    built = {}
    with ctx.Manager() as manager:
        messages, cancel = manager.Queue(), manager.Event()
        pool = ProcessPoolExecutor(max_workers=workers, mp_context=ctx)
        futures = {}
        try:
            for k in missing:
                futures[pool.submit(_build_worker, _bearing_values(machine.bearings[k]),
                                    [float(w) for w in loads[k]], omega, k, tuple(span), points,
                                    messages, cancel)] = k
            progress(0, total, f"building {len(missing)} tables on {workers} processes")
            pending = set(futures)

            def drain():
                while True:
                    try:
                        k, d, _t, label = messages.get_nowait()
                    except queue_module.Empty:
                        return
                    done[k] = max(done[k], d)
                    progress(sum(done.values()), total, f"bearing {k + 1}: {label}")

            while pending:
                finished, pending = wait(pending, timeout=0.1, return_when=FIRST_COMPLETED)
                drain()
                for f in finished:
                    k = futures[f]
                    built[k] = store(k, _from_arrays(f.result(), k))
            drain()
        except BaseException:
            cancel.set()
            for f in futures:
                f.cancel()
            pool.shutdown(wait=True, cancel_futures=True)
            raise
        pool.shutdown(wait=True)
    return built
