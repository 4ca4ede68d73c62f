"""The suite's memo of time integrations (`tests/memo.py`) keys its inputs so that the key holds on another host: the
seeded integrations were all run again on a CPU whose BLAS moved the films' numbers by ~1e-14 (session 60), and again
on one whose fresh install moved them by ~1e-11 (session 66)."""

import dataclasses

import numpy as np

from tests.memo import _key


@dataclasses.dataclass(frozen=True)
class _Film:
    position: np.ndarray
    pressure: np.ndarray
    eccentricity: float
    nodes: tuple


def _inputs(rng, nudge: float = 0.0):
    film = _Film(position=np.array([1e-20, -7.4e-6]), pressure=rng.normal(size=(40, 30)) ** 2 * 1e6,
                 eccentricity=0.6123456789012, nodes=(6, 20))
    k = rng.normal(size=(12, 12)) + 1j * rng.normal(size=(12, 12))
    if nudge:
        film = dataclasses.replace(film, position=film.position * (1 + nudge) * np.array([-1.0, 1.0]),
                                   pressure=film.pressure * (1 + nudge), eccentricity=film.eccentricity * (1 + nudge))
        k = k * (1 + nudge)
    return (film, k), {"dt": 1e-5, "revolutions": 40, "progress": print}


def test_a_memo_s_key_holds_under_a_host_s_last_bits_and_moves_with_the_inputs():
    args, kwargs = _inputs(np.random.default_rng(1))
    key = _key(args, kwargs)
    # a few ulps, the sign of a number that is zero but for noise, and the ~1e-11 another host's films differ by
    for nudge in (2.2e-16, -6.6e-15, 4e-14, 2e-11, -3e-11):
        assert _key(*_inputs(np.random.default_rng(1), nudge)) == key
    (film, k), kw = _inputs(np.random.default_rng(1))
    pressure = film.pressure.copy()
    pressure[3, 4] *= 1 + 1e-2  # one entry of 1200 by a percent (the field's sum by ~1e-5)
    assert _key((dataclasses.replace(film, pressure=pressure), k), kw) != key
    assert _key((dataclasses.replace(film, pressure=film.pressure.T.copy().T[::-1].copy()), k), kw) != key
    assert _key((dataclasses.replace(film, nodes=(6, 21)), k), kw) != key
    assert _key((film, k), {**kw, "dt": 2e-5}) != key
    assert _key((film, k), {**kw, "progress": None}) == key  # a callback is not an input
