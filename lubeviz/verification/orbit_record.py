"""Large-orbit records along another path than the identification's large-orbit model.

The identification with `large_orbit` declared (`identify.orbit_fit`) uses the linear chain (tables on
the 100 x 100 film, the 20-element rotor, beta = 2e-5 s) plus a harmonic balance on that film with 5
harmonics and 24 points per revolution. This source computes the periodic orbit with

| stage     | identification                              | this source                                      |
|-----------|---------------------------------------------|--------------------------------------------------|
| film      | 100 x 100, groove refinement 4              | 200 x 200, groove refinement 1 (`fine_bearing`)  |
| rotor     | 20 elements, beta = 2e-5 s                  | 40 elements (`split_rotor`), beta = 3e-5 s        |
| loads     | support reactions of the 20-element rotor   | of the 40-element rotor                          |
| balance   | 5 harmonics, 24 points per revolution       | 6 harmonics, 28 points                           |

and samples it for 5 s at 10 kHz with white noise at 12 dB (seeded), as the probes at their declared
angles read it (the DC removed). It shares the harmonic-balance method with the model, not its
discretization: the balance itself was checked against the time integration on the same films
(`tests/rotor/test_orbit_balance.py`).

The balance costs about 1.5 minutes (200 x 200 films at 28 points, Newton's method from the orbit on coarser
films, START_MESH), so its harmonics are
cached on disk beside the independent equilibria (`<cache_dir()>/independent/orbit-<sha256>.npz`): the key
a sha256 of every input of the balance (speed, flows, planes, unbalance scale, harmonics and points, the
machine file's bytes, the source of the film, rotor and verification packages, a format version); a file
with another key, a wrong shape or a non-finite value is deleted with a warning and the balance solved
again. The noise, the probes and the record are made from the harmonics each time.
"""

from __future__ import annotations

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
from ..rotor.orbit_balance import orbit_balance
from ..rotor.response import Unbalance, machine_unbalance
from ..rotor.statics import simple_support_reactions
from ..signals.noise import add_noise
from ..signals.records import record_from_arrays
from ..identify.cache import cache_dir
from ..rotor.orbit_balance import OrbitBalance
from . import equilibria
from .equilibria import fine_bearing
from .independent import IndependentRecord, IndependentSpec, _machine, fine_node, split_rotor

HARMONICS, POINTS = 6, 28
START_MESH = 50  # film volumes each way of the orbit Newton's method starts from (the answer is the 200 x 200
# films' own, to its tolerance): at the paper's unbalance, 460 / 600 ml/min, 13.5 s there then 4 Newton steps on
# 200 x 200, 88 s in all, against 10 steps and 232 s from the linear orbit; the two orbits agree to 2.4e-9
ORBIT_FORMAT = 1


def _balance_key(spec: IndependentSpec, unbalance_scale: float) -> str:
    machine_file = Path(spec.machine or DEFAULT_MACHINE)
    inputs = {"format": ORBIT_FORMAT, "kind": "orbit balance",
              "code": equilibria.code_version("film", "rotor", "verification"),
              "machine": hashlib.sha256(machine_file.read_bytes()).hexdigest(),
              "speed_hz": float(spec.speed_hz), "flows_mlmin": [float(spec.q1_mlmin), float(spec.q2_mlmin)],
              "nodes": [int(n) for n in spec.nodes], "unbalance_scale": float(unbalance_scale),
              "harmonics": HARMONICS, "points": POINTS}
    text = json.dumps(inputs, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode()).hexdigest()


def _shapes(n_nodes: int) -> dict:
    h = HARMONICS + 1
    return {"x": (h, n_nodes), "y": (h, n_nodes), "bearing_x": (h, 2), "bearing_y": (h, 2),
            "linear_x": (n_nodes,), "linear_y": (n_nodes,), "iterations": (), "max_eccentricity": (), "seconds": ()}


def _cached_balance(spec: IndependentSpec, unbalance_scale: float, solve) -> OrbitBalance:
    """The balance of `spec` from the disk cache, or `solve()` (then stored)."""
    key = _balance_key(spec, unbalance_scale)
    path = cache_dir() / "independent" / f"orbit-{key}.npz"
    shapes = _shapes(len(spec.nodes))
    data = equilibria._load(path, key, shapes)
    omega = 2.0 * math.pi * spec.speed_hz
    if data is not None:
        return OrbitBalance(omega=omega, nodes=tuple(fine_node(n) for n in spec.nodes), x=data["x"], y=data["y"],
                            bearing_x=data["bearing_x"], bearing_y=data["bearing_y"], linear_x=data["linear_x"],
                            linear_y=data["linear_y"], iterations=int(data["iterations"]), film_solves=0,
                            residual=0.0, max_eccentricity=float(data["max_eccentricity"]),
                            seconds=float(data["seconds"]))
    ob = solve()
    arrays = {name: np.asarray(getattr(ob, name)) for name in shapes}
    if all(a.shape == shapes[name] and np.all(np.isfinite(a)) for name, a in arrays.items()):
        equilibria._store(path, key, arrays)
    return ob


