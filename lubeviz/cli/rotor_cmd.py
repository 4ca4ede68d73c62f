"""`lubeviz response` and `lubeviz simulate` (SPEC §7)."""

from __future__ import annotations

import json
import math
import time
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..model.machine import load_machine
from ..rotor import machine_unbalance, modal_analysis, rotor_from_machine, unbalance_response
from ..rotor.film_bearings import film_bearings
from ..units import MLMIN_PER_M3S, mlmin_to_m3s
from ..effects import parse_effects
from ..progress import StderrBar
from .common import add_common, finite_float


def nodes_arg(text: str) -> tuple[int, ...]:
    try:
        nodes = tuple(int(v) for v in text.split(","))
    except ValueError:
        raise InputError(f"--nodes {text!r}: expected comma-separated node numbers, e.g. 5,6,20,21") from None
    return nodes


def _speed(machine, speed_hz):
    speed_hz = machine.operating_speed if speed_hz is None else speed_hz
    if not machine.speed_min <= speed_hz <= machine.speed_max:
        raise InputError(f"--speed-hz {speed_hz:g}: outside the model's range {machine.speed_min:g}-"
                         f"{machine.speed_max:g} Hz")
    return speed_hz


def _flows(args, machine) -> tuple:
    """Every fluid-film bearing's supply flow (m^3/s, file order): `--q-mlmin Q1,Q2,...` (SPEC §8), or `--q1-mlmin` and
    `--q2-mlmin` for a machine of two."""
    names = ", ".join(b.name for b in machine.bearings)
    if getattr(args, "q_mlmin", None) is not None:
        if args.q1_mlmin is not None or args.q2_mlmin is not None:
            raise InputError("give either --q-mlmin Q1,Q2,... or --q1-mlmin/--q2-mlmin, not both")
        values = [finite_float_or_error(v, "--q-mlmin") for v in args.q_mlmin.split(",")]
        if len(values) != len(machine.bearings):
            raise InputError(f"--q-mlmin {args.q_mlmin!r}: {len(values)} value(s) for {len(machine.bearings)} "
                             f"fluid-film bearings; expected one per bearing in file order ({names})")
        labels = [f"--q-mlmin value {k}" for k in range(1, len(values) + 1)]
    else:
        if len(machine.bearings) != 2:
            raise InputError(f"this machine has {len(machine.bearings)} fluid-film bearings ({names}): give "
                             "--q-mlmin Q1,Q2,... (one per bearing, file order)")
        values, labels = [args.q1_mlmin, args.q2_mlmin], ["--q1-mlmin", "--q2-mlmin"]
        for v, label in zip(values, labels):
            if v is None:
                raise InputError(f"{label} is required (or --q-mlmin Q1,Q2; or --coefficients FILE for response)")
    for v, label in zip(values, labels):
        if v <= 0:
            raise InputError(f"{label} {v:g}: expected a positive supply flow in ml/min")
    return tuple(mlmin_to_m3s(v) for v in values)


def read_coefficients(path: str) -> list[tuple[np.ndarray, np.ndarray]]:
    """`{"bearings": [{"K": [[..]], "C": [[..]]}, ...]}` (N/m, N*s/m, SPEC §1 sign)."""
    try:
        data = json.loads(Path(path).read_text())
    except FileNotFoundError:
        raise InputError(f"--coefficients {path}: no such file") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise InputError(f"--coefficients {path}: not valid JSON ({exc})") from None
    if not isinstance(data, dict) or not isinstance(data.get("bearings"), list):
        raise InputError(f"--coefficients {path}: expected an object with a 'bearings' list")
    out = []
    for k, b in enumerate(data["bearings"], start=1):
        pair = []
        for key in ("K", "C"):
            try:
                m = np.array(b[key], dtype=float)
            except (KeyError, TypeError, ValueError):
                raise InputError(f"--coefficients {path}: bearing {k}: missing or non-numeric {key!r}; "
                                 "expected a 2x2 list of numbers") from None
            if m.shape != (2, 2) or not np.all(np.isfinite(m)):
                raise InputError(f"--coefficients {path}: bearing {k}: {key} must be a finite 2x2 matrix, "
                                 f"got shape {m.shape}")
            pair.append(m)
        out.append(tuple(pair))
    return out


