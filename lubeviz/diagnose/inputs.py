"""What a diagnosis starts from, read off its records: one rule for the CLI and the Diagnose page.

For a record (or the records of one `set:`): the forward chain at its speed, planes and probe angles,
with the record's oil temperature reading held (`identify.fit.oil_reading`); its measured features; the model
budget widened by the reading's tolerance; the lines beyond 1X the record holds (named in the verdict);
and the notes a user must see (a reading not used, a record's own warnings).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

from ..identify.batch import beyond_1x, check_model_speed, model_speed, record_checks
from ..identify.forward.measured import measure
from ..identify.fit.oil_reading import budget_with_reading, oil_reading
from ..progress import ProgressFn, silent


@dataclass(frozen=True)
class DiagnosisInputs:
    chains: list  # one ForwardChain per record, the oil reading held
    measured: list  # one MeasuredFeatures per record
    budget: object  # ModelBudget or None (the default)
    lines: tuple  # signals.lines.Line beyond 1X, all records
    notes: tuple[str, ...]  # warnings to show
    findings: tuple = ()  # identify.fit.plausibility.Finding: what is impossible or suspicious in the records



def _plain_chain(machine, speed_hz, nodes, probe_angles_deg, progress):
    from ..identify.forward.chain import ForwardChain

    return ForwardChain(machine, speed_hz, nodes, probe_angles_deg=probe_angles_deg, progress=progress)


def diagnosis_inputs(records: Sequence, machine, *, measured: Sequence | None = None,
                     chain_for: Callable | None = None, progress: ProgressFn = silent) -> DiagnosisInputs:
    """`records` of one diagnosis (one record, or a set already checked). `chain_for(machine, speed_hz,
    nodes, probe_angles_deg, progress)` gives the plain chain (the app passes its shared one); `measured`:
    the records' features when already measured."""
    chain_for = chain_for or _plain_chain
    chains, meas, notes, tolerance = [], [], [], 0.0
    for j, rec in enumerate(records):
        speed = model_speed(machine, rec)
        check_model_speed(machine, speed)
        oil_effects, tol, oil_notes = oil_reading(rec, machine)
        tolerance = max(tolerance, tol)
        notes += list(oil_notes)
        chain = chain_for(machine, speed, tuple(rec.nodes), rec.probe_angles_deg, progress)
        chains.append(chain.adding(*oil_effects) if oil_effects else chain)
        meas.append(measure(rec) if measured is None else measured[j])
    budget = budget_with_reading(None, tolerance) if tolerance > 0 else None
    lines, _ = beyond_1x(list(records))  # named in the verdict (identify's warnings say the same)
    notes += [w for r in records for w in getattr(r, "warnings", ())]
    findings = record_checks(list(records), meas, machine)
    return DiagnosisInputs(chains=chains, measured=meas, budget=budget, lines=lines, notes=tuple(notes),
                           findings=findings)
