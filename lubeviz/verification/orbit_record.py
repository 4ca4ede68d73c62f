"""Large-orbit records along another path than the identification's large-orbit model.

The identification with `large_orbit` declared (`identify.fit.large_orbit`) uses the linear chain (tables on
the 100 x 100 film, the machine's rotor as its file declares it, beta = 2e-5 s) plus a harmonic balance on that film
with 5-16 harmonics. This source computes the periodic orbit of any machine (every fluid-film bearing's flow, every
plane) with

| stage     | identification                              | this source                                      |
|-----------|---------------------------------------------|--------------------------------------------------|
| film      | 100 x 100, groove refinement 4              | 200 x 200, groove refinement 1 (`fine_bearing`)  |
| rotor     | the file's elements, beta = 2e-5 s          | each element split in two (`split_rotor`), 3e-5 s |
| loads     | the model's statics                         | the split rotor's (`_film_loads`)                |
| balance   | 5-16 harmonics, its own points              | 6 harmonics, 28 points                           |

and samples it for 5 s at 10 kHz with white noise at 12 dB (seeded), as the probes at their declared
angles read it (the DC removed). It shares the harmonic-balance method with the model, not its
discretization: the balance itself was checked against the time integration on the same films
(`tests/rotor/test_orbit_balance.py`).

That check found the balance's own truncation: near the bearings' Q_T at the paper's unbalance the journal's
velocity turns sharply where the film is thinnest, the orbit's lines fall off only as 1/h, and the balance's 1X
with 5 harmonics is measurably off the time integration's at the paper's unbalance; more harmonics close the
gap only slowly (docs/notes/large-orbits.md, sessions 17-18).
A source that shares the method shares that error. `method="time"` takes another path: the time integration
(`rotor.film_time_response`, implicit coupling, TIME_STEPS steps per revolution) of the split rotor on the
declared films (the model's mesh), started on this source's own balance on them, over TIME_REVOLUTIONS
revolutions; the record holds the harmonics 0..TIME_HARMONICS of the last TIME_WINDOW (every line the
integration holds), about 4 minutes per record on one core.

The balance costs about 1.5 minutes (200 x 200 films at 28 points, Newton's method from the orbit on coarser
films, START_MESH), so its harmonics are
cached on disk beside the independent equilibria (`<cache_dir()>/independent/orbit-<sha256>.npz`): the key
a sha256 of every input of the balance (speed, flows, planes, unbalance scale, harmonics and points, the
machine file's bytes, the source of the film, rotor and verification packages but its benches, a format version); a file
with another key, a wrong shape or a non-finite value is deleted with a warning and the balance solved
again. The noise, the probes and the record are made from the harmonics each time.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import time
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..film.equilibrium import find_equilibrium
from ..film.feed import Feed
from ..model.machine import DEFAULT_MACHINE
from ..rotor.film_bearings import FilmBearings
from ..rotor.film_transient import film_time_response
from ..rotor.orbit_balance import orbit_balance
from ..rotor.response import Unbalance, machine_unbalance, unbalance_response
from ..rotor.statics import simple_support_reactions
from ..signals.noise import add_noise
from ..signals.records import record_from_arrays
from ..identify.tables.cache import cache_dir
from ..rotor.orbit_balance import OrbitBalance
from . import equilibria
from .equilibria import fine_bearing
from .independent import (IndependentRecord, IndependentSpec, _determinate, _machine, fine_node, split_rotor,
                          static_equilibrium)
from ..units import MLMIN_PER_M3S

HARMONICS, POINTS = 6, 28
METHODS = ("balance", "time")
TIME_REVOLUTIONS, TIME_STEPS = 6, 512  # the time integration: revolutions from the start orbit, steps in each
TIME_HARMONICS = 40  # the harmonics kept of its last revolutions (at the paper's point on 60 x 40 films its lines
# are negligible against the 1X well below 40X; how they fall off: docs/notes/large-orbits.md, session 18); those at
# or above the record's Nyquist frequency are left out of the record
TIME_WINDOW = 2  # revolutions the harmonics are taken over (the last ones): an even number, so that a line at
# 0.5X cancels from them (at the paper's unbalance near Q_T the 100 x 100 films' orbit holds one, decaying over
# tens of revolutions: the onset of period doubling, which a periodic record leaves out; its size:
# docs/notes/large-orbits.md, session 18, "A half-order line")
START_MESH = 50  # film volumes each way of the orbit Newton's method starts from (the answer is the 200 x 200
# films' own, to its tolerance): at the paper's unbalance, 460 / 600 ml/min, 13.5 s there then 4 Newton steps on
# 200 x 200, 88 s in all, against 10 steps and 232 s from the linear orbit; the two orbits agree to 2.4e-9
ORBIT_FORMAT = 4  # 2: the residual stored; 3: the time integration's over a shifted window; 4: over 2


def _balance_key(spec: IndependentSpec, unbalance_scale: float, method: str = "balance") -> str:
    machine_file = Path(spec.machine or DEFAULT_MACHINE)
    inputs = {"format": ORBIT_FORMAT, "kind": "orbit balance",
              "code": equilibria.code_version("film", "rotor", "verification"),
              "machine": hashlib.sha256(machine_file.read_bytes()).hexdigest(),
              "speed_hz": float(spec.speed_hz), "flows_mlmin": [float(q) for q in spec.flows_mlmin],
              "nodes": [int(n) for n in spec.nodes], "unbalance_scale": float(unbalance_scale),
              "harmonics": HARMONICS, "points": POINTS}
    if method == "time":
        inputs.update(kind="orbit time integration", harmonics=TIME_HARMONICS, revolutions=TIME_REVOLUTIONS,
                      steps=TIME_STEPS, window=TIME_WINDOW, start_harmonics=HARMONICS)
    text = json.dumps(inputs, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode()).hexdigest()


def _shapes(n_nodes: int, method: str, n_bearings: int) -> dict:
    h = (TIME_HARMONICS if method == "time" else HARMONICS) + 1
    return {"x": (h, n_nodes), "y": (h, n_nodes), "bearing_x": (h, n_bearings), "bearing_y": (h, n_bearings),
            "linear_x": (n_nodes,), "linear_y": (n_nodes,), "iterations": (), "max_eccentricity": (), "seconds": (),
            "residual": (), **({"half_order": ()} if method == "time" else {})}


def _cached_balance(spec: IndependentSpec, unbalance_scale: float, solve, method: str = "balance"):
    """The orbit of `spec` and its extra figures (a dict: the time integration's `half_order`) from the disk
    cache, or `solve()` (then stored)."""
    key = _balance_key(spec, unbalance_scale, method)
    path = cache_dir() / "independent" / f"orbit-{key}.npz"
    shapes = _shapes(len(spec.nodes), method, len(spec.flows_mlmin))
    data = equilibria._load(path, key, shapes)
    omega = 2.0 * math.pi * spec.speed_hz
    if data is not None:
        ob = OrbitBalance(omega=omega, nodes=tuple(fine_node(n) for n in spec.nodes), x=data["x"], y=data["y"],
                          bearing_x=data["bearing_x"], bearing_y=data["bearing_y"], linear_x=data["linear_x"],
                          linear_y=data["linear_y"], iterations=int(data["iterations"]), film_solves=0,
                          residual=float(data["residual"]), max_eccentricity=float(data["max_eccentricity"]),
                          seconds=float(data["seconds"]))
        return ob, {name: float(data[name]) for name in ("half_order",) if name in shapes}
    ob, extra = solve()
    arrays = {name: np.asarray(extra[name] if name in extra else getattr(ob, name)) for name in shapes}
    if all(a.shape == shapes[name] and np.all(np.isfinite(a)) for name, a in arrays.items()):
        equilibria._store(path, key, arrays)
    return ob, extra


def _time_orbit(rotor, films, unbalances, nodes, start: OrbitBalance, progress=None) -> tuple[OrbitBalance, dict]:
    """The periodic orbit by time integration (`film_time_response`, implicit coupling) on `films` from the
    balance `start`: TIME_REVOLUTIONS revolutions of TIME_STEPS steps, the harmonics 0..TIME_HARMONICS of the
    last TIME_WINDOW at `nodes` and the journals. Its `residual`: the largest change of a 1X from the window one
    revolution earlier, relative to the largest 1X (how far the start's transient, mostly the least damped
    sub-synchronous mode, still moves it); `max_eccentricity` over the window. Also returns {"half_order": the
    largest 0.5X line over the window, of the largest 1X} (a line the record leaves out)."""
    omega = films.omega
    period = 2.0 * math.pi / omega
    b_nodes = tuple(int(b) for b in rotor.bearing_nodes)
    kw = {"progress": progress} if progress else {}
    tr = film_time_response(rotor, films, unbalances, duration=TIME_REVOLUTIONS * period, dt=period / TIME_STEPS,
                            nodes=tuple(nodes) + b_nodes, start=start.state(0.0), implicit=True, **kw)
    h = np.arange(TIME_HARMONICS + 1)

    def lines(first_rev, n_rev):  # harmonics of every sampled signal over revolutions [first, first + n)
        k0 = first_rev * TIME_STEPS
        sel = slice(k0, k0 + n_rev * TIME_STEPS)  # whole revolutions, the end point excluded
        e = np.exp(-1j * np.outer(tr.t[sel], h * omega))
        c = tr.displacement[:, sel] @ e / (n_rev * TIME_STEPS)
        c[:, 1:] *= 2.0
        c[:, 0] = c[:, 0].real
        return c.T  # (H + 1, 2 * n_signals)

    c = lines(TIME_REVOLUTIONS - TIME_WINDOW, TIME_WINDOW)
    before = lines(TIME_REVOLUTIONS - TIME_WINDOW - 1, TIME_WINDOW)  # the window one revolution earlier
    drift = float(np.abs(c[1] - before[1]).max() / np.abs(c[1]).max())
    k0 = (TIME_REVOLUTIONS - TIME_WINDOW) * TIME_STEPS
    sel = slice(k0, k0 + TIME_WINDOW * TIME_STEPS)
    half = 2.0 * np.abs(tr.displacement[:, sel] @ np.exp(-0.5j * omega * tr.t[sel])) / (TIME_WINDOW * TIME_STEPS)
    half_order = float(half.max() / np.abs(c[1]).max())  # the 0.5X line the record leaves out, of the largest 1X
    n = len(nodes)
    window = slice((TIME_REVOLUTIONS - TIME_WINDOW) * TIME_STEPS, None)
    ecc = max(float(np.max(np.hypot(e.position[0] + tr.displacement[2 * (n + j), window],
                                    e.position[1] + tr.displacement[2 * (n + j) + 1, window])) / e.bearing.clearance)
              for j, e in enumerate(films.equilibria))
    lin = unbalance_response(rotor, omega, unbalances, films.coefficients, nodes=nodes)
    return OrbitBalance(omega=omega, nodes=tuple(int(v) for v in nodes), x=c[:, 0:2 * n:2], y=c[:, 1:2 * n:2],
                        bearing_x=c[:, 2 * n::2], bearing_y=c[:, 2 * n + 1::2],
                        linear_x=np.asarray(lin.x), linear_y=np.asarray(lin.y),
                        film_solves=tr.film_solves + start.film_solves, residual=drift, max_eccentricity=ecc,
                        seconds=tr.seconds + start.seconds, iterations=0), {"half_order": half_order}


def make_orbit_record(spec: IndependentSpec, *, unbalance_scale: float = 1.0, method: str = "balance",
                      progress=None, use_cache: bool = True) -> IndependentRecord:
    """A large-orbit record of `spec` (speed, flows, planes, probes, noise, seed; no other effects), the
    machine's unbalance times `unbalance_scale` (the strength of the nonlinearity: 2X grows with it). The
    orbit comes from the disk cache when `use_cache` and it holds this one (see the module's doc).
    `method`: "balance" (200 x 200 films, 6 harmonics, 28 points) or "time" (the time integration on the
    declared films from that source's orbit on START_MESH films: every harmonic, see `_time_orbit`).

    Truth: the flows, the orbit's 2X/1X ratio and static shift at each plane, its largest eccentricity."""
    if method not in METHODS:
        raise InputError(f"make_orbit_record: method {method!r}; expected one of {', '.join(METHODS)}")
    if spec.effects:
        raise InputError(f"make_orbit_record: large orbits alone; also given {spec.effects_text()}")
    if spec.static:
        raise InputError("make_orbit_record: records without the static position (static=False)")
    if not (math.isfinite(unbalance_scale) and unbalance_scale > 0):
        raise InputError(f"unbalance_scale {unbalance_scale!r}; expected a positive number")
    t0 = time.perf_counter()

    def solve() -> OrbitBalance:
        machine = _machine(spec.machine)
        rotor = split_rotor(spec.machine)
        omega = 2.0 * math.pi * spec.speed_hz
        loads = _film_loads(spec, machine, rotor)

        def films(on_mesh):
            eqs = []
            for k, (b, w, q) in enumerate(zip(machine.bearings, loads, spec.flows_mlmin)):
                eq = find_equilibrium(on_mesh(b), omega, tuple(float(v) for v in w), Feed.flow(q / MLMIN_PER_M3S),
                                      coefficients="fixed-pattern")
                if not eq.converged:
                    raise InputError(f"bearing {k + 1}: no equilibrium at {q:g} ml/min ({eq.message})")
                eqs.append(eq)
            return FilmBearings(omega=omega, flows=tuple(q / MLMIN_PER_M3S for q in spec.flows_mlmin),
                                equilibria=tuple(eqs))

        unbalances = [Unbalance(fine_node(u.node), u.moment * unbalance_scale, u.phase)
                      for u in machine_unbalance(machine)]
        nodes = tuple(fine_node(n) for n in spec.nodes)
        kw = dict(nodes=nodes, harmonics=HARMONICS, points=POINTS, **({"progress": progress} if progress else {}))
        # Newton on the 200 x 200 films starts from this source's own orbit on START_MESH films
        start = orbit_balance(rotor, films(lambda b: b.copy(n_circumferential=START_MESH, n_axial=START_MESH)),
                              unbalances, tol=1e-5, **kw)
        if method == "time":  # the declared films, fixed-pattern tangents (the residual force second order),
            declared = films(lambda b: b)  # from the balance on them (the slow sub-synchronous transient small)
            start = orbit_balance(rotor, declared, unbalances, tol=1e-5, start=start, **kw)
            return _time_orbit(rotor, declared, unbalances, nodes, start, progress)
        return orbit_balance(rotor, films(fine_bearing), unbalances, tol=1e-7, start=start, **kw), {}

    ob, extra = _cached_balance(spec, unbalance_scale, solve, method) if use_cache else solve()
    n = int(round(spec.duration_s * spec.sample_rate_hz))
    t = (spec.total_s - spec.duration_s) + np.arange(n) / spec.sample_rate_hz
    above = np.arange(ob.harmonics + 1) * spec.speed_hz >= 0.5 * spec.sample_rate_hz
    if above.any():  # lines at or above the record's Nyquist frequency: the probes' anti-alias filter takes them out
        ob = dataclasses.replace(ob, x=np.where(above[:, None], 0, ob.x), y=np.where(above[:, None], 0, ob.y))
    x, y = ob.signals(t)
    d = np.stack([x - ob.x[0].real[:, None], y - ob.y[0].real[:, None]], axis=1)  # (plane, xy, n), DC removed
    angles = np.radians(np.asarray(spec.probe_angles_deg))
    u = np.stack([np.cos(angles), np.sin(angles)], axis=-1)  # (plane, probe, xy)
    readings = np.einsum("kpj,kjn->kpn", u, d)
    if spec.snr_db is not None:
        readings = add_noise(readings, spec.snr_db, np.random.default_rng(spec.seed))
    flows = {"q1_mlmin": f"{spec.q1_mlmin:.10g}", "q2_mlmin": f"{spec.q2_mlmin:.10g}"} if spec.q_mlmin is None else \
        {"truth_q_mlmin": ", ".join(f"{q:.10g}" for q in spec.flows_mlmin)}  # N flows: as `make_record` keeps them
    meta = {**flows, "seed": str(spec.seed),
            "snr_db": "none" if spec.snr_db is None else f"{spec.snr_db:g}", "synthetic": "independent",
            "effects": "large_orbit", "x_unbalance_scale": f"{unbalance_scale:g}", "x_orbit_method": method}
    record = record_from_arrays(*readings.reshape(2 * len(spec.nodes), -1), speed_hz=spec.speed_hz,
                                sample_rate_hz=spec.sample_rate_hz, units="m", nodes=spec.nodes,
                                probe_angles_deg=spec.probe_angles_deg, t0=float(t[0]),
                                machine=Path(spec.machine or DEFAULT_MACHINE).name, metadata=meta,
                                source=f"independent large orbit, {method} ({spec.speed_hz:g} Hz, seed {spec.seed})")
    planes = range(len(spec.nodes))
    truth = {"speed_hz": spec.speed_hz, "q1_mlmin": spec.q1_mlmin, "q2_mlmin": spec.q2_mlmin,
             "q_mlmin": list(spec.flows_mlmin),
             "effects": [("large_orbit", {"unbalance_scale": unbalance_scale})],
             "ratio_2x": [ob.harmonic_ratio(2, k) for k in planes],
             "static_shift_m": np.stack([ob.x[0].real, ob.y[0].real], axis=-1),
             "one_x_over_linear": [abs(ob.x[1, k]) / abs(ob.linear_x[k]) for k in planes],
             "max_eccentricity": ob.max_eccentricity, "balance_iterations": ob.iterations, "method": method,
             "periodicity": ob.residual if method == "time" else None, "half_order": extra.get("half_order"),
             "seconds": time.perf_counter() - t0}
    return IndependentRecord(record=record, truth=truth, spec=spec)


def _film_loads(spec: IndependentSpec, machine, rotor) -> np.ndarray:
    """What each film carries, (N, 2) [Wx, Wy] N: on two bearings the split rotor's reactions pinned at their centres
    (the lever rule), on 3+ supports the source's coupled statics on its fine films (`static_equilibrium`: the loads
    follow the journals, which sit where their supply puts them)."""
    if _determinate(machine):
        reactions = simple_support_reactions(rotor, machine.gravity).forces
        return np.stack([np.zeros_like(reactions), -reactions], axis=-1)
    return static_equilibrium(spec.machine, spec.speed_hz, spec.flows_mlmin).loads


def _solve_into_cache(spec: IndependentSpec, unbalance_scale: float, method: str = "balance") -> None:
    from ..rotor import orbit_balance as module

    module.FILM_THREADS = 1  # this worker process is one of several, one per core
    make_orbit_record(spec, unbalance_scale=unbalance_scale, method=method)


def solve_orbits(jobs, *, processes: int = 2, method: str = "balance") -> list:
    """Solve into the cache the orbits of `jobs`, pairs (spec, unbalance_scale), not yet there, in `processes`
    worker processes at once (each is serial: two make a 2-core machine twice as fast). Returns, per job, None or
    the error (a LubevizError: no periodic orbit, a balance that did not settle) that kept its orbit from being
    made; the other jobs go on."""
    import concurrent.futures
    import multiprocessing

    from ..errors import LubevizError

    jobs = [(spec, float(scale)) for spec, scale in jobs]
    out: list = [None] * len(jobs)
    missing = [i for i, (s, u) in enumerate(jobs)
               if not (cache_dir() / "independent" / f"orbit-{_balance_key(s, u, method)}.npz").exists()]
    if len(missing) > 1 and processes > 1:
        ctx = multiprocessing.get_context("spawn")  # no fork of a process holding numba/BLAS threads
        with concurrent.futures.ProcessPoolExecutor(min(processes, len(missing)), mp_context=ctx) as pool:
            futures = {i: pool.submit(_solve_into_cache, *jobs[i], method) for i in missing}
            for i, f in futures.items():
                try:
                    f.result()
                except LubevizError as exc:
                    out[i] = exc
    else:
        for i in missing:
            try:
                make_orbit_record(jobs[i][0], unbalance_scale=jobs[i][1], method=method)
            except LubevizError as exc:
                out[i] = exc
    return out


def make_orbit_records(jobs, *, processes: int = 2, method: str = "balance") -> list[IndependentRecord]:
    """The records of `jobs`, pairs (spec, unbalance_scale): the orbits not yet cached are solved first
    (`solve_orbits`), then every record is made from the cache; the first orbit that could not be made raises."""
    jobs = [(spec, float(scale)) for spec, scale in jobs]
    for error in solve_orbits(jobs, processes=processes, method=method):
        if error is not None:
            raise error
    return [make_orbit_record(s, unbalance_scale=u, method=method) for s, u in jobs]
