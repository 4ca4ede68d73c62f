"""The residual loop (issue 12): find the residual, trace it to an effect the model lacks, add it, and
report the error before and after. `loop.diagnose` is the headless entry point; `report` writes the
self-contained HTML report an engineer attaches to a work order."""

from .loop import Candidate, Diagnosis, diagnose, diagnosis_dict
from .pipeline import DiagnosisRun, run_diagnosis

__all__ = ["Candidate", "Diagnosis", "DiagnosisRun", "diagnose", "diagnosis_dict", "run_diagnosis"]
