"""The same command gives the same answer whatever the table cache holds (issue 34, item 10: `identify --json`
once gave another `q1_interval_any_oil_mlmin` on a warm cache than on a cold one) and whether the cache can be
used at all (item 6: a cache directory that is a file, FIFOs in place of slices). Run as a user runs it: the
CLI in a subprocess, `LUBEVIZ_CACHE_DIR` pointing at the cache under test.

The tests use the paper's machine on a coarse film mesh (40 x 20: a slice in well under a second): the cache's
logic does not depend on the mesh. (A slow test ran the same four commands on the shipped model's 100 x 100 films,
as the issue measured it: 71 s of the suite's time for no branch the coarse machine leaves out; dropped in session
61 for CI's 15 minutes.)"""

import json
import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from lubeviz.identify.tables.cache import geometry_table
from lubeviz.identify.tables.dimensionless import sommerfeld_number
from lubeviz.model.machine import load_machine
from lubeviz.rotor.statics import bearing_static_loads

REPO = Path(__file__).resolve().parents[2]
RECORD = REPO / "assets" / "sample_record.csv"
TIMING = ("seconds", "seconds_total")  # wall-clock times: the only keys allowed to differ between runs
ORACLE_OIL_RANGE = (0.75, 1.0 / 0.75)  # the viscosity range README states for the oil check


def coarse_machine_file(directory: Path) -> Path:
    text = (REPO / "models" / "paper_machine.toml").read_text()
    assert text.count("mesh_circumferential = 100") == 2 and text.count("mesh_axial = 100") == 2
    path = directory / "coarse_machine.toml"
    path.write_text(text.replace("mesh_circumferential = 100", "mesh_circumferential = 40")
                    .replace("mesh_axial = 100", "mesh_axial = 20"))
    return path


def identify(cache_dir, *options, machine=None, timeout=900):
    """`lubeviz identify --json [options] assets/sample_record.csv` with the given cache: (JSON dict, stderr).
    Exit status 0 and no traceback are part of every test."""
    env = dict(os.environ, LUBEVIZ_CACHE_DIR=str(cache_dir))
    cmd = [sys.executable, "-m", "lubeviz.cli.main", "identify", "--json", *options]
    cmd += [] if machine is None else ["--machine", str(machine)]
    proc = subprocess.run(cmd + [str(RECORD)], env=env, cwd=REPO, capture_output=True, text=True, timeout=timeout)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "Traceback" not in proc.stderr, proc.stderr[-3000:]
    return json.loads(proc.stdout), proc.stderr


def answer(d: dict) -> dict:
    return {k: v for k, v in d.items() if k not in TIMING}


def assert_same_answer(a: dict, b: dict) -> None:
    assert a.keys() == b.keys()
    differ = [k for k in answer(a) if a[k] != b[k]]
    assert not differ, {k: (a[k], b[k]) for k in differ}


def prebuild_oil_range(machine_file: Path, cache_dir: Path) -> None:
    """Store every slice a view within the oil check's viscosity range needs: a warm cache in which an
    'if tabled' branch would take the other way."""
    m = load_machine(machine_file)
    omega = 2 * math.pi * m.operating_speed
    for bearing, load in zip(m.bearings, bearing_static_loads(m)):
        s0 = sommerfeld_number(bearing, load, omega)
        geometry_table(bearing, s0 * np.linspace(*ORACLE_OIL_RANGE, 9), directory=cache_dir)


@pytest.fixture(scope="module")
def coarse_cold(tmp_path_factory):
    """The coarse machine's file, `identify --json` of it on an empty cache, and the cache directory that run left
    (the slices it built, nothing else), made once: each test below starts from a copy of that directory, so that
    what it adds or breaks there is its own (the same cold run was made three times; ~5 s each)."""
    root = tmp_path_factory.mktemp("coarse_cold")
    machine = coarse_machine_file(root)
    plain_cold, _ = identify(root / "cache", machine=machine)
    return machine, plain_cold, root / "cache"


def test_identify_json_is_the_same_on_a_cold_and_on_a_warm_cache(tmp_path, coarse_cold):
    machine, plain_cold, cold_cache = coarse_cold
    cold, warm = tmp_path / "cold", tmp_path / "warm"
    shutil.copytree(cold_cache, cold)  # what the cold run stored: the slices of the declared oil only

    prebuild_oil_range(machine, warm)
    oil_warmup, _ = identify(warm, "--oil-check", machine=machine)
    plain_warm, _ = identify(warm, machine=machine)
    assert_same_answer(plain_cold, plain_warm)
    # without --oil-check the check does not run (whatever is cached): its keys say so, a warning says why
    assert plain_cold["q1_interval_any_oil_mlmin"] is None and plain_cold["q2_interval_any_oil_mlmin"] is None
    assert plain_cold["oil_degeneracy"] == {}
    assert any("assume the declared oil viscosity" in w for w in plain_cold["warnings"])

    oil_cold, _ = identify(cold, "--oil-check", machine=machine)  # cold for the oil range: builds its slices
    oil_warm, _ = identify(warm, "--oil-check", machine=machine)
    assert_same_answer(oil_cold, oil_warm)
    assert_same_answer(oil_cold, oil_warmup)
    assert oil_cold["oil_degeneracy"]["range"] == pytest.approx(list(ORACLE_OIL_RANGE))
    # a nuisance parameter set free can only widen a profile interval: the any-oil one holds the declared-oil one
    for k in (1, 2):
        narrow, wide = oil_cold[f"q{k}_interval_mlmin"], oil_cold[f"q{k}_interval_any_oil_mlmin"]
        assert wide[0] <= narrow[0] and (wide[1] is None or (narrow[1] is not None and wide[1] >= narrow[1]))
    assert (oil_cold["q1_mlmin"], oil_cold["q2_mlmin"]) == (plain_cold["q1_mlmin"], plain_cold["q2_mlmin"])


def test_identify_answers_with_a_warning_when_the_cache_directory_is_a_file(tmp_path, coarse_cold):
    machine, good, _ = coarse_cold
    not_a_dir = tmp_path / "cache-is-a-file"
    not_a_dir.write_text("a file where the cache directory should be")
    for _ in range(2):  # and again: nothing stored, nothing broken, the same answer
        got, err = identify(not_a_dir, machine=machine)
        assert_same_answer(got, good)
        assert "could not store" in err and str(not_a_dir) in err and "rebuilt next time" in err
    assert not_a_dir.read_text() == "a file where the cache directory should be"


def test_identify_answers_without_hanging_when_fifos_stand_in_for_the_slices(tmp_path, coarse_cold):
    machine, good, cold_cache = coarse_cold
    cache_dir = tmp_path / "cache"
    shutil.copytree(cold_cache, cache_dir)  # the slices the cold run stored
    slices = sorted((cache_dir / "slices").glob("*.npz"))
    assert slices
    for path in slices:
        path.unlink()
        os.mkfifo(path)
    got, err = identify(cache_dir, machine=machine, timeout=300)  # a reader that opens a FIFO blocks for ever
    assert_same_answer(got, good)
    assert "a FIFO, not a regular file; not opened" in err
    assert all(path.is_file() for path in slices)  # replaced by the slices, rebuilt and stored
