"""The rate benches' speed bands and flow errors on any machine: bands are fractions of the machine's operating
speed (the paper's 50-62.5-80-100 Hz at 75 Hz), every corpus speed falls in one, and a flooded flow's error (which
the film hardly depends on) is kept apart from the starved ones'."""

from __future__ import annotations

import numpy as np

from lubeviz.bench.records import _bands, _summary
from lubeviz.model.machine import MODELS_DIR, load_machine
from lubeviz.verification.independent import corpus_speeds


def test_the_paper_s_bands_are_its_published_ones_and_every_machine_s_corpus_falls_in_its_bands():
    paper = load_machine()
    assert [(label, round(lo, 6), round(hi, 6)) for label, lo, hi in _bands(paper)] == [
        ("50-62.5 Hz", 50.0, 62.5), ("62.5-80 Hz", 62.5, 80.0), ("80-100 Hz", 80.0, 100.0)]
    assert [lo <= 80.0 < hi for _, lo, hi in _bands(paper)] == [False, False, True]  # an edge: the band above
    assert [lo <= 100.0 < hi for _, lo, hi in _bands(paper)] == [False, False, True]  # the last band is closed
    for path in sorted(MODELS_DIR.glob("*.toml")):
        m = load_machine(path)
        bands = _bands(m)
        speeds = corpus_speeds(m)
        assert speeds.size
        for v in speeds:  # each speed in exactly one band
            assert sum(lo <= v < hi for _, lo, hi in bands) == 1, (path.name, v)
        assert bands[0][1] <= speeds.min() and speeds.max() < bands[-1][2]


def test_the_flow_errors_count_each_flow_and_keep_the_flooded_ones_apart():
    def row(err, above):
        return {"max_abs_error_pct": max(abs(e) for e in err), "error_pct": err, "above_qt": above,
                "holds": [True] * len(err), "explained": True, "truth_in_alt": False, "seconds": 0.1}

    rows = [row([1.0, -2.0, 40.0], [False, False, True]), row([-3.0, 0.5, 60.0], [False, False, True])]
    s = _summary(rows)
    assert s["error_pct_median"] == 50.0  # the largest of each record
    assert s["flow_error_pct_median"] == np.median([1, 2, 40, 3, 0.5, 60])
    assert s["flow_error_pct_median_below_qt"] == np.median([1, 2, 3, 0.5])
