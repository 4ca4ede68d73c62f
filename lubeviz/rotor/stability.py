"""Campbell diagram over speed on speed-dependent film coefficients; critical speeds and the
instability threshold (paper Sec. 3: the operating speed, 75 Hz, lies between the first critical
speed and the instability threshold).

Two steps, usable apart:
1. `film_coefficients_over_speed`: at every speed, each bearing's static equilibrium under its share
   of the weight (`bearing_static_loads`; on 3+ supports the share moves with the speed and the flows, as the
   journals do: `rotor.load_shift`, its Newton steps at every speed) and its fixed-pattern K, C (Lund's sign,
   SPEC §1), swept from the highest speed down, each equilibrium warm-started from the previous speed's.
2. `stability_map`: the damped modes of Eq. 8 at every speed on those coefficients (or on any
   coefficients: a callable speed -> one (K, C) per bearing), modes tracked from speed to speed, and the
   1X crossings and zero-damping crossings found by linear interpolation between sweep points.

Supply rule (`Supply`). The default is a fixed *fraction of the flooded threshold* Q_T(Omega), 1.0:
Q_T grows with speed (the paper's bearing: 211 ml/min at 5 Hz, 545 at 75 Hz, 585 at 150 Hz), so a fixed
flow would starve the bearing above the speed it was set for and over-feed it below, mixing two effects
in one curve. Holding q/Q_T fixed keeps the lubrication condition the same along the sweep, so the
Campbell diagram shows the effect of speed alone and the curves for 0.5-1.5 Q_T compare like with like.
A fixed flow per bearing (the paper's 546 ml/min, a pump that does not follow the speed) is the option.

Mode tracking. Each speed's modes are matched to the previous speed's by the modal assurance
criterion of the complex mode shapes, MAC = |a^H b|^2 / (|a|^2 |b|^2), with an optimal one-to-one
assignment (scipy's linear_sum_assignment). Forward and backward whirl of the same shape are orthogonal
in this product, so the match keeps the whirl direction; a match with MAC below `min_mac` starts a new
track. Sorting by frequency instead would swap labels wherever two lines cross, and near 80 Hz on the
paper's machine the lightly damped bending mode crosses two heavily damped film modes.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

from ..errors import ConvergenceError, InputError
from ..film.equilibrium import Equilibrium, find_equilibrium
from ..film.feed import Feed
from ..progress import ProgressFn, silent
from .assembly import Rotor, rotor_from_machine
from .modal import modal_analysis
from .load_shift import STEPS
from .statics import bearing_static_loads
from ..units import MLMIN_PER_M3S

TWO_PI = 2.0 * math.pi


# --- supply rule and film coefficients over speed ----------------------------------------------------

@dataclass(frozen=True)
class Supply:
    """How much oil each bearing gets at each speed.

    kind "threshold_fraction": q = value * Q_T(Omega) (the default, value 1.0); kind "flow": q = value
    (m^3/s), fixed. `value` is one number for every bearing or a tuple with one per bearing.
    """

    kind: str
    value: tuple[float, ...] | float

    @staticmethod
    def threshold_fraction(fraction=1.0) -> Supply:
        return Supply("threshold_fraction", _positive_values(fraction, "supply fraction of Q_T"))

    @staticmethod
    def flow(q_supply) -> Supply:
        return Supply("flow", _positive_values(q_supply, "supply flow (m^3/s)"))

    def per_bearing(self, n: int) -> tuple[float, ...]:
        v = self.value if isinstance(self.value, tuple) else (self.value,)
        if len(v) == 1:
            return v * n
        if len(v) != n:
            raise InputError(f"supply {self.describe()} gives {len(v)} values for {n} bearings")
        return v

    def describe(self) -> str:
        v = self.value if isinstance(self.value, tuple) else (self.value,)
        if self.kind == "flow":
            return "fixed flow " + "/".join(f"{x * MLMIN_PER_M3S:.4g}" for x in v) + " ml/min"
        return "/".join(f"{x:.4g}" for x in v) + " x Q_T(speed)"


def _positive_values(value, what) -> tuple[float, ...] | float:
    vals = np.atleast_1d(np.asarray(value, dtype=float))
    if vals.ndim != 1 or vals.size == 0 or not np.all(np.isfinite(vals) & (vals > 0.0)):
        raise InputError(f"{what} {value!r}: expected one positive number or one per bearing")
    return float(vals[0]) if vals.size == 1 else tuple(float(x) for x in vals)


@dataclass(frozen=True)
class SpeedCoefficients:
    """Film equilibrium and coefficients per speed (rows, ascending) and bearing (columns).

    q_supply, q_threshold (m^3/s), eccentricity_ratio: (n_speeds, n_bearings); position (m): (.., 2);
    K (N/m), C (N s/m): (n_speeds, n_bearings, 2, 2), SPEC §1 sign.
    """

    speeds: np.ndarray
    supply: Supply
    q_supply: np.ndarray
    q_threshold: np.ndarray
    eccentricity_ratio: np.ndarray
    position: np.ndarray
    K: np.ndarray
    C: np.ndarray
    seconds: float
    loads: np.ndarray | None = None  # (n_speeds, n_bearings, 2) N: the static loads each speed's films carry

    def bearings_at(self, omega: float) -> list[tuple[np.ndarray, np.ndarray]]:
        """One (K, C) per bearing at a sweep speed (exactly one of `speeds`); for `stability_map`."""
        i = int(np.argmin(np.abs(self.speeds - omega)))
        if not math.isclose(self.speeds[i], omega, rel_tol=1e-12, abs_tol=1e-12):
            raise InputError(f"speed {omega!r} rad/s is not a sweep speed; coefficients are only known at "
                             f"{self.speeds.size} sweep speeds")
        return [(self.K[i, j], self.C[i, j]) for j in range(self.K.shape[1])]


def _check_speeds(speeds) -> np.ndarray:
    speeds = np.atleast_1d(np.asarray(speeds, dtype=float))
    if speeds.ndim != 1 or speeds.size == 0 or not np.all(np.isfinite(speeds) & (speeds > 0.0)):
        raise InputError(f"speeds must be a non-empty 1-D sequence of positive numbers (rad/s), got {speeds!r}")
    if np.any(np.diff(np.sort(speeds)) <= 0.0):
        raise InputError("speeds must be distinct")
    return np.sort(speeds)


def film_coefficients_over_speed(machine, speeds, supply: Supply | None = None, *, loads=None,
                                 max_eccentricity: float = 0.9,
                                 progress: ProgressFn = silent) -> SpeedCoefficients:
    """Each bearing's equilibrium and fixed-pattern K, C at every speed (rad/s) under `supply`.

    Swept from the highest speed down (the lightly loaded end first), each solve warm-started from the
    previous speed's position and cavitation pattern. `loads`: external load per bearing [[Wx, Wy], ..]
    (N), default the support reactions of the rotor's weight. Raises InputError at a speed where the film
    needs an eccentricity ratio above `max_eccentricity` to carry the load (default 0.9: minimum film
    1/10 of the clearance, 12 um on the paper's bearing; the rigid, isothermal, smooth-surface film and
    its linearization are not to be trusted closer to contact), ConvergenceError where the equilibrium
    search fails.
    """
    t0 = time.perf_counter()
    speeds = _check_speeds(speeds)
    supply = Supply.threshold_fraction(1.0) if supply is None else supply
    if supply.kind not in ("threshold_fraction", "flow"):
        raise InputError(f"unknown supply kind {supply.kind!r}; use Supply.threshold_fraction or Supply.flow")
    bearings = list(machine.bearings)
    nb = len(bearings)
    default_loads = loads is None
    loads = bearing_static_loads(machine) if loads is None else np.asarray(loads, dtype=float)
    if loads.shape != (nb, 2):
        raise InputError(f"loads must be one [Wx, Wy] per bearing, shape ({nb}, 2); got {loads.shape}")
    values = supply.per_bearing(nb)
    n = speeds.size
    out = {k: np.empty((n, nb)) for k in ("q_supply", "q_threshold", "eccentricity_ratio")}
    position, K, C = np.empty((n, nb, 2)), np.empty((n, nb, 2, 2)), np.empty((n, nb, 2, 2))
    loads_out = np.empty((n, nb, 2))
    flooded_hist: list[list[tuple[float, Equilibrium]]] = [[] for _ in range(nb)]
    flow_hist: list[list[tuple[float, Equilibrium]]] = [[] for _ in range(nb)]
    twin = _identical_predecessor(bearings, loads)
    shift = _load_shift(machine) if default_loads else None
    current = loads.copy()  # the loads at the previous speed: the next speed's first guess

    def solve(w, at) -> list[tuple[Equilibrium, Equilibrium, float]]:
        """(flooded, supplied, q) of every bearing at speed w under loads `at`."""
        got = []
        for j, b in enumerate(bearings):
            where = f"{b.name} at {w / TWO_PI:.4g} Hz"
            t = twin[j] if shift is None else None  # twins carry the same load only where the loads are fixed
            # Q_T(Omega): side leakage of the flooded film at its equilibrium (film.equilibrium.flooded_threshold),
            # started from the equilibrium extrapolated from the two previous speeds, or from an identical bearing.
            start = (got[t][0] if t is not None else _predict(flooded_hist[j], w))
            flooded = _equilibrium(b, w, at[j], Feed.flooded(), start, where, max_eccentricity)
            q_t = flooded.film.side_leakage
            q = values[j] * q_t if supply.kind == "threshold_fraction" else values[j]
            # The supplied film moves with speed like the flooded one: shift the previous speed's position by
            # the flooded film's move (at q = Q_T this is nearly exact, one Newton step).
            if t is not None and values[t] == values[j]:
                start = got[t][1]
            elif flow_hist[j]:
                prev = flow_hist[j][-1][1]
                start = (prev.position + flooded.position - flooded_hist[j][-1][1].position, prev.film)
            else:
                start = flooded
            eq = _equilibrium(b, w, at[j], Feed.flow(q), start, where, max_eccentricity)
            got.append((flooded, eq, q))
        return got

    for step, i in enumerate(range(n - 1, -1, -1)):
        w = float(speeds[i])
        got = solve(w, current)
        if shift is not None:  # 3+ supports: the loads at this speed's journals (`rotor.load_shift`, Newton steps)
            for _ in range(STEPS):
                current = shift.shifted(np.array([g[1].position for g in got]),
                                        np.array([g[1].coefficients.K for g in got]), current)
                got = solve(w, current)
        for j, b in enumerate(bearings):
            flooded, eq, q = got[j]
            flooded_hist[j].append((w, flooded))
            flow_hist[j].append((w, eq))
            del flooded_hist[j][:-2], flow_hist[j][:-2]
            if not (np.all(np.isfinite(eq.coefficients.K)) and np.all(np.isfinite(eq.coefficients.C))):
                raise ConvergenceError(f"{b.name} at {w / TWO_PI:.4g} Hz: film coefficients are not finite "
                                       f"({eq.coefficients.method})")
            out["q_supply"][i, j], out["q_threshold"][i, j] = q, flooded.film.side_leakage
            out["eccentricity_ratio"][i, j] = eq.eccentricity_ratio
            position[i, j], K[i, j], C[i, j] = eq.position, eq.coefficients.K, eq.coefficients.C
        loads_out[i] = current
        progress(step + 1, n, f"film {w / TWO_PI:.4g} Hz")
    return SpeedCoefficients(speeds=speeds, supply=supply, position=position, K=K, C=C, loads=loads_out,
                             seconds=time.perf_counter() - t0, **out)


def _load_shift(machine):
    """The `LoadShift` of a machine on 3+ supports (the loads at each speed's journals), None on two bearings."""
    from .film_bearings import _load_shift as shift_of

    return shift_of(machine, 2.0 * math.pi * machine.operating_speed)


def _identical_predecessor(bearings, loads) -> list[int | None]:
    """For each bearing, an earlier bearing with the same geometry, oil and mesh and nearly the same load
    (the paper's two bearings: 3272.77 N and 3272.87 N), whose equilibrium at the same speed is an
    excellent start (one Newton step); None if there is none."""
    out: list[int | None] = []
    for j, b in enumerate(bearings):
        mine = {k: v for k, v in b.param.values().items() if k not in ("name", "node")}
        out.append(next((k for k in range(j)
                         if {q: v for q, v in bearings[k].param.values().items() if q not in ("name", "node")} == mine
                         and np.linalg.norm(loads[k] - loads[j]) <= 1e-3 * np.linalg.norm(loads[j])), None))
    return out


def _predict(history: list[tuple[float, Equilibrium]], omega: float):
    """Start for the equilibrium at `omega`: linear extrapolation in speed of the last two positions,
    with the last cavitation pattern; None (cold, short-bearing guess) without history."""
    if not history:
        return None
    w1, e1 = history[-1]
    if len(history) == 1:
        return e1
    w0, e0 = history[-2]
    return e1.position + (e1.position - e0.position) * (omega - w1) / (w1 - w0), e1.film


def _equilibrium(bearing, omega, load, feed, start, where, max_eccentricity) -> Equilibrium:
    """find_equilibrium from `start`: None, an Equilibrium, or (position, film); raises on failure."""
    if isinstance(start, Equilibrium):
        start = (start.position, start.film)
    pos, film = (None, None) if start is None else start
    if pos is not None and np.hypot(*pos) > 0.98 * bearing.clearance:  # an extrapolation past the clearance
        pos = np.asarray(pos) * (0.98 * bearing.clearance / np.hypot(*pos))
    eq = find_equilibrium(bearing, omega, load, feed, start=pos, warm=film)
    if not eq.converged:
        raise ConvergenceError(f"{where}, {feed.describe()}: no static equilibrium under "
                               f"{np.hypot(*load):.5g} N ({eq.message}); the film cannot carry the load "
                               "at this speed: raise the lowest speed")
    if eq.eccentricity_ratio > max_eccentricity:
        raise InputError(f"{where}, {feed.describe()}: the film carries {np.hypot(*load):.5g} N only at "
                         f"eccentricity ratio {eq.eccentricity_ratio:.3f} > {max_eccentricity:g} (minimum film "
                         f"{(1 - eq.eccentricity_ratio) * bearing.clearance * 1e6:.3g} um): below this speed the "
                         "film model cannot carry the load; raise the lowest speed")
    return eq


# --- modes over speed, tracked; crossings --------------------------------------------------------------

@dataclass(frozen=True)
class Crossing:
    """Where a tracked mode crosses the 1X line or zero damping (speed by linear interpolation, rad/s)."""

    speed: float
    mode: int | None  # track index into StabilityMap columns; None: a root outside the tracked modes
    frequency: float  # damped frequency of the mode there (rad/s)
    damping_ratio: float
    whirl: str

    @property
    def speed_hz(self) -> float:
        return self.speed / TWO_PI

    @property
    def frequency_hz(self) -> float:
        return self.frequency / TWO_PI


@dataclass(frozen=True)
class StabilityMap:
    """Campbell data with modes tracked over speed (rows: speeds ascending, columns: tracks).

    damped_frequencies (rad/s), damping_ratios, forward_ratio (|Zf|/(|Zf|+|Zb|) at the largest orbit):
    (n_speeds, n_tracks), NaN where a track has no mode; whirl: per speed, per track "forward",
    "backward" or "" (absent). max_real_part: largest Re(lambda) over *all* roots per speed (1/s).
    critical_speeds: every forward-mode crossing of the 1X line, ascending; a crossing counts when the mode
    whirls forward at both bracketing speeds (an orbit close to a line, forward_ratio ~ 0.5, may flip
    label between speeds and is then not counted). first_critical_speed and
    instability_threshold in rad/s (None if none in the range; a threshold equal to the lowest speed
    means the rotor is already unstable there).
    """

    speeds: np.ndarray
    damped_frequencies: np.ndarray
    damping_ratios: np.ndarray
    forward_ratio: np.ndarray
    whirl: tuple[tuple[str, ...], ...]
    max_real_part: np.ndarray
    critical_speeds: tuple[Crossing, ...]
    unstable_mode: Crossing | None

    @property
    def first_critical_speed(self) -> float | None:
        return self.critical_speeds[0].speed if self.critical_speeds else None

    @property
    def instability_threshold(self) -> float | None:
        return None if self.unstable_mode is None else self.unstable_mode.speed

    @property
    def stable(self) -> np.ndarray:
        return self.max_real_part < 0.0

    @property
    def damped_frequencies_hz(self) -> np.ndarray:
        return self.damped_frequencies / TWO_PI


def _mac(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Modal assurance criterion between the columns of a and b (complex)."""
    num = np.abs(a.conj().T @ b) ** 2
    return num / np.outer(np.sum(np.abs(a) ** 2, axis=0), np.sum(np.abs(b) ** 2, axis=0))


def _interp_zero(x0, x1, y0, y1) -> float:
    return float(x0 + y0 * (x1 - x0) / (y0 - y1)) if y0 != y1 else float(x0)


def stability_map(rotor: Rotor, speeds, bearing_coefficients: Callable[[float], list], *, n_modes: int = 8,
                  min_mac: float = 0.5, progress: ProgressFn = silent) -> StabilityMap:
    """Damped modes at each speed (rad/s), tracked by MAC; 1X crossings and the instability threshold.

    `bearing_coefficients(omega)` returns one (K, C) per bearing (e.g. `SpeedCoefficients.bearings_at`).
    The lowest `n_modes` underdamped modes are tracked at each speed; stability is judged on all roots.
    """
    speeds = _check_speeds(speeds)
    if not (isinstance(n_modes, (int, np.integer)) and n_modes >= 1):
        raise InputError(f"n_modes = {n_modes!r}; expected a positive integer")
    n = speeds.size
    tracks: list[dict] = []  # per track: {speed index: (lambda, forward_ratio, whirl)}
    last_shapes, last_ids = None, []
    max_real = np.empty(n)
    for i, w in enumerate(speeds):
        res = modal_analysis(rotor, float(w), bearing_coefficients(float(w)), n_modes=n_modes)
        max_real[i] = res.max_real_part
        ids = [-1] * res.eigenvalues.size
        if last_shapes is not None and res.eigenvalues.size and last_shapes.shape[1]:
            mac = _mac(last_shapes, res.modes)
            rows, cols = linear_sum_assignment(-mac)
            for r, c in zip(rows, cols):
                if mac[r, c] >= min_mac:
                    ids[c] = last_ids[r]
        for k in range(len(ids)):
            if ids[k] < 0:
                ids[k] = len(tracks)
                tracks.append({})
            tracks[ids[k]][i] = (res.eigenvalues[k], res.forward_ratio[k], res.whirl[k])
        last_shapes, last_ids = res.modes, ids
        progress(i + 1, n, f"modes {w / TWO_PI:.4g} Hz")

    m = len(tracks)
    lam = np.full((n, m), np.nan + 0j)
    fwd = np.full((n, m), np.nan)
    whirl = [[""] * m for _ in range(n)]
    for t, tr in enumerate(tracks):
        for i, (lm, fr, wh) in tr.items():
            lam[i, t], fwd[i, t], whirl[i][t] = lm, fr, wh
    wd = lam.imag
    zeta = -lam.real / np.abs(lam)

    critical = []
    unstable = []
    for t in range(m):
        for i in range(n - 1):
            if np.isnan(wd[i, t]) or np.isnan(wd[i + 1, t]):
                continue
            g0, g1 = wd[i, t] - speeds[i], wd[i + 1, t] - speeds[i + 1]
            if whirl[i][t] == whirl[i + 1][t] == "forward" and (g0 >= 0.0) != (g1 >= 0.0):
                s = _interp_zero(speeds[i], speeds[i + 1], g0, g1)
                f = (s - speeds[i]) / (speeds[i + 1] - speeds[i])
                critical.append(Crossing(s, t, s, float((1 - f) * zeta[i, t] + f * zeta[i + 1, t]), "forward"))
        z = zeta[:, t]
        first = np.flatnonzero(~np.isnan(z))
        if first.size and z[first[0]] <= 0.0:
            unstable.append(Crossing(float(speeds[first[0]]), t, float(wd[first[0], t]), float(z[first[0]]),
                                     whirl[first[0]][t]))
        for i in range(n - 1):
            if not np.isnan(z[i]) and not np.isnan(z[i + 1]) and z[i] > 0.0 >= z[i + 1]:
                s = _interp_zero(speeds[i], speeds[i + 1], z[i], z[i + 1])
                f = (s - speeds[i]) / (speeds[i + 1] - speeds[i])
                unstable.append(Crossing(s, t, float((1 - f) * wd[i, t] + f * wd[i + 1, t]), 0.0,
                                         whirl[i + 1][t]))
                break
    # A root outside the tracked modes (a higher mode, or a real root) can go unstable too.
    bad = np.flatnonzero(max_real > 0.0)
    if bad.size:
        i = int(bad[0])
        s = float(speeds[0]) if i == 0 else _interp_zero(speeds[i - 1], speeds[i], max_real[i - 1], max_real[i])
        if not unstable or min(u.speed for u in unstable) > speeds[i]:
            unstable.append(Crossing(s, None, float("nan"), float("nan"), ""))
    critical.sort(key=lambda c: c.speed)
    return StabilityMap(speeds=speeds, damped_frequencies=wd, damping_ratios=zeta, forward_ratio=fwd,
                        whirl=tuple(tuple(r) for r in whirl), max_real_part=max_real,
                        critical_speeds=tuple(critical),
                        unstable_mode=min(unstable, key=lambda u: u.speed) if unstable else None)


# --- the machine on its film bearings ---------------------------------------------------------------------

@dataclass(frozen=True)
class MachineStability:
    """`film_coefficients_over_speed` + `stability_map` for one machine and supply rule."""

    coefficients: SpeedCoefficients
    modes: StabilityMap
    seconds: float

    @property
    def first_critical_speed(self) -> float | None:
        return self.modes.first_critical_speed

    @property
    def instability_threshold(self) -> float | None:
        return self.modes.instability_threshold


def machine_stability(machine, speeds: Sequence[float], supply: Supply | None = None, *, rotor: Rotor | None = None,
                      n_modes: int = 8, max_eccentricity: float = 0.9,
                      progress: ProgressFn = silent) -> MachineStability:
    """Campbell diagram, first critical speed and instability threshold on the film bearings.

    speeds in rad/s; supply default `Supply.threshold_fraction(1.0)` (see the module docstring).
    Progress: one step per speed for the film, then one per speed for the modes.
    """
    t0 = time.perf_counter()
    speeds = _check_speeds(speeds)
    n = speeds.size
    coef = film_coefficients_over_speed(machine, speeds, supply, max_eccentricity=max_eccentricity,
                                        progress=lambda d, t, label: progress(d, 2 * n, label))
    rotor = rotor_from_machine(machine) if rotor is None else rotor
    modes = stability_map(rotor, speeds, coef.bearings_at, n_modes=n_modes,
                          progress=lambda d, t, label: progress(n + d, 2 * n, label))
    return MachineStability(coefficients=coef, modes=modes, seconds=time.perf_counter() - t0)
