"""Identification with large orbits declared: the linear chain plus a defect correction from the balance.

Every evaluation of the nonlinear model is a harmonic balance on the p-theta films (`rotor.orbit_balance`,
32 film solves per iteration, tens of seconds), too slow to sit inside a fit's Jacobians. The fit keeps
the fast linear chain and adds to it, as a fixed correction, what the nonlinearity changes at the last
flows (a defect correction, as in multigrid and in iterative refinement):

    d_k(q) = [orbit_balance(q_k) - its own linear orbit(q_k)] + D_k (q - q_k) + 1/2 (q - q_k)^T H_k (q - q_k)
             (1X at every plane; 0X at bearing-centre planes)
    q_{k+1} = argmin chi2( chain(q) + d_k(q) )   (the usual fit, refined locally from q_k)

repeated until the flows move by less than `tol` of Q_T. At the fixed point the model is the balance's
orbit itself (up to the linear chain's own table error, which the budget already carries), and with the
slope the fit's Jacobian is the nonlinear model's, so its intervals are too. The correction is the
balance's nonlinear part measured against its own linear orbit on the same films, so the film mesh and the
coefficients' linearization cancel in it; its remaining error (harmonics and points per revolution) is one
more budget column (`ModelBudget.orbit_defect`).

Why the slope: the nonlinear part is not small in its dependence on the flows. At the paper's unbalance
near Q_T it cancels about two thirds of the linear model's sensitivity to the flows: a correction held
constant converged by a factor 0.68 per balance and gave intervals three times too narrow. The slope D_k is
the balance's own derivative (session 15): implicit differentiation of the converged balance (each film's
supply derivative, the equilibria's, the balance's Newton matrix; `orbit_balance(flow_slopes=...)`), exact on
the model's films and nearly free. Within 5 % Q_T of a flow's Q_T, where the film's response has its kink and
the local derivative on the flooded side is nearly zero (with it a record's rounds stopped on a false point
17 % off, chi2 13), the slope is a one-sided difference of balances over 5 % Q_T on the flow's side (on coarser
films below Q_T, SLOPE_MESH; on the model's films above).

Why the curvature H_k: Q2 or Q1 above Q_T, where the flooded film barely answers to the supply, leaves the chi2
valley flat along the two flows together: there the linear model's and the correction's first-order
sensitivities nearly cancel, and where the minimum lies along the valley hangs on second-order terms. The
chain carries its own; without the correction's, the rounds crept along the valley about one sigma each (10
rounds on the independent source's 1 x record, `verification.orbit_record`, with 5 % differences or exact
slopes alike). H_k is Powell's symmetric secant update from the slopes of consecutive rounds that took them
the same way (exact along the step, which runs along the valley): 10 -> 8 rounds there, 206 -> 86 s, the last
rounds converging fast. Within 5 % of Q_T (one-sided differences over the step) the rounds still move about
0.2 sigma each on a record whose chi2 is already < 0.4 (1 x, 592 / 491 ml/min: 8 rounds, 67 s). Along the valley
the slope sets the intervals' ends, so they are the union over the slope x (1 +- 0.2).

The slope also carries the correction's change through the unbalance's size the record implies at other flows
(`with_scale_coupling`; the balance's derivative in its unbalance's size is implicit too, free): the fit's
Jacobian is then the nonlinear model's total derivative. It changed no round count measured.

Why the unbalance's size: the linear features are invariants of an unknown unbalance (its size and phase
cancel in them), but the nonlinearity grows with the orbit, so the balance must run at the orbit the record
shows, not at the declared unbalance. Each round scales the machine's unbalance by the ratio of the measured
1X amplitudes to the model's (RMS over the four channels) and divides the correction by the same factor, so
that it adds to the chain's unit-unbalance output as the nonlinear part of an orbit of the record's size. (With
the declared unbalance a record at 0.6 x of it was left "unexplained", chi2 47-62: the correction was that of
an orbit 1.7 times too large.) A single unbalance's phase only shifts the orbit in time, so it needs no fit.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ...errors import InputError, LubevizError
from ...progress import ProgressFn, silent
from ...rotor.film_bearings import equilibrium_flow_slopes, film_bearings, flooded_thresholds
from ...rotor.orbit_balance import HARMONICS, POINTS, HarmonicsNotSettled, OrbitBalance, orbit_balance
from ...rotor.orbit_stability import OrbitStability, orbit_stability
from ...rotor.response import machine_unbalance
from ...rotor.whirl import Stability, equilibrium_stability
from ..forward.budget import ModelBudget, truncation_factor
from ..forward.chain import ForwardChain, ResponseDefect
from .least_squares import Z95, Fit, fit, sandwich_cov, std_within, whole_theta
from ...units import MLMIN_PER_M3S


SIGMA_TOL = 0.2  # the rounds also stop when the flows move by less than this fraction of their standard deviation
# (along a flat valley the record cannot tell the points apart, and the rounds would creep along it)
SLOPE_REUSE = 0.01  # the correction's slope is taken again when the flows move more than this (of Q_T) or cross Q_T
SCALE_TOL = 0.01  # ... or when the unbalance's size moves by more than this fraction; the rounds stop only below it
SLOPE_MESH = 50  # film volumes each way for the slope of a flow below its Q_T (the value, and the slope of a flow
# at or above Q_T, keep the model's mesh). A balance from the linear orbit: 8.0 s against 35.9 s on 100 x 100. Its
# slope against the model's films', relative to the slope's size, at 75 Hz and the paper's unbalance:
# 4.9 / 5.5 % at 0.86 / 0.95 Q_T; 19.5 / 7.4 / 5.3 / 5.1 % at 1.06 / 1.14 / 1.24 / 1.39 Q_T. Above Q_T the slope is
# small (the flooded film barely answers) and the 50 x 50 films' Q_T lies 1.7 % higher, so near the kink a
# difference straddles it on one mesh and not the other. With coarse slopes for every flow, a record with Q1 at
# 1.23 Q_T settled on Q1 = 575 ml/min (1.06 Q_T), 14.5 % off, intervals missing the truth; with the rule here it
# ends 1.25 / 1.48 % off, held (every slope on the model's films: 1.39 / 1.69 %; one record, BENCHMARKS "Large
# orbits" and the diagnosis rows of sessions 12-13). Scaling these slopes' coarse flows by the two meshes' Q_T
# ratio instead halved the error at 1.06 Q_T and tripled it at 1.24 Q_T: not used for them (the coarse rounds
# before the model's, `fit_large_orbit`, do scale their flows: there every balance is on the coarse films).
ORBIT_TOL = 1e-4  # each round's balances settle to this change of the orbit, relative to its 1X: the last Newton
# step that takes them from ~5e-5 to 1e-8 (at 1e-6) moved the 16-harmonic fit's flows by 1e-5 of themselves, against
# its 1 % (the time integration's record at 0.6 x the unbalance: 478.903 / 521.539 -> 478.899 / 521.537 ml/min, chi2
# 0.2950 -> 0.2958, intervals the same to 4 digits; 86 -> 58 s; at 1e-3: flows 0.08 ml/min off, no faster; session 61)
COARSE_ROUNDS = 6  # rounds on the SLOPE_MESH films before those on the model's (see fit_large_orbit) ...
COARSE_TOL = 0.01  # ... until the flows move by less than this fraction of Q_T (or SIGMA_TOL of their std)
TIME_REVOLUTIONS, TIME_STEPS = 6, 512  # a time round's integration: revolutions from the balance's orbit, steps in
# each (at 75 Hz on 100 x 100 films 5-6 min on one core); its 1X is that of the last 2 revolutions, which differs
# from that of the 2 before by 0.1-0.4 % on the bench's records (`time_gap`'s `settled`)
KINK_BAND = 0.04  # a time round at flows within this of their Q_T also integrates across Q_T (`fit_large_orbit`) ...
KINK_MIRROR = 0.02  # ... at the answer mirrored about Q_T, at least this far from it (of Q_T)
SLOPE_UNCERTAINTY = 0.2  # of the correction's slope: the model's 100 x 100 slope is not the 200 x 200 source's, and
# below Q_T the slope comes from 50 x 50 films, 5 % off (see SLOPE_MESH); the intervals are the union over the
# slope x (1 +- this) (`_slope_union`), and each flow's std is at least their half-width / 1.96 (`fit.std_within`)


def _with_mesh(machine, mesh: int):
    """A copy of `machine` whose bearings' films have `mesh` x `mesh` finite volumes (nothing else changed)."""
    from ...model.machine import Machine

    values = {k: getattr(machine, k) for k in machine.param if k != "name"}
    values["bearings"] = [b.copy(n_circumferential=int(mesh), n_axial=int(mesh)) for b in machine.bearings]
    return Machine(**values)


