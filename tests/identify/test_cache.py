"""The on-disk cache of dimensionless table slices: hits without recomputation, keys that track every
relevant input, untrustworthy files rebuilt, never inside the repository, parallel builds identical to
serial ones, bearings of one geometry sharing slices."""

import contextlib
import dataclasses
import errno
import math
import os
import signal
import warnings
from pathlib import Path

import numpy as np
import pytest

import lubeviz
from lubeviz.errors import InputError
from lubeviz.identify.tables import cache
from lubeviz.identify.tables import supply as tables
from lubeviz.identify.tables.cache import (StaleCacheWarning, cache_dir, cached_table, machine_tables, slice_key,
                                    table_key)
from lubeviz.identify.tables.dimensionless import geometry_values, sommerfeld_nodes
from lubeviz.model.machine import ShaftElement, load_machine
from lubeviz.progress import Cancelled

POINTS = 9  # few ratios (the fewest with a node at Q_T and a spline each side) on a coarse mesh: each slice takes well under a second
SLICES = 4  # a view interpolates the 4 slices around its Sommerfeld number
REPO = Path(lubeviz.__file__).resolve().parents[1]


def coarse_machine():
    """The paper's machine with a 40 x 20 film mesh (fast; the cache does not care about accuracy), at
    70 Hz: its S lies between slices (at 75 Hz it sits on the grid's anchor and needs one slice)."""
    m = load_machine()
    m.bearings = [b.copy(n_circumferential=40, n_axial=20) for b in m.bearings]
    m.operating_speed = 70.0
    return m


def slice_files(directory):
    return sorted((directory / "slices").glob("*.npz"))


def assert_same_table(a, b):
    assert a.bearing == b.bearing
    assert a.omega == b.omega and a.q_threshold == b.q_threshold
    for name in ("q", "K", "C", "position"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))


def test_cache_hit_returns_the_same_table_without_rebuilding(tmp_path, builds):
    m = coarse_machine()
    first = cached_table(m, 0, points=POINTS, directory=tmp_path)
    assert len(builds) == SLICES
    g = geometry_values(m.bearings[0])
    assert sorted(f.stem for f in slice_files(tmp_path)) == sorted(slice_key(g, s, points=POINTS) for s in builds)
    assert first.key == table_key(m, 0, points=POINTS)
    second = cached_table(m, 0, points=POINTS, directory=tmp_path)
    assert len(builds) == SLICES
    assert_same_table(first, second)
    assert second.key == first.key
    # machine_tables: bearing 2 has the same geometry and (to 3e-5) the same S: it shares the slices
    both = machine_tables(m, points=POINTS, directory=tmp_path, workers=1)
    assert len(builds) == SLICES
    assert_same_table(both[0], first)
    assert both[1].bearing == 1 and both[1].q_threshold != first.q_threshold


def test_a_default_grid_table_with_its_dense_band_is_read_back(tmp_path, builds):
    """The default grid (a dense band around Q_T plus the sqrt(Q) grid) passes the cache's own grid check."""
    m = coarse_machine()
    first = cached_table(m, 0, directory=tmp_path)
    # DEFAULT_POINTS over BASE_BOTTOM-BASE_TOP x Q_T, then the nodes beyond it to the span's ends
    r = tables.table_flows(1.0)
    beyond = (r > tables.BASE_TOP * (1 + 1e-12)) | (r < tables.BASE_BOTTOM * (1 - 1e-12))
    assert first.q.size == tables.DEFAULT_POINTS + int(beyond.sum()) and beyond.sum() > 0
    np.testing.assert_allclose(first.q, tables.table_flows(first.q_threshold), rtol=1e-14)
    with warnings.catch_warnings():
        warnings.simplefilter("error", StaleCacheWarning)
        second = cached_table(m, 0, directory=tmp_path)
    assert len(builds) == SLICES
    assert_same_table(first, second)


def _variant(change):
    m = coarse_machine()
    change(m)
    return m


def _bearing_change(**values):
    def change(m):
        m.bearings = [m.bearings[0].copy(**values), m.bearings[1]]
    return change


def _element_change(m):
    elements = list(m.elements)
    elements[11] = ShaftElement(elements[11].length, elements[11].diameter * 1.01)
    m.elements = elements


