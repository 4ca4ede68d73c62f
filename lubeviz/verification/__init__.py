"""An independent source of test records (issue 11, item 5).

Every test of the identification or the diagnosis must be fed records made along another path than
the identification's own model, so that no test passes only because the record and the model share a
discretization. `independent.make_record` makes such records. It differs from the model at every stage:

- Film. The model reads K, C from cached tables of the 100 x 100 mesh with groove refinement 4 and
  the "sub-cell" tangent, interpolated in the supply. The source solves each bearing's equilibrium
  directly at its exact supply on a 200 x 200 mesh with groove refinement 1 (the paper's uniform mesh
  at twice its resolution) and takes the "fixed-pattern" tangent (the exact small-step derivative of
  that discrete film, a different linearization); these equilibria are cached on disk by content
  (`equilibria.py`, under `lubeviz.identify.tables.cache.cache_dir() / "independent"`).
- Rotor. The model has 20 Timoshenko elements and shaft damping beta = 2e-5 s; the source splits each
  element into two (40 elements; machine node n is node 2n - 1) and uses beta = 3e-5 s.
- Response. The model is a steady-state complex solve; the source integrates from rest with its own
  Newmark (trapezoidal) integrator (`newmark.py`), 15 s at 1e-4 s by default, keeps the last 5 s and
  adds white noise at 12 dB per channel from a seeded numpy Generator.
- Effects. Declared and applied here (`effects.py`), never imported from `lubeviz.effects`, plus
  `seal`, an effect the diagnosis library does not have.
- Static position. With `static=True` the probes keep a 1 mm DC gap and the record says
  `static: absolute` with its `rest_position` (SPEC §6).

The differences of the resulting features from the model's (a few tenths of a percent in fb, a few
hundredths of a degree to a few tenths in phi; see tests/verification/test_independent.py) are the
model uncertainty an identification must carry.
"""

from .effects import EFFECTS, normalize_effects, parse_effect
from .independent import (GAP, SHAFT_DAMPING_BETA, IndependentRecord, IndependentSpec, clean_corpus, fine_node,
                          make_record, make_set, max_growth_rate, split_rotor, steady_truth,
                          thresholds_mlmin, write_record_csv)

__all__ = ["EFFECTS", "GAP", "SHAFT_DAMPING_BETA", "IndependentRecord", "IndependentSpec", "clean_corpus",
           "fine_node", "make_record", "make_set", "max_growth_rate", "normalize_effects", "parse_effect",
           "split_rotor", "steady_truth", "thresholds_mlmin", "write_record_csv"]