class SlopeFilms:
    """Where the correction's slope is taken: the chain's machine on `mesh` x `mesh` films (None: the chain's
    own mesh), and the last balance solved there, from which the next one continues."""

    def __init__(self, chain: ForwardChain, mesh: int | None = SLOPE_MESH, *, machine=None):
        own = chain.machine.bearings if machine is None else machine.bearings
        same = mesh is None or all(b.n_circumferential == mesh and b.n_axial == mesh for b in own)
        base = chain.machine if machine is None else machine
        self.machine = base if same else _with_mesh(base, mesh)
        self.own_mesh = same
        self.last: OrbitBalance | None = None


@dataclass(frozen=True)
class OrbitFit:
    """A fit with large orbits: the final fit (with the correction), the plain linear fit it started from,
    the balance at the answer, and the flows of each round (m^3/s)."""

    fit: Fit
    plain: Fit
    orbit: OrbitBalance
    defect: ResponseDefect
    history: tuple
    converged: bool
    seconds: float
    stability: Stability | None = None  # of the equilibrium at the answer (rotor.whirl)
    unbalance_scale: float = 1.0  # the unbalance's size the record's 1X implies, relative to the declared one
    orbit_stability: OrbitStability | None = None  # of the periodic orbit at the answer (Floquet multipliers)
    time_rounds: tuple[TimeRound, ...] = ()  # the time rounds after the balance's (`fit_large_orbit(time_rounds=)`)
    # with time rounds: the flows' 95 % intervals from the slope's union alone (no truncation term, no union with
    # the balance's), m^3/s by name; for measuring their coverage, not the answer's intervals
    time_round_intervals: dict | None = None

    @property
    def balances(self) -> int:
        return len(self.history) - 1


def check_orbit_chain(chain: ForwardChain) -> None:
    """Large orbits are computed on the declared machine: no effect may change the machine, the rotor or the
    forcing underneath (probe effects, which act after the response, are fine), and each film acts between its
    journal and the ground (no pedestal under a fluid-film bearing). Any number of bearings and planes: the rounds
    move the flows of unknown supply (`moving_flows`), a known supply is held at its flow."""
    chain.rotor.require_films_on_ground("large_orbit (the films solved along the orbit)")
    if not moving_flows(chain):
        raise InputError(f"large_orbit fits supply flows; every fluid-film bearing of {chain.machine.source} has a "
                         "known supply (SPEC §8 supply_mlmin): there is no flow to identify")
    other = [e.label() for e in chain.effects if e.stage != "probes"]
    if other:
        raise InputError(f"large_orbit combines with probe effects only (the balance runs on the declared "
                         f"machine); also declared: {', '.join(other)}")


def moving_flows(chain: ForwardChain) -> list[int]:
    """The bearings (0-based) whose flow the rounds move: every fluid-film bearing but those of known supply
    (held at their flow, so neither their slope nor their curvature is taken)."""
    return [k for k in range(chain.n_flows) if k not in chain.known_flows]


def orbit_points(harmonics: int) -> int:
    """Points per revolution of a balance with `harmonics`: the model's POINTS at its HARMONICS, else 4 per
    harmonic (no harmonic aliases onto another, and the sharp turn of the orbit is sampled)."""
    return POINTS if int(harmonics) == HARMONICS else 4 * int(harmonics)


def _balance(chain: ForwardChain, flows, start, harmonics, points, tol, progress, scale=1.0,
             machine=None, slopes: bool = False, flow_factor=None) -> OrbitBalance:
    """The balance at `flows` on `machine` (default the chain's); with `flow_factor`, at flows x that factor
    (per bearing), its flow slopes per unit of the unscaled flows."""
    machine = chain.machine if machine is None else machine
    factor = np.ones(len(flows)) if flow_factor is None else np.asarray(flow_factor, float)
    # the equilibria start from those of the orbit the balance starts from (a nearby operating point)
    fb = film_bearings(machine, [float(q) for q in np.asarray(flows, float) * factor], chain.omega,
                       previous=None if start is None else start.bearings)
    unbalances = [dataclasses.replace(u, moment=u.moment * scale) for u in machine_unbalance(machine)]
    fs = equilibrium_flow_slopes(machine, fb, chain.q_threshold * factor) if slopes else None
    if fs is not None and flow_factor is not None:  # d/dq = factor d/d(scaled q)
        fs = [tuple(np.asarray(v) * f for v in parts) for parts, f in zip(fs, factor)]
    return orbit_balance(chain.rotor, fb, unbalances, nodes=chain.nodes, harmonics=harmonics,
                         points=points, tol=tol, start=start, flow_slopes=fs, progress=progress)


def _parts(chain: ForwardChain, ob: OrbitBalance, scale: float = 1.0):
    """The balance's defect at the chain's planes: 1X minus its own linear 1X, per unit of the unbalance's
    scale (the chain's 1X is the declared unbalance's); the 0X at bearing centres (absolute, metres)."""
    static = np.zeros((chain.n_planes, 2))
    for k in chain.static_planes:
        static[k] = (ob.x[0, k].real, ob.y[0, k].real)
    return (ob.x[1] - ob.linear_x) / scale, (ob.y[1] - ob.linear_y) / scale, static


