"""Sub-synchronous whirl: the equilibrium's stability on the films, and the onset of oil whirl in time.

Above the instability threshold (`rotor.stability`: the lowest speed where a mode's damping crosses zero)
the static equilibrium on the films is linearly unstable: a forward mode, near the first bending
frequency and at 0.42-0.5 of the shaft speed, grows as e^{sigma t} out of any disturbance (oil whirl,
and oil whip once it locks onto the critical). The periodic orbit that the harmonic balance finds there
(`rotor.orbit_balance`) is a solution of the equations but not what a machine shows: the whirl grows
on top of it, a sub-synchronous line in the spectrum that the balance, periodic at the shaft speed,
cannot hold.

`equilibrium_stability` gives the least stable mode of the linearized machine (K, C of the films at their
equilibria): its damped frequency, growth rate sigma (1/s, > 0: unstable) and shape. `whirl_onset`
integrates the machine on its p-theta films in time (`film_transient.film_time_response`, the film
re-solved at every step, its nonlinear part coupled implicitly: the orbits at the paper's unbalance are
far from the film's linearization) from a start orbit disturbed along that mode, so the record holds the
whirl's growth (above the threshold) or its decay (below). The whirl grows until it nears the wall (oil
whip, a limit cycle the quasi-static film cannot follow): `reach_time` is how long a disturbance of a
given size takes to grow to a stated fraction of the clearance, and a request beyond it is refused before
any work is done.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ..errors import InputError
from ..progress import ProgressFn, silent
from .assembly import Rotor
from .elements import X, Y, node_dofs
from .film_bearings import FilmBearings
from .film_transient import FilmTimeResponse, film_time_response
from .response import Unbalance, unbalance_response
from .transient import linear_system

KICK = 0.005  # the disturbance along the whirl mode, largest journal displacement relative to the clearance
REACH = 0.15  # the whirl's size (of the clearance) up to which its onset is computed


@dataclass(frozen=True)
class Stability:
    """The least stable mode of the machine linearized at its equilibrium on the films."""

    omega: float  # shaft speed (rad/s)
    frequency_hz: float  # damped frequency of the mode
    growth: float  # sigma (1/s): Re(lambda); > 0 grows (unstable)
    damping_ratio: float  # -sigma / |lambda|
    forward: bool  # whirls with the shaft
    mode: np.ndarray  # (2 n_dof,) complex state eigenvector (q, q')

    @property
    def unstable(self) -> bool:
        return self.growth > 0.0

    @property
    def order(self) -> float:
        """The mode's frequency over the shaft speed (oil whirl: 0.42-0.5)."""
        return 2 * math.pi * self.frequency_hz / self.omega

    def describe(self) -> str:
        kind = "forward" if self.forward else "backward"
        if self.unstable:
            return (f"above the instability threshold: a {kind} mode at {self.frequency_hz:.1f} Hz "
                    f"({self.order:.2f}X) grows e-fold every {1 / self.growth:.3g} s (oil whirl)")
        return (f"below the instability threshold: the least damped mode, {kind} at {self.frequency_hz:.1f} Hz "
                f"({self.order:.2f}X), has a damping ratio {self.damping_ratio:.3f}")


def equilibrium_stability(rotor: Rotor, bearings: FilmBearings) -> Stability:
    """The least stable mode (largest Re(lambda)) with 0 < frequency, of the machine on `bearings`' K, C."""
    return mode_stability(rotor, bearings.omega, bearings.coefficients)


def mode_stability(rotor: Rotor, omega: float, coefficients) -> Stability:
    """As `equilibrium_stability`, from one (K, C) per bearing at shaft speed `omega` (e.g. from the tables)."""
    ls = linear_system(rotor, omega, coefficients)
    lam = ls.eigenvalues
    candidates = np.flatnonzero(lam.imag > 1e-6 * omega)
    k = int(candidates[np.argmax(lam[candidates].real)])
    v = ls.V[:, k]
    n = rotor.n_dof
    # the whirl direction at the bearings: x + iy = (vx + i vy) e^{i w t} / 2 + conj((vx - i vy) e^{i w t}) / 2
    dofs = np.array([node_dofs(nd)[[X, Y]] for nd in rotor.bearing_nodes])
    zf = np.abs(v[dofs[:, 0]] + 1j * v[dofs[:, 1]]).sum()
    zb = np.abs(v[dofs[:, 0]] - 1j * v[dofs[:, 1]]).sum()
    return Stability(omega=omega, frequency_hz=float(lam[k].imag / (2 * math.pi)), growth=float(lam[k].real),
                     damping_ratio=float(-lam[k].real / abs(lam[k])), forward=bool(zf >= zb), mode=v[:2 * n])


