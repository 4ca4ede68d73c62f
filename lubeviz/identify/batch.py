"""Identification of records from files, one or many (in parallel), as the CLI and the app use it."""

from __future__ import annotations

import math
import os
import time
from pathlib import Path
from concurrent.futures import ProcessPoolExecutor, as_completed
import dataclasses
from dataclasses import dataclass


from ..errors import InputError, LubevizError
from ..model.machine import load_machine
from ..progress import ProgressFn, silent
from ..signals.records import read_record
from .tables.cache import machine_tables
from .forward.model import ALL_FEATURES, ForwardModel
from .forward.measured import measure
from .paper.newton import identify
from .fit.result import Identification, union_interval
from .fit.oil_reading import budget_with_reading, oil_reading
from .fit.settings import IdentificationSettings
from ..units import MLMIN_PER_M3S


@dataclass(frozen=True)
class RecordIdentification:
    """An identification with the record's name and the model's flooded thresholds."""

    file: str
    result: Identification
    nodes: tuple[int, int]
    speed_hz: float
    warnings: tuple[str, ...] = ()  # the record reader's (e.g. an unknown metadata key)
    speeds_hz: tuple[float, ...] = ()  # a set: every record's speed
    set_name: str | None = None
    lines: tuple = ()  # `signals.lines.Line`s present beyond 1X (the linear model has none)
    findings: tuple = ()  # `plausibility.Finding`s: what is impossible or suspicious in the record as declared
    bearings: tuple = ()  # (name, node, supply) of each fluid-film bearing in file order (SPEC §8 `flows`)


# The caveat every record at one speed without a static position carries (a note on the pages, not a warning: it is
# true of every such record, issue 38).
OIL_ASSUMED = "the flows assume the declared oil viscosity"

def fit_features(settings, chain) -> tuple[str, ...]:
    """The features a best-mode fit uses: the settings' list, or, when it is the default (the paper's six invariants
    of two planes), every invariant of the chain's planes (`model.plane_features`)."""
    from .forward.model import plane_features

    names = tuple(settings.features)
    return plane_features(len(chain.nodes)) if names == ALL_FEATURES else names


def bearing_names(machine) -> tuple:
    """(name, node, supply) of each fluid-film bearing, in the model file's order."""
    return tuple((b.name or f"bearing {k}", b.node, getattr(b, "supply", "unknown"))
                 for k, b in enumerate(machine.bearings, start=1))


def check_model_speed(machine, speed_hz: float) -> None:
    """Raise InputError when a record's speed lies outside the speeds the machine model is meant for."""
    if not machine.speed_min <= speed_hz <= machine.speed_max:
        raise InputError(f"record speed {speed_hz:g} Hz is outside the model's range "
                         f"{machine.speed_min:g}-{machine.speed_max:g} Hz")


def model_for(machine, speed_hz: float, nodes, *, progress: ProgressFn = silent) -> ForwardModel:
    check_model_speed(machine, speed_hz)
    tables = machine_tables(machine, 2 * math.pi * speed_hz, progress=progress)
    return ForwardModel(machine, tables, nodes)


def model_speed(machine, record) -> float:
    """The speed (Hz) the model is built at for `record`: the machine's operating speed when the record
    runs at it (to 0.1 %, so its cached tables serve), else the record's own speed."""
    if abs(record.speed_hz / machine.operating_speed - 1) < 1e-3:
        return machine.operating_speed
    return record.speed_hz


