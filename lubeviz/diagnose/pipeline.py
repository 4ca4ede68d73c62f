"""One diagnosis from records to what is shown: the CLI's `diagnose` and the Diagnose page run this alone.

Records -> their inputs (`inputs.diagnosis_inputs`: chains with the oil reading held, features, budget, lines,
findings) -> the residual loop (`loop.diagnose`) -> optionally the chi^2 maps over Q1 x Q2, the plain model's
and the one with the effect added, each with the fit that searched it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

from ..progress import ProgressFn, silent
from .inputs import DiagnosisInputs, diagnosis_inputs
from .loop import Diagnosis, cost_map, diagnose
from .settings import DiagnosisSettings


@dataclass(frozen=True)
class DiagnosisRun:
    diagnosis: Diagnosis
    inputs: DiagnosisInputs
    maps: tuple = ()  # (title, (q1, q2, chi2), fit) per map: the plain model's, then with the effect added


def run_diagnosis(records: Sequence, machine, settings: DiagnosisSettings | None = None, *, candidates=None,
                  measured=None, chain_for: Callable | None = None, truth: dict | None = None,
                  progress: ProgressFn = silent) -> DiagnosisRun:
    """Diagnose `records` (one record, or the records of one set, already checked) of `machine`.

    `candidates`: the effects to try (default: the library's diagnosable ones); `measured`: the records'
    features when already measured; `chain_for`: where plain chains come from (the app's shared cache);
    `truth`: what made a synthetic record, carried into the result."""
    settings = settings or DiagnosisSettings()
    inputs = diagnosis_inputs(records, machine, measured=measured, chain_for=chain_for, progress=progress)
    chains, meas = inputs.chains, inputs.measured
    d = diagnose(chains, meas, candidates=candidates, level=settings.level, progress=progress, truth=truth,
                 budget=inputs.budget, lines=inputs.lines, findings=inputs.findings)
    maps, map_points = [], settings.map_points
    if map_points > 0 and chains[0].n_flows >= 2:  # one flow: no map over two
        # over Q1 x Q2; on a machine of more bearings the others held at each fit's flows
        maps.append(("plain model", cost_map(chains, meas, n=map_points, flows=d.before.flow_values()), d.before))
        if d.added is not None and d.after is not None:
            maps.append((f"with {d.added.label}", cost_map(chains, meas, candidate=d.added, n=map_points,
                                                          flows=d.after.flow_values()), d.after))
    return DiagnosisRun(diagnosis=d, inputs=inputs, maps=tuple(maps))
