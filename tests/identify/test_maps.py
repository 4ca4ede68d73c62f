"""Sensitivity maps (Figs. 4-11): sweeps, Q1 x Q2 grids, error functions and their root curves."""

import json
import math

import numpy as np
import pytest

from lubeviz.cli.main import main
from lubeviz.errors import InputError
from lubeviz.identify.tables.cache import machine_tables
from lubeviz.identify.forward.model import PAPER_FEATURES, ForwardModel, wrap_difference
from lubeviz.identify.paper.maps import (FeatureGrid, branch_cut_mask, domain_axes, error_grid, feature_grid,
                                   flow_sweep, paper_figures, root_curves)
from lubeviz.identify.forward.measured import MeasuredFeatures
from lubeviz.identify.fit.settings import IdentificationSettings
from lubeviz.progress import Cancelled
from lubeviz.rotor.directional import orbit_angle
from lubeviz.rotor.response import Unbalance
from lubeviz.units import MLMIN_PER_M3S

MLMIN = 1 / MLMIN_PER_M3S
SWEEP = np.linspace(273.0, 819.0, 61) * MLMIN  # Sec. 3.1: 50-150 % of Q_T


@pytest.fixture(scope="module")
def tables(machine):
    return machine_tables(machine)


@pytest.fixture(scope="module", params=[(6, 20), (5, 21)], ids=["centre", "outside"])
def model(request, machine, tables):
    return ForwardModel(machine, tables, request.param)


def _distance(point, curves, scale):
    """Smallest distance from `point` to the polylines' vertices and segments, in units of `scale`."""
    best = np.inf
    p = np.asarray(point) / scale
    for c in curves:
        a, b = c[:-1] / scale, c[1:] / scale
        ab = b - a
        t = np.clip(np.sum((p - a) * ab, axis=1) / np.maximum(np.sum(ab * ab, axis=1), 1e-300), 0.0, 1.0)
        best = min(best, np.min(np.hypot(*(a + t[:, None] * ab - p).T)))
    return best


# --- sweeps and grids ----------------------------------------------------------------------------

def test_grid_diagonal_equals_the_sweep(model):
    sweep = flow_sweep(model, SWEEP)
    grid = feature_grid(model, SWEEP, SWEEP)
    for k, (fb, phi) in enumerate((("fb1", "phi1"), ("fb2", "phi2"))):
        assert np.allclose(np.diag(grid[fb]), sweep.fb[:, k], rtol=1e-12)
        # the sweep unwraps phi along Q; the grid keeps the branch: equal modulo pi
        d = wrap_difference((np.diag(grid[phi]) - sweep.phi[:, k])[:, None], ("phi1",))[:, 0]
        assert np.all(np.abs(d) < 1e-10)


def test_sweep_phi_is_continuous_along_the_flow(model):
    sweep = flow_sweep(model, SWEEP)
    assert np.all(np.abs(np.diff(sweep.phi, axis=0)) < math.radians(20))
    assert np.allclose(orbit_angle(sweep.zf, sweep.zb), wrap_difference(sweep.phi, ("phi1", "phi2")), atol=1e-12)


def test_feature_grid_is_indexed_q2_rows_q1_columns(model):
    q1 = np.linspace(300, 800, 17) * MLMIN
    q2 = np.linspace(350, 700, 11) * MLMIN
    grid = feature_grid(model, q1, q2)
    assert grid["fb1"].shape == (q2.size, q1.size)
    rng = np.random.default_rng(7)
    for _ in range(20):
        i, j = rng.integers(q2.size), rng.integers(q1.size)
        direct = model.features(q1[j], q2[i], PAPER_FEATURES)
        assert np.allclose(grid.stack()[i, j], direct, rtol=1e-12, atol=0)


