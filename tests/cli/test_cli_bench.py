"""`lubeviz bench` argument checks: bad input is a clear error with exit 2, before any work is done."""

import pytest

from lubeviz.cli.main import main


@pytest.mark.parametrize("arg, words", [
    ("foo=1", ["'foo=1'", "coefficient_k"]),
    ("coefficient_k", ["'coefficient_k'", "NAME=VALUE"]),
    ("coefficient_k=abc", ["coefficient_k", "'abc'", "not a number"]),
    ("coefficient_k=-1", ["coefficient_k"]),
])
def test_a_bad_budget_variant_names_the_option_and_the_term(capsys, arg, words):
    assert main(["bench", "coverage", "--records", "1", "--budgets", arg]) == 2
    err = capsys.readouterr().err
    assert "--budgets" in err
    for w in words:
        assert w in err


def test_budget_variants_are_parsed_into_model_budgets():
    from lubeviz.cli.bench_cmd import _budgets
    from lubeviz.identify.forward.budget import ModelBudget

    got = _budgets("coefficient_k=0.0025, shaft_damping_high=3 ; calibration=0.9;")
    assert got == [{"coefficient_k": 0.0025, "shaft_damping_high": 3.0}, {"calibration": 0.9}]
    b = ModelBudget(**got[0])
    assert b.coefficient_k == 0.0025 and b.coefficient_c == ModelBudget().coefficient_c


def test_an_unknown_diagnose_case_names_the_known_ones(capsys):
    assert main(["bench", "diagnose", "--cases", "large_orbit,foo"]) == 2
    err = capsys.readouterr().err
    assert "--cases" in err and "unknown foo" in err
    assert "large_orbit" in err and "viscosity" in err  # the cases it knows


@pytest.mark.parametrize("extra", [["--calibrations", "0.8"], ["--budgets", "coefficient_k=0.002"]])
def test_static_coverage_refuses_the_clean_corpus_options(capsys, extra):
    assert main(["bench", "coverage", "--static", "--records", "1", *extra]) == 2
    assert "--static" in capsys.readouterr().err


@pytest.mark.parametrize("extra, words", [
    (["--orbit-harmonics", "4"], ["--orbit-harmonics", "5-32"]),
    (["--orbit-harmonics", "5,x"], ["--orbit-harmonics", "'5,x'", "integers"]),
    (["--static"], ["--large-orbit", "--static"]),
    (["--calibrations", "0.8"], ["--large-orbit", "--calibrations"]),
    (["--orbit-time-rounds", "6"], ["--orbit-time-rounds", "0-5"]),
    (["--orbit-workers", "0"], ["--orbit-workers", "at least 1"]),
    (["--unbalance-scales", "4,2.5"], ["--unbalance-scales", "'4,2.5'", "LOW <= HIGH"]),
    (["--unbalance-scales", "3"], ["--unbalance-scales", "two numbers"]),
    (["--orbit-flows", "0.6,nan"], ["--orbit-flows", "'0.6,nan'"]),
    (["--orbit-flows", "0,1"], ["--orbit-flows", "0.05 < LOW"]),
])
def test_large_orbit_coverage_checks_its_options_before_making_records(capsys, extra, words):
    assert main(["bench", "coverage", "--large-orbit", "--records", "1", *extra]) == 2
    err = capsys.readouterr().err
    for w in words:
        assert w in err


@pytest.mark.parametrize("n", ["0", "-2"])
def test_coverage_workers_are_counted_before_any_record_is_made(capsys, n):
    """`--processes` for the coverage corpus (session 68: each record its own stream, drawn, made and identified by a
    worker): fewer than one is refused before a record is drawn."""
    assert main(["bench", "coverage", "--records", "1", "--processes", n]) == 2
    assert "--processes" in capsys.readouterr().err


def test_a_coverage_record_of_the_workers_is_drawn_from_its_own_stream(monkeypatch):
    """Record i of a run with worker processes comes from `default_rng([seed, i])` whatever ran before it (so the
    corpus is the same for any count of processes, and a record can be made again alone)."""
    from lubeviz.bench import records

    drawn = []

    def corpus(n, rng, machine=None):
        drawn.append(rng.integers(0, 2**31))
        raise StopIteration  # no record made: the draw is what is checked

    monkeypatch.setattr("lubeviz.verification.independent.clean_corpus", corpus)
    for i in (3, 0, 3):
        with pytest.raises(StopIteration):
            records._coverage_job(None, 68, i, (), ())
    assert drawn[0] == drawn[2] != drawn[1]
