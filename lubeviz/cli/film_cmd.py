"""`lubeviz film` and `lubeviz bearing` (SPEC §7)."""

from __future__ import annotations

import math
import time

import numpy as np

from ..errors import InputError
from ..film.derived import summarize
from ..film.equilibrium import find_equilibrium, flooded_threshold
from ..film.feed import Feed, setup_problem
from ..film.solver import solve
from ..model.machine import load_machine
from ..rotor.statics import bearing_static_loads
from ..units import m3s_to_mlmin, mlmin_to_m3s
from .common import add_common, finite_float, mesh_arg



def _feed_args(p, *, plain: bool):
    g = p.add_mutually_exclusive_group(required=True)
    g.add_argument("--q-mlmin", type=finite_float, metavar="Q", help="prescribed oil supply flow (ml/min)")
    g.add_argument("--flooded", action="store_true", help="groove held full at ambient pressure")
    if plain:
        g.add_argument("--no-groove", action="store_true",
                       help="plain 360-degree bearing fed at ambient pressure at the thickest film")


def _feed(args) -> Feed:
    if getattr(args, "no_groove", False):
        return Feed.plain()
    if args.flooded:
        return Feed.flooded()
    if args.q_mlmin <= 0.0:
        raise InputError(f"--q-mlmin {args.q_mlmin:g}: expected a positive supply flow in ml/min")
    return Feed.flow(mlmin_to_m3s(args.q_mlmin))


def _bearing(args):
    machine = load_machine(args.machine)
    index = int(machine.part_number("bearing", args.bearing, "--bearing")) - 1
    b = machine.bearings[index]
    changes = {}
    for flag, name, scale in (("length_mm", "length", 1e-3), ("radius_mm", "radius", 1e-3),
                              ("clearance_um", "clearance", 1e-6), ("viscosity_pas", "viscosity", 1.0)):
        value = getattr(args, flag, None)
        if value is not None:
            if value <= 0.0:
                raise InputError(f"--{flag.replace('_', '-')} {value:g}: expected a positive value")
            changes[name] = value * scale
    if getattr(args, "mesh", None) is not None:
        changes["n_circumferential"], changes["n_axial"] = args.mesh
    if getattr(args, "groove_refinement", None) is not None:  # bounds: Bearing.groove_refinement
        changes["groove_refinement"] = args.groove_refinement
    if getattr(args, "no_groove", False):
        changes["groove_length"] = changes["groove_width"] = 0.0
    try:
        b = b.copy(**changes) if changes else b
    except ValueError as exc:
        raise InputError(str(exc)) from None
    speed_hz = machine.operating_speed if args.speed_hz is None else args.speed_hz
    if speed_hz <= 0.0:
        raise InputError(f"--speed-hz {speed_hz:g}: expected a positive shaft speed")
    return machine, index, b, 2.0 * math.pi * speed_hz


def _bearing_arg(p) -> None:
    p.add_argument("--bearing", default="1", metavar="K",
                   help="which fluid-film bearing: its number in the model file (1..N) or its name (default 1)")


def register(sub) -> None:
    p = sub.add_parser("film", help="one p-theta solve at a fixed journal position")
    add_common(p)
    p.add_argument("--eccentricity", type=finite_float, required=True, metavar="E",
                   help="eccentricity ratio e/c, 0 <= E < 1")
    p.add_argument("--attitude-deg", type=finite_float, default=0.0, metavar="A",
                   help="direction of the journal centre, from -Y in the direction of rotation (deg)")
    _bearing_arg(p)
    _feed_args(p, plain=True)
    for flag, what in (("--length-mm", "bearing length"), ("--radius-mm", "journal radius"),
                       ("--clearance-um", "radial clearance"), ("--viscosity-pas", "oil viscosity (Pa*s)")):
        p.add_argument(flag, type=finite_float, default=None, help=f"override the {what}")
    p.add_argument("--speed-hz", type=finite_float, default=None, help="shaft speed (default: the machine's)")
    p.add_argument("--mesh", type=mesh_arg, default=None, metavar="NxM", help="circumferential x axial cells")
    p.add_argument("--groove-refinement", type=int, default=None, metavar="R",
                   help="split the groove's columns and their neighbours in R (1: uniform mesh; default: the model's)")
    p.set_defaults(run=run_film)

    p = sub.add_parser("bearing", help="static equilibrium and dynamic coefficients of one bearing")
    add_common(p)
    _bearing_arg(p)
    _feed_args(p, plain=False)
    p.add_argument("--speed-hz", type=finite_float, default=None, help="shaft speed (default: the machine's)")
    p.add_argument("--load-n", type=finite_float, default=None,
                   help="vertical load on the journal, downwards (default: the bearing's static share "
                        "of the rotor weight, from the rotor model)")
    p.add_argument("--mesh", type=mesh_arg, default=None, metavar="NxM", help="circumferential x axial cells")
    p.add_argument("--groove-refinement", type=int, default=None, metavar="R",
                   help="split the groove's columns and their neighbours in R (1: uniform mesh; default: the model's)")
    p.set_defaults(run=run_bearing)


