"""Results shared by every browser session of one server: the machine, its coefficient tables, the
bearing frames of the Bearing page, forward models. All deterministic, so sharing them is safe: a
second session, or a revisit, gets them instantly. Each is computed once (a per-key lock stops two
sessions computing the same thing at once); the coefficient tables are also cached on disk by
`identify.tables.cache`. Nothing here is numeric: it calls the headless package and keeps what it returns.

Every store keyed by a speed (which an uploaded record chooses freely) or by a flow keeps only its most
recently used entries (`Recent`, a few each): records at a hundred speeds cannot fill the server's memory.
"""

from __future__ import annotations

import math
import threading
from collections import OrderedDict
from concurrent.futures import Future

import numpy as np

from typing import TYPE_CHECKING

from ..model.machine import Machine, load_machine
from ..progress import ProgressFn, silent
from ..units import M3S_PER_MLMIN

# The numerics (film, identify, rotor: numba, scipy; about 2 s to import) are imported by the functions that
# use them, not here: the shell imports this module for the machine only, and the start page must not wait
# for them. `import_numerics` imports them ahead of use (the shell calls it in the background).
if TYPE_CHECKING:
    from ..film.explore import SupplyFrame
    from ..identify.forward.chain import ForwardChain
    from ..identify.forward.model import ForwardModel
    from ..rotor.assembly import Rotor


def import_numerics() -> None:
    """Import the numerical modules this module's functions use (idempotent; cheap once done)."""
    from ..film import equilibrium, explore  # noqa: F401
    from ..identify.forward import chain, model  # noqa: F401
    from ..identify.tables import cache  # noqa: F401
    from ..rotor import assembly, statics  # noqa: F401


class Recent(OrderedDict):
    """A dict that keeps its `size` most recently used entries (read with `[]` or `get`, or stored),
    dropping the least recently used one. Thread-safe for single reads and stores."""

    def __init__(self, size: int):
        super().__init__()
        self.size = int(size)
        self._lock = threading.RLock()

    def __getitem__(self, key):
        with self._lock:
            value = super().__getitem__(key)
            self.move_to_end(key)
            return value

    def get(self, key, default=None):
        with self._lock:
            return self[key] if key in self else default

    def __setitem__(self, key, value):
        with self._lock:
            super().__setitem__(key, value)
            self.move_to_end(key)
            while len(self) > self.size:
                self.popitem(last=False)

    def setdefault(self, key, default=None):
        with self._lock:
            if key not in self:
                self[key] = default
            return self[key]


_LOCK = threading.Lock()
# A lock per key being computed; a lock dropped while held only lets a second session compute the same
# (deterministic) thing once more.
_KEY_LOCKS = Recent(256)
_MACHINES: dict = {}  # by the model file the server was started with: not chosen by a visitor
_TABLES = Recent(8)  # (machine source, speed) -> both bearings' coefficient tables (also on disk)
_MODELS = Recent(16)
_ROTORS: dict = {}  # by machine only
_THRESHOLDS = Recent(64)  # (machine source, bearing index, speed) -> Q_T (a float)
_FRAMES = Recent(8)  # (machine source, bearing index, speed) -> {q: SupplyFrame} (q on the page's grid)
_CHAINS = Recent(16)
_VIEWS = Recent(16)  # (machine source, speed, bearing index) -> {(viscosity factor, clearance): table}, all chains
_MEMO = Recent(16)  # other deterministic results (Campbell diagrams, maps), least recent dropped

FRAME_STEP_MLMIN = 10.0  # the Bearing page's supply slider moves on this grid, so frames can be reused


def _key_lock(key) -> threading.Lock:
    with _LOCK:
        return _KEY_LOCKS.setdefault(key, threading.Lock())


def machine(path=None) -> Machine:
    """The machine of `path` (default: the paper's), loaded once per server."""
    key = str(path)
    with _key_lock(("machine", key)):
        if key not in _MACHINES:
            _MACHINES[key] = load_machine(path)
        return _MACHINES[key]


def rotor(m: Machine) -> Rotor:
    with _key_lock(("rotor", m.source)):
        if m.source not in _ROTORS:
            from ..rotor.assembly import rotor_from_machine
            _ROTORS[m.source] = rotor_from_machine(m)
        return _ROTORS[m.source]


