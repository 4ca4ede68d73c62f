"""The fan (models/three_bearing_fan.toml) and its bearings' Q_T at its operating speed, for the effects tests on a
shaft held at three or more places; `quiet` runs a call without its notices (the statics' sideways-lean one)."""

import warnings

import pytest

from lubeviz.model.files import load_machine
from lubeviz.verification.independent import thresholds_mlmin

FAN = "models/three_bearing_fan.toml"
MESH = (80, 40)  # the independent films' mesh in these tests' statics (tests/effects/test_misalignment.py)


def quiet(fn, *args, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return fn(*args, **kw)


@pytest.fixture(scope="module")
def fan():
    return load_machine(FAN)


@pytest.fixture(scope="module")
def qt(fan):
    return quiet(thresholds_mlmin, fan.operating_speed, FAN)