def _flow_arguments(p) -> None:
    p.add_argument("--q-mlmin", type=str, default=None, metavar="Q1,Q2,...",
                   help="every fluid-film bearing's supply flow (ml/min), in the model file's order (SPEC §8)")
    p.add_argument("--q1-mlmin", type=finite_float, default=None, help="supply flow of bearing 1 (ml/min)")
    p.add_argument("--q2-mlmin", type=finite_float, default=None, help="supply flow of bearing 2 (ml/min)")


def register(sub) -> None:
    p = sub.add_parser("response", help="steady unbalance response of the machine on its film bearings")
    add_common(p)
    _flow_arguments(p)
    p.add_argument("--coefficients", metavar="FILE", default=None,
                   help="JSON bearing coefficients, bypassing the film model")
    p.add_argument("--speed-hz", type=finite_float, default=None, help="shaft speed (default: the machine's)")
    p.add_argument("--nodes", type=str, default=None, help="output nodes (default: the machine's measurement planes, with its outside nodes if it declares any)")
    p.add_argument("--shaft-damping-beta", type=finite_float, default=None, metavar="B",
                   help="stiffness-proportional shaft damping (s), default from the machine file")
    p.set_defaults(run=run_response)

    p = sub.add_parser("simulate", help="write a synthetic measured record (SPEC §6) as the paper makes it")
    add_common(p)
    _flow_arguments(p)
    p.add_argument("--nodes", type=str, default=None,
                   help="the two measurement nodes (default: the machine's measurement planes)")
    p.add_argument("--snr-db", type=str, default="12", help="noise SNR in dB, or 'none' (default 12)")
    p.add_argument("--seed", type=int, default=0, help="noise seed (default 0)")
    p.add_argument("--duration-s", type=finite_float, default=5.0, help="length of the record kept (s)")
    p.add_argument("--total-s", type=finite_float, default=15.0,
                   help="simulated time from rest; the last --duration-s are kept (default 15)")
    p.add_argument("--sample-rate-hz", type=finite_float, default=1.0e4, help="samples per second")
    p.add_argument("--speed-hz", type=finite_float, default=None, help="shaft speed (default: the machine's)")
    p.add_argument("--method", choices=("time", "steady"), default=None,
                   help="time integration from rest (the paper; default without effects) or the steady state "
                        "sampled (the default, and the only method, with --effect)")
    p.add_argument("--effect", action="append", default=[], metavar="NAME[:key=value,...]",
                   help="add an effect to the machine or the measurement (SPEC §7, repeatable), e.g. "
                        "viscosity:factor=0.8 or probe_gain:channel=x1,gain=1.1; parameters not given take "
                        "their defaults")
    p.add_argument("-o", "--output", required=True, metavar="FILE", help="record file: .csv, .npz or .mat")
    p.set_defaults(run=run_simulate)


def run_response(args) -> dict:
    t0 = time.perf_counter()
    machine = load_machine(args.machine)
    machine.require_modelled("response")
    speed_hz = _speed(machine, args.speed_hz)
    omega = 2 * math.pi * speed_hz
    nodes = nodes_arg(args.nodes) if args.nodes else tuple(machine.outside_nodes[:1]) + tuple(
        machine.center_nodes) + tuple(machine.outside_nodes[1:])
    beta = args.shaft_damping_beta
    if beta is not None and beta < 0:
        raise InputError(f"--shaft-damping-beta {beta:g}: expected a non-negative value (s)")
    rotor = rotor_from_machine(machine, shaft_damping_beta=beta)
    bearings_out = None
    if args.coefficients is not None:
        if args.q1_mlmin is not None or args.q2_mlmin is not None or args.q_mlmin is not None:
            raise InputError("give either the flows (--q-mlmin or --q1-mlmin/--q2-mlmin) or --coefficients, not both")
        coeffs = read_coefficients(args.coefficients)
    else:
        fb = film_bearings(machine, _flows(args, machine), omega)
        coeffs = fb.coefficients
        bearings_out = [{"q_mlmin": q * MLMIN_PER_M3S, "eccentricity_ratio": e.eccentricity_ratio,
                         "attitude_deg": math.degrees(e.attitude_angle), "position_m": e.position,
                         "K": e.coefficients.K, "C": e.coefficients.C}
                        for q, e in zip(fb.flows, fb.equilibria)]
    r = unbalance_response(rotor, omega, machine_unbalance(machine), coeffs, nodes=nodes)
    modal = modal_analysis(rotor, omega, coeffs, n_modes=8)
    out = {
        "speed_hz": speed_hz,
        "nodes": {str(n): {"x": [r.x[k].real, r.x[k].imag], "y": [r.y[k].real, r.y[k].imag],
                           "zf": [r.zf[k].real, r.zf[k].imag], "zb": [r.zb[k].real, r.zb[k].imag],
                           "fb": r.fb[k], "phi_deg": math.degrees(r.phi[k])} for k, n in enumerate(r.nodes)},
        "natural_frequencies_hz": modal.damped_frequencies_hz,
        "damping_ratios": modal.damping_ratios,
        "whirl": list(modal.whirl),
        "stable": modal.stable,
    }
    if bearings_out is not None:
        out["bearings"] = bearings_out
    out["seconds"] = time.perf_counter() - t0
    return out


