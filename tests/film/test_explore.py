"""Frames of the Bearing page (film.explore): what they keep must be the equilibrium's own numbers."""

import math

import numpy as np
import pytest

from lubeviz.film.equilibrium import find_equilibrium
from lubeviz.film.explore import supply_frame, supply_frames
from lubeviz.film.feed import Feed
from lubeviz.model.machine import load_machine
from lubeviz.rotor.statics import bearing_static_loads
from lubeviz.units import MLMIN_PER_M3S

OMEGA = 2 * math.pi * 75.0


def _setup():
    m = load_machine()
    return m.bearings[0].copy(n_circumferential=60, n_axial=40), bearing_static_loads(m)[0]


def test_frame_keeps_the_equilibrium_and_its_coefficients():
    b, load = _setup()
    frame, eq = supply_frame(b, OMEGA, load, 400 / MLMIN_PER_M3S)
    ref = find_equilibrium(b, OMEGA, load, Feed.flow(400 / MLMIN_PER_M3S))
    np.testing.assert_allclose(frame.position, ref.position, rtol=1e-6)
    np.testing.assert_allclose(frame.K, ref.coefficients.K, rtol=1e-6)
    np.testing.assert_allclose(frame.C, ref.coefficients.C, rtol=1e-6)
    # The film force balances the load, and the whole-film field is the mirror image about z = L/2.
    np.testing.assert_allclose(eq.film.force, -load, atol=1e-6 * np.hypot(*load))
    np.testing.assert_array_equal(frame.pressure, frame.pressure[::-1])
    # The groove mask covers the groove's area (16.2 mm x 35 mm) to within one cell in each direction.
    cells = b.radius * frame.d_alpha[None, :] * (b.length / b.n_axial) * np.ones_like(frame.groove, float)
    area = cells[frame.groove].sum()
    cell_w, cell_h = b.radius * 2 * math.pi / b.n_circumferential, b.length / b.n_axial  # a nominal cell
    assert abs(area - b.groove_length * b.groove_width) < cell_w * b.groove_width + cell_h * b.groove_length


def test_fields_on_a_uniform_grid_keep_each_column_at_its_width():
    b, load = _setup()
    frame, _ = supply_frame(b, OMEGA, load, 400 / MLMIN_PER_M3S)
    assert frame.d_alpha.max() > 1.5 * frame.d_alpha.min()  # the groove's columns are refined
    alpha, p = frame.on_uniform_grid(frame.pressure)
    np.testing.assert_allclose(np.diff(alpha), alpha[1] - alpha[0], rtol=1e-9, atol=1e-12)
    assert alpha[-1] - alpha[0] + (alpha[1] - alpha[0]) == pytest.approx(2 * math.pi)
    # every uniform pixel shows the cell its centre lies in, and integrals are unchanged
    edges = frame.alpha - 0.5 * frame.d_alpha
    cell = np.searchsorted(edges, alpha, side="right") - 1
    np.testing.assert_array_equal(p, frame.pressure[:, cell])
    np.testing.assert_allclose((p.sum(axis=1) * (alpha[1] - alpha[0])),
                               (frame.pressure * frame.d_alpha).sum(axis=1), rtol=1e-12)


def test_starving_the_bearing_raises_the_eccentricity_and_shrinks_the_full_film():
    b, load = _setup()
    frames = supply_frames(b, OMEGA, load, np.array([250.0, 400.0, 550.0, 800.0]) / MLMIN_PER_M3S)
    qs = sorted(frames)
    ecc = [frames[q].eccentricity_ratio for q in qs]
    full = [((frames[q].theta >= 1.0) * frames[q].d_alpha).sum() for q in qs]  # full-film area
    assert all(a > b for a, b in zip(ecc, ecc[1:]))
    assert full[0] < full[-1]
    # The half-Sommerfeld comparison is the same shape of film whatever the supply: it peaks in the
    # loaded half and is never negative.
    for q in qs:
        assert frames[q].half_sommerfeld.min() >= 0.0 and frames[q].half_sommerfeld.max() > 0.0
