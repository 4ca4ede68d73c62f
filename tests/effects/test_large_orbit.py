"""The large_orbit effect: a record of the periodic orbit on the p-theta films (harmonic balance, another
path than the identification's linear tables), what the linear identification and the diagnosis make of
it, and the refusals where the effect cannot be used (the chain; with other effects). The identification and
the diagnosis with the effect: tests/identify/test_orbit_fit_balance.py and test_orbit_fit.py, on records
from another path."""

import numpy as np
import pytest

from lubeviz.cli.main import main
from lubeviz.effects import parse_effect
from lubeviz.errors import InputError
from lubeviz.identify.batch import identify_record
from lubeviz.identify.forward.chain import ForwardChain
from lubeviz.signals.lines import present_lines
from lubeviz.signals.synthesize import synthesize_record
from lubeviz.units import MLMIN_PER_M3S

pytestmark = pytest.mark.slow

Q = (450.0, 600.0)


@pytest.fixture(scope="module")
def record(machine):
    return synthesize_record(machine, np.array(Q) / MLMIN_PER_M3S, snr_db=12.0, rng=np.random.default_rng(11),
                             duration_s=5.0, total_s=5.0, method="orbit")


def test_the_record_holds_the_orbits_2x_and_the_line_detector_reads_it(record):
    """At the paper's unbalance (orbits of about an eighth of the clearance) the periodic orbit has a 2X of
    ~20 % of 1X at plane 1; the record's +2X and -2X lines, measured by `signals.lines`, add up to it."""
    ratio = [float(v) for v in record.metadata["ratio_2x"].split()]
    assert ratio[0] > 0.1
    lines = {(ln.kind, ln.plane): ln.relative_to_1x for ln in present_lines(record)}
    both = lines.get(("+2X", 1), 0.0) + lines.get(("-2X", 1), 0.0)
    assert both == pytest.approx(ratio[0], rel=0.1)


def test_the_linear_identification_flags_it_and_its_intervals_hold_the_truth(machine, record):
    r = identify_record(record, machine)
    res = r.result
    assert res.model_explains_data is False
    for k in range(2):
        low, high = res.intervals[k]
        assert low * MLMIN_PER_M3S <= Q[k] and (high is None or Q[k] <= high * MLMIN_PER_M3S)
    assert any("2X" in w and "large orbits" in w for w in r.warnings)


def test_where_it_cannot_be_used_it_says_so(machine, tmp_path, capsys):
    with pytest.raises(InputError, match="replaces the linear response"):
        ForwardChain(machine, 75.0, (6, 20), (parse_effect("large_orbit"),))
    code = main(["simulate", "--q1-mlmin", "450", "--q2-mlmin", "600", "--effect", "large_orbit",
                 "--effect", "viscosity:factor=0.8", "-o", str(tmp_path / "x.csv")])
    assert code == 2 and "no other effect" in capsys.readouterr().err


def test_the_record_says_how_stable_its_orbit_is(record):
    """The paper's unbalance near Q_T lies at the onset of period doubling (the time integration's 0.5X line
    decays at about -2 /s there, a multiplier near -0.97 a revolution; BENCHMARKS "Stability of the orbit"): the
    record's metadata carries the orbit's half-order multiplier, close to -1 but not past it."""
    text = record.metadata["orbit_stability"]
    assert record.metadata["orbit_stability_state"] in ("stable", "undecided")
    mu = float(text.split("multiplier -")[1].split()[0])
    assert 0.9 < mu < 1.03 and "0.5X" in text

