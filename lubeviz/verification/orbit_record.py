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
"""

from __future__ import annotations

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
from .equilibria import fine_bearing
from .independent import IndependentRecord, IndependentSpec, _machine, fine_node, split_rotor

HARMONICS, POINTS = 6, 28


def make_orbit_record(spec: IndependentSpec, *, unbalance_scale: float = 1.0, progress=None) -> IndependentRecord:
    """A large-orbit record of `spec` (speed, flows, planes, probes, noise, seed; no other effects), the
    machine's unbalance times `unbalance_scale` (the strength of the nonlinearity: 2X grows with it).

    Truth: the flows, the orbit's 2X/1X ratio and static shift at each plane, its largest eccentricity."""
    if spec.effects:
        raise InputError(f"make_orbit_record: large orbits alone; also given {spec.effects_text()}")
    if spec.static:
        raise InputError("make_orbit_record: records without the static position (static=False)")
    t0 = time.perf_counter()
    machine = _machine(spec.machine)
    rotor = split_rotor(spec.machine)
    omega = 2.0 * math.pi * spec.speed_hz
    reactions = simple_support_reactions(rotor, machine.gravity).forces
    eqs = []
    for k, (b, w, q) in enumerate(zip(machine.bearings, reactions, (spec.q1_mlmin, spec.q2_mlmin))):
        eq = find_equilibrium(fine_bearing(b), omega, (0.0, -w), Feed.flow(q / 6e7), coefficients="fixed-pattern")
        if not eq.converged:
            raise InputError(f"bearing {k + 1}: no equilibrium at {q:g} ml/min ({eq.message})")
        eqs.append(eq)
    fb = FilmBearings(omega=omega, flows=(spec.q1_mlmin / 6e7, spec.q2_mlmin / 6e7), equilibria=tuple(eqs))
    if not (math.isfinite(unbalance_scale) and unbalance_scale > 0):
        raise InputError(f"unbalance_scale {unbalance_scale!r}; expected a positive number")
    unbalances = [Unbalance(fine_node(u.node), u.moment * unbalance_scale, u.phase) for u in machine_unbalance(machine)]
    nodes = tuple(fine_node(n) for n in spec.nodes)
    ob = orbit_balance(rotor, fb, unbalances, nodes=nodes, harmonics=HARMONICS, points=POINTS, tol=1e-7,
                       **({"progress": progress} if progress else {}))
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
