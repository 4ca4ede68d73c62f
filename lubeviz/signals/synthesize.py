"""Synthetic measured records, built exactly as the paper builds its references (Sec. 3, SPEC §5).

The machine, on film bearings at supply flows (Q1, Q2), starts at rest under the unbalance force
(Eq. 9) and is integrated for `total_s` = 15 s at dt = 1/`sample_rate_hz` = 1e-4 s (exact
discretization, `lubeviz.rotor.transient`); the last `duration_s` = 5 s are kept, white noise is added
to each channel at `snr_db` = 12 dB of its measured power (SPEC §1), seeded. Displacements are the
dynamic motion about the static equilibrium (zero mean apart from noise), as a DC-coupled probe
would read after removing its gap voltage.

`method="steady"` skips the integration and samples the frequency-domain steady state instead
(the two agree to the time integrator's hold error, ~2e-4 in amplitude; tests check it).
`method="orbit"` samples the periodic orbit on the p-theta films themselves (the `large_orbit` effect:
harmonic balance, `rotor.orbit_balance`), 0X to 5X; its static shift is in the metadata, not the signals.
Above the instability threshold (`rotor.whirl`) that orbit is unstable: the record is then the time
integration on the films from it, disturbed along the unstable mode, so that it holds the onset of oil
whirl (a growing sub-synchronous line); a record longer than the whirl stays within the integration's
reach is refused with the time it may last.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Sequence

import numpy as np

from ..errors import InputError
from .records.record import MAX_PLANES
from ..rotor.assembly import probe_housings, rotor_from_machine
from ..rotor.film_bearings import FilmBearings, film_bearings
from ..rotor.response import machine_unbalance, unbalance_response
from ..rotor.transient import unbalance_time_response
from .noise import add_noise
from .records import Record
from ..units import MLMIN_PER_M3S


def synthesize_record(machine, flows: Sequence[float], *, nodes: Sequence[int] | None = None,
                      snr_db: float | None = 12.0, rng: np.random.Generator | None = None,
                      duration_s: float = 5.0, total_s: float = 15.0, sample_rate_hz: float = 1.0e4,
                      speed_hz: float | None = None, method: str = "time",
                      bearings: FilmBearings | None = None, rotor=None, progress=None) -> Record:
    """A record of the machine at supply flows `flows` (m^3/s) measured at `nodes` (default the bearing centres)."""
    speed_hz = machine.operating_speed if speed_hz is None else float(speed_hz)
    if not (math.isfinite(speed_hz) and speed_hz > 0):
        raise InputError(f"speed {speed_hz!r} Hz; expected a positive number")
    if not (duration_s > 0 and total_s >= duration_s and sample_rate_hz > 0):
        raise InputError(f"expected 0 < duration ({duration_s!r} s) <= total ({total_s!r} s) and a positive "
                         f"sample rate ({sample_rate_hz!r} Hz)")
    if snr_db is not None and rng is None:
        raise InputError("a noisy record needs an explicit rng (numpy.random.Generator); pass snr_db=None "
                         "for a clean one")
    nodes = tuple(machine.center_nodes) if nodes is None else tuple(int(n) for n in nodes)
    if not 2 <= len(nodes) <= MAX_PLANES or len(set(nodes)) != len(nodes):
        raise InputError(f"a record has 2 to {MAX_PLANES} distinct measurement planes; got nodes {nodes!r}")
    omega = 2.0 * math.pi * speed_hz
    rotor = rotor_from_machine(machine) if rotor is None else rotor
    if method == "orbit":  # before any film solve
        rotor.require_films_on_ground("simulate --method orbit (the films solved along the orbit)")
    fb = film_bearings(machine, flows, omega) if bearings is None else bearings
    dt = 1.0 / sample_rate_hz
    extra = {}
    if method == "time":
        from ..rotor.whirl import equilibrium_stability

        stab = equilibrium_stability(rotor, fb)
        if stab.unstable:  # the linear integration would grow without bound (a record of NaN)
            raise InputError(f"at {speed_hz:g} Hz and flows {', '.join(f'{q * MLMIN_PER_M3S:.4g}' for q in flows)} "
                             f"ml/min the machine is {stab.describe()}: there is no steady 1X orbit to record; "
                             "choose flows nearer the bearings' Q_T, or --method orbit for the whirl's onset")
        tr = unbalance_time_response(rotor, omega, machine_unbalance(machine), fb.coefficients,
                                     duration=total_s, dt=dt, keep_last=duration_s, nodes=nodes, probes=True)
        t = tr.t
        xy = tr.displacement.reshape(len(nodes), 2, -1)
    elif method == "steady":
        r = unbalance_response(rotor, omega, machine_unbalance(machine), fb.coefficients, nodes=nodes)
        n_keep = int(round(duration_s * sample_rate_hz))
        t = total_s - duration_s + dt * np.arange(1, n_keep + 1)  # the same samples as "time" keeps
        x, y = r.x.copy(), r.y.copy()
        for k, h in enumerate(probe_housings(rotor, nodes)):  # probes on a pedestal read the shaft relative to it
            if h is not None:
                x[k], y[k] = x[k] - r.q[h[0]], y[k] - r.q[h[1]]
        xy = steady_signals(x, y, omega, t)
    elif method == "orbit":
        from ..progress import silent
        from ..rotor.orbit_balance import orbit_balance
        from ..rotor.orbit_stability import orbit_stability
        from ..errors import ConvergenceError
        from ..rotor.whirl import check_duration, equilibrium_stability, whirl_onset

        stab = equilibrium_stability(rotor, fb)
        n_keep = int(round(duration_s * sample_rate_hz))
        if stab.unstable:
            check_duration(stab, n_keep * dt)  # before the balance: a record too long is refused at once
        ob = orbit_balance(rotor, fb, machine_unbalance(machine), nodes=nodes, progress=progress or silent)
        extra = {"static_shift_um": " ".join(f"{v:.3f}" for v in 1e6 * np.ravel(np.stack([ob.x[0].real,
                                                                                          ob.y[0].real], 1))),
                 "ratio_2x": " ".join(f"{ob.harmonic_ratio(2, k):.4f}" for k in range(len(nodes))),
                 "stability": stab.describe()}
        if stab.unstable:  # the periodic orbit is not what the machine shows: the whirl grows on top of it
            try:
                tr, _ = whirl_onset(rotor, fb, machine_unbalance(machine), duration=n_keep * dt, dt=dt, nodes=nodes,
                                    start=ob.state(0.0), stability=stab, progress=progress or silent)
            except ConvergenceError as exc:
                raise ConvergenceError(f"{stab.describe()}: the record would hold its onset, but the time "
                                       f"integration on the films cannot follow this orbit ({exc})") from None
            t = tr.t[1:]
            dc = np.stack([ob.x[0].real, ob.y[0].real], 1).ravel()  # the orbit's static shift: the probes' gap
            xy = (tr.displacement[:, 1:] - dc[:, None]).reshape(len(nodes), 2, -1)
            extra.update({"method": "time integration on the p-theta films from the periodic orbit, disturbed "
                                    "along the unstable mode (oil whirl onset)",
                          "whirl_hz": f"{stab.frequency_hz:.3f}", "whirl_growth_per_s": f"{stab.growth:.4g}"})
        else:
            t = total_s - duration_s + dt * np.arange(1, n_keep + 1)
            x, y = ob.signals(t)
            x, y = x - ob.x[0].real[:, None], y - ob.y[0].real[:, None]  # the probes' DC gap removed
            xy = np.stack([x, y], axis=1)
            extra["method"] = "orbit (harmonic balance on the p-theta films, 0X-5X)"
            ost = orbit_stability(rotor, fb, ob)  # whether the machine stays on the periodic orbit written
            extra.update({"orbit_stability": ost.describe(), "orbit_stability_state": ost.state})
    else:
        raise InputError(f"method {method!r}; expected 'time', 'steady' or 'orbit'")
    # what the machine's probes read (SPEC §8: its planes' probe directions; X and Y at other nodes)
    planes = {p.node: tuple(float(v) for v in p.probe_angles_deg) for p in machine.measurement_planes}
    angles = tuple(planes.get(n, (0.0, 90.0)) for n in nodes)
    xy = np.stack([np.stack([math.cos(math.radians(a)) * xy[k, 0] + math.sin(math.radians(a)) * xy[k, 1]
                             for a in angles[k]]) for k in range(len(nodes))])
    if snr_db is not None:
        xy = add_noise(xy, snr_db, rng)
    return Record(speed_hz=speed_hz, sample_rate_hz=sample_rate_hz, displacement=xy, nodes=nodes,
                  probe_angles_deg=angles, t0=float(t[0]),
                  machine=Path(machine.source).name if machine.source else None,
                  metadata={**{f"q{k + 1}_mlmin": f"{q * MLMIN_PER_M3S:.6g}" for k, q in enumerate(flows)},
                            "snr_db": "none" if snr_db is None else f"{snr_db:g}", "synthetic": "lubeviz simulate",
                            **extra})


def steady_signals(x_amp, y_amp, omega: float, t) -> np.ndarray:
    """Probe signals x(t) = Re(X e^{i Omega t}), y(t) likewise, of steady 1X amplitudes X, Y (one per node).

    Returns shape (n_nodes, 2, n_t): for each node its x and y displacement (units of X, Y).
    """
    x_amp, y_amp = np.atleast_1d(x_amp), np.atleast_1d(y_amp)
    e = np.exp(1j * omega * np.asarray(t, dtype=float))
    return np.stack([(x_amp[:, None] * e).real, (y_amp[:, None] * e).real], axis=1)
