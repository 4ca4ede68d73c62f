import os

# One BLAS thread per process, as `lubeviz/__init__.py` sets when it is imported before numpy; here numpy comes
# first (this file imports it before lubeviz), and under xdist two workers with two BLAS threads each
# oversubscribed the two cores (a 128 x 128 complex determinant took 95 ms instead of 0.4 ms).
for _var in ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "OMP_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import collections
import math
import shutil
import time
from pathlib import Path

import numpy as np
import pytest

from lubeviz.film.equilibrium import find_equilibrium
from lubeviz.film.feed import Feed
from lubeviz.model.bearing import Bearing
from lubeviz.model.machine import load_machine

if os.environ.get("PYTEST_XDIST_WORKER"):  # each worker has a core: the balance's film solves one at a time (its two
    # threads per worker oversubscribed the cores: the three balance-heavy files took 138 s, 130 s with one)
    import lubeviz.rotor.orbit_balance as _orbit_balance

    _orbit_balance.FILM_THREADS = 1

PAPER_LOAD = np.array([0.0, -3272.8])  # the paper's static share of the rotor weight (N)
OMEGA_75HZ = 2.0 * math.pi * 75.0


@pytest.fixture(scope="session")
def machine():
    return load_machine()


@pytest.fixture(scope="session")
def paper_bearing(machine):
    return machine.bearings[0]


@pytest.fixture(scope="session")
def flooded_equilibrium(paper_bearing):
    return find_equilibrium(paper_bearing, OMEGA_75HZ, PAPER_LOAD, Feed.flooded())


def plain_bearing(l_over_d: float, n_circ: int = 120, n_axial: int = 40) -> Bearing:
    """A plain (groove-less) bearing with the paper's radius and clearance and the given L/D."""
    return Bearing(length=2 * 0.045 * l_over_d, groove_length=0.0, groove_width=0.0,
                   n_circumferential=n_circ, n_axial=n_axial)


# --- the order in which xdist's workers get the files ---------------------------------------------------------------
# Under the README's `-n auto --dist loadfile` each file runs whole on one worker and the files are handed out in
# turn. xdist's own order is by the number of tests, most first, so files of a few tests that take minutes (a
# time-integration record made by a fixture) went out late (`test_time_rounds.py`, one test, last of 80) and the
# run waited for them on one core while the other idled. Here the files below go out first, longest first, then
# the others in xdist's order: the short files fill the end on both cores. The figures are each file's seconds on
# a fresh clone (caches built) with `--durations=0` under the README's command on this 2-core machine; only their
# order matters. A file renamed or gone from here stops the run (UsageError), so that the list cannot drift.
LONG_FILES = {  # seconds at f3cfc59 with the seeds (docs/notes/test-suite-time.md, session 61)
    "tests/app/test_start_and_layout.py": 126,
    "tests/identify/test_orbit_fit_balance.py": 117,
    # the time integration's record (a seed): the 5- and 16-harmonic fits, the time rounds' loop in a file of its own
    "tests/identify/test_orbit_fit.py": 114,
    "tests/rotor/test_orbit_balance.py": 82,  # the time integrations kept (tests/memo.py, session 58)
    "tests/app/test_consistency.py": 80,
    "tests/app/test_pages.py": 68,
    "tests/identify/test_cache.py": 66,
    "tests/app/test_hostile_browser.py": 64,
    "tests/identify/test_orbit_fit_time_round.py": 62,
    "tests/identify/test_orbit_fit_any_machine.py": 65,  # session 64: the fan's large orbits (a seed), 5 harmonics
    "tests/app/test_uploads.py": 59,
    "tests/diagnose/test_loop.py": 58,
    "tests/identify/test_dimensionless.py": 50,
    "tests/identify/test_answer_independent_of_cache.py": 43,  # cold caches, by design
    "tests/bench/test_loop_bench.py": 32,
}


def _distributed(config) -> bool:
    """True in an xdist worker, and in the controller of a run that hands out whole files (or classes)."""
    return hasattr(config, "workerinput") or getattr(config.option, "dist", "no") in ("loadfile", "loadscope")


# --- seeds: the suite's independent records and film tables, made once ------------------------------------------
# The records along another path than the model (200 x 200 films, the time integration) and the dimensionless slices
# cost ~6 min of a fresh clone's run; `tests/seeds/` holds the cache files a run on an empty cache built, and the
# controller copies each one into the cache directory where that file is missing, before any test. Nothing is
# trusted for being a seed: every file carries the key of its inputs (the source of the code that made it
# included) and is read as any cache file is, so after a change to that code the seeds no longer match, are not
# read, and the records are made again. The run then says so at its end: `bash tests/seeds/refresh.sh` makes the
# seeds again from a run on an empty cache.
SEEDS = Path(__file__).parent / "seeds"
SEEDED = ("slices", "independent", "turns")  # turns: each bearing's measured turn error (`forward.turn`)


def _cache_root() -> Path:
    from lubeviz.identify.tables.cache import cache_dir

    return cache_dir()


def _plant_seeds() -> float:
    root = _cache_root()
    for sub in SEEDED:
        for seed in sorted((SEEDS / sub).glob("*.npz")):
            target = root / sub / seed.name
            if not target.exists():
                target.parent.mkdir(parents=True, exist_ok=True)
                shutil.copyfile(seed, target)
    return time.time()


def pytest_configure(config):
    if not hasattr(config, "workerinput"):  # the controller (or a run without xdist), before any worker starts
        config._seeds_planted = _plant_seeds()
    if _distributed(config) and not hasattr(config, "workerinput"):
        config.option.loadscopereorder = False  # the controller keeps the workers' order (below)


def pytest_terminal_summary(terminalreporter, config):
    start = getattr(config, "_seeds_planted", None)
    if start is None:
        return
    built = [f for sub in SEEDED for f in (_cache_root() / sub).glob("*.npz")
             if f.stat().st_mtime >= start and not (SEEDS / sub / f.name).exists()]
    if built:
        kinds = collections.Counter(f"{f.parent.name}/{f.name.split('-')[0] + '-' if '-' in f.name else ''}"
                                    for f in built)
        terminalreporter.write_line(
            f"lubeviz: this run built {len(built)} cache file(s) the seeds lack (independent records, film "
            f"slices): the seeds are stale or missing; `bash tests/seeds/refresh.sh` makes them again")
        # which kind: a slice, a film's equilibrium, a kept integration (memo-) or a large orbit (orbit-)
        terminalreporter.write_line("lubeviz: built " + ", ".join(f"{n} {k}" for k, n in sorted(kinds.items())))


@pytest.hookimpl(trylast=True)  # after -m and -k have deselected
def pytest_collection_modifyitems(config, items):
    if not _distributed(config):
        return
    gone = [name for name in LONG_FILES if not (config.rootpath / name).is_file()]
    if gone:
        raise pytest.UsageError(f"tests/conftest.py LONG_FILES names {', '.join(gone)}, which no longer exist")
    files = [item.nodeid.split("::", 1)[0] for item in items]
    count = collections.Counter(files)
    order = sorted(range(len(items)), key=lambda k: (-LONG_FILES.get(files[k], 0), -count[files[k]], k))
    items[:] = [items[k] for k in order]