def measured_scale(chain: ForwardChain, measured, theta, defect: ResponseDefect | None = None) -> float:
    """The unbalance's size relative to the declared machine's that the record's 1X implies: the measured 1X
    amplitudes (every plane, x and y) against the chain's at `theta` (with `defect`), RMS over the channels."""
    out = (chain if defect is None else chain.with_defect(defect)).output(np.asarray(theta, dtype=float))
    model = np.abs(np.concatenate([out.x, out.y])) ** 2
    meas = np.abs(np.concatenate([np.asarray(measured.x), np.asarray(measured.y)])) ** 2
    if not (np.sum(model) > 0 and np.isfinite(np.sum(meas))):
        raise InputError("large orbits: the model's 1X is zero at the planes; the unbalance's size cannot be read")
    return float(np.sqrt(np.sum(meas) / np.sum(model)))


def orbit_defect(chain: ForwardChain, flows, *, start: OrbitBalance | None = None, slope: bool = True,
                 step: float = 0.05, harmonics: int = HARMONICS, points: int = POINTS, tol: float = ORBIT_TOL,
                 scale: float = 1.0, slope_films: SlopeFilms | None = None, machine=None,
                 flow_factor=None, gap=None, progress: ProgressFn = silent) -> tuple[ResponseDefect, OrbitBalance]:
    """The balance at `flows` (m^3/s) on the chain's machine, speed and rotor, with the machine's unbalance
    times `scale`, and its defect per unit of that scale, with (`slope`) its slope in each flow and its change
    with the scale (`ResponseDefect.dscale`). A flow whose +-`step` Q_T lies on one side of its Q_T takes the
    balance's own derivative (implicit, `orbit_balance(flow_slopes=...)`); one within `step` of its Q_T, where
    the film's response has its kink, a one-sided difference of balances over `step` Q_T on its own side: on
    `slope_films` (default: SLOPE_MESH films, continued from a balance at `flows` there) below Q_T, on the
    model's films from this balance at or above it, or when those films are the chain's own. `machine`: the
    films of the balance (default the chain's machine; another one comes with `slope_films` on it too);
    `flow_factor`: every balance on them at the flows x this (per bearing), e.g. the ratio of `machine`'s Q_T
    to the chain's, so that a coarser mesh's kink lies where the model's does (Q_T below is the chain's).
    `gap`: (x, y, static) added to the defect (`time_gap`: the time integration's orbit against the balance's at
    nearby flows), held constant in the flows: the slopes stay the balance's."""
    q = np.asarray(flows, dtype=float)
    qt = chain.q_threshold
    # a flow whose +-step lies on one side of its Q_T takes the balance's own derivative (implicit, exact, local);
    # one within a step of the kink a one-sided difference of balances over the step (below)
    moving = moving_flows(chain) if slope else []  # a known supply is held: no slope in it
    smooth = smooth_flows(chain, q, step) if slope else []
    n_bal = 1 + len(moving)  # progress: the balance, then the slope in each flow
    films = (SlopeFilms(chain) if slope_films is None else slope_films) if slope else None
    # a flow at or above its Q_T takes its slope on the model's own films (see SLOPE_MESH); the others on `films`
    coarse = [k for k in moving if not films.own_mesh and q[k] < qt[k] and k not in smooth]
    base = None
    if coarse:  # the slope's own centre on its films, continued from their last balance;
        last = films.last if films.last is not None and films.last.harmonics == harmonics else None
        base = _balance(chain, q, last, harmonics, points, tol, lambda i, n, t: progress(0, n_bal, t), scale,
                        machine=films.machine)
        films.last = base
        start = base if start is None else start  # a first balance starts from the coarse orbit's harmonics
    ob = _balance(chain, q, start, harmonics, points, tol, lambda i, n, t: progress(i / n, n_bal, t), scale,
                  slopes=slope, machine=machine, flow_factor=flow_factor)
    x, y, static = _parts(chain, ob, scale)
    npl, nq = chain.n_planes, chain.n_flows
    dx, dy, dst = np.zeros((npl, nq), complex), np.zeros((npl, nq), complex), np.zeros((npl, 2, nq))
    dscale = None
    if slope:  # per unit scale: d(nl / s)/ds = (dnl/d ln s - nl) / s^2; the static shift is absolute: dnl/d ln s / s
        dss = np.zeros((npl, 2))
        for p in chain.static_planes:
            dss[p] = ob.scale_slope_x[0, p].real / scale, ob.scale_slope_y[0, p].real / scale
        dscale = ((ob.scale_slope_x[1] - x * scale) / scale**2, (ob.scale_slope_y[1] - y * scale) / scale**2, dss)
    for k in smooth:
        dx[:, k], dy[:, k] = ob.flow_slope_x[k, 1] / scale, ob.flow_slope_y[k, 1] / scale
        for p in chain.static_planes:
            dst[p, :, k] = ob.flow_slope_x[k, 0, p].real, ob.flow_slope_y[k, 0, p].real
    for i, k in enumerate(k for k in moving if k not in smooth):
        centre, on = (base, films.machine) if k in coarse else (ob, chain.machine if machine is None else machine)
        bx, by, bst = _parts(chain, centre, scale)
        # within a step of Q_T (the film's kink): one-sided on the flow's own side, over the step
        hs = step * qt[k] * (1.0 if q[k] >= qt[k] else -1.0)
        qk = q.copy()
        qk[k] += hs
        obk = _balance(chain, qk, centre, harmonics, points, tol,
                       lambda j, n, t, i=i: progress(1 + i + j / n, n_bal, t), scale, machine=on,
                       flow_factor=None if k in coarse else flow_factor)
        xk, yk, sk = _parts(chain, obk, scale)
        dx[:, k], dy[:, k], dst[:, :, k] = (xk - bx) / hs, (yk - by) / hs, (sk - bst) / hs
    if gap is not None:
        x, y, static = x + gap[0], y + gap[1], static + gap[2]
    return ResponseDefect(x=x, y=y, static=static, q0=q, dx=dx, dy=dy, dstatic=dst, dscale=dscale), ob


@dataclass(frozen=True)
class TimeRound:
    """One time round: the time integration's gap to the balance at the flows it ran at, and the flows after."""

    flows_at: np.ndarray  # m^3/s: where the time integration ran (the answer before the round)
    flows_after: np.ndarray  # m^3/s: the answer after the round's balances
    gap_percent: np.ndarray  # |time 1X - balance 1X| / |balance 1X| at (x1, y1, x2, y2, ...), %
    settled_percent: float  # the largest change of the time integration's 1X between its last two windows, %
    seconds: float
    chi2: float = math.nan  # after the round's balances
    consistent: bool = True  # the answer lies on the side of each near flow's Q_T its gap was taken on
    others: tuple = ()  # the same from across Q_T (a flow within KINK_BAND of its Q_T), not kept