def test_key_tracks_every_input_that_affects_the_table(monkeypatch):
    base = table_key(coarse_machine(), 0, points=POINTS)
    changed = {
        "viscosity": table_key(_variant(_bearing_change(viscosity=0.1)), 0, points=POINTS),
        "clearance": table_key(_variant(_bearing_change(clearance=121e-6)), 0, points=POINTS),
        "mesh": table_key(_variant(_bearing_change(n_circumferential=41)), 0, points=POINTS),
        "axial mesh": table_key(_variant(_bearing_change(n_axial=22)), 0, points=POINTS),
        "groove": table_key(_variant(_bearing_change(groove_width=30e-3)), 0, points=POINTS),
        "speed": table_key(coarse_machine(), 0, 2 * math.pi * 65.0, points=POINTS),
        "operating speed": table_key(_variant(lambda m: setattr(m, "operating_speed", 80.0)), 0, points=POINTS),
        "shaft element": table_key(_variant(_element_change), 0, points=POINTS),
        "disc": table_key(_variant(lambda m: setattr(m, "discs", m.discs[:2])), 0, points=POINTS),
        "gravity": table_key(_variant(lambda m: setattr(m, "gravity", 9.80)), 0, points=POINTS),
        "span": table_key(coarse_machine(), 0, span=(0.3, 2.0), points=POINTS),
        "points": table_key(coarse_machine(), 0, points=POINTS + 1),
        "bearing": table_key(coarse_machine(), 1, points=POINTS),
    }
    with monkeypatch.context() as mp:
        mp.setattr(lubeviz, "__version__", "0.0.0-test")
        changed["package version"] = table_key(coarse_machine(), 0, points=POINTS)
    with monkeypatch.context() as mp:
        mp.setattr(cache, "TABLE_FORMAT_VERSION", cache.TABLE_FORMAT_VERSION + 1)
        changed["format version"] = table_key(coarse_machine(), 0, points=POINTS)
    with monkeypatch.context() as mp:
        mp.setattr(cache, "solver_version", lambda: "edited solver")
        changed["solver source"] = table_key(coarse_machine(), 0, points=POINTS)
    same = [k for k, v in changed.items() if v == base]
    assert not same, f"key unchanged when these changed: {same}"
    assert len(set(changed.values())) == len(changed)


def test_key_ignores_what_does_not_affect_the_table():
    base = table_key(coarse_machine(), 0, points=POINTS)

    def unbalance(m):
        m.unbalance_moment = 2.0e-2
        m.unbalance_phase = 1.0
        m.unbalance_node = 10

    for change in (unbalance, lambda m: setattr(m, "shaft_damping_beta", 1e-4),
                   lambda m: setattr(m, "center_nodes", [5, 21]), lambda m: setattr(m, "source", "")):
        assert table_key(_variant(change), 0, points=POINTS) == base


def test_solver_version_follows_the_film_code_not_its_wording(monkeypatch):
    """The slices' key hashes the film's code (`lubeviz.code_key`): an edit to a statement of the solver changes
    it, a reworded docstring or a new comment does not (session 56: a reworded docstring had made every seed
    stale)."""
    import pathlib

    from lubeviz.film import solver

    original = pathlib.Path.read_bytes
    text = original(pathlib.Path(solver.__file__))
    doc = b'"""'

    def version_with(source):
        monkeypatch.setattr(pathlib.Path, "read_bytes",
                            lambda path: source if path.name == "solver.py" and path.parent.name == "film"
                            else original(path))
        cache.solver_version.cache_clear()
        try:
            return cache.solver_version()
        finally:
            monkeypatch.setattr(pathlib.Path, "read_bytes", original)
            cache.solver_version.cache_clear()

    base = version_with(text)
    assert len(base) == 64
    reworded = text.replace(doc, doc + b"Reworded. ", 1).replace(b"class PatternSystem:\n    " + doc,
                                                                  b"class PatternSystem:\n    " + doc + b"Reworded. ")
    assert reworded.count(b"Reworded. ") == 2
    assert version_with(reworded) == base  # the module's docstring and a class's
    assert version_with(text + b"\n# a comment\n") == base
    assert version_with(text + b"\nAN_EDIT = 1\n") != base
    assert version_with(text.replace(b"MAX_SWITCHED = ", b"MAX_SWITCHED_ = ", 1)) != base  # a name


