"""Synthetic records made as the paper makes them: time and frequency domain agree, files round-trip."""

import numpy as np
import pytest

from lubeviz.errors import InputError
from lubeviz.rotor.film_bearings import film_bearings, machine_response
from lubeviz.signals import record_features, write_record
from lubeviz.signals.synthesize import synthesize_record
from lubeviz.units import MLMIN_PER_M3S
from tests.records import read_record

FLOWS = (450 / MLMIN_PER_M3S, 600 / MLMIN_PER_M3S)


@pytest.fixture(scope="module")
def bearings(machine):
    return film_bearings(machine, FLOWS)


def test_time_simulated_record_has_the_steady_state_features(machine, bearings):
    rec = synthesize_record(machine, FLOWS, snr_db=None, bearings=bearings)
    assert rec.n_samples == 50_000 and rec.duration == pytest.approx(5.0) and rec.t[0] == pytest.approx(10.0001)
    freq, _ = machine_response(machine, FLOWS, nodes=(6, 20), bearings=bearings)
    f = record_features(rec)
    assert np.allclose([p.fb for p in f.planes], freq.fb, rtol=1e-6)
    assert np.allclose([p.phi for p in f.planes], freq.phi, atol=1e-6)
    steady = record_features(synthesize_record(machine, FLOWS, snr_db=None, bearings=bearings, method="steady"))
    assert np.allclose(steady.vector(), f.vector(), rtol=1e-6, atol=1e-9)


def test_noisy_records_are_seeded_and_within_their_own_uncertainty(machine, bearings):
    a = synthesize_record(machine, FLOWS, rng=np.random.default_rng(5), bearings=bearings, method="steady")
    b = synthesize_record(machine, FLOWS, rng=np.random.default_rng(5), bearings=bearings, method="steady")
    c = synthesize_record(machine, FLOWS, rng=np.random.default_rng(6), bearings=bearings, method="steady")
    assert np.array_equal(a.displacement, b.displacement) and not np.array_equal(a.displacement, c.displacement)
    clean = record_features(synthesize_record(machine, FLOWS, snr_db=None, bearings=bearings, method="steady"))
    noisy = record_features(a)
    assert np.all(np.abs(noisy.vector() - clean.vector()) < 5 * noisy.std())
    with pytest.raises(InputError, match="rng"):
        synthesize_record(machine, FLOWS, bearings=bearings)


@pytest.mark.parametrize("suffix", [".csv", ".npz", ".mat"])
def test_records_round_trip_through_files_with_their_features(machine, bearings, tmp_path, suffix):
    rec = synthesize_record(machine, FLOWS, rng=np.random.default_rng(1), bearings=bearings, method="steady",
                            duration_s=1.0)
    path = write_record(rec, tmp_path / f"rec{suffix}")
    back = read_record(path)
    assert np.array_equal(back.displacement, rec.displacement)
    assert back.metadata["q1_mlmin"] == "450" and back.nodes == (6, 20)
    assert np.allclose(record_features(back).vector(), record_features(rec).vector(), rtol=1e-12)