def time_gap(chain: ForwardChain, ob: OrbitBalance, scale: float, *, revolutions: int = TIME_REVOLUTIONS,
             steps: int = TIME_STEPS, progress: ProgressFn = silent):
    """The time integration's orbit against the balance `ob` (at its flows, the machine's unbalance x `scale`):
    ((gap_x, gap_y, gap_static), gap_percent, settled_percent). The integration (`film_time_response`, implicit,
    on the balance's own films and the chain's rotor, from the balance's orbit, `revolutions` of `steps`) has
    no truncation in harmonics: its 1X over the last 2 revolutions minus the balance's, per unit of `scale` as
    the defect is; the 0X at the chain's static planes likewise, absolute. `settled_percent`: how much its 1X
    moved between the last 2 revolutions and the 2 before."""
    from ...rotor.film_transient import film_time_response

    if revolutions < 4:
        raise InputError(f"time rounds: {revolutions} revolutions; at least 4 (two windows of 2)")
    omega = chain.omega
    period = 2 * math.pi / omega
    unbalances = [dataclasses.replace(u, moment=u.moment * scale) for u in machine_unbalance(chain.machine)]
    tr = film_time_response(chain.rotor, ob.bearings, unbalances, duration=revolutions * period, dt=period / steps,
                            nodes=chain.nodes, start=ob.state(0.0), implicit=True, progress=progress)

    def window(a: int, b: int):
        sel = slice(a * steps, b * steps)
        d = tr.displacement[:, sel]
        return 2 * d @ np.exp(-1j * omega * tr.t[sel]) / ((b - a) * steps), d.mean(axis=1)

    (last, mean), (before, _) = window(revolutions - 2, revolutions), window(revolutions - 4, revolutions - 2)
    bal = np.ravel(np.stack([ob.x[1], ob.y[1]], axis=-1))  # (x1, y1, x2, y2, ...)
    gx, gy = (last[0::2] - ob.x[1]) / scale, (last[1::2] - ob.y[1]) / scale
    gs = np.zeros((chain.n_planes, 2))
    for k in chain.static_planes:
        gs[k] = mean[2 * k] - ob.x[0, k].real, mean[2 * k + 1] - ob.y[0, k].real
    return ((gx, gy, gs), 100 * np.abs(last / bal - 1), float(100 * np.max(np.abs(last / before - 1))))


def with_scale_coupling(chain: ForwardChain, measured, theta, defect: ResponseDefect) -> ResponseDefect:
    """`defect` with its change through the unbalance's scale folded into its slope in the flows.

    The balance runs at the scale the record's 1X implies at the last flows; at other flows the model's 1X
    per unit unbalance differs, so the record implies another scale, and the correction (nonlinear in the
    orbit's size) another value. The slope at a fixed scale misses that: d(q, s(q)) has the slope
    dd/dq + dd/ds ds/dq, dd/ds from the balance (implicit, `OrbitBalance.scale_slope_x`), ds/dq from the chain
    (the measured amplitudes against the model's)."""
    if defect.dscale is None:
        return defect
    th = np.asarray(theta, dtype=float)
    ds = np.zeros(chain.n_flows)  # a known supply's flow is held: no change through it
    for k in moving_flows(chain):
        h = 1e-3 * chain.q_threshold[k]
        tp, tm = th.copy(), th.copy()
        tp[k] += h
        tm[k] -= h
        ds[k] = (measured_scale(chain, measured, tp, defect) - measured_scale(chain, measured, tm, defect)) / (2 * h)
    sx, sy, ss = defect.dscale
    return dataclasses.replace(defect, dx=defect.dx + np.outer(sx, ds), dy=defect.dy + np.outer(sy, ds),
                               dstatic=defect.dstatic + ss[:, :, None] * ds[None, None, :])


def smooth_flows(chain: ForwardChain, q, step: float = 0.05) -> list[int]:
    """The flows the rounds move (`moving_flows`) whose +-`step` Q_T lies on one side of their Q_T (away from the
    film's kink)."""
    qt = chain.q_threshold
    return [k for k in moving_flows(chain) if q[k] - step * qt[k] >= qt[k] or q[k] + step * qt[k] < qt[k]]


def secant_curvature(prev: ResponseDefect, new: ResponseDefect) -> ResponseDefect:
    """`new` with the correction's curvature in the flows from the change of its slope since `prev` (both taken
    the same way: exact, or a difference over the same step on the same side of Q_T), by Powell's symmetric
    secant update of prev's curvature: exact along the step, unchanged across it.

    Along the chi2 valley the linear model's and the correction's first-order sensitivities nearly cancel, so
    where the minimum lies along it hangs on their second-order terms; the chain carries its own, the
    correction's come from here (with slopes alone the rounds crept along the valley at about one sigma each)."""
    s = np.asarray(new.q0, float) - np.asarray(prev.q0, float)
    ss = float(s @ s)
    if not ss > 0:
        return new

    def update(H, d_new, d_old):
        H = np.zeros(d_new.shape + (s.size,), d_new.dtype) if H is None else H
        r = (d_new - d_old) - H @ s
        rs = r @ s
        sym = (r[..., :, None] * s + s[:, None] * r[..., None, :]) / ss
        return H + sym - rs[..., None, None] * np.outer(s, s) / ss**2

    return dataclasses.replace(new, hx=update(prev.hx, new.dx, prev.dx), hy=update(prev.hy, new.dy, prev.dy),
                               hstatic=update(prev.hstatic, new.dstatic, prev.dstatic))


@dataclass(frozen=True)
class _RoundsOn:
    """Where a run of rounds solves its balances and when it stops: on `machine`'s films (None: the chain's
    machine) at the flows x `factor` (per bearing; None: the flows themselves), with the correction's slopes
    from `films`, at most `limit` rounds, settled when the flows move by less than `stop_tol` of Q_T (or
    SIGMA_TOL of their std)."""

    machine: object
    films: SlopeFilms
    limit: int
    stop_tol: float
    factor: np.ndarray | None = None


@dataclass(frozen=True)
class _FitContext:
    """What every step of one large-orbit fit shares: the chain and the record, the fits' keywords (`fit`'s
    names, working budget, bounds, level), the balance's harmonics and points, the rounds on the model's films
    (`model`), the progress report and its total, and the flows of each round so far (`history`, appended to)."""

    chain: ForwardChain
    measured: object
    kw: dict
    harmonics: int
    points: int
    model: _RoundsOn
    progress: ProgressFn
    total: int
    history: list


@dataclass(frozen=True)
class _SlopeTaken:
    """The last round that took the correction's slope: the flows and the unbalance's scale it was taken at,
    how (per flow: exact, and at or above Q_T) and the correction it gave."""

    q: np.ndarray
    scale: float
    how: tuple
    defect: ResponseDefect


@dataclass(frozen=True)
class _RoundMove:
    """How far one round moved: the flows, relative to Q_T and to their std, and the unbalance's scale
    (relative)."""

    flows: float
    flows_sigma: float
    scale: float

    def settled(self, stop_tol: float) -> bool:
        return (self.flows < stop_tol or self.flows_sigma < SIGMA_TOL) and self.scale < SCALE_TOL


@dataclass(frozen=True)
class _Branch:
    """One branch of a time round (at the answer, or across Q_T from it): the rounds' state after its
    balances, whether they settled, whether the answer lies on the side of each near flow's Q_T its gap was
    taken on, and its `TimeRound`."""

    state: dict
    converged: bool
    consistent: bool
    round: TimeRound