# --- untrustworthy files ----------------------------------------------------------------------------

def _rewrite(path, **changes):
    with np.load(path, allow_pickle=False) as z:
        data = {k: z[k] for k in z.files}
    data.update(changes)
    with open(path, "wb") as fh:
        np.savez(fh, **data)


def _stored(path):
    with np.load(path, allow_pickle=False) as z:
        return {k: z[k] for k in z.files}


def _truncate(path):
    raw = path.read_bytes()
    path.write_bytes(raw[: len(raw) // 2])


def _garbage(path):
    path.write_bytes(b"not a zip file at all")


def _wrong_key(path):
    _rewrite(path, key=np.array("0" * 64))


def _nan_with_valid_checksum(path):
    d = _stored(path)
    values = d["values"].copy()
    values[2, 1] = np.nan
    arrays = {k: (values if k == "values" else d[k]) for k in cache._ARRAYS}
    _rewrite(path, values=values, checksum=np.array(cache._checksum(str(d["key"]), arrays)))


def _tampered_value(path):
    d = _stored(path)
    values = d["values"].copy()
    values[1, 7] *= 1.0001
    _rewrite(path, values=values)


def _pickled_object(path):
    d = _stored(path)
    d["key"] = np.array([str(d["key"])], dtype=object)
    with open(path, "wb") as fh:
        np.savez(fh, **d)


def _wrong_shape(path):
    d = _stored(path)
    values = d["values"][:-1]
    arrays = {k: (values if k == "values" else d[k]) for k in cache._ARRAYS}
    _rewrite(path, values=values, checksum=np.array(cache._checksum(str(d["key"]), arrays)))


def _other_grid_with_valid_checksum(path):
    d = _stored(path)
    ratio = d["ratio"].copy()
    ratio[3] *= 1.001
    arrays = {k: (ratio if k == "ratio" else d[k]) for k in cache._ARRAYS}
    _rewrite(path, ratio=ratio, checksum=np.array(cache._checksum(str(d["key"]), arrays)))


def _claims_a_huge_array(path):
    """A member whose .npy header claims 10^13 values (80 TB) while the file holds a few bytes of them."""
    import io
    import zipfile

    d = _stored(path)
    member = io.BytesIO()
    np.lib.format.write_array_header_1_0(member, {"descr": "<f8", "fortran_order": False, "shape": (10**12, 10)})
    member.write(d["values"].tobytes())
    with zipfile.ZipFile(path, "w") as z:
        for name, a in d.items():
            if name != "values":
                buf = io.BytesIO()
                np.save(buf, a)
                z.writestr(name + ".npy", buf.getvalue())
        z.writestr("values.npy", member.getvalue())


@pytest.mark.parametrize("damage", [_truncate, _garbage, _wrong_key, _nan_with_valid_checksum, _tampered_value,
                                    _pickled_object, _wrong_shape, _other_grid_with_valid_checksum,
                                    _claims_a_huge_array])
def test_untrustworthy_file_is_rebuilt(tmp_path, builds, damage):
    m = coarse_machine()
    good = cached_table(m, 0, points=POINTS, directory=tmp_path)
    path = slice_files(tmp_path)[1]
    damage(path)
    with pytest.warns(StaleCacheWarning, match=str(path.name)):
        rebuilt = cached_table(m, 0, points=POINTS, directory=tmp_path)
    assert len(builds) == SLICES + 1  # only the damaged slice is solved again
    assert_same_table(rebuilt, good)
    again = cached_table(m, 0, points=POINTS, directory=tmp_path)  # the rebuilt file is trusted
    assert len(builds) == SLICES + 1
    assert_same_table(again, good)


def test_file_of_other_inputs_under_this_key_is_rebuilt(tmp_path, builds):
    """A file renamed to another key's name (or a key collision) is not trusted."""
    m = coarse_machine()
    cached_table(m, 1, points=POINTS, directory=tmp_path)
    first, second = slice_files(tmp_path)[:2]
    first.unlink()
    second.rename(first)
    with pytest.warns(StaleCacheWarning, match="stored key"):
        cached_table(m, 0, points=POINTS, directory=tmp_path)
    assert len(builds) == SLICES + 2
    assert len(slice_files(tmp_path)) == SLICES


def test_slice_key_tracks_the_geometry_and_ignores_oil_clearance_and_node():
    b = coarse_machine().bearings[0]
    s = float(sommerfeld_nodes()[10])
    base = slice_key(geometry_values(b), s, points=POINTS)
    for change in ({"viscosity": 0.05}, {"clearance": 150e-6}, {"node": 7}):
        assert slice_key(geometry_values(b.copy(**change)), s, points=POINTS) == base
    changed = [slice_key(geometry_values(b.copy(**change)), s, points=POINTS)
               for change in ({"radius": 0.046}, {"length": 0.071}, {"groove_length": 15e-3}, {"groove_width": 30e-3},
                              {"groove_angle": 0.1}, {"n_circumferential": 41}, {"n_axial": 22},
                              {"groove_refinement": 2})]
    changed += [slice_key(geometry_values(b), float(sommerfeld_nodes()[11]), points=POINTS),
                slice_key(geometry_values(b), s, points=POINTS + 1),
                slice_key(geometry_values(b), s, span=(0.3, 2.0), points=POINTS)]
    assert base not in changed and len(set(changed)) == len(changed)


# --- where -----------------------------------------------------------------------------------------

def test_cache_dir_is_in_the_user_cache_never_in_the_repository(monkeypatch, tmp_path):
    monkeypatch.delenv("LUBEVIZ_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache_dir() == (tmp_path / "xdg" / "lubeviz").resolve()
    monkeypatch.setenv("LUBEVIZ_CACHE_DIR", str(tmp_path / "mine"))
    assert cache_dir() == (tmp_path / "mine").resolve()
    for inside in (REPO, REPO / ".cache", REPO / "lubeviz" / "identify"):
        monkeypatch.setenv("LUBEVIZ_CACHE_DIR", str(inside))
        with pytest.raises(InputError, match="inside the lubeviz source tree"):
            cache_dir()
    with pytest.raises(InputError, match="inside the lubeviz source tree"):
        cached_table(coarse_machine(), 0, points=POINTS, directory=REPO / "tmp-cache")
    assert not (REPO / "tmp-cache").exists()


def test_default_directory_comes_from_the_environment(monkeypatch, tmp_path, builds):
    monkeypatch.setenv("LUBEVIZ_CACHE_DIR", str(tmp_path))
    cached_table(coarse_machine(), 0, points=POINTS)
    assert len(slice_files(tmp_path)) == SLICES


# --- parallel build, progress, cancellation -----------------------------------------------------------

def test_parallel_build_equals_serial_build_and_reports_progress(tmp_path):
    m = coarse_machine()
    serial = machine_tables(m, points=POINTS, directory=tmp_path / "serial", workers=1)
    seen = []
    parallel = machine_tables(m, points=POINTS, directory=tmp_path / "parallel", workers=2,
                              progress=lambda done, total, label="": seen.append((done, total)))
    for a, b in zip(serial, parallel):
        assert_same_table(a, b)
        assert a.key == b.key
    per = tables.table_flows(1.0, points=POINTS).size  # a slice's equilibria (POINTS up to BASE_TOP, more above)
    assert per > POINTS
    assert seen[-1] == (SLICES * per, SLICES * per)
    assert all(t == SLICES * per for _, t in seen)
    assert [d for d, _ in seen] == sorted(d for d, _ in seen)
    # a second call builds nothing: both come from the cache
    assert_same_table(machine_tables(m, points=POINTS, directory=tmp_path / "parallel")[1], serial[1])


def test_whole_slice_jobs_equal_two_part_jobs_and_the_serial_build(tmp_path):
    """With at least as many slices as processes each job solves a whole slice (its flooded equilibrium once);
    with fewer, each slice's two parts are two jobs (each solving that equilibrium itself). Same slices, bit
    for bit, as the serial build."""
    from lubeviz.identify.tables.cache import geometry_table

    b = coarse_machine().bearings[0]
    nodes = sommerfeld_nodes()[20:22]
    serial = geometry_table(b, None, points=POINTS, directory=tmp_path / "serial", workers=1, nodes=nodes)
    whole = geometry_table(b, None, points=POINTS, directory=tmp_path / "whole", workers=2, nodes=nodes)
    parts = geometry_table(b, None, points=POINTS, directory=tmp_path / "parts", workers=4, nodes=nodes)
    assert len(serial.slices) == 2
    for i, s in serial.slices.items():
        for other in (whole, parts):
            np.testing.assert_array_equal(other.slices[i].values, s.values)
            assert other.slices[i].q_threshold == s.q_threshold


def test_two_geometries_are_built_in_one_pool_with_the_slices_each_alone_gives(tmp_path, monkeypatch):
    """A machine's bearings each lean their own way, and each lean is a geometry of its own: `geometry_tables` builds
    the slices missing over every geometry in one pool (one `_build_parallel` call, not one per geometry), the same
    slices bit for bit as each geometry built alone; a request of a geometry already asked for shares its table; an S
    off the grid gives None when asked to skip it, and raises otherwise."""
    from lubeviz.identify.tables.cache import geometry_table, geometry_tables

    b = coarse_machine().bearings[0]
    other = b.copy(groove_angle=b.groove_angle + 0.3)  # a lean of 0.3 rad: another geometry
    nodes = sommerfeld_nodes()[20:26]
    s = [float(nodes[2]) * 1.01]  # four slices around it
    calls = []
    real = cache._build_parallel
    monkeypatch.setattr(cache, "_build_parallel", lambda plans, jobs, *a: calls.append(len(jobs)) or real(plans, jobs,
                                                                                                        *a))
    joint = geometry_tables([(b, s), (other, s), (b, [float(nodes[2]) * 1.02])], points=POINTS,
                            directory=tmp_path / "joint", workers=2, nodes=nodes)
    assert calls == [8] and joint[0] is joint[2]
    alone = [geometry_table(x, s, points=POINTS, directory=tmp_path / "alone", workers=1, nodes=nodes)
             for x in (b, other)]
    for t, a in zip(joint, alone):
        assert sorted(t.slices) == sorted(a.slices) and len(a.slices) == 4
        for i in a.slices:
            np.testing.assert_array_equal(t.slices[i].values, a.slices[i].values)
    assert not np.array_equal(joint[0].slices[2].values, joint[1].slices[2].values)
    off = [float(nodes[-1]) * 10.0]
    assert geometry_tables([(b, off), (b, s)], points=POINTS, directory=tmp_path / "joint", nodes=nodes,
                           off_grid="skip")[0] is None
    with pytest.raises(InputError, match="outside"):
        geometry_tables([(b, off)], points=POINTS, directory=tmp_path / "joint", nodes=nodes)
    assert calls == [8]  # the rest came from the cache


@pytest.mark.parametrize("workers", [1, 2])
def test_cancel_from_progress_stops_the_build(tmp_path, workers):
    def cancel_soon(done, total, label=""):
        if done >= 2:
            raise Cancelled("user pressed stop")

    with pytest.raises(Cancelled):
        machine_tables(coarse_machine(), points=POINTS, directory=tmp_path, workers=workers, progress=cancel_soon)
    # no temporary file is left behind, and whatever was stored is a complete, trusted table
    assert not list(tmp_path.rglob("*.tmp"))
    with warnings.catch_warnings():
        warnings.simplefilter("error", StaleCacheWarning)
        machine_tables(coarse_machine(), points=POINTS, directory=tmp_path, workers=1)


def test_table_key_is_stored_on_the_returned_table(tmp_path):
    t = cached_table(coarse_machine(), 1, points=POINTS, directory=tmp_path)
    assert dataclasses.replace(t).key == t.key == table_key(coarse_machine(), 1, points=POINTS)
    assert t.bearing == 1


def test_a_changed_view_from_the_slices_in_memory_equals_the_cached_view():
    """An effect fit asks a bearing for thousands of views at changed viscosity or clearance. After the first,
    each comes from the slices already in memory (`scaled.scaled_view`: no bearing copy, no file read, its splines
    combined from the slices' instead of fitted): the same table and the same interpolated K, C, position and
    slopes at any flow (both sides of Q_T, its node, the span's ends) as `bearing_view` of the changed bearing,
    whose splines are fitted to the combined values; a view whose slices are not loaded takes the slow path."""
    from lubeviz.identify.tables.cache import bearing_view
    from lubeviz.identify.forward.chain import BearingSource

    m = load_machine()
    omega = 2 * math.pi * 75.0
    src = BearingSource(m, 0, omega)
    b = src.bearing
    first = src.view(0.9)  # slow path: loads (or builds) the slices around its S and keeps them
    assert src._table is not None and first.key
    for factor, clearance in ((0.905, b.clearance), (0.9, 1.01 * b.clearance), (0.91, 0.995 * b.clearance)):
        fast = src.view(factor, clearance)
        assert fast.key == ""  # made from memory
        slow = bearing_view(b.copy(viscosity=b.viscosity * factor, clearance=clearance), src.load, omega)
        assert fast.q_threshold == pytest.approx(slow.q_threshold, rel=1e-12)
        for name in ("q", "K", "C", "position"):
            np.testing.assert_allclose(getattr(fast, name), getattr(slow, name), rtol=1e-12, atol=0)
        q = np.concatenate([np.linspace(slow.q_min, slow.q_max, 397), [slow.q_threshold],
                            slow.q_threshold * (1 + np.array([-1e-3, 1e-3, 0.0123]))])
        for method in ("coefficients", "coefficient_derivatives"):
            for a, b_ in zip(getattr(fast, method)(q), getattr(slow, method)(q)):
                scale = np.max(np.abs(b_), axis=0)
                assert np.max(np.abs(a - b_) / scale) < 1e-9, method
        np.testing.assert_allclose(fast.journal_position(q), slow.journal_position(q), rtol=0,
                                   atol=1e-9 * float(np.max(np.abs(slow.position))))
        # a fit asks only for the values at its flows: `evaluate` takes them from the slices, making no view
        beyond = np.concatenate([q, [0.5 * slow.q_min, 3 * slow.q_max]])  # clipped to the span, as a view clips
        K, C, pos = src.evaluate(beyond[:, None], np.full((beyond.size, 1), factor), clearance)
        K0, C0 = slow.coefficients(np.clip(beyond, slow.q_min, slow.q_max))
        for a, b_ in ((K[:, 0], K0), (C[:, 0], C0)):
            assert np.max(np.abs(a - b_) / np.max(np.abs(b_), axis=0)) < 1e-9
    # a Jacobian's batch: each point its own bearing (the declared one among them), none made into a view
    src.view()  # the declared bearing's own view
    views = len(src._views)
    f = np.array([1.0, 0.9031, 0.897, 0.92, 0.9])
    c = b.clearance * np.array([1.0, 1.0, 1.004, 0.998, 1.0])
    lf = np.array([1.0, 1.0, 1.0, 1.03, 0.98])
    qs = first.q_threshold * np.array([0.7, 1.0, 1.3, 0.45, 1.9])
    K, C, pos = src.evaluate(qs, f, c, lf)
    assert len(src._views) == views
    for k in range(f.size):
        slow = bearing_view(b.copy(viscosity=b.viscosity * f[k], clearance=c[k]), src.load * lf[k], omega)
        K0, C0 = slow.coefficients(np.clip(qs[k], slow.q_min, slow.q_max))
        np.testing.assert_allclose(K[k], K0, rtol=1e-9, atol=1e-9 * np.max(np.abs(K0)))
        np.testing.assert_allclose(C[k], C0, rtol=1e-9, atol=1e-9 * np.max(np.abs(C0)))
        np.testing.assert_allclose(pos[k], slow.journal_position(np.clip(qs[k], slow.q_min, slow.q_max)),
                                   rtol=1e-9, atol=1e-12)
    far = src.view(0.55)  # S outside the slices loaded so far: the slow path, which loads them
    assert far.key


def test_two_builders_of_one_geometry_take_turns_and_solve_each_slice_once(tmp_path, builds):
    """A second builder (here a thread; another app session or test worker is a process, the same `flock`)
    that misses the slices a first one is building waits, says so, then loads what the first stored: no
    film is solved twice. A Cancel while waiting ends the wait."""
    import threading

    m = coarse_machine()
    building, waiting = threading.Event(), threading.Event()
    tables_, messages = {}, []

    def first_progress(done, total, label=""):  # the first builder, inside its build, lets the second arrive
        building.set()
        assert waiting.wait(timeout=60)

    def second_progress(done, total, label=""):
        messages.append(label)
        if "waiting for another build" in label:
            waiting.set()

    def build(name, progress):
        tables_[name] = cached_table(m, 0, points=POINTS, directory=tmp_path, progress=progress)

    first = threading.Thread(target=build, args=("first", first_progress))
    first.start()
    assert building.wait(timeout=60)
    second = threading.Thread(target=build, args=("second", second_progress))
    second.start()
    first.join(timeout=120)
    second.join(timeout=120)
    assert not first.is_alive() and not second.is_alive()
    assert len(builds) == SLICES  # each slice solved once, by the first builder
    assert any("built by another process" in label for label in messages)
    assert_same_table(tables_["first"], tables_["second"])

    # a builder held up by another one's lock can be cancelled while it waits
    lock = cache._lock_path(tmp_path / "elsewhere" / "slices", geometry_values(m.bearings[0]), tables.DEFAULT_SPAN,
                            POINTS)

    def cancel(done, total, label=""):
        raise Cancelled("user pressed stop")

    with cache._build_lock(lock, cancel):
        with pytest.raises(Cancelled):
            cached_table(m, 0, points=POINTS, directory=tmp_path / "elsewhere", progress=cancel)
    assert len(builds) == SLICES


# --- a cache that cannot be used: the answer all the same, a warning, never a hang ----------------------

@contextlib.contextmanager
def no_hang(seconds=60):
    """Fail (instead of blocking the test run for ever) when the block takes longer than `seconds`: SIGALRM
    interrupts a blocking open() of a FIFO and raises here."""
    def expire(signum, frame):
        raise TimeoutError(f"blocked for more than {seconds} s")

    previous = signal.signal(signal.SIGALRM, expire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


@pytest.fixture
def reference(tmp_path_factory):
    """Bearing 1's table from a cache that works (built once per test, in its own directory)."""
    return cached_table(coarse_machine(), 0, points=POINTS, directory=tmp_path_factory.mktemp("good"))


@pytest.fixture
def fresh_memory(monkeypatch):
    """No slices kept in memory from earlier tests (those a broken cache could not store)."""
    monkeypatch.setattr(cache, "_UNSTORED", {})
    monkeypatch.setattr(cache, "_VALIDATED", {})


def read_only(monkeypatch, directory):
    """Make `directory` behave as read-only (the tests run as root, for whom chmod 0o555 stops no write):
    creating a directory or opening a file for writing under it raises PermissionError (EACCES)."""
    directory = str(directory)
    real_open, real_mkdir = os.open, os.mkdir
    writing = os.O_WRONLY | os.O_RDWR | os.O_CREAT

    def inside(path):
        return os.path.abspath(os.fsdecode(path)).startswith(directory + os.sep)

    def guarded_open(path, flags, *args, **kwargs):
        if flags & writing and inside(path):
            raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), os.fsdecode(path))
        return real_open(path, flags, *args, **kwargs)

    def guarded_mkdir(path, *args, **kwargs):
        if inside(path) and not os.path.isdir(path):
            raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), os.fsdecode(path))
        return real_mkdir(path, *args, **kwargs)

    monkeypatch.setattr(os, "open", guarded_open)
    monkeypatch.setattr(os, "mkdir", guarded_mkdir)


