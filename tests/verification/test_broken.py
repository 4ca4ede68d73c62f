"""The broken-record bench's column operations (written by hand) against the effect library's `wiring`
(written apart): the same mix-up of the same record, for every fault the library knows."""

import numpy as np
import pytest

from lubeviz.effects import parse_effect
from lubeviz.effects.wiring import FAULTS
from lubeviz.identify.forward.chain import ForwardChain, simulate
from lubeviz.verification.broken import KINDS, broken_record
from lubeviz.units import MLMIN_PER_M3S

Q = np.array([480.0, 560.0]) / MLMIN_PER_M3S


@pytest.mark.parametrize("fault", sorted(FAULTS))
def test_the_benchs_mix_up_is_the_librarys(machine, fault):
    chain = ForwardChain(machine, 75.0, (6, 20))
    clean = simulate(chain, Q, snr_db=None, duration_s=0.2)
    mixed = simulate(chain.adding(parse_effect(f"wiring:fault={fault}")), Q, snr_db=None, duration_s=0.2)
    rec, expect = broken_record(clean.displacement.reshape(4, -1), 75.0, clean.sample_rate_hz, fault,
                                np.random.default_rng(0), nodes=clean.nodes)
    assert expect == {"wiring": fault}
    np.testing.assert_allclose(rec.displacement, mixed.displacement, atol=1e-12 * np.abs(clean.displacement).max())


def test_every_break_is_made_and_says_what_to_expect(machine):
    chain = ForwardChain(machine, 75.0, (6, 20))
    clean = simulate(chain, Q, snr_db=30.0, rng=np.random.default_rng(1), duration_s=0.5)
    for kind in KINDS:
        rec, expect = broken_record(clean.displacement.reshape(4, -1), 75.0, clean.sample_rate_hz, kind,
                                    np.random.default_rng(2), nodes=clean.nodes)
        assert (expect == {}) == (kind == "none")
        assert rec.displacement.shape == clean.displacement.shape