def fit_large_orbit(chain: ForwardChain, measured, *, names: Sequence[str] | None = None,
                    budget: ModelBudget | None = None, lower: float = 0.25, upper: float = 2.0,
                    level: float = 0.01, tol: float = 1e-3, max_rounds: int = 10, harmonics: int = HARMONICS, points: int = POINTS,
                    slope_mesh: int | None = SLOPE_MESH, time_rounds: int = 0,
                    time_revolutions: int = TIME_REVOLUTIONS, progress: ProgressFn = silent) -> OrbitFit:
    """Fit the flows (and the chain's free probe parameters) with the film force along the orbit.

    Starts from the linear fit (global search), then (with `slope_mesh` coarser than the model's films) up to
    COARSE_ROUNDS rounds with every balance on the slope's films, at the flows scaled by the two meshes' Q_T
    ratio so that the coarse kink lies where the model's does, until the flows move by less than COARSE_TOL of
    Q_T; then the rounds on the model's films from there (the first of their balances starts from the coarse
    orbit's harmonics and its films' patterns, `orbit_balance._mapped_film`: 7 -> 3 Newton steps). Measured on
    the bench's 1 x records and the test's
    (session 16; balances' Newton steps on 100 x 100 films): 34 / 41 / 39 -> 15 / 14 / 12, flows within -0.4 /
    -0.6 %, -1.6 / -2.2 %, -0.6 / -0.6 % (before: -0.4 / -0.6, -2.2 / -3.2, -2.7 / -2.8 %). Unscaled, a record's
    coarse rounds stopped at their own kink, 17 % short, and saved nothing.
    Each round solves the balance at the last flows with its slope
    (taken again every round while every flow it moves lies more than 5 % Q_T from its Q_T, where it is exact and
    free; nearer, when the flows have moved more than SLOPE_REUSE of Q_T since, crossed Q_T or the scale moved), the
    secant curvature between rounds that took their slopes the same way, and refits locally with the
    correction: Newton's method on the nonlinear model. (A slope taken below Q_T and used above it made the
    iteration settle on flows 7 % off with chi2 24 on a clean record of this very model.) It stops when the flows move by less than `tol` of
    Q_T, or by less than SIGMA_TOL of their own standard deviation. `tol`: largest flow change between rounds,
    relative to Q_T, at which it stops. `slope_mesh`: film volumes each way of the slope's balances for flows
    below Q_T (None: the model's own mesh; the correction itself, and the slope of a flow at or above Q_T, are
    always solved on the model's films).

    `time_rounds`: after the balance's rounds, this many time rounds. Each integrates the model in time at the
    answer (`time_gap`, 5-6 min on one core at 75 Hz), adds the gap between that orbit's 1X and the balance's to
    the correction, held constant, and runs the balance's rounds again from there. The balance truncated at 16
    harmonics is 1-5 % off the periodic orbit in 1X at the fuller unbalances, and the flat chi2 valley turns that
    into 2-7 % in the flows (BENCHMARKS "The large-orbit misses: the balance's truncation"); the time rounds take
    the truncation out of the model. The film's kink at Q_T is in the gap too (record 5 of the bench: 1.6-2.0 % of
    the 1X just above Q_T, 1.3-2.4 % at the truth 2.6 % below it), so a gap taken on the wrong side of Q_T holds the
    rounds there: for flows within KINK_BAND of their Q_T a time round also integrates at the answer mirrored
    about Q_T (at least KINK_MIRROR from it) and runs the rounds from there too; of the two answers it keeps the
    one on the side of Q_T its gap was taken on (both: the lower chi2); the rounds across Q_T start there. The sigma
    keeps the balance's truncation term (`truncation_factor`), and the intervals hold the balance's own (their
    union): how much the time rounds may narrow them is not yet measured on enough records.
    """
    t0 = time.perf_counter()
    check_orbit_chain(chain)
    if int(time_rounds) < 0:
        raise InputError(f"time rounds {time_rounds!r}; expected 0 or more")
    ladder, stalled = harmonic_ladder(harmonics), []
    for h in ladder:  # a count whose balance stalls near an orbit gives way to the next (HARMONIC_LADDER)
        try:
            of = _fit_at(chain, measured, dict(names=names, budget=budget, lower=lower, upper=upper, level=level),
                         tol, max_rounds, h, points if h == int(harmonics) else orbit_points(h), slope_mesh,
                         int(time_rounds), time_revolutions, progress)
            break
        except HarmonicsNotSettled as exc:
            if h == ladder[-1]:
                raise
            stalled.append(f"{h} harmonics ({exc})")
    if stalled:  # said, with the budget's truncation term that of the harmonics used
        said = (f"large orbits: the balance did not settle with {'; nor with '.join(stalled)}; fitted with "
                f"{of.orbit.harmonics} harmonics, the model budget's truncation term theirs")
        of = dataclasses.replace(of, fit=dataclasses.replace(of.fit, warnings=(said,) + tuple(of.fit.warnings)))
    return dataclasses.replace(of, seconds=time.perf_counter() - t0)


HARMONIC_LADDER = (16, 8, 5)  # the counts a large-orbit fit falls back to when its balance stalls near an orbit
# (`HarmonicsNotSettled`): on the fan's 100 x 60 films 16 harmonics stall at 1e-2 of the orbit (90 s on 50 x 50,
# 250 s on the model's films, session 64) where 8 settle in 17 steps (21 s)


def harmonic_ladder(harmonics: int) -> tuple[int, ...]:
    """`harmonics`, then each count of HARMONIC_LADDER below it."""
    h = int(harmonics)
    return (h,) + tuple(c for c in HARMONIC_LADDER if c < h)


def _fit_at(chain: ForwardChain, measured, kw: dict, tol: float, max_rounds: int, harmonics: int, points: int,
            slope_mesh: int | None, time_rounds: int, time_revolutions: int, progress: ProgressFn) -> OrbitFit:
    """`fit_large_orbit` with the balance at `harmonics` and `points` (`kw`: the fits' names, budget, bounds and
    level)."""
    t0 = time.perf_counter()
    names, budget, lower, upper, level = (kw[k] for k in ("names", "budget", "lower", "upper", "level"))
    full_budget, working = _fit_budgets(budget, harmonics)
    slope_films = SlopeFilms(chain, slope_mesh)
    total = (max_rounds + 1) * (1 + 2 * int(time_rounds)) + (0 if slope_films.own_mesh else COARSE_ROUNDS)  # a time
    # round near Q_T runs its balances twice (`KINK_BAND`)
    ctx = _FitContext(chain, measured, dict(names=names, budget=working, lower=lower, upper=upper, level=level),
                      harmonics, points, _RoundsOn(None, slope_films, max_rounds, tol), progress, total, [])
    progress(0, total, "large orbits: the linear fit")
    plain, state = _plain_fit(ctx)
    _coarse_rounds(ctx, state)
    converged = _balance_rounds(ctx, state, ctx.model, "round")
    balance_intervals = None
    if time_rounds:  # the balance's own intervals: those with time rounds are never narrower (below)
        balance_intervals = _intervals_at(ctx, state, full_budget)[2]
    time_log, time_warnings, converged = _run_time_rounds(ctx, state, int(time_rounds), time_revolutions, converged)
    progress(total - 1, total, "large orbits: intervals")
    final, slope_intervals, intervals = _intervals_at(ctx, state, full_budget)
    # the time rounds' own intervals, without the truncation term they take out and the balance's union: reported
    # so that their coverage can be measured (`bench coverage --large-orbit --orbit-time-rounds`), never shown as
    # the answer's
    own = ({n: slope_intervals[n] for n in chain.names[:chain.n_flows] if n in slope_intervals} if time_log
           else None)
    if balance_intervals is not None:  # near Q_T the time rounds can end on the kink with a narrow interval (record
        # 5 of the bench: Q2 +2.8 % with sigma 0.9 %); until their own sigma is measured, the balance's bounds it
        intervals = _interval_union(intervals, balance_intervals)
    final = _with_std_of(final, intervals)
    stability, orbit_stab, answer_warnings = _answer_checks(ctx, state, converged)
    warnings = list(final.warnings) + time_warnings + answer_warnings
    final = dataclasses.replace(final, warnings=tuple(warnings), seconds=time.perf_counter() - t0)
    progress(total, total, "large orbits: done")
    return OrbitFit(fit=final, plain=plain, orbit=state["ob"], defect=state["defect"], history=tuple(ctx.history),
                    converged=converged, seconds=time.perf_counter() - t0, stability=stability,
                    unbalance_scale=state["ob_scale"],  # the size the last balance ran at
                    orbit_stability=orbit_stab, time_rounds=time_log, time_round_intervals=own)