def test_a_read_only_cache_directory_still_gives_the_table_with_a_warning(tmp_path, monkeypatch, builds,
                                                                           reference, fresh_memory):
    (tmp_path / "slices").mkdir()
    read_only(monkeypatch, tmp_path)
    with no_hang(), pytest.warns(cache.CacheStoreWarning,
                                 match=r"could not store 4 coefficient table slice\(s\) in .*Permission denied.*"
                                       "rebuilt next time"):
        table = cached_table(coarse_machine(), 0, points=POINTS, directory=tmp_path)
    assert_same_table(table, reference)
    assert list((tmp_path / "slices").iterdir()) == []  # nothing written, not even the lock
    n = len(builds)
    with warnings.catch_warnings():  # the slices built are kept in memory: no second solve in this process
        warnings.simplefilter("error")
        again = cached_table(coarse_machine(), 0, points=POINTS, directory=tmp_path)
    assert len(builds) == n
    assert_same_table(again, reference)


def test_a_read_only_cache_that_holds_the_slices_serves_them_without_a_warning(tmp_path, monkeypatch, builds,
                                                                                 fresh_memory):
    first = cached_table(coarse_machine(), 0, points=POINTS, directory=tmp_path)
    read_only(monkeypatch, tmp_path)
    with no_hang(), warnings.catch_warnings():
        warnings.simplefilter("error")
        second = cached_table(coarse_machine(), 0, points=POINTS, directory=tmp_path)
    assert len(builds) == SLICES
    assert_same_table(second, first)


