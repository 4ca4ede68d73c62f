"""Identification of records from files, one or many (in parallel), as the CLI and the app use it."""

from __future__ import annotations

import math
import os
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass

from ..errors import InputError, LubevizError
from ..model.machine import load_machine
from ..progress import ProgressFn, silent
from ..signals.records import read_record
from .cache import machine_tables
from .forward import ALL_FEATURES, ForwardModel
from .measured import measure
from .newton import Identification, identify
from .settings import IdentificationSettings


@dataclass(frozen=True)
class RecordIdentification:
    """An identification with the record's name and the model's flooded thresholds."""

    file: str
    result: Identification
    nodes: tuple[int, int]
    speed_hz: float


def model_for(machine, speed_hz: float, nodes, *, progress: ProgressFn = silent) -> ForwardModel:
    if not machine.speed_min <= speed_hz <= machine.speed_max:
        raise InputError(f"record speed {speed_hz:g} Hz is outside the model's range "
                         f"{machine.speed_min:g}-{machine.speed_max:g} Hz")
    tables = machine_tables(machine, 2 * math.pi * speed_hz, progress=progress)
    return ForwardModel(machine, tables, nodes)


def identify_file(path, machine=None, settings: IdentificationSettings | None = None, *,
                  progress: ProgressFn = silent, model: ForwardModel | None = None) -> RecordIdentification:
    """Read a record (SPEC §6) and identify Q1, Q2. The model is built at the record's speed."""
    machine = load_machine() if machine is None else machine
    settings = settings or IdentificationSettings()
    rec = read_record(path, default_nodes=tuple(machine.center_nodes))
    speed = machine.operating_speed if abs(rec.speed_hz / machine.operating_speed - 1) < 1e-3 else rec.speed_hz
    if model is None or model.nodes != tuple(rec.nodes) or abs(model.omega / (2 * math.pi) - speed) > 1e-9:
        model = model_for(machine, speed, rec.nodes, progress=progress)
    result = identify(model, measure(rec, ALL_FEATURES), settings)
    return RecordIdentification(file=str(path), result=result, nodes=tuple(rec.nodes), speed_hz=rec.speed_hz)


def _worker(path, machine_path, mode):
    try:
        return identify_file(path, load_machine(machine_path), IdentificationSettings(mode=mode)), None
    except LubevizError as exc:
        return None, str(exc)


def identify_files(paths, machine_path=None, mode: str = "best", *, workers: int | None = None,
                   progress: ProgressFn = silent) -> list[tuple[str, RecordIdentification | None, str | None]]:
    """Identify many records; returns (file, result or None, error message or None) in input order.

    Tables are built (or loaded) once, up front, then records run on `workers` processes.
    """
    paths = [str(p) for p in paths]
    machine = load_machine(machine_path)
    machine_tables(machine, progress=progress)  # warm the cache before fanning out
    workers = min(len(paths), os.cpu_count() or 1) if workers is None else max(1, int(workers))
    out: dict[str, tuple] = {}
    t0 = time.perf_counter()
    if workers == 1 or len(paths) == 1:
        settings = IdentificationSettings(mode=mode)
        model = None
        for n, p in enumerate(paths, start=1):
            try:
                r = identify_file(p, machine, settings, model=model)
                model = None
                out[p] = (r, None)
            except LubevizError as exc:
                out[p] = (None, str(exc))
            progress(n, len(paths), os.path.basename(p))
    else:
        with ProcessPoolExecutor(max_workers=workers) as pool:
            futures = {pool.submit(_worker, p, machine_path, mode): p for p in paths}
            for n, f in enumerate(as_completed(futures), start=1):
                out[futures[f]] = f.result()
                progress(n, len(paths), f"{os.path.basename(futures[f])} ({time.perf_counter() - t0:.1f} s)")
    return [(p, *out[p]) for p in paths]