def reach_time(stability: Stability, kick: float = KICK, reach: float = REACH) -> float:
    """Seconds for a disturbance of `kick` (of the clearance) to grow to `reach` (inf when it decays)."""
    if not stability.unstable:
        return math.inf
    return math.log(reach / kick) / stability.growth


def check_duration(stability: Stability, duration: float, kick: float = KICK) -> None:
    """Refuse (InputError) a whirl onset longer than the whirl stays within the integration's reach."""
    t_reach = reach_time(stability, kick)
    if duration > t_reach:
        raise InputError(f"{stability.describe()}; from a disturbance of {kick:.1%} of the clearance it reaches "
                         f"{REACH:.0%} of it after {t_reach:.2f} s, beyond which the film's time integration "
                         f"does not hold (oil whip, a limit cycle near the wall): ask for at most {t_reach:.2f} s")


def whirl_onset(rotor: Rotor, bearings: FilmBearings, unbalances: Sequence[Unbalance], *, duration: float,
                dt: float = 1e-4, nodes: Sequence[int] | None = None, start: np.ndarray | None = None,
                kick: float = KICK, stability: Stability | None = None, implicit: bool = True,
                progress: ProgressFn = silent) -> tuple[FilmTimeResponse, Stability]:
    """The machine on its films integrated in time for `duration` s from `start` (a state (q, q') from the
    equilibrium, e.g. `OrbitBalance.state()`; default the linear steady orbit) disturbed along its least
    stable mode by `kick` of the clearance (largest journal displacement). Refuses a duration over which an
    unstable whirl would grow beyond a fraction of the clearance (`reach_time`)."""
    rotor.require_films_on_ground("the whirl's onset on the p-theta films")
    stab = stability or equilibrium_stability(rotor, bearings)
    check_duration(stab, duration, kick)
    n = rotor.n_dof
    if start is None:
        q = unbalance_response(rotor, bearings.omega, unbalances, bearings.coefficients).q
        start = np.concatenate([q.real, (1j * bearings.omega * q).real])
    start = np.asarray(start, dtype=float)
    if start.shape != (2 * n,):
        raise InputError(f"whirl_onset: start state of {start.shape} values; expected {2 * n}")
    v = stab.mode
    dofs = np.array([node_dofs(nd)[[X, Y]] for nd in rotor.bearing_nodes])
    clearance = np.array([e.bearing.clearance for e in bearings.equilibria])
    size = np.max(np.abs(v[dofs]).max(axis=1) / clearance)
    z0 = start + kick * np.real(v / size)  # the mode's real part at t = 0: q and q' consistent
    tr = film_time_response(rotor, bearings, unbalances, duration=duration, dt=dt, nodes=nodes, start=z0,
                            implicit=implicit, progress=progress)
    return tr, stab


WHIRL_MATCH = 0.1  # a line within this fraction of a mode's frequency is read as that mode


def whirl_reading(stability: Stability, line_hz: float) -> str:
    """What the model's stability at the identified flows says of a sub-synchronous line at `line_hz` (Hz):
    oil whirl (the model is above its threshold and its unstable mode is at the line), a lightly damped
    film mode excited near the threshold, or neither (then not oil whirl, as far as the model knows)."""
    near = abs(line_hz - stability.frequency_hz) <= WHIRL_MATCH * stability.frequency_hz
    order = 2 * math.pi * line_hz / stability.omega
    head = f"the sub-synchronous line at {line_hz:.1f} Hz ({order:.2f}X)"
    if stability.unstable and near:
        return (f"{head} is oil whirl: at the flows found the model is above its instability threshold, its "
                f"unstable forward mode at {stability.frequency_hz:.1f} Hz growing e-fold every "
                f"{1 / stability.growth:.2g} s; lower the speed or change the supply before it locks into oil whip")
    if stability.unstable:
        return (f"{head} is not at the model's unstable mode ({stability.frequency_hz:.1f} Hz), though at the flows "
                "found the model is above its instability threshold: oil whirl is to be expected, and this line "
                "may be it on a machine that differs from the model, or another cause")
    if near and stability.damping_ratio < 0.1:
        return (f"{head} sits at the model's least damped mode ({stability.frequency_hz:.1f} Hz, damping ratio "
                f"{stability.damping_ratio:.3f}): the film's whirl mode excited below the threshold (oil whirl "
                "near its onset, or a machine less stable than the model)")
    return (f"{head} is not oil whirl as far as the model knows: at the flows found it is below its instability "
            f"threshold with no lightly damped mode there ({stability.describe()}); look for a rub, a loose part "
            "(1/2X) or a neighbouring machine")
