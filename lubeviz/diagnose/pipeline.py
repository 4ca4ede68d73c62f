"""One diagnosis from records to what is shown: the CLI's `diagnose` and the Diagnose page run this alone.

Records -> their inputs (`inputs.diagnosis_inputs`: chains with the oil reading held, features, budget, lines,
findings) -> the residual loop (`loop.diagnose`) -> optionally the chi^2 maps over the first two unknown flows,
the plain model's and the one with the effect added, each with the fit that searched it (`FlowMap`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, NamedTuple, Sequence

from ..progress import ProgressFn, silent
from .inputs import DiagnosisInputs, diagnosis_inputs
from .loop import Diagnosis, cost_map, diagnose
from .settings import DiagnosisSettings


class FlowMap(NamedTuple):
    """chi^2 over two unknown flows `pair` (0-based bearing indices), the others held at `fit`'s: `grid` is
    (q_i (n,), q_j (n,), chi2 (n, n)), m^3/s; `fit` the fit whose search it shows."""

    title: str
    grid: tuple
    fit: object
    pair: tuple[int, int] = (0, 1)


@dataclass(frozen=True)
class DiagnosisRun:
    diagnosis: Diagnosis
    inputs: DiagnosisInputs
    maps: tuple = ()  # FlowMap per map: the plain model's, then with the effect added


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
    unknown = [k for k in range(chains[0].n_flows) if k not in chains[0].known_flows]
    if map_points > 0 and len(unknown) >= 2:  # one unknown flow: no map over two
        # over the first two unknown flows; the others held at each fit's flows
        pair = (unknown[0], unknown[1])
        maps.append(FlowMap("plain model", cost_map(chains, meas, n=map_points, flows=d.before.flow_values(),
                                                    pair=pair), d.before, pair))
        if d.added is not None and d.after is not None:
            maps.append(FlowMap(f"with {d.added.title}", cost_map(chains, meas, candidate=d.added, n=map_points,
                                                                  flows=d.after.flow_values(), pair=pair),
                                d.after, pair))
    return DiagnosisRun(diagnosis=d, inputs=inputs, maps=tuple(maps))