def test_fb_and_phi_do_not_depend_on_the_unbalance(machine, tables):
    nodes = (5, 21)
    ref = flow_sweep(ForwardModel(machine, tables, nodes), SWEEP)
    other = Unbalance(machine.unbalance_node, 3.7 * machine.unbalance_moment, machine.unbalance_phase + 1.1)
    scaled = flow_sweep(ForwardModel(machine, tables, nodes, unbalances=(other,)), SWEEP)
    assert np.allclose(scaled.forward_amplitude, 3.7 * ref.forward_amplitude, rtol=1e-9)
    assert np.allclose(scaled.fb, ref.fb, rtol=1e-9)
    assert np.allclose(scaled.phi, ref.phi, atol=1e-9)


def test_sweeps_show_the_papers_sensitivity_at_the_bearing_centres(machine, tables):
    """Sec. 3.1: fb rises monotonically with the flow (Fig. 5); the forward amplitude peaks near Q_T (Fig. 4a);
    the backward amplitude is monotonic at bearing 2 (Fig. 4b)."""
    sweep = flow_sweep(ForwardModel(machine, tables, machine.center_nodes), SWEEP)
    assert np.all(np.diff(sweep.fb, axis=0) > 0)
    peak = SWEEP[np.argmax(sweep.forward_amplitude, axis=0)] / sweep.q_threshold
    assert np.all((peak > 0.9) & (peak < 1.2)), peak
    assert np.all(np.diff(sweep.backward_amplitude[:, 1]) < 0) or np.all(np.diff(sweep.backward_amplitude[:, 1]) > 0)


# --- error functions and root curves -----------------------------------------------------------------

CASES = [(448.5, 604.5), (604.5, 487.5), (300.0, 800.0), (700.0, 330.0)]


@pytest.mark.parametrize("q_true", CASES)
def test_true_flows_lie_on_every_root_curve_and_minimize_eps_total(model, q_true):
    """Figs. 9-11: each error function vanishes along a curve through the true flows; eps_T is least there."""
    q_true = np.array(q_true) * MLMIN
    q1, q2 = domain_axes(model, 101)
    eg = error_grid(model, model.features(*q_true), q1_axis=q1, q2_axis=q2)
    cell = np.hypot(q1[1] - q1[0], q2[1] - q2[0])
    for name, curves in eg.roots().items():
        assert curves, name
        assert _distance(q_true, curves, 1.0) < 0.5 * cell, name
    assert np.all(np.abs(eg.lowest() - q_true) <= np.array([q1[1] - q1[0], q2[1] - q2[0]]))


@pytest.mark.parametrize("q_true", CASES[:2])
def test_every_point_of_a_root_curve_is_a_root_of_the_model(model, q_true):
    """The curves come from linear interpolation in grid cells: checked against the model evaluated on them.
    A spurious crossing at the phi branch cut would show a 90 deg error."""
    q_true = np.array(q_true) * MLMIN
    ref = model.features(*q_true)
    eg = error_grid(model, ref, q1_axis=np.linspace(140, 1080, 121) * MLMIN,
                    q2_axis=np.linspace(140, 1080, 121) * MLMIN)
    for k, (name, curves) in enumerate(eg.roots().items()):
        pts = np.concatenate(curves)
        d = wrap_difference(model.features(pts[:, 0], pts[:, 1]) - ref, PAPER_FEATURES)[:, k]
        if name.startswith("phi"):
            assert np.max(np.abs(np.degrees(d))) < 10.0, name
            assert np.median(np.abs(np.degrees(d))) < 0.5, name
        else:
            assert np.max(np.abs(d / ref[k])) < 0.02, name


def _branch(theta):
    """An orbit angle on its branch (-pi/2, pi/2], from a continuous angle."""
    return orbit_angle(np.exp(1j * theta), np.exp(1j * theta))


