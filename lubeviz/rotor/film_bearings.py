"""The machine on its film bearings: each bearing's equilibrium and coefficients at its supply flow.

This is where the film model (Sec. 2.1) meets the rotor (Sec. 2.2): the static load on each journal
is its support reaction from the rotor's weight (`statics.bearing_static_loads`; on 3+ supports moved by where the
journals sit at their flows, `load_shift.LoadShift`), the film finds the
journal's equilibrium for the bearing's own supply flow, and its K, C enter Eq. 8: by default the
sub-cell tangent (`find_equilibrium`'s default, smooth in the supply); `coefficients="fixed-pattern"`
gives the exact small-amplitude derivative of this mesh's discrete film instead (what a time
integration on that film tends to as the orbit shrinks, `film_transient`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ..errors import ConvergenceError, InputError
from ..film.equilibrium import DEFAULT_COEFFICIENTS, Equilibrium, find_equilibrium, flooded_threshold
from ..film.feed import Feed
from .assembly import Rotor, rotor_from_machine
from .response import UnbalanceResponse, machine_unbalance, unbalance_response
from .load_shift import STEPS
from .statics import bearing_static_loads
from ..units import MLMIN_PER_M3S


@dataclass(frozen=True)
class FilmBearings:
    """Both bearings of a machine at one speed: equilibria (with K, C) and their supply flows (m^3/s)."""

    omega: float
    flows: tuple[float, ...]
    equilibria: tuple[Equilibrium, ...]

    @property
    def coefficients(self) -> list[tuple[np.ndarray, np.ndarray]]:
        """One (K, C) pair per bearing, SPEC §1 sign, for `unbalance_response` and friends."""
        return [(e.coefficients.K, e.coefficients.C) for e in self.equilibria]


def _flows(machine, flows) -> tuple[float, ...]:
    flows = tuple(float(q) for q in flows)
    if len(flows) != len(machine.bearings):
        raise InputError(f"{len(flows)} supply flows for {len(machine.bearings)} bearings")
    for k, q in enumerate(flows, start=1):
        if not (math.isfinite(q) and q > 0.0):
            raise InputError(f"supply flow of bearing {k}: {q!r} m^3/s; expected a positive number")
    return flows


def film_bearings(machine, flows: Sequence[float], omega: float | None = None, *,
                  previous: FilmBearings | None = None, coefficients: str = DEFAULT_COEFFICIENTS) -> FilmBearings:
    """Equilibrium and coefficients of every bearing at its supply flow (m^3/s) and speed (rad/s).

    `previous` (a nearby operating point) warm-starts each equilibrium from its position and film.
    `coefficients`: how K, C are computed at each equilibrium (`find_equilibrium`'s option).
    Raises ConvergenceError naming the bearing and flow when no equilibrium is found.
    """
    omega = 2.0 * math.pi * machine.operating_speed if omega is None else float(omega)
    if not (math.isfinite(omega) and omega > 0.0):
        raise InputError(f"shaft speed {omega!r} rad/s; expected a positive number")
    flows = _flows(machine, flows)
    loads = bearing_static_loads(machine)
    eqs = _equilibria(machine, omega, flows, loads, previous.equilibria if previous is not None else None,
                      coefficients)
    shift = _load_shift(machine, omega)
    if shift is not None:  # 3+ supports: the loads follow the journals (a starved film's journal sinks)
        loads = None
        for _ in range(STEPS):
            loads = shift.shifted(np.array([e.position for e in eqs]), np.array([e.coefficients.K for e in eqs]),
                                  loads)
            eqs = _equilibria(machine, omega, flows, loads, eqs, coefficients)
    return FilmBearings(omega=omega, flows=flows, equilibria=tuple(eqs))


def _equilibria(machine, omega, flows, loads, previous, coefficients) -> list:
    eqs = []
    for k, (b, q, load) in enumerate(zip(machine.bearings, flows, loads)):
        prev = previous[k] if previous is not None else None
        eq = find_equilibrium(b, omega, load, Feed.flow(q), start=None if prev is None else prev.position,
                              warm=None if prev is None else prev.film, coefficients=coefficients)
        if not eq.converged:
            raise ConvergenceError(f"bearing {k + 1} at {q * MLMIN_PER_M3S:.1f} ml/min, {omega / 2 / math.pi:g} Hz: "
                                   f"{eq.message}")
        eqs.append(eq)
    return eqs


def _load_shift(machine, omega: float):
    """The `LoadShift` of a machine on 3+ supports about its statics (flooded films at the operating speed: a record
    at another speed moves its journals, and the loads, as its flows do), None on two bearings."""
    from .load_shift import LoadShift
    from .statics import statically_determinate

    rotor = rotor_from_machine(machine)
    if statically_determinate(machine, rotor):
        return None
    from .statics import coupled_statics

    statics = coupled_statics(machine)
    return LoadShift(rotor, [b.node for b in machine.bearings], statics.loads, statics.positions)


def equilibrium_flow_slopes(machine, fb: FilmBearings, thresholds=None, *, rel: float = 1e-3,
                            coefficients: str = DEFAULT_COEFFICIENTS) -> list[tuple]:
    """Each bearing's equilibrium derivatives in its own supply flow: (d position (2,), d K (2, 2), d C (2, 2))
    per m^3/s, by central differences of +-`rel` of the flow, warm-started from `fb` (two equilibria each). A
    flow within that step of its Q_T (`thresholds`, m^3/s), where the film's response has its kink, takes the
    one-sided difference on its own side. `coefficients`: how K, C are computed, as `fb` was (`film_bearings`).
    For the harmonic balance's `flow_slopes`."""
    loads = bearing_static_loads(machine)
    out = []
    for k, (b, q, load, e0) in enumerate(zip(machine.bearings, fb.flows, loads, fb.equilibria)):
        h = rel * q
        qt = None if thresholds is None else float(thresholds[k])
        if qt is None or q - h >= qt or q + h < qt:
            sides = (+h, -h)
        else:
            sides = (+h,) if q >= qt else (-h,)
        got = []
        for hs in sides:
            eq = find_equilibrium(b, fb.omega, load, Feed.flow(q + hs), start=e0.position, warm=e0.film,
                                  coefficients=coefficients)
            if not eq.converged:
                raise ConvergenceError(f"bearing {k + 1} at {(q + hs) * MLMIN_PER_M3S:.1f} ml/min: {eq.message}")
            got.append((hs, np.asarray(eq.position, float), eq.coefficients.K, eq.coefficients.C))
        if len(got) == 1:
            got.append((0.0, np.asarray(e0.position, float), e0.coefficients.K, e0.coefficients.C))
        (ha, pa, Ka, Ca), (hb, pb, Kb, Cb) = got
        out.append(((pa - pb) / (ha - hb), (Ka - Kb) / (ha - hb), (Ca - Cb) / (ha - hb)))
    return out


def flooded_thresholds(machine, omega: float | None = None) -> np.ndarray:
    """Q_T of each bearing (m^3/s) under its static load at `omega` (rad/s; default the operating speed)."""
    omega = 2.0 * math.pi * machine.operating_speed if omega is None else float(omega)
    loads = bearing_static_loads(machine)
    return np.array([flooded_threshold(b, omega, load)[0] for b, load in zip(machine.bearings, loads)])


def machine_response(machine, flows: Sequence[float], omega: float | None = None, *,
                     nodes: Sequence[int] | None = None, rotor: Rotor | None = None,
                     bearings: FilmBearings | None = None) -> tuple[UnbalanceResponse, FilmBearings]:
    """Steady unbalance response of the machine with both bearings at their supply flows (m^3/s)."""
    omega = 2.0 * math.pi * machine.operating_speed if omega is None else float(omega)
    rotor = rotor_from_machine(machine) if rotor is None else rotor
    fb = film_bearings(machine, flows, omega) if bearings is None else bearings
    nodes = tuple(machine.center_nodes) if nodes is None else tuple(nodes)
    return unbalance_response(rotor, omega, machine_unbalance(machine), fb.coefficients, nodes=nodes), fb