def identify_record(record, machine=None, settings: IdentificationSettings | None = None, *,
                    progress: ProgressFn = silent, model: ForwardModel | None = None,
                    measured=None, effects=(), budget=None, tables=None) -> RecordIdentification:
    """Identify every unknown supply flow (and the free parameters of declared `effects`) from a `Record`
    (already read). `model` (paper mode) or `tables` (best mode, one per bearing at the record's speed): what the
    caller already holds (the dashboard's shared ones), else built or read from the cache.

    Best mode: the fit on named parameters (`fit.fit`: global search over the flow box, model budget,
    profile intervals) through the forward chain with the record's probe angles. Paper mode: the paper's
    Newton-Raphson on the table model (`newton.identify_paper`), without effects.
    """
    machine = load_machine() if machine is None else machine
    settings = settings or IdentificationSettings()
    speed = model_speed(machine, record)
    check_model_speed(machine, speed)
    measured = measure(record, ALL_FEATURES if settings.mode == "paper" else None) if measured is None else measured
    if settings.mode == "paper":
        if effects:
            raise InputError("paper mode identifies the flows only; declare effects in best mode")
        if model is None or model.nodes != tuple(record.nodes) or abs(model.omega / (2 * math.pi) - speed) > 1e-9:
            model = model_for(machine, speed, record.nodes, progress=progress)
        result = identify(model, measured, settings)
    else:
        if tables is None and model is not None:
            tables = model.tables
        result = _fit_record(record, machine, speed, measured, settings, effects, budget, progress, tables)
    lines, notes = beyond_1x(record)
    findings = record_checks([record], [measured], machine)
    return RecordIdentification(file=str(record.source or "record"), result=result, nodes=tuple(record.nodes),
                                bearings=bearing_names(machine),
                                speed_hz=record.speed_hz, warnings=tuple(f.text for f in findings) +
                                tuple(getattr(record, "warnings", ())) + notes, lines=lines, findings=findings)


def record_checks(records, measured, machine) -> tuple:
    """`plausibility.record_findings` of each record (its measured features in `measured`) against the plain
    model of `machine` at the record's speed, planes and probes."""
    from .forward.chain import ForwardChain
    from .fit.plausibility import record_findings

    out = []
    for rec, m in zip(records, measured):
        chain = ForwardChain(machine, model_speed(machine, rec), rec.nodes, probe_angles_deg=rec.probe_angles_deg)
        out += record_findings(rec, m, chain)
    return tuple(out)


def beyond_1x(records) -> tuple[tuple, tuple[str, ...]]:
    """The lines beyond 1X present in `records` (one or several) and a warning for each one above
    LINE_NOTICE of 1X: the linear model produces none, so the flows rest on the 1X part alone."""
    from ..signals.lines import CAUSES, LINE_NOTICE, present_lines

    records = records if isinstance(records, (list, tuple)) else [records]
    lines, notes = [], []
    for rec in records:
        try:
            found = present_lines(rec)
        except LubevizError:  # too short for a spectrum: the 1X fit has already judged the record
            continue
        lines += found
        where = str(getattr(rec, "source", None) or "record")
        notes += [(f"{where}: {line.describe()}: {CAUSES['mains']}" if line.kind == "mains" else
                   f"{where}: {line.describe()}; the linear model has none ({CAUSES[line.kind]}): the flows rest on "
                   "the 1X part") for line in found if line.relative_to_1x > LINE_NOTICE]
    return tuple(lines), tuple(notes)





def _fit_record(record, machine, speed, measured, settings, effects, budget, progress, tables) -> Identification:
    from .forward.chain import ForwardChain
    from .fit.least_squares import fit, to_identification
    from .fit.result import check_record

    from .forward.budget import ModelBudget

    if budget is None and not settings.include_model_error:
        budget = ModelBudget.none()
    oil_effects, tolerance, oil_notes = oil_reading(record, machine, effects)
    if oil_effects and settings.include_model_error:
        budget = budget_with_reading(budget, tolerance)
    effects, settings = response_setting(tuple(oil_effects) + tuple(effects), settings)
    if tables is not None and any(abs(t.omega / (2 * math.pi) - speed) > 1e-9 * speed for t in tables):
        tables = None  # tables of another speed: the chain reads its own
    chain = ForwardChain(machine, speed, record.nodes, effects, probe_angles_deg=record.probe_angles_deg,
                         tables=tables, progress=progress)
    check_record(_NodesSpeed(chain), measured, settings)
    if settings.response == "large orbit":  # the linear chain plus the balance's correction, round by round
        from .fit.large_orbit import check_orbit_chain, fit_large_orbit, orbit_points, orbit_summary

        check_orbit_chain(chain)
        of = fit_large_orbit(chain, measured, names=fit_features(settings, chain), budget=budget, lower=settings.lower,
                             upper=settings.upper, harmonics=settings.orbit_harmonics,
                             points=orbit_points(settings.orbit_harmonics),
                             time_rounds=settings.orbit_time_rounds, progress=progress)
        out = to_identification(of.fit, chain)
        out = dataclasses.replace(out, effect_details={**out.effect_details, "large_orbit": orbit_summary(of)})
        return dataclasses.replace(out, warnings=out.warnings + oil_notes) if oil_notes else out
    res = fit(chain, measured, names=fit_features(settings, chain), budget=budget, lower=settings.lower,
              upper=settings.upper)
    out = to_identification(res, chain)
    if oil_notes:
        out = dataclasses.replace(out, warnings=out.warnings + oil_notes)
    if settings.oil_check != "never" and not measured.static_names and not any(
            e.stage == "bearings" for e in effects):  # the film's scale declared
        # Whether it runs depends on the setting only, never on what the cache holds: the same command gives
        # the same answer on a cold or a warm cache.
        if settings.oil_check == "always":
            out = _oil_check(out, res, chain, measured, settings, budget)
        else:
            out = dataclasses.replace(out, warnings=out.warnings + (
                f"{OIL_ASSUMED}: one record at one speed cannot tell hotter or colder "
                "oil from a supply change (--oil-check quantifies it: it builds the tables over x0.75-1.33 viscosity once; "
                "the static shaft position or records at other speeds separate them)",))
    return out