def make_orbit_record(spec: IndependentSpec, *, unbalance_scale: float = 1.0, progress=None,
                      use_cache: bool = True) -> IndependentRecord:
    """A large-orbit record of `spec` (speed, flows, planes, probes, noise, seed; no other effects), the
    machine's unbalance times `unbalance_scale` (the strength of the nonlinearity: 2X grows with it). The
    balance comes from the disk cache when `use_cache` and it holds this one (see the module's doc).

    Truth: the flows, the orbit's 2X/1X ratio and static shift at each plane, its largest eccentricity."""
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
        reactions = simple_support_reactions(rotor, machine.gravity).forces

        def films(on_mesh):
            eqs = []
            for k, (b, w, q) in enumerate(zip(machine.bearings, reactions, (spec.q1_mlmin, spec.q2_mlmin))):
                eq = find_equilibrium(on_mesh(b), omega, (0.0, -w), Feed.flow(q / 6e7),
                                      coefficients="fixed-pattern")
                if not eq.converged:
                    raise InputError(f"bearing {k + 1}: no equilibrium at {q:g} ml/min ({eq.message})")
                eqs.append(eq)
            return FilmBearings(omega=omega, flows=(spec.q1_mlmin / 6e7, spec.q2_mlmin / 6e7), equilibria=tuple(eqs))

        unbalances = [Unbalance(fine_node(u.node), u.moment * unbalance_scale, u.phase)
                      for u in machine_unbalance(machine)]
        nodes = tuple(fine_node(n) for n in spec.nodes)
        kw = dict(nodes=nodes, harmonics=HARMONICS, points=POINTS, **({"progress": progress} if progress else {}))
        # Newton on the 200 x 200 films starts from this source's own orbit on START_MESH films
        start = orbit_balance(rotor, films(lambda b: b.copy(n_circumferential=START_MESH, n_axial=START_MESH)),
                              unbalances, tol=1e-5, **kw)
        return orbit_balance(rotor, films(fine_bearing), unbalances, tol=1e-7, start=start, **kw)

    ob = _cached_balance(spec, unbalance_scale, solve) if use_cache else solve()
    n = int(round(spec.duration_s * spec.sample_rate_hz))
    t = (spec.total_s - spec.duration_s) + np.arange(n) / spec.sample_rate_hz
    x, y = ob.signals(t)
    d = np.stack([x - ob.x[0].real[:, None], y - ob.y[0].real[:, None]], axis=1)  # (plane, xy, n), DC removed
    angles = np.radians(np.asarray(spec.probe_angles_deg))
    u = np.stack([np.cos(angles), np.sin(angles)], axis=-1)  # (plane, probe, xy)
    readings = np.einsum("kpj,kjn->kpn", u, d)
    if spec.snr_db is not None:
        readings = add_noise(readings, spec.snr_db, np.random.default_rng(spec.seed))
    meta = {"q1_mlmin": f"{spec.q1_mlmin:.10g}", "q2_mlmin": f"{spec.q2_mlmin:.10g}", "seed": str(spec.seed),
            "snr_db": "none" if spec.snr_db is None else f"{spec.snr_db:g}", "synthetic": "independent",
            "effects": "large_orbit", "unbalance_scale": f"{unbalance_scale:g}"}
    record = record_from_arrays(*readings.reshape(4, -1), speed_hz=spec.speed_hz,
                                sample_rate_hz=spec.sample_rate_hz, units="m", nodes=spec.nodes,
                                probe_angles_deg=spec.probe_angles_deg, t0=float(t[0]),
                                machine=Path(spec.machine or DEFAULT_MACHINE).name, metadata=meta,
                                source=f"independent large orbit({spec.speed_hz:g} Hz, seed {spec.seed})")
    truth = {"speed_hz": spec.speed_hz, "q1_mlmin": spec.q1_mlmin, "q2_mlmin": spec.q2_mlmin,
             "effects": [("large_orbit", {"unbalance_scale": unbalance_scale})],
             "ratio_2x": [ob.harmonic_ratio(2, k) for k in range(2)],
             "static_shift_m": np.stack([ob.x[0].real, ob.y[0].real], axis=-1),
             "one_x_over_linear": [abs(ob.x[1, k]) / abs(ob.linear_x[k]) for k in range(2)],
             "max_eccentricity": ob.max_eccentricity, "balance_iterations": ob.iterations,
             "seconds": time.perf_counter() - t0}
    return IndependentRecord(record=record, truth=truth, spec=spec)


def _solve_into_cache(spec: IndependentSpec, unbalance_scale: float) -> None:
    from ..rotor import orbit_balance as module

    module.FILM_THREADS = 1  # this worker process is one of several, one per core
    make_orbit_record(spec, unbalance_scale=unbalance_scale)


def make_orbit_records(jobs, *, processes: int = 2) -> list[IndependentRecord]:
    """The records of `jobs`, pairs (spec, unbalance_scale): the balances not yet cached are solved in
    `processes` worker processes at once (each balance is serial: two make a 2-core machine twice as
    fast), then every record is made from the cache."""
    import concurrent.futures
    import multiprocessing

    jobs = [(spec, float(scale)) for spec, scale in jobs]
    missing = [(s, u) for s, u in jobs
               if not (cache_dir() / "independent" / f"orbit-{_balance_key(s, u)}.npz").exists()]
    if len(missing) > 1 and processes > 1:
        ctx = multiprocessing.get_context("spawn")  # no fork of a process holding numba/BLAS threads
        with concurrent.futures.ProcessPoolExecutor(min(processes, len(missing)), mp_context=ctx) as pool:
            for f in [pool.submit(_solve_into_cache, s, u) for s, u in missing]:
                f.result()
    return [make_orbit_record(s, unbalance_scale=u) for s, u in jobs]