def _fit_budgets(budget: ModelBudget | None, harmonics: int) -> tuple[ModelBudget, ModelBudget]:
    """The whole model budget, its `orbit_truncation` term that of a balance with `harmonics`, and the working
    budget the rounds and the fits weigh the features with."""
    # the rounds and the fits weigh the features with the budget less its `orbit_truncation` term, whose size is
    # itself uncertain (measured against the time integration at two points); the flows' uncertainty carries it
    # (`_truncation_union`: the sandwich covariance of these weights under the whole budget)
    full_budget = budget or ModelBudget()
    full_budget = ModelBudget(**{**full_budget.param.values(), "name": None,
                                 "orbit_truncation": full_budget.orbit_truncation * truncation_factor(harmonics)})
    working = ModelBudget(**{**full_budget.param.values(), "name": None, "orbit_truncation": 0.0})
    return full_budget, working


def _plain_fit(ctx: _FitContext) -> tuple[Fit, dict]:
    """The plain linear fit (global search) the rounds start from, and the rounds' state at its answer: the flows
    `q` and every parameter `theta`, the unbalance's `scale` the record's 1X implies, the last balance `ob`, the
    correction `defect`, the balances so far (`rounds`), the time integration's `gap` held in the correction, the
    last refit's `chi2` and the scale the last balance ran at (`ob_scale`)."""
    plain = fit(ctx.chain, ctx.measured, intervals=False, **ctx.kw)
    theta = whole_theta(ctx.chain, plain)  # a known supply among the flows, held
    q = theta[:ctx.chain.n_flows].copy()
    scale = measured_scale(ctx.chain, ctx.measured, theta)  # the linear model's reading; each round reads it again
    ctx.history.append(q.copy())
    return plain, dict(q=q, theta=theta, scale=scale, ob=None, defect=None, rounds=0, gap=None, chi2=None,
                       ob_scale=scale)


def _coarse_rounds(ctx: _FitContext, state: dict) -> None:
    """With the slope's films coarser than the model's: the rounds on them first, the state moved to their
    answer (its correction dropped: the model's rounds take their own)."""
    slope_films = ctx.model.films
    if slope_films.own_mesh:
        return
    # First the whole iteration on the slope's coarser films (their balances ~4 x cheaper): the correction
    # there differs from the model's films' by 2-13 % of itself (BENCHMARKS "Large orbits"), so the rounds
    # on the model's films start near their answer instead of at the linear fit's, 20-27 % off. Their Q_T
    # lies about 1.7 % higher on 50 x 50: the flows are scaled by the Q_T ratio, so that near Q_T both
    # meshes' films are at the same side of their kink and the same distance from it.
    ctx.progress(0, ctx.total, "large orbits: rounds on coarser films")
    coarse_films = SlopeFilms(ctx.chain, None, machine=slope_films.machine)
    factor = flooded_thresholds(coarse_films.machine, ctx.chain.omega) / ctx.chain.q_threshold
    _balance_rounds(ctx, state, _RoundsOn(coarse_films.machine, coarse_films, COARSE_ROUNDS, COARSE_TOL, factor),
                    "coarse round")
    slope_films.last = state["ob"]  # the fine rounds' coarse balances continue from here
    state["defect"] = None


def _balance_rounds(ctx: _FitContext, state: dict, on: _RoundsOn, label: str) -> bool:
    """Rounds of balances on `on.machine`'s films (at the flows x `on.factor`) with slopes from `on.films`, from
    the state's flows; True when they settled (the flows moved by less than `on.stop_tol` of Q_T or SIGMA_TOL of
    their std)."""
    taken = None  # the last of these rounds that took the slopes
    for _ in range(on.limit):
        state["rounds"] += 1
        rnd = state["rounds"]

        def sub(i, n, text, rnd=rnd):
            ctx.progress(rnd - 1 + min(i / max(n, 1), 1.0), ctx.total, f"large orbits, {label} {rnd}: {text}")

        defect, ob, taken = _round_correction(ctx, state, on, taken, sub)
        if _refit(ctx, state, defect, ob).settled(on.stop_tol):
            return True
    return False


def _round_correction(ctx: _FitContext, state: dict, on: _RoundsOn, taken: _SlopeTaken | None,
                      progress: ProgressFn) -> tuple[ResponseDefect, OrbitBalance, _SlopeTaken | None]:
    """One round's balance at the state's flows and the correction from it: with its slope taken again (the
    scale's coupling folded in, the secant curvature since `taken` when that took its slopes the same way) when
    `taken` is none or stale, else `taken`'s slope with the defect itself from here; and the slope last taken."""
    chain, q, scale = ctx.chain, state["q"], state["scale"]
    qt = chain.q_threshold
    exact = smooth_flows(chain, q)
    smooth = len(exact) == len(moving_flows(chain))
    # how each flow's slope is taken (exact, or a difference over the step on its side of Q_T): the secant
    # curvature is consistent between rounds that take every slope the same way
    how = tuple((k in exact, bool(q[k] >= qt[k])) for k in range(chain.n_flows))
    fresh = (smooth or taken is None or np.max(np.abs(q - taken.q) / qt) > SLOPE_REUSE
             or np.any((q >= qt) != (taken.q >= qt)) or abs(scale / taken.scale - 1.0) > SCALE_TOL)
    new, ob = orbit_defect(chain, q, start=state["ob"], slope=fresh, harmonics=ctx.harmonics, points=ctx.points,
                           scale=scale, slope_films=on.films, machine=on.machine, flow_factor=on.factor,
                           gap=state["gap"], progress=progress)
    if not fresh:  # the slope from nearby flows, the defect itself from here
        return dataclasses.replace(state["defect"], x=new.x, y=new.y, static=new.static, q0=new.q0), ob, taken
    new = with_scale_coupling(chain, ctx.measured, state["theta"], new)
    if taken is not None and taken.how == how:
        new = secant_curvature(taken.defect, new)
    return new, ob, _SlopeTaken(q=q.copy(), scale=scale, how=how, defect=new)