def response_setting(effects, settings: IdentificationSettings) -> tuple[tuple, IdentificationSettings]:
    """`effects` without a response-model effect (`large_orbit`, as `--effect` names it), and the settings with
    the response model it names: it replaces the chain's linear response rather than joining its stages."""
    named = {e.effect_name for e in effects if e.stage == "response"}
    if not named:
        return tuple(effects), settings
    if named != {"large_orbit"}:
        raise InputError(f"response models {sorted(named)}: one at a time")
    values = {k: v for k, v in settings.param.values().items() if k != "name"}
    return tuple(e for e in effects if e.stage != "response"), type(settings)(**{**values, "response": "large orbit"})


OIL_RANGE = (0.75, 1.0 / 0.75)


def _oil_check(out: Identification, res, chain, measured, settings, budget) -> Identification:
    """The flows' intervals with the oil viscosity a free nuisance within OIL_RANGE (both bearings), and
    how strongly it is tied to the flows: what a single record at one speed can and cannot say."""
    from ..effects import Viscosity
    from .fit.least_squares import fit
    from .forward.chain import flow_names

    oil = Viscosity(bearing="both").release("factor").limited(factor=OIL_RANGE)
    try:
        wide = fit(chain.with_effects(chain.effects + (oil,)), measured, names=fit_features(settings, chain),
                   budget=budget, lower=settings.lower, upper=settings.upper)
    except LubevizError as exc:  # the tables cannot serve the range: say so
        return dataclasses.replace(out, warnings=out.warnings + (f"oil check skipped: {exc}",))
    j = wide.names.index("viscosity.factor")
    names = flow_names(chain.n_flows)
    corr = [float(wide.correl[j, wide.names.index(n)]) if n in wide.names else 0.0 for n in names]
    # over any oil in the range, the declared oil included: never an interval that leaves out the answer
    iv = tuple(union_interval(wide.intervals.get(n), own) for n, own in zip(names, out.intervals))
    warnings = out.warnings
    top = chain.bounds(settings.lower, settings.upper)[1]

    def width(interval, k):
        return 0.0 if interval is None else (interval[1] if interval[1] is not None else top[k]) - interval[0]

    if any(width(w, k) > 2 * width(n, k) for k, (w, n) in enumerate(zip(iv, out.intervals)) if w is not None):
        spans = ", ".join(f"Q{k + 1} in [{a * MLMIN_PER_M3S:.0f}, {'open' if b is None else f'{b * MLMIN_PER_M3S:.0f}'}]"
                          for k, (a, b) in ((k, w) for k, w in enumerate(iv) if w is not None))
        warnings = warnings + (
            "the flows are tied to the oil viscosity in this record (correlation "
            + ", ".join(f"{c:+.2f}" for c in corr) + f"): if the oil may be x{OIL_RANGE[0]:g}-{OIL_RANGE[1]:.2f} as "
            f"viscous as declared, {spans} ml/min; the oil temperature, the static shaft position or records at "
            "other speeds would pin it",)
    return dataclasses.replace(out, intervals_any_oil=iv, warnings=warnings,
                               oil_degeneracy={**{f"correlation_q{k + 1}": c for k, c in enumerate(corr)},
                                               "factor": float(wide.values[j]), "factor_std": float(wide.std[j]),
                                               "range": list(OIL_RANGE)})


