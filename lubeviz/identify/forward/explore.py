"""What the Rotor page shows, computed headless: the response at a node with or without an effect, the probe
signals and their full spectrum, the modes, the static positions; and the large orbit with its stability.

The page only displays these (and caches the rotor, tables and chains per server through `chain_for` and
`prepare`); tests call them without a browser.
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

from ...progress import ProgressFn, silent
from ...rotor.directional import directional_components, orbit_angle
from ...rotor.film_bearings import film_bearings
from ...rotor.modal import modal_analysis
from ...rotor.orbit_balance import orbit_balance
from ...rotor.orbit_stability import orbit_stability
from ...rotor.response import Unbalance, machine_unbalance
from ...rotor.whirl import equilibrium_stability
from ...signals.noise import add_noise
from ...signals.spectrum import full_spectrum
from ...signals.synthesize import steady_signals
from .chain import ForwardChain, bearing_changes
from .model import tabled_response

SAMPLES_PER_REV = 64  # the page's signals: 64 samples a revolution, 64 revolutions for the spectrum
REVOLUTIONS = 64


def prepare_views(chain: ForwardChain, effects, progress: ProgressFn = silent) -> None:
    """Build the coefficient views a chain with `effects` needs (a viscosity or clearance change: the film's
    tables at another Sommerfeld number, seconds the first time, then cached)."""
    for k, src in enumerate(chain.sources):
        src.view(*bearing_changes(effects, k, src.bearing.clearance).as_floats(), progress=progress)


def rotor_state(machine, tables, rotor, flows, node: int, effect=None, *, snr_db: float, seed: int,
                chain_for: Callable | None = None, prepare: Callable = prepare_views,
                progress: ProgressFn = silent) -> dict:
    """Everything the Rotor page draws at `flows` (m^3/s), `node` and `effect` (None: the plain model): the
    orbit there (with and without the effect), the static positions in each bearing, a noisy probe record
    of it (`snr_db`, seeded by `seed` + node) and its full spectrum, the modes.

    `chain_for(nodes)`: the plain forward chain at planes `nodes` (default: built here on `tables`)."""
    omega = tables[0].omega
    speed = omega / (2 * math.pi)
    if chain_for is None:
        def chain_for(nodes):
            return ForwardChain(machine, speed, nodes, tables=tables, rotor=rotor)
    resp = tabled_response(machine, tables, flows, rotor=rotor)
    x, y = base_x, base_y = resp.x[node - 1], resp.y[node - 1]
    theta = np.array(flows, dtype=float)
    centres = tuple(rotor.bearing_nodes)
    planes = chain_for(centres)  # the bearing centres: statics
    clearance = [b.clearance for b in machine.bearings]
    static0 = planes.output(theta).static - np.stack([np.zeros(len(clearance)), clearance], -1)
    static, clearance_eff, coefs = static0, clearance, None
    q_threshold = q_threshold0 = [tab.q_threshold for tab in tables]
    if effect is not None:
        effect = effect.bind(machine)
        effects = (effect,)
        prepare(planes, effects, progress)
        out = planes.with_effects(effects).output(theta)
        changes = [bearing_changes(effects, j, clearance[j]).as_floats() for j in range(len(clearance))]
        clearance_eff = [c.clearance for c in changes]
        static = out.static - np.stack([np.zeros(len(clearance)), clearance_eff], -1)
        if node in centres:
            j = centres.index(node)
            x, y = out.x[j], out.y[j]
        else:  # probes are on the measurement planes only: away from them the shaft's own motion
            shown = effects if effect.stage != "probes" else ()
            o = chain_for((node, *centres[1:])).with_effects(shown).output(theta)
            x, y = o.x[0], o.y[0]
        coefs = [planes.sources[j].evaluate(theta[j], *changes[j])[:2] for j in range(len(clearance))]
        # a worn bearing or another oil has its own flooded threshold: Q/Q_T is judged against it
        q_threshold = [planes.sources[j].view(*changes[j]).q_threshold for j in range(len(clearance))]
    fs = SAMPLES_PER_REV * speed
    t = np.arange(SAMPLES_PER_REV * REVOLUTIONS) / fs
    clean = steady_signals(np.array([x]), np.array([y]), omega, t)
    noisy = add_noise(clean, snr_db, np.random.default_rng(seed + node))
    spec = full_spectrum(noisy[0, 0] + 1j * noisy[0, 1], fs, speed)
    if coefs is None:
        coefs = [tab.coefficients(q) for tab, q in zip(tables, flows)]
    modal = modal_analysis(rotor, omega, coefs, n_modes=6)
    zf, zb = directional_components(x, y)
    zf0, zb0 = directional_components(base_x, base_y)
    return dict(resp=resp, node=node, x=x, y=y, base_x=base_x, base_y=base_y, t=t, clean=clean[0],
                noisy=noisy[0], fs=fs, speed=speed, spectrum=spec, modal=modal, flows=flows,
                q_threshold=q_threshold, q_threshold_declared=q_threshold0, effect=effect,
                zf=complex(zf), zb=complex(zb), phi=float(orbit_angle(zf, zb)), zf0=complex(zf0),
                zb0=complex(zb0), phi0=float(orbit_angle(zf0, zb0)), static=static, static0=static0,
                clearance=clearance, clearance_eff=clearance_eff)


def large_orbit(machine, rotor, flows, speed_hz: float, node: int, scale: float, resolution: tuple[int, int],
                progress: ProgressFn = silent):
    """The periodic orbit on the films at `flows` (m^3/s) and `speed_hz` under the machine's unbalance times
    `scale`, at `node`; the equilibrium's stability and the orbit's (Floquet multipliers)."""
    progress(0, 0, "film equilibria at the supply flows")
    bearings = film_bearings(machine, list(flows), 2 * math.pi * speed_hz)
    unbalances = [Unbalance(u.node, u.moment * scale, u.phase) for u in machine_unbalance(machine)]
    harmonics, points = resolution
    orbit = orbit_balance(rotor, bearings, unbalances, nodes=(node,), harmonics=harmonics, points=points,
                          progress=progress)
    progress(0, 0, "the orbit's stability (Floquet multipliers)")
    return orbit, equilibrium_stability(rotor, bearings), orbit_stability(rotor, bearings, orbit)