@pytest.mark.parametrize("where", ["cache directory", "slices directory"])
def test_a_cache_directory_that_is_a_file_still_gives_the_table_with_a_warning(tmp_path, builds, reference,
                                                                              fresh_memory, where):
    root, before = tmp_path / "cache", len(builds)
    if where == "cache directory":
        root.write_text("not a directory")
    else:
        root.mkdir()
        (root / "slices").write_text("not a directory")
    with no_hang(), pytest.warns(cache.CacheStoreWarning, match=r"could not store .* in .*cache.*slices: "
                                                               r"(NotADirectoryError|FileExistsError)"):
        table = cached_table(coarse_machine(), 0, points=POINTS, directory=root)
    assert_same_table(table, reference)
    assert len(builds) == before + SLICES


def _fifo(path):
    os.mkfifo(path)


def _directory(path):
    path.mkdir()
    (path / "inside").write_text("kept")


def _symlink_outside(path):
    outside = path.parents[2] / "outside.npz"
    outside.write_bytes(b"a file outside the cache: never read, never changed")
    path.symlink_to(outside)


@pytest.mark.parametrize("special, kind", [(_fifo, "a FIFO"), (_directory, "a directory"),
                                           (_symlink_outside, "a symbolic link")])
def test_a_special_file_in_place_of_a_slice_is_never_opened_and_the_table_still_comes(
        tmp_path, builds, reference, fresh_memory, special, kind):
    m = coarse_machine()
    cached_table(m, 0, points=POINTS, directory=tmp_path)
    path = slice_files(tmp_path)[1]
    path.unlink()
    special(path)
    before = len(builds)
    with no_hang(), warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        table = cached_table(m, 0, points=POINTS, directory=tmp_path)
    assert_same_table(table, reference)
    assert len(builds) == before + 1  # the special file's slice solved again, the others read
    stale = {str(w.message) for w in caught if issubclass(w.category, StaleCacheWarning)}  # read before and
    assert len(stale) == 1  # after the build lock: one message, shown once under Python's default filter
    assert path.name in min(stale) and f"{kind}, not a regular file; not opened" in min(stale)
    if special is _directory:  # left in place (it may hold anything): the slice cannot be stored there
        assert (path / "inside").read_text() == "kept"
        assert any(issubclass(w.category, cache.CacheStoreWarning) and "IsADirectoryError" in str(w.message)
                   for w in caught)
    else:  # the name is replaced by the slice, a regular file; a symlink's target is untouched
        assert path.is_file() and not path.is_symlink()
        assert not any(issubclass(w.category, cache.CacheStoreWarning) for w in caught)
    if special is _symlink_outside:
        assert (tmp_path.parent / "outside.npz").read_bytes().startswith(b"a file outside the cache")


