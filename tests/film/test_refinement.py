"""Local circumferential refinement at the groove (mesh.refined_split): geometry, exactness, smoothness."""

import math

import numpy as np
import pytest

from lubeviz.errors import InputError
from lubeviz.film.equilibrium import find_equilibrium, flooded_threshold
from lubeviz.film.feed import Feed, make_mesh, setup_problem
from lubeviz.film.mesh import FilmMesh, groove_cells
from lubeviz.film.roughness import SHORT_WINDOW, coefficient_roughness
from lubeviz.film.solver import solve
from lubeviz.film.sweep import sweep_supply
from tests.conftest import OMEGA_75HZ, PAPER_LOAD
from lubeviz.units import MLMIN_PER_M3S


def test_refined_mesh_tiles_the_circumference_and_keeps_the_groove(paper_bearing):
    uniform = make_mesh(paper_bearing.copy(groove_refinement=1))
    refined = make_mesh(paper_bearing)
    assert paper_bearing.groove_refinement == 4 and refined.n_nominal == uniform.n_circ == 100
    assert refined.d_alpha.sum() == pytest.approx(2 * math.pi, rel=1e-12)
    assert np.all(np.diff(refined.alpha) > 0) and refined.alpha_east[-1] == pytest.approx(refined.alpha_offset + 2 * math.pi)
    # 6 groove columns + 2 upstream + 6 downstream, each split in 4
    assert refined.n_circ == 100 + 3 * 14
    # each nominal column's sub-columns share its span
    for k in (0, 50, 99):
        sub = refined.nominal_column == k
        assert refined.d_alpha[sub].sum() == pytest.approx(uniform.d_alpha[k], rel=1e-12)
        assert (refined.alpha[sub] - 0.5 * refined.d_alpha[sub]).min() == pytest.approx(
            uniform.alpha[k] - 0.5 * uniform.d_alpha[k], abs=1e-12)
    # the groove covers the same nominal cells whatever the refinement
    b = paper_bearing
    g_u = groove_cells(uniform, b.groove_angle, b.groove_length, b.groove_width)
    g_r = groove_cells(refined, b.groove_angle, b.groove_length, b.groove_width)
    assert np.array_equal(g_u[:, np.unique(refined.nominal_column[g_r.any(axis=0)])].any(axis=0),
                          np.ones(6, bool))
    area_u = (np.broadcast_to(uniform.cell_area, uniform.shape))[g_u].sum()
    area_r = (np.broadcast_to(refined.cell_area, refined.shape))[g_r].sum()
    assert area_r == pytest.approx(area_u, rel=1e-12)


@pytest.mark.parametrize("split", [(0,) + (1,) * 9, (2,) * 7])
def test_bad_split_is_refused(split):
    with pytest.raises(InputError, match="split|nominal"):
        FilmMesh(sum(split), 10, 0.045, 0.07, split=split)


def test_splitting_every_column_in_two_is_the_uniform_mesh_of_twice_the_columns(paper_bearing):
    """The non-uniform operator reduces exactly to the uniform one (a plain bearing: any split is legal)."""
    b = paper_bearing.copy(groove_length=0.0, groove_width=0.0)
    pos = (0.5 * b.clearance * math.sin(0.7), -0.5 * b.clearance * math.cos(0.7))
    uniform = FilmMesh(120, 40, b.radius, b.length, 0.1)
    split = FilmMesh(120, 40, b.radius, b.length, 0.1, split=(2,) * 60)
    sols = [solve(setup_problem(b, OMEGA_75HZ, pos, Feed.plain(), mesh=m)) for m in (uniform, split)]
    np.testing.assert_allclose(sols[1].P, sols[0].P, rtol=1e-10, atol=1e-12 * sols[0].P.max())
    np.testing.assert_allclose(sols[1].force, sols[0].force, rtol=1e-10)
    assert sols[1].mass_residual < 1e-10