def tables(m: Machine, speed_hz: float, progress: ProgressFn = silent):
    """Both bearings' coefficient tables at `speed_hz` (disk cache; built in parallel when missing)."""
    key = (m.source, round(float(speed_hz), 9))
    with _key_lock(("tables",) + key):
        found = _TABLES.get(key)  # kept in a local: another thread may drop the entry meanwhile
        if found is None:
            from ..identify.tables.cache import machine_tables
            found = _TABLES[key] = machine_tables(m, 2.0 * math.pi * speed_hz, progress=progress)
        return found


def forward_model(m: Machine, speed_hz: float, nodes, progress: ProgressFn = silent) -> ForwardModel:
    key = (m.source, round(float(speed_hz), 9), tuple(int(n) for n in nodes))
    t = tables(m, speed_hz, progress)
    with _key_lock(("model",) + key):
        found = _MODELS.get(key)
        if found is None:
            from ..identify.forward.model import ForwardModel
            found = _MODELS[key] = ForwardModel(m, t, key[2], rotor=rotor(m))
        return found


def chain(m: Machine, speed_hz: float, nodes, probe_angles_deg=None,
          progress: ProgressFn = silent) -> ForwardChain:
    """The plain forward chain (no effects) at `speed_hz` and planes `nodes`; add effects with
    `.with_effects(...)`. Every chain of one machine and speed shares its bearings' coefficient views (a
    viscosity or clearance change is built once per server, whatever the planes)."""
    from ..identify.forward.chain import ForwardChain

    if probe_angles_deg is None:  # probes along X and Y at every plane
        probe_angles_deg = ((0.0, 90.0),) * len(tuple(nodes))
    angles = tuple(tuple(float(a) for a in p) for p in probe_angles_deg)
    key = (m.source, round(float(speed_hz), 9), tuple(int(n) for n in nodes), angles)
    t = tables(m, speed_hz, progress)
    with _key_lock(("chain",) + key):
        found = _CHAINS.get(key)
        if found is None:
            found = ForwardChain(m, speed_hz, key[2], probe_angles_deg=angles, tables=t, rotor=rotor(m))
            for k, src in enumerate(found.sources):
                src.share_views(_VIEWS.setdefault((m.source, key[1], k), {}))
            _CHAINS[key] = found
        return found


def bearing_changes(effects, k: int, declared_clearance: float):
    """The `BearingChange` (numbers) of bearing k (0-based) after the bearings-stage `effects`, at their current
    values: the chain's own rule."""
    from ..identify.forward.chain import bearing_changes as chain_bearing_changes

    return chain_bearing_changes(effects, k, declared_clearance).as_floats()


def prepare_views(c: ForwardChain, effects, progress: ProgressFn = silent) -> None:
    """Build (with progress) the coefficient views a chain with `effects` will need: a viscosity or
    clearance change needs the film's tables at another Sommerfeld number (seconds the first time, then
    cached on disk and here)."""
    for k, src in enumerate(c.sources):
        change = bearing_changes(effects, k, src.bearing.clearance)
        with _key_lock(("view", c.machine.source, round(c.speed_hz, 9), k, *src._key(*change))):
            src.view(*change, progress=progress)


def bearing_load(m: Machine, index: int) -> np.ndarray:
    from ..rotor.statics import bearing_static_loads

    return bearing_static_loads(m)[index]


def flooded_flow(m: Machine, index: int, speed_hz: float, progress: ProgressFn = silent) -> float:
    """Q_T (m^3/s) of bearing `index` at `speed_hz` under its static load."""
    key = (m.source, index, round(float(speed_hz), 9))
    with _key_lock(("qt",) + key):
        q = _THRESHOLDS.get(key)
        if q is None:
            progress(0, 1, "flooded threshold Q_T")
            from ..film.equilibrium import flooded_threshold
            q, _ = flooded_threshold(m.bearings[index], 2.0 * math.pi * speed_hz, bearing_load(m, index))
            _THRESHOLDS[key] = q
            progress(1, 1, "flooded threshold Q_T")
        return q


def frame_grid(q_threshold: float, span=(0.25, 2.0)) -> np.ndarray:
    """The supply flows (m^3/s) the Bearing page offers: multiples of FRAME_STEP_MLMIN over the span of Q_T."""
    lo, hi = (f * q_threshold / M3S_PER_MLMIN for f in span)
    step = FRAME_STEP_MLMIN
    return np.arange(math.ceil(lo / step) * step, hi + 0.5 * step, step) * M3S_PER_MLMIN