def run_simulate(args) -> dict:
    from ..signals.records.record import MAX_PLANES
    from ..signals.records import write_record
    from ..signals.synthesize import synthesize_record

    t0 = time.perf_counter()
    machine = load_machine(args.machine)
    machine.require_modelled("simulate")
    speed_hz = _speed(machine, args.speed_hz)
    nodes = nodes_arg(args.nodes) if args.nodes else tuple(machine.center_nodes)
    if not 2 <= len(nodes) <= MAX_PLANES:
        given = f"--nodes {args.nodes!r}" if args.nodes else f"the machine's {len(nodes)} measurement planes"
        raise InputError(f"{given}: a record holds 2 to {MAX_PLANES} measurement planes")
    snr = None if args.snr_db.strip().lower() == "none" else finite_float_or_error(args.snr_db, "--snr-db")
    out = Path(args.output)
    if out.suffix.lower() not in (".csv", ".npz", ".mat"):
        raise InputError(f"-o {out}: expected a .csv, .npz or .mat file name")
    if not out.parent.exists():
        raise InputError(f"-o {out}: folder {out.parent} does not exist")
    effects = parse_effects(args.effect, machine)
    flows = _flows(args, machine)
    method = args.method or ("steady" if effects else "time")
    if effects and method != "steady":
        raise InputError("--method time with --effect: effects are simulated through the steady forward chain; "
                         "use --method steady (or leave --method out)")
    if any(e.stage == "response" for e in effects):  # large orbits: the film solved along the orbit
        if len(effects) > 1:
            raise InputError("--effect large_orbit: combine it with no other effect (not supported yet)")
        method = "orbit"
        rec = synthesize_record(machine, flows, nodes=nodes, snr_db=snr, rng=np.random.default_rng(args.seed),
                                duration_s=args.duration_s, total_s=args.duration_s,
                                sample_rate_hz=args.sample_rate_hz, speed_hz=speed_hz, method="orbit",
                                progress=StderrBar())
        import dataclasses

        rec = dataclasses.replace(rec, metadata={**rec.metadata, "effects": "large_orbit", "seed": str(args.seed)})
    elif effects:
        from ..identify.forward.chain import ForwardChain, simulate

        held = tuple(e.hold() for e in effects)
        chain = ForwardChain(machine, speed_hz, nodes, held, progress=StderrBar())
        rec = simulate(chain, np.array(flows), snr_db=snr, rng=np.random.default_rng(args.seed),
                       duration_s=args.duration_s, sample_rate_hz=args.sample_rate_hz,
                       metadata={"effects": "; ".join(e.spec() for e in held), "seed": str(args.seed)})
    else:
        rec = synthesize_record(machine, flows, nodes=nodes, snr_db=snr,
                                rng=np.random.default_rng(args.seed), duration_s=args.duration_s,
                                total_s=args.total_s, sample_rate_hz=args.sample_rate_hz, speed_hz=speed_hz,
                                method=method)
    write_record(rec, out)
    ml = {f"q{k}_mlmin": float(f"{q * MLMIN_PER_M3S:.12g}") for k, q in enumerate(flows, start=1)}
    return {"file": str(out), **ml, "nodes": list(nodes),
            "snr_db": snr, "seed": args.seed, "n_samples": rec.n_samples, "duration_s": rec.duration,
            "sample_rate_hz": rec.sample_rate_hz, "speed_hz": speed_hz, "method": method,
            "effects": [e.spec() for e in effects], "seconds": time.perf_counter() - t0,
            **{k: rec.metadata[k] for k in ("stability", "whirl_hz", "whirl_growth_per_s", "orbit_stability",
                                            "orbit_stability_state") if k in rec.metadata}}


def finite_float_or_error(text: str, flag: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise InputError(f"{flag} {text!r}: expected a number in dB or 'none'") from None
    if not math.isfinite(v):
        raise InputError(f"{flag} {text!r}: expected a finite number in dB or 'none'")
    return v