class _NodesSpeed:
    """What `result.check_record` reads of a model: its speed and planes."""

    def __init__(self, chain):
        self.omega, self.nodes = chain.omega, chain.nodes


def machine_for(record, machine_path=None):
    """The machine model of a record: --machine when given (a warning if the record names another),
    else the model file the record names (`machine: NAME`, resolved under models/), else the default."""
    from ..model.machine import resolve_machine_name

    where = str(record.source or "record")
    named = getattr(record, "machine", None)
    warnings = []
    if machine_path is not None:
        if named and Path(named).name != Path(machine_path).name:
            warnings.append(f"{where}: the record names machine {named!r}; using --machine {machine_path}")
        return load_machine(machine_path), tuple(warnings)
    if named:
        return load_machine(resolve_machine_name(named, where)), ()
    return load_machine(), ()


def read_for_machine(path, machine_path=None):
    """(record, machine, notes): the record read with its machine's measurement planes as the defaults for what
    it does not name (SPEC §8: nodes, probe angles), the machine as `machine_for` chooses it (--machine, else the
    model file the record names, else the default)."""
    from ..model.machine import resolve_machine_name

    if machine_path is not None:
        machine = load_machine(machine_path)
        rec = read_record(path, **machine.record_defaults())
        return (rec, *machine_for(rec, machine_path))
    rec = read_record(path, **load_machine().record_defaults())
    if getattr(rec, "machine", None):
        named = load_machine(resolve_machine_name(rec.machine, str(rec.source or path)))
        rec = read_record(path, **named.record_defaults())
    return (rec, *machine_for(rec))


def identify_set(records, machine=None, settings: IdentificationSettings | None = None, *,
                   progress: ProgressFn = silent, effects=(), budget=None) -> RecordIdentification:
    """One identification from the records of one `set:` (SPEC §6): the same flows (and free effect
    parameters) at every speed, one forward chain per record, residuals stacked (`fit.fit`)."""
    from ..signals.records import check_set
    from .forward.chain import ForwardChain
    from .fit.least_squares import fit, to_identification
    from .fit.result import check_record

    records = check_set(list(records))
    machine = load_machine() if machine is None else machine
    settings = settings or IdentificationSettings()
    if settings.mode == "paper":
        raise InputError("paper mode identifies one record; a set is identified in best mode")
    if budget is None and not settings.include_model_error:
        from .forward.budget import ModelBudget

        budget = ModelBudget.none()
    chains, meas, notes, tolerance = [], [], [], 0.0
    for n, rec in enumerate(records, start=1):
        speed = model_speed(machine, rec)
        check_model_speed(machine, speed)
        oil_effects, tol, oil_notes = oil_reading(rec, machine, effects)
        tolerance, notes = max(tolerance, tol), notes + list(oil_notes)
        chain = ForwardChain(machine, speed, rec.nodes, tuple(oil_effects) + tuple(effects),
                             probe_angles_deg=rec.probe_angles_deg, progress=progress)
        m = measure(rec)
        check_record(_NodesSpeed(chain), m, settings)
        chains.append(chain)
        meas.append(m)
    if tolerance > 0 and settings.include_model_error:
        budget = budget_with_reading(budget, tolerance)
    res = fit(chains, meas, names=fit_features(settings, chains[0]), budget=budget, lower=settings.lower,
              upper=settings.upper)
    result = to_identification(res, chains[0])
    files = "+".join(str(r.source or "record") for r in records)
    warnings = tuple(w for r in records for w in getattr(r, "warnings", ())) + tuple(notes)
    lines, line_notes = beyond_1x(records)
    findings = record_checks(records, meas, machine)
    return RecordIdentification(file=files, result=result, nodes=tuple(records[0].nodes),
                                bearings=bearing_names(machine),
                                speed_hz=records[0].speed_hz,
                                warnings=tuple(f.text for f in findings) + warnings + line_notes, lines=lines,
                                speeds_hz=tuple(r.speed_hz for r in records), set_name=records[0].set_name,
                                findings=findings)