def snap(q: float) -> float:
    """A flow (m^3/s) rounded to the frame grid (so two sessions share one frame)."""
    step = FRAME_STEP_MLMIN * M3S_PER_MLMIN
    return round(q / step) * step


def cached_frames(m: Machine, index: int, speed_hz: float) -> dict[float, SupplyFrame]:
    """The frames computed so far for this bearing and speed (a live dict: do not modify)."""
    return _FRAMES.setdefault((m.source, index, round(float(speed_hz), 9)), {})


def frames(m: Machine, index: int, speed_hz: float, flows, progress: ProgressFn = silent) -> dict[float, SupplyFrame]:
    """Frames at `flows` (m^3/s, snapped to the grid), computing the missing ones here (warm-started in
    ascending order) and keeping them for every session. Two sessions asking at once may both compute a
    frame; the result is the same."""
    store = cached_frames(m, index, speed_hz)
    wanted = sorted({snap(q) for q in flows})
    missing = [q for q in wanted if q not in store]
    if missing:
        from ..film.explore import supply_frames
        store.update(supply_frames(m.bearings[index], 2.0 * math.pi * speed_hz, bearing_load(m, index), missing,
                                   progress=progress))
    return {q: store[q] for q in wanted}


_FIRST_FILMS = Recent(16)


def first_films(m: Machine, k: int, speed_hz: float, q: float) -> Future:
    """The Bearing page's first films in the job pool (`_first_films`), once per (machine, bearing, speed, flow)
    and server: the shell starts it for the start page's operating point before the page is opened, and the
    page awaits the same future instead of solving the same films again. A failed one is retried."""
    from .jobs import EXECUTOR

    key = (m.source, k, round(float(speed_hz), 9), snap(q))
    with _LOCK:
        future = _FIRST_FILMS.get(key)
        if future is None or (future.done() and future.exception() is not None):
            future = _FIRST_FILMS[key] = EXECUTOR.submit(_first_films, m, k, speed_hz, q)
        return future


def _first_films(m: Machine, k: int, speed_hz: float, q: float) -> None:
    """Q_T and the films the Bearing page draws first into the shared cache: at `q` brought onto the slider's
    range, and at both ends of that range (the fixed colour scale), these two on a second thread."""
    grid = frame_grid(flooded_flow(m, k, speed_hz))
    ends: list = []
    other = threading.Thread(target=lambda: ends.append(frames(m, k, speed_hz, [grid[0], grid[-1]])),
                             name="lubeviz-first-films", daemon=True)
    other.start()
    try:
        frames(m, k, speed_hz, [snap(min(max(q, grid[0]), grid[-1]))])
    finally:
        other.join()
    if not ends:
        frames(m, k, speed_hz, [grid[0], grid[-1]])  # the thread failed: again here, to raise its error


def memo_get(key):
    """A result stored by `memo_put` under `key` (a tuple of every input that affects it), or None."""
    return _MEMO.get(key)


def memo_put(key, value) -> None:
    """Keep `value` under `key` (the _MEMO.size most recently used results are kept)."""
    _MEMO[key] = value


# --- work for the process pool (module-level, picklable; each worker loads the machine once) -----------

def compute_frames(machine_path: str, index: int, speed_hz: float, flows) -> dict[float, SupplyFrame]:
    """Frames at `flows` (snapped to the grid) computed in a worker process; the caller stores them with
    `store_frames`."""
    from ..film.explore import supply_frames

    m = machine(machine_path or None)
    return supply_frames(m.bearings[index], 2.0 * math.pi * speed_hz, bearing_load(m, index),
                         sorted({snap(q) for q in flows}))


def store_frames(m: Machine, index: int, speed_hz: float, new: dict) -> None:
    cached_frames(m, index, speed_hz).update(new)


def compute_stability(machine_path: str, speeds, ratios):
    """The Campbell diagram (rotor.stability.machine_stability) at supply fractions `ratios` of Q_T."""
    from ..rotor.stability import Supply, machine_stability

    m = machine(machine_path or None)
    return machine_stability(m, speeds, Supply.threshold_fraction(tuple(ratios)), rotor=rotor(m))
