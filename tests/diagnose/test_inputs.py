"""What a diagnosis starts from (`diagnose.inputs`): the CLI and the Diagnose page read a record the same
way — its oil temperature held with the reading's tolerance in the budget, its lines beyond 1X, its notes."""

import copy
import dataclasses

import numpy as np
import pytest

from lubeviz.diagnose.inputs import diagnosis_inputs
from lubeviz.identify.forward.chain import ForwardChain, simulate
from lubeviz.units import MLMIN_PER_M3S


@pytest.fixture(scope="module")
def record(machine):
    chain = ForwardChain(machine, machine.operating_speed, machine.center_nodes)
    return simulate(chain, np.array([450.0, 600.0]) / MLMIN_PER_M3S, rng=np.random.default_rng(3))


def test_a_temperature_reading_is_held_and_widens_the_viscosity_budget(machine, record):
    read = dataclasses.replace(record, oil_temperature_c=45.0)
    inputs = diagnosis_inputs([read], machine)
    (chain,) = inputs.chains
    held = [e for e in chain.effects if e.effect_name == "oil_temperature"]
    assert len(held) == 1 and held[0].temperature_c == pytest.approx(45.0)
    assert "oil_temperature.temperature_c" not in chain.names  # held, not fitted
    # the reading's 1 K, through the oil's Walther law: |d ln mu / dT| x 1 K, a few % for a VG 100 oil
    slope = abs(np.log(machine.oil.factor(45.5) / machine.oil.factor(44.5)))
    assert inputs.budget.viscosity == pytest.approx(slope, rel=0.05)
    assert 0.02 < inputs.budget.viscosity < 0.08
    assert inputs.notes == ()


def test_without_a_reading_nothing_is_held_and_the_budget_is_the_default(machine, record):
    inputs = diagnosis_inputs([record], machine)
    assert inputs.chains[0].effects == () and inputs.budget is None
    assert inputs.lines == ()  # the linear model's own record has no line beyond 1X


def test_a_reading_without_a_declared_oil_is_not_used_and_says_so(machine, record):
    no_oil = copy.deepcopy(machine)
    no_oil.oil = None
    inputs = diagnosis_inputs([dataclasses.replace(record, oil_temperature_c=45.0)], no_oil)
    assert inputs.chains[0].effects == () and inputs.budget is None
    assert any("45" in n and "not used" in n for n in inputs.notes)