def test_phi_branch_cut_gives_no_spurious_root_curve():
    """eps_phi of a field phi = theta (mod pi) with theta = x + y/2 in -2.7..2.7: its only zero is theta = phi_m
    (phi_m -+ pi lie outside). The wrapped difference jumps by pi where theta - phi_m = +-pi/2 (and phi itself
    at theta = +-pi/2): unmasked, contouring reports two more "roots" there."""
    x = np.linspace(-2.2, 2.2, 89)
    y = np.linspace(-1.0, 1.0, 41)
    theta = x[None, :] + 0.5 * y[:, None]
    phi_m = 0.3
    ones = np.ones_like(theta)
    grid = FeatureGrid(q1=x + 3.0, q2=y + 3.0, nodes=(6, 20), names=PAPER_FEATURES,
                       values={"fb1": ones, "fb2": ones, "phi1": _branch(theta), "phi2": _branch(theta)},
                       q_threshold=np.array([3.0, 3.0]))
    eg = error_grid(grid, [1.0, 1.0, phi_m, phi_m])
    assert math.isclose(eg.periods["phi1"], math.pi / IdentificationSettings.paper().phi_scale)
    curves = eg.roots()["phi1"]
    pts = np.concatenate(curves) - 3.0
    assert np.allclose(pts[:, 0] + 0.5 * pts[:, 1], phi_m, atol=1e-9)  # only the true line
    assert np.ptp(pts[:, 1]) > 1.9  # and the whole of it
    unmasked = root_curves(grid.q1, grid.q2, eg.eps["phi1"])
    thetas = np.unique(np.round([np.mean(c[:, 0] - 3.0 + 0.5 * (c[:, 1] - 3.0)) for c in unmasked], 2))
    assert np.allclose(thetas, [phi_m - math.pi / 2, phi_m, phi_m + math.pi / 2], atol=0.02)


def test_branch_cut_mask_marks_only_the_jump_and_non_finite_points():
    z = np.tile(np.linspace(-1.0, 1.0, 9), (3, 1))
    z[:, 5:] -= 2.0  # a jump of one period (2) between columns 4 and 5
    z[0, 0] = np.nan
    mask = branch_cut_mask(z, period=2.0)
    expected = np.zeros_like(mask)
    expected[:, 4:6] = True
    expected[0, 0] = True
    assert np.array_equal(mask, expected)
    assert np.array_equal(branch_cut_mask(z), ~np.isfinite(z))


def test_root_curves_of_a_circle_are_the_circle():
    x = np.linspace(-2, 2, 201)
    z = x[None, :] ** 2 + x[:, None] ** 2 - 1.0
    (c,) = root_curves(x, x, z)
    assert np.allclose(np.hypot(c[:, 0], c[:, 1]), 1.0, atol=1e-3)
    assert np.allclose(c[0], c[-1])  # closed
    with pytest.raises(InputError):
        root_curves(x, x[:-1], z)


def test_phi_scale_and_best_mode_cost_follow_their_definitions(machine, tables):
    model = ForwardModel(machine, tables, (6, 20))
    q1 = q2 = np.linspace(300, 800, 21) * MLMIN
    grid = feature_grid(model, q1, q2, ("fb1", "fb2", "phi1", "phi2", "log_zf_ratio", "arg_zf_ratio"))
    names = grid.names
    values = model.features(500 * MLMIN, 600 * MLMIN, names)
    std = np.array([0.02, 0.03, 0.004, 0.005, 0.01, 0.02])
    meas = MeasuredFeatures(names=names, values=values, cov=np.diag(std**2), x=np.zeros(2), y=np.zeros(2),
                            nodes=(6, 20), speed_hz=75.0, line_snr=np.full((2, 2), 100.0))
    for scale_deg in (30.0, 0.0):
        settings = IdentificationSettings.paper(phi_scale=math.radians(scale_deg))
        eg = error_grid(grid, meas, settings)
        i, j = 4, 13
        s = math.radians(scale_deg) if scale_deg else abs(values[2])
        d_phi = (grid["phi1"][i, j] - values[2] + math.pi / 2) % math.pi - math.pi / 2
        assert math.isclose(eg.eps["phi1"][i, j], d_phi / s, rel_tol=1e-12)
        assert math.isclose(eg.eps["fb2"][i, j], grid["fb2"][i, j] / values[1] - 1.0, rel_tol=1e-12)
        assert math.isclose(eg.total[i, j], sum(abs(eg.eps[n][i, j]) for n in PAPER_FEATURES), rel_tol=1e-12)
    d = wrap_difference(grid.stack()[i, j] - values, names)
    assert math.isclose(eg.cost[i, j], float(np.sum((d / std) ** 2)), rel_tol=1e-9)
    assert eg.cost.min() < 1e-12 and np.allclose(eg.lowest_cost(), [500 * MLMIN, 600 * MLMIN])


