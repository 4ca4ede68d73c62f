import os

# One BLAS thread per process, as `lubeviz/__init__.py` sets when it is imported before numpy; here numpy comes
# first (this file imports it before lubeviz), and under xdist two workers with two BLAS threads each
# oversubscribed the two cores (a 128 x 128 complex determinant took 95 ms instead of 0.4 ms).
for _var in ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "OMP_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import math

import numpy as np
import pytest

from lubeviz.film.equilibrium import find_equilibrium
from lubeviz.film.feed import Feed
from lubeviz.model.bearing import Bearing
from lubeviz.model.machine import load_machine

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
