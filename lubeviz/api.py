"""lubeviz's public API: records and a machine in, result objects out. The CLI and the pages call these.

    from lubeviz.api import load_machine, read_record, identify_record, result_text
    machine = load_machine("models/paper_machine.toml")
    result = identify_record(read_record("assets/sample_record.csv"), machine)
    print("\\n".join(result_text(result)))      # or result.result.summary(): every parameter, with its unit

- `identify_record(record, machine, settings, effects=())` -> `RecordIdentification`: each bearing's supply
  flow (and the free parameters of declared effects) from one record;
- `identify_set(records, machine, settings, effects=())`: the same from the records of one `set:` (several
  speeds of a coast-down), one answer for all;
- `diagnose(records, machine, settings, candidates=None)` -> `DiagnosisRun`: the residual loop (what, if
  anything, the model misses; `.diagnosis.outcome`, `diagnosis_dict` for the JSON, `diagnose.report` for HTML).

Settings are objects (`IdentificationSettings`, `DiagnosisSettings`) declared once with bounds and docs;
effects come from `parse_effects("probe_rotation:plane=1", ...)` or the `EFFECTS` registry.
"""

from __future__ import annotations

from typing import Callable, Sequence

from .diagnose.pipeline import DiagnosisRun, run_diagnosis
from .diagnose.settings import DiagnosisSettings
from .effects import EFFECTS, parse_effects
from .identify.batch import RecordIdentification
from .identify.batch import identify_record as _identify_record
from .identify.batch import identify_set as _identify_set
from .identify.fit.settings import IdentificationSettings
from .identify.output.export import result_csv, result_dict, result_text
from .model.machine import load_machine
from .progress import ProgressFn, silent
from .signals.records import read_record


def identify_record(record, machine, settings: IdentificationSettings | None = None, effects: Sequence = (), *,
                    progress: ProgressFn = silent, model=None, tables=None, measured=None) -> RecordIdentification:
    """Identify one record (`read_record`) of `machine`. `model` (paper mode) or `tables` (best mode: one
    coefficient table per bearing at the record's speed), `measured`: what is already at hand (the app's shared
    cache), else made here."""
    return _identify_record(record, machine, settings, effects=tuple(effects), progress=progress, model=model,
                            tables=tables, measured=measured)


def identify_set(records: Sequence, machine, settings: IdentificationSettings | None = None,
                 effects: Sequence = (), *, progress: ProgressFn = silent) -> RecordIdentification:
    """Identify the records of one `set:` together: the same flows at every speed."""
    return _identify_set(records, machine, settings, effects=tuple(effects), progress=progress)


def diagnose(records: Sequence, machine, settings: DiagnosisSettings | None = None, candidates=None, *,
             progress: ProgressFn = silent, measured=None, chain_for: Callable | None = None,
             truth: dict | None = None) -> DiagnosisRun:
    """Diagnose one record, or the records of one set. `candidates`: effects to try (default: the library)."""
    return run_diagnosis(records, machine, settings, candidates=candidates, measured=measured, chain_for=chain_for,
                         truth=truth, progress=progress)


__all__ = ["DiagnosisRun", "DiagnosisSettings", "EFFECTS", "IdentificationSettings", "RecordIdentification",
           "diagnose", "identify_record", "identify_set", "load_machine", "parse_effects", "read_record",
           "result_csv", "result_dict", "result_text"]