def run_film(args) -> dict:
    t0 = time.perf_counter()
    if not 0.0 <= args.eccentricity < 1.0:
        raise InputError(f"--eccentricity {args.eccentricity:g}: expected 0 <= E < 1 (the journal inside the clearance)")
    _, _, b, omega = _bearing(args)
    feed = _feed(args)
    e = args.eccentricity * b.clearance
    psi = math.radians(args.attitude_deg)
    position = (e * math.sin(psi), -e * math.cos(psi))  # direction from -Y, in the direction of rotation
    sol = solve(setup_problem(b, omega, position, feed))
    s = summarize(sol, position)
    load = s.load
    sommerfeld = (b.viscosity * omega / (2 * math.pi) * b.length * b.diameter / load * (b.radius / b.clearance) ** 2
                  if load > 0 else None)
    result = {
        "force_n": sol.force, "load_n": load, "sommerfeld": sommerfeld,
        "attitude_deg": math.degrees(s.attitude_angle) if load > 0 else None,
        "side_leakage_mlmin": m3s_to_mlmin(sol.side_leakage), "supply_mlmin": m3s_to_mlmin(sol.supply),
        "max_pressure_pa": s.max_pressure, "cavitated_fraction": s.cavitated_fraction,
        "starved_fraction": s.starved_fraction, "groove_pressure_pa": s.groove_pressure,
        "friction_torque_nm": s.friction_torque, "power_loss_w": s.power_loss,
        "mass_residual": sol.mass_residual, "converged": sol.converged, "iterations": sol.iterations,
        "method": sol.method, "seconds": time.perf_counter() - t0,
    }
    if not sol.converged:
        raise InputError(f"film solve did not converge: {sol.message}")
    return result


def run_bearing(args) -> dict:
    t0 = time.perf_counter()
    machine, index, b, omega = _bearing(args)
    feed = _feed(args)
    if args.load_n is None:
        load = bearing_static_loads(machine)[index]
        w = float(-load[1])
    else:
        w = args.load_n
        if w <= 0.0:
            raise InputError(f"--load-n {w:g}: expected a positive load in N")
        load = np.array([0.0, -w])
    q_t, eq_flooded = flooded_threshold(b, omega, load)
    eq = eq_flooded if feed.kind == "flooded" else find_equilibrium(
        b, omega, load, feed, start=eq_flooded.position, warm=eq_flooded.film)
    if not eq.converged:
        raise InputError(f"no static equilibrium found for {feed.describe()} under {w:g} N: {eq.message}")
    s = summarize(eq.film, eq.position)
    return {
        "bearing": index + 1, "bearing_name": b.name, "q_mlmin": m3s_to_mlmin(eq.film.supply),
        "eccentricity_ratio": eq.eccentricity_ratio, "attitude_deg": math.degrees(eq.attitude_angle),
        "position_m": eq.position, "K": eq.coefficients.K, "C": eq.coefficients.C,
        "coefficient_method": eq.coefficients.method,
        "side_leakage_mlmin": m3s_to_mlmin(eq.film.side_leakage), "q_threshold_mlmin": m3s_to_mlmin(q_t),
        "max_pressure_pa": s.max_pressure, "min_film_um": s.min_film * 1e6,
        "cavitated_fraction": s.cavitated_fraction, "starved_fraction": s.starved_fraction,
        "groove_pressure_pa": s.groove_pressure, "power_loss_w": s.power_loss, "load_n": w,
        "speed_hz": omega / (2 * math.pi), "newton_steps": eq.iterations, "seconds": time.perf_counter() - t0,
    }