def _refit(ctx: _FitContext, state: dict, defect: ResponseDefect, ob: OrbitBalance) -> _RoundMove:
    """A round's local refit with the correction `defect` (of the balance `ob`) from the state's parameters, and
    the unbalance's scale the record's 1X implies at its answer; the state moves there."""
    q, scale = state["q"], state["scale"]
    qt = ctx.chain.q_threshold
    res = fit(ctx.chain.with_defect(defect), ctx.measured, intervals=False, start=state["theta"], **ctx.kw)
    state["chi2"], state["ob_scale"] = res.chi2, scale  # the balance of this round ran at `scale`
    theta = whole_theta(ctx.chain, res)
    nq, moving = ctx.chain.n_flows, moving_flows(ctx.chain)
    ctx.history.append(theta[:nq].copy())
    step = np.abs(theta[:nq] - q)[moving]
    moved = float(np.max(step / qt[moving]))
    moved_sigma = float(np.max(step / np.maximum(res.flow_stds()[moving], 1e-300)))
    new_scale = measured_scale(ctx.chain, ctx.measured, theta, defect)
    state.update(q=theta[:nq].copy(), theta=theta, scale=new_scale, ob=ob, defect=defect)
    return _RoundMove(moved, moved_sigma, abs(new_scale / scale - 1.0))


def _copied(state: dict) -> dict:
    """The rounds' state, its arrays copied (a branch must not move another's)."""
    return {key: (v.copy() if isinstance(v, np.ndarray) else v) for key, v in state.items()}


def _run_time_rounds(ctx: _FitContext, state: dict, count: int, revolutions: int,
                     converged: bool) -> tuple[tuple[TimeRound, ...], list[str], bool]:
    """`count` time rounds from the state's answer (see `fit_large_orbit`), the state moved to each one's kept
    branch: the rounds kept, the warnings, and whether the last kept branch's rounds settled (else `converged`)."""
    time_log = []
    time_warnings = []
    for k in range(count):
        t_round = time.perf_counter()
        base = _copied(state)
        where, near = _time_round_flows(ctx.chain, base["ob"])
        branches = []
        for b, pt in enumerate(where):
            label = f"time round {k + 1}" + ("" if b == 0 else ", across Q_T")
            branch = _time_branch(ctx, state, base, pt, b > 0, near, label, revolutions, time_warnings)
            if branch is not None:
                branches.append(branch)
        state.clear()
        if not branches:  # every integration failed: the answer before this round stands
            state.update(base)
            time_warnings[-1] += f"; the flows are the {'balance' if k == 0 else 'last time round'}'s"
            break
        pick = min(branches, key=lambda br: (not br.consistent, br.round.chi2))
        state.update(pick.state)
        converged = pick.converged
        others = tuple(br.round for br in branches if br is not pick)
        time_log.append(dataclasses.replace(pick.round, seconds=time.perf_counter() - t_round, others=others))
    return tuple(time_log), time_warnings, converged


def _time_round_flows(chain: ForwardChain, ob: OrbitBalance) -> tuple[list[np.ndarray], list[int]]:
    """Where a time round integrates (at the last balance `ob`'s flows, and across Q_T from them), and the
    flows within KINK_BAND of their Q_T."""
    qt = chain.q_threshold
    at = np.asarray(ob.bearings.flows, dtype=float)  # the last balance's flows, within the rounds'
    # tolerance of the answer: the gap is taken there
    where = [at]  # there, and across Q_T from it for a flow near its kink
    near = [j for j in moving_flows(chain) if abs(at[j] / qt[j] - 1.0) < KINK_BAND]
    if near:
        other = at.copy()
        for j in near:
            side = 1.0 if at[j] >= qt[j] else -1.0
            other[j] = qt[j] * (1.0 - side * max(KINK_MIRROR, abs(at[j] / qt[j] - 1.0)))
        where.append(other)
    return where, near


def _time_branch(ctx: _FitContext, state: dict, base: dict, pt: np.ndarray, across: bool, near: list[int],
                 label: str, revolutions: int, time_warnings: list[str]) -> _Branch | None:
    """One branch of a time round, in `state` from the state `base`: the time integration at `pt` (the last
    balance's flows, or with `across` a balance at `pt` across Q_T from them), its gap held in the correction and
    the balance's rounds again. None, with a warning, when the balance or the integration failed."""
    qt = ctx.chain.q_threshold
    state.clear()
    state.update(_copied(base))
    done = state["rounds"]

    def sub(i, n, text):
        ctx.progress(done + min(i / max(n, 1), 1.0) * 0.99, ctx.total, f"large orbits, {label}: {text}")

    try:
        ob_pt = state["ob"] if not across else _balance(ctx.chain, pt, state["ob"], ctx.harmonics, ctx.points,
                                                        ORBIT_TOL, lambda i, n, t: sub(0, 1, f"balance, {t}"),
                                                        state["ob_scale"])
        gap, gap_pct, settled = time_gap(ctx.chain, ob_pt, state["ob_scale"], revolutions=revolutions,
                                         progress=lambda i, n, t: sub(i, n, f"integrating, {t}"))
    except LubevizError as exc:
        time_warnings.append(f"large orbits: {label} failed ({exc})")
        return None
    state["gap"], state["defect"] = gap, None
    if across:  # across Q_T the rounds start there, with that balance: from the answer they would cross the
        # kink with the far side's slope and stop on Q_T (record 5 of the bench: 544.8 ml/min, Q_T 545)
        theta_pt = state["theta"].copy()
        theta_pt[:ctx.chain.n_flows] = pt
        state.update(q=pt.copy(), theta=theta_pt, ob=ob_pt)
    settled_rounds = _balance_rounds(ctx, state, ctx.model, f"{label}, balance")
    consistent = all((state["q"][j] >= qt[j]) == (pt[j] >= qt[j]) for j in near)
    return _Branch(state=_copied(state), converged=settled_rounds, consistent=consistent,
                   round=TimeRound(flows_at=pt.copy(), flows_after=state["q"].copy(), gap_percent=gap_pct,
                                   settled_percent=settled, seconds=0.0, chi2=float(state["chi2"]),
                                   consistent=consistent))


def _intervals_at(ctx: _FitContext, state: dict, budget: ModelBudget) -> tuple[Fit, dict, dict]:
    """The refit at the state's answer with its intervals, the flows' intervals from the slope's union
    (`_slope_union`), and those widened by the balance's truncation under the whole `budget`
    (`_truncation_union`)."""
    chain, measured, kw, defect, theta = ctx.chain, ctx.measured, ctx.kw, state["defect"], state["theta"]
    final = fit(chain.with_defect(defect), measured, start=theta, **kw)
    intervals = _slope_union(chain, measured, defect, theta, final, kw)
    return final, intervals, _truncation_union(chain.with_defect(defect), measured, final, intervals, kw, budget)