def identify_file(path, machine=None, settings: IdentificationSettings | None = None, *,
                  progress: ProgressFn = silent, model: ForwardModel | None = None,
                  effects=()) -> RecordIdentification:
    """Read a record (SPEC §6) and identify Q1, Q2. The model is built at the record's speed."""
    from ..effects import parse_effect

    if machine is None:
        rec, machine, notes = read_for_machine(path)
    else:
        rec, notes = read_record(path, **machine.record_defaults()), ()
    effects = tuple(parse_effect(e, machine) if isinstance(e, str) else e for e in effects)  # names: this machine's
    out = identify_record(rec, machine, settings, progress=progress, model=model, effects=effects)
    return dataclasses.replace(out, file=str(path), warnings=notes + out.warnings)


def _worker(path, machine_path, settings, effect_specs=()):
    try:
        return identify_file(path, None if machine_path is None else load_machine(machine_path), settings,
                             effects=tuple(effect_specs)), None
    except LubevizError as exc:
        return None, str(exc)


def identify_files(paths, machine_path=None, settings: IdentificationSettings | None = None, *,
                   workers: int | None = None, progress: ProgressFn = silent,
                   effect_specs=()) -> list[tuple[str, RecordIdentification | None, str | None]]:
    """Identify many records; returns (file, result or None, error message or None) in input order. The
    records of one `set:` are identified together (`identify_set`).

    Tables are built (or loaded) once, up front, then records run on `workers` processes.
    """
    from ..effects import parse_effects

    settings = settings or IdentificationSettings()
    paths = [str(p) for p in paths]
    grouped = _set_groups(paths, machine_path)
    if grouped is not None:
        return _identify_groups(grouped, machine_path, settings, progress, effect_specs)
    machine = load_machine(machine_path)
    machine_tables(machine, progress=progress)  # warm the cache before fanning out
    workers = min(len(paths), os.cpu_count() or 1) if workers is None else max(1, int(workers))
    out: dict[str, tuple] = {}
    t0 = time.perf_counter()
    if workers == 1 or len(paths) == 1:
        for n, p in enumerate(paths, start=1):
            try:
                rec, mach, notes = read_for_machine(p, machine_path)
                r = identify_record(rec, mach, settings, effects=parse_effects(effect_specs, mach))
                out[p] = (dataclasses.replace(r, file=p, warnings=notes + r.warnings), None)
            except LubevizError as exc:
                out[p] = (None, str(exc))
            progress(n, len(paths), os.path.basename(p))
    else:
        with ProcessPoolExecutor(max_workers=workers) as pool:
            futures = {pool.submit(_worker, p, machine_path, settings, tuple(effect_specs)): p for p in paths}
            for n, f in enumerate(as_completed(futures), start=1):
                out[futures[f]] = f.result()
                progress(n, len(paths), f"{os.path.basename(futures[f])} ({time.perf_counter() - t0:.1f} s)")
    return [(p, *out[p]) for p in paths]


def _set_groups(paths, machine_path=None):
    """Records read and grouped by `set:` when any of them belongs to one; None otherwise (or on a read
    error, which the per-file path reports)."""
    from ..signals.records import group_records

    try:
        records = [read_for_machine(p, machine_path)[0] for p in paths]
    except LubevizError:
        return None
    if not any(r.set_name for r in records):
        return None
    return group_records(records)


def _identify_groups(groups, machine_path, settings, progress, effect_specs):
    from ..effects import parse_effects

    out = []
    for group in groups:
        label = "+".join(str(r.source) for r in group)
        try:
            machine, notes = machine_for(group[0], machine_path)
            effects = parse_effects(effect_specs, machine)  # names: this machine's
            if len(group) == 1:
                item = identify_record(group[0], machine, settings, effects=effects, progress=progress)
            else:
                item = identify_set(group, machine, settings, effects=effects, progress=progress)
            out.append((label, dataclasses.replace(item, warnings=notes + item.warnings), None))
        except LubevizError as exc:
            out.append((label, None, str(exc)))
    return out