def test_error_grid_rejects_bad_references(machine, tables):
    model = ForwardModel(machine, tables, (6, 20))
    grid = feature_grid(model, SWEEP, SWEEP)
    with pytest.raises(InputError):
        error_grid(grid, [1.0, 2.0])
    with pytest.raises(InputError):
        error_grid(grid, [0.0, 2.0, 0.1, 0.1])  # fb_m = 0: Eq. 11 undefined
    with pytest.raises(InputError):
        error_grid(model, [1.0, 2.0, 0.1, 0.1])  # a model needs axes


# --- Figs. 4-11 in one call, and the command -----------------------------------------------------------

def test_paper_figures_stop_when_the_progress_callback_cancels(machine, tables):
    def cancel(done, total, label=""):
        raise Cancelled()

    with pytest.raises(Cancelled):
        paper_figures(machine, grid=11, tables=tables, progress=cancel)


def test_figures_command_writes_every_figure_and_identifies_the_reference(tmp_path, capsys, tables):
    out = tmp_path / "figs"
    assert main(["figures", "--out", str(out), "--grid", "21", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert sorted(summary["files"]) == sorted(f"fig{k}" for k in range(4, 12))
    for path in summary["files"].values():
        assert (out / path.split("/")[-1]).stat().st_size > 0
    lines = (out / "fig9.csv").read_text().splitlines()
    header = next(k for k, line in enumerate(lines) if not line.startswith("#"))
    rows = [r.split(",") for r in lines[header + 1:]]
    ref = next(r for r in rows if r[0] == "reference")
    ident = next(r for r in rows if r[0] == "identified")
    for k in (3, 4):  # q1_mlmin, q2_mlmin: the paper-mode search finds the case within the 12 dB noise
        assert abs(float(ident[k]) / float(ref[k]) - 1.0) < 0.02
    assert {r[0] for r in rows} >= {"grid", "root_eps_fb1", "root_eps_fb2", "root_eps_phi1", "root_eps_phi2", "path"}


@pytest.mark.parametrize("argv", [["--grid", "1"], ["--grid", "5000"], ["--machine", "no-such-model.toml"]])
def test_figures_command_refuses_bad_input_with_exit_2(tmp_path, capsys, argv):
    assert main(["figures", "--out", str(tmp_path / "x"), "--json", *argv]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and len(captured.err.strip().splitlines()) == 1


def test_figures_command_refuses_a_file_as_output_directory(tmp_path, capsys):
    f = tmp_path / "file"
    f.write_text("")
    assert main(["figures", "--out", str(f)]) == 2
    assert "not a directory" in capsys.readouterr().err


def test_the_map_s_start_grid_is_where_the_paper_s_searches_start(machine, model):
    """The Maps page draws `start_grid` under the search paths (it computes nothing): every path begins on it,
    and it holds the settings' fractions of Q_T, every pair."""
    from lubeviz.identify.fit.settings import IdentificationSettings
    from lubeviz.identify.paper.maps import identification_map, simulated_measurement

    settings = IdentificationSettings.paper()
    q_true = np.array([450.0, 620.0]) * MLMIN
    measured = simulated_measurement(machine, model, q_true, snr_db=30.0, rng=np.random.default_rng(1))
    out = identification_map(model, measured, settings, domain_axes(model, 21))
    grid = out["start_grid"]
    assert grid.shape == (len(settings.starts) ** 2, 2)
    np.testing.assert_allclose(sorted(set(np.round(grid[:, 0] / model.q_threshold[0], 12))), settings.starts)
    for path in out["paths"]:
        assert np.min(np.max(np.abs(grid - path[0]) / model.q_threshold, axis=1)) < 1e-12