@pytest.mark.parametrize("special", [_fifo, _directory])
def test_a_build_lock_that_cannot_be_taken_lets_the_build_go_on_unlocked(tmp_path, builds, reference,
                                                                        fresh_memory, special):
    m = coarse_machine()
    lock = cache._lock_path(tmp_path / "slices", geometry_values(m.bearings[0]), tables.DEFAULT_SPAN, POINTS)
    lock.parent.mkdir(parents=True)
    special(lock)
    with no_hang(), pytest.warns(cache.CacheWarning, match="could not take the build lock"):
        table = cached_table(m, 0, points=POINTS, directory=tmp_path)
    assert_same_table(table, reference)
    assert len(slice_files(tmp_path)) == SLICES  # stored all the same


def test_a_failed_write_mid_build_keeps_the_built_slices_and_warns(tmp_path, monkeypatch, builds, reference,
                                                                  fresh_memory):
    """A disk that fills up after two slices: those two are stored, the others used from memory."""
    real_write, written = cache._write, []

    def write_twice(path, *args):
        if len(written) == 2:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))
        written.append(path)
        return real_write(path, *args)

    monkeypatch.setattr(cache, "_write", write_twice)
    with pytest.warns(cache.CacheStoreWarning, match=r"could not store 2 .*No space left on device"):
        table = cached_table(coarse_machine(), 0, points=POINTS, directory=tmp_path)
    assert_same_table(table, reference)
    assert slice_files(tmp_path) == sorted(written)