@pytest.mark.parametrize("eps", [0.3, 0.6, 0.8])
def test_a_non_uniform_mesh_converges_to_the_fine_mesh(paper_bearing, eps):
    """A mesh of alternating narrow and wide columns (1 : 3) converges as it is halved: consistency of the
    non-uniform operator (measured error ratio per halving 0.18-0.47; plain bearing, 960-column reference)."""
    b = paper_bearing.copy(groove_length=0.0, groove_width=0.0)
    pos = (eps * b.clearance * math.sin(0.4), -eps * b.clearance * math.cos(0.4))

    def force(mesh):
        return solve(setup_problem(b, OMEGA_75HZ, pos, Feed.plain(), mesh=mesh)).force

    fine = force(FilmMesh(960, 40, b.radius, b.length, 0.05))
    err = []
    for split in ((1, 3) * 30, (2, 6) * 30):
        f = force(FilmMesh(sum(split), 40, b.radius, b.length, 0.05, split=split))
        err.append(np.abs(f - fine).max() / np.abs(fine).max())
    assert err[1] < 0.6 * err[0] and err[1] < 2e-3


def test_refinement_keeps_the_flooded_threshold_and_conserves_mass(paper_bearing):
    q_u, _ = flooded_threshold(paper_bearing.copy(groove_refinement=1), OMEGA_75HZ, PAPER_LOAD)
    q_r, eq = flooded_threshold(paper_bearing, OMEGA_75HZ, PAPER_LOAD)
    assert q_r == pytest.approx(q_u, rel=1e-9)  # the cells next to a flooded groove are cavitated
    for q in (0.8 * q_r, 1.03 * q_r):
        film = find_equilibrium(paper_bearing, OMEGA_75HZ, PAPER_LOAD, Feed.flow(q), start=eq.position).film
        assert film.side_leakage == pytest.approx(q, rel=1e-8) and film.mass_residual < 1e-8


def test_refinement_moves_the_coefficients_towards_the_finer_mesh_above_q_t(paper_bearing):
    """Where the groove's pressurized zone grows (Q_T .. Q_T + 25), the refined 100 x 100 coefficients are
    closer to the 400 x 100 uniform ones than the uniform 100 x 100 are."""
    fine = paper_bearing.copy(groove_refinement=1, n_circumferential=400)
    uniform = paper_bearing.copy(groove_refinement=1)
    for q in (552 / MLMIN_PER_M3S, 560 / MLMIN_PER_M3S, 566 / MLMIN_PER_M3S):
        ref = find_equilibrium(fine, OMEGA_75HZ, PAPER_LOAD, Feed.flow(q)).coefficients
        dist = []
        for b in (uniform, paper_bearing):
            c = find_equilibrium(b, OMEGA_75HZ, PAPER_LOAD, Feed.flow(q)).coefficients
            dist.append(max(np.abs(c.K - ref.K).max() / np.abs(ref.K).max(),
                            np.abs(c.C - ref.C).max() / np.abs(ref.C).max()))
        assert dist[1] <= dist[0] and dist[1] < 0.01


@pytest.mark.slow
def test_refinement_removes_the_staircase_where_the_groove_pressurizes(paper_bearing):
    """Local-cubic deviation over 15 ml/min across Q_T - 20 .. Q_T + 60 (measured: uniform 0.18 %, refined
    0.024 %); the fits are split at Q_T, where the regime changes."""
    q_t, _ = flooded_threshold(paper_bearing, OMEGA_75HZ, PAPER_LOAD)
    flows = np.round(q_t * MLMIN_PER_M3S) / MLMIN_PER_M3S + np.arange(-20.0, 61.0) / MLMIN_PER_M3S
    breaks = np.zeros(flows.size, bool)
    breaks[1:] = (flows[1:] >= q_t) & (flows[:-1] < q_t)
    out = {}
    for r in (1, 4):
        s = sweep_supply(paper_bearing.copy(groove_refinement=r), OMEGA_75HZ, PAPER_LOAD, flows)
        rough = coefficient_roughness(s.K, s.C, breaks, window=SHORT_WINDOW)
        out[r] = max(rough["K_max"], rough["C_max"])
    assert out[1] > 1e-3  # the uniform mesh's column-by-column staircase
    assert out[4] < 5e-4