def _answer_checks(ctx: _FitContext, state: dict, converged: bool) -> tuple[Stability, OrbitStability, list[str]]:
    """The stability of the equilibrium and of the periodic orbit at the state's answer, and the warnings on the
    answer: the rounds did not settle, either is unstable, the orbit is too large for its harmonics."""
    chain, q, ob = ctx.chain, state["q"], state["ob"]
    warnings = []
    if not converged:
        warnings.append(f"large orbits: the flows still moved by more than {100 * ctx.model.stop_tol:g} % of Q_T "
                        f"after {ctx.model.limit} balances")
    stability = equilibrium_stability(chain.rotor, film_bearings(chain.machine, [float(v) for v in q], chain.omega,
                                                                 previous=ob.bearings))
    if stability.unstable:
        warnings.append(f"large orbits: at the flows found the model is {stability.describe()}; the periodic orbit "
                        "fitted is then not what the machine would show (a sub-synchronous line would grow)")
    ctx.progress(ctx.total - 1, ctx.total, "large orbits: the orbit's stability")
    orbit_stab = orbit_stability(chain.rotor, ob.bearings, ob)  # a few seconds: the films along it, Hill's method
    if orbit_stab.unstable:
        warnings.append(f"large orbits: the periodic orbit fitted is unstable, {orbit_stab.describe()}; the machine "
                        "would not stay on it, and its record would hold lines the model has not")
    if ob.max_eccentricity > 0.8:
        warnings.append(f"large orbits: the journal reaches {ob.max_eccentricity:.2f} of the clearance; "
                        f"{ob.harmonics} harmonics may not hold such an orbit")
    return stability, orbit_stab, warnings


def _slope_union(chain: ForwardChain, measured, defect: ResponseDefect, theta, final: Fit, kw) -> dict:
    """The flows' profile intervals with the correction's slope uncertain: the union of the intervals with the
    slope as solved and x (1 +- SLOPE_UNCERTAINTY). Near Q_T the slope cancels most of the linear model's
    sensitivity to a flow, so the intervals' width hangs on it (on the independent record at the paper's
    unbalance a 20 % change of the slope moves Q2's upper end by 1 %)."""
    out = dict(final.intervals)
    for f in (1.0 - SLOPE_UNCERTAINTY, 1.0 + SLOPE_UNCERTAINTY):
        moved = dataclasses.replace(defect, dx=defect.dx * f, dy=defect.dy * f, dstatic=defect.dstatic * f,
                                    **({} if defect.hx is None else dict(hx=defect.hx * f, hy=defect.hy * f,
                                                                        hstatic=defect.hstatic * f)))
        try:
            other = fit(chain.with_defect(moved), measured, start=theta, **kw)
        except LubevizError:
            continue
        out = _interval_union(out, other.intervals)
    return out


def _truncation_union(chain: ForwardChain, measured, final: Fit, intervals: dict, kw, budget: ModelBudget) -> dict:
    """`intervals` widened to hold each flow +- 1.96 sigma of the fit's answer when the model's error is the whole
    `budget` (its `orbit_truncation` term included) and the weights are the fit's (`fit.sandwich_cov`). Against the
    time integration the balance's correction is 12 % off at the paper's unbalance near Q_T (0.45 share^2 per
    component, `ModelBudget.orbit_truncation`); the bench's 1 x records' sigma grows from 4-7 % of the flows to
    11-20 % with the answers unchanged (0.6 x: nearly unchanged, the per-entry 3 % is the larger term there)."""
    if budget.orbit_truncation <= 0:
        return intervals
    theta = whole_theta(chain, final)
    free = [chain.names.index(n) for n in final.names]
    cov = sandwich_cov(chain, measured, theta, names=kw["names"], weights=kw["budget"], budget=budget, free=free)
    out = dict(intervals)
    floor = chain.bounds(kw["lower"], kw["upper"])[0]
    for j, k in enumerate(free):
        if k >= chain.n_flows:  # the flows' intervals only
            continue
        n = chain.names[k]
        half = Z95 * math.sqrt(max(cov[j, j], 0.0))
        lo, hi = out.get(n, (theta[k], theta[k]))
        out[n] = (max(min(lo, theta[k] - half), floor[k]), None if hi is None else max(hi, theta[k] + half))
    return out


def _interval_union(a: dict, b: dict) -> dict:
    """Each parameter's interval holding both `a`'s and `b`'s (an open upper end stays open)."""
    out = dict(a)
    for n, (lo, hi) in b.items():
        if n in out:
            lo0, hi0 = out[n]
            out[n] = (min(lo0, lo), None if (hi is None or hi0 is None) else max(hi0, hi))
    return out


def _with_std_of(final: Fit, intervals: dict) -> Fit:
    """`final` with `intervals` (the slope's union), each flow's std at least their half-width / 1.96."""
    std, cov = std_within(final.names, final.values, final.std, final.cov, intervals)
    return dataclasses.replace(final, intervals=intervals, std=std, cov=cov)


def _time_round(r: TimeRound) -> dict:
    return {"flows_at_mlmin": (r.flows_at * MLMIN_PER_M3S).tolist(),
            "flows_after_mlmin": (r.flows_after * MLMIN_PER_M3S).tolist(),
            "gap_1x_percent": r.gap_percent.tolist(), "settled_percent": r.settled_percent, "chi2": r.chi2,
            "consistent": r.consistent}


def orbit_summary(of: OrbitFit) -> dict:
    """What the identification reports of the large-orbit model at its answer (JSON-ready)."""
    ob = of.orbit
    return {"rounds": of.balances, "converged": of.converged, "harmonics": ob.harmonics,
            "unbalance_scale": of.unbalance_scale,  # the balance's unbalance over the declared one
            "ratio_2x_model": [ob.harmonic_ratio(2, k) for k in range(len(ob.nodes))],
            "one_x_over_linear": [float(abs(ob.x[1, k]) / abs(ob.linear_x[k])) for k in range(len(ob.nodes))],
            "static_shift_um": (1e6 * np.stack([ob.x[0].real, ob.y[0].real], axis=-1)).tolist(),
            "max_eccentricity": ob.max_eccentricity,
            "plain_q_mlmin": (of.plain.flow_values() * MLMIN_PER_M3S).tolist(), "plain_chi2": of.plain.chi2,
            **({} if of.stability is None else {
                "stability": of.stability.describe(), "unstable": of.stability.unstable,
                "least_stable_mode_hz": of.stability.frequency_hz, "growth_per_s": of.stability.growth}),
            **({} if of.orbit_stability is None else {"orbit_stability": of.orbit_stability.summary()}),
            "time_rounds": [{**_time_round(r), "seconds": r.seconds,
                             "not_kept": [_time_round(o) for o in r.others]} for r in of.time_rounds],
            **({} if of.time_round_intervals is None else {"time_round_intervals_mlmin": [
                [lo * MLMIN_PER_M3S, None if hi is None else hi * MLMIN_PER_M3S]
                for lo, hi in of.time_round_intervals.values()]}),
            "seconds": of.seconds}
