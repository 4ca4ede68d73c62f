"""The oil's viscosity-temperature law, the model file's [oil], the oil_temperature effect and a record's
oil temperature reading (what separates hotter oil from less oil on one record)."""

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from lubeviz.effects import EFFECTS, parse_effect
from lubeviz.errors import DataFormatError, InputError, ModelFileError
from lubeviz.identify.tables.cache import machine_tables
from lubeviz.identify.forward.chain import ForwardChain
from lubeviz.model.machine import DEFAULT_MACHINE, load_machine
from lubeviz.model.oil import ISO_VG_NU100_CST, Oil, walther_nu_cst
from lubeviz.signals.records import write_record
from lubeviz.units import MLMIN_PER_M3S
from tests.records import read_record, record_from_arrays

Q = np.array([420.0, 600.0]) / MLMIN_PER_M3S
FEATURES = ("fb1", "fb2", "phi1", "phi2", "log_zf_ratio", "arg_zf_ratio")


def _machine_file(tmp_path, oil_text):
    """The paper's machine file with its [oil] table replaced by `oil_text` ('' removes it)."""
    text = Path(DEFAULT_MACHINE).read_text()
    start = text.index("[oil]")
    end = text.index("[measurement]")
    path = tmp_path / "m.toml"
    path.write_text(text[:start] + oil_text + "\n" + text[end:])
    return path


# --- the law ------------------------------------------------------------------------------------------

@pytest.mark.parametrize("vg", [22, 68, 100, 320])
def test_walther_passes_through_its_two_points_and_is_straight_in_loglog_vs_log_t(vg):
    nu100 = ISO_VG_NU100_CST[vg]
    assert walther_nu_cst(40.0, vg, nu100) == pytest.approx(vg, rel=1e-12)
    assert walther_nu_cst(100.0, vg, nu100) == pytest.approx(nu100, rel=1e-12)
    t = np.array([0.0, 25.0, 60.0, 80.0, 130.0])
    ll = np.log10(np.log10(walther_nu_cst(t, vg, nu100) + 0.7))
    slope = np.diff(ll) / np.diff(np.log10(t + 273.15))
    assert np.allclose(slope, slope[0], rtol=1e-10)  # ASTM D341: a straight line on its chart
    assert np.all(np.diff(walther_nu_cst(t, vg, nu100)) < 0)  # thins when heated


def test_dynamic_viscosity_is_density_times_kinematic_and_the_factor_inverts():
    oil = Oil(nu40_cst=100.0, nu100_cst=11.3, density_15c=870.0, temperature_c=40.0)
    assert oil.dynamic_viscosity(40.0) == pytest.approx(100e-6 * 870.0 * (1 - 6.5e-4 * 25.0), rel=1e-12)
    assert oil.factor(40.0) == pytest.approx(1.0)
    for f in (0.5, 0.75, 1.0, 1.6):
        assert oil.factor(oil.temperature_for_factor(f)) == pytest.approx(f, rel=1e-9)
    # a VG 100 oil keeps roughly 40 % of its viscosity from 40 to 60 °C (charts: 100 -> 39-41 cSt)
    assert 0.37 < oil.kinematic_cst(60.0) / 100.0 < 0.43
    with pytest.raises(ValueError, match="must be below"):
        Oil(nu40_cst=10.0, nu100_cst=20.0)


# --- the model file --------------------------------------------------------------------------------------

def test_the_paper_machine_declares_an_oil_consistent_with_its_bearings(machine):
    oil = machine.oil
    assert oil is not None and oil.grade == "ISO VG 100"
    for b in machine.bearings:
        assert float(oil.dynamic_viscosity(oil.temperature_c)) == pytest.approx(b.viscosity, rel=0.01)


@pytest.mark.parametrize("oil_text, fragment", [
    ("[oil]\niso_vg = 90\ntemperature_c = 38.3", "iso_vg: 90 is not an ISO 3448 grade"),
    ("[oil]\niso_vg = 100", "missing key 'temperature_c'"),
    ("[oil]\ntemperature_c = 40.0", "expected iso_vg"),
    ("[oil]\niso_vg = 100\nnu40_cst = 90.0\ntemperature_c = 40.0", "not both"),
    ("[oil]\niso_vg = 100\ntemperature_c = 60.0", "viscosity_pa_s = 0.094"),
    ("[oil]\nnu40_cst = 50.0\nnu100_cst = 80.0\ntemperature_c = 20.0", "must be below"),
    ("[oil]\niso_vg = 100\ntemperatur_c = 38.3", "unknown key"),
])
def test_a_bad_oil_table_is_refused_naming_the_field(tmp_path, oil_text, fragment):
    with pytest.raises(ModelFileError, match=fragment) as info:
        load_machine(_machine_file(tmp_path, oil_text))
    assert "[oil]" in str(info.value)


def test_the_oil_is_optional(tmp_path):
    assert load_machine(_machine_file(tmp_path, "")).oil is None


# --- the effect --------------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def tables(machine):
    return machine_tables(machine)


def test_an_oil_temperature_is_the_viscosity_effect_at_the_walther_factor(machine, tables):
    """Same features as viscosity:factor=mu(T)/mu(declared); at the declared temperature, the plain model."""
    t = 47.0
    hot = ForwardChain(machine, 75.0, (6, 20), (parse_effect(f"oil_temperature:temperature_c={t}"),), tables=tables)
    f = float(machine.oil.factor(t))
    assert 0.6 < f < 0.8
    visc = ForwardChain(machine, 75.0, (6, 20), (parse_effect(f"viscosity:factor={f!r}"),), tables=tables)
    assert np.allclose(hot.features(Q, FEATURES), visc.features(Q, FEATURES), rtol=1e-12, atol=1e-14)
    plain = ForwardChain(machine, 75.0, (6, 20), tables=tables)
    same = ForwardChain(machine, 75.0, (6, 20), (parse_effect(f"oil_temperature:temperature_c={machine.oil.temperature_c}"),),
                        tables=tables)
    assert np.allclose(same.features(Q, FEATURES), plain.features(Q, FEATURES), rtol=1e-12, atol=1e-14)
    assert not np.allclose(hot.features(Q, FEATURES), plain.features(Q, FEATURES), rtol=1e-3)
    # a free temperature starts at the declared one and round-trips through its SPEC §7 text
    free = ForwardChain(machine, 75.0, (6, 20), (parse_effect("oil_temperature"),), tables=tables)
    assert free.names[-1] == "oil_temperature.temperature_c" and free.start()[-1] == machine.oil.temperature_c
    e = parse_effect("oil_temperature:bearing=2,temperature_c=55")
    assert parse_effect(e.spec()).values() == e.values()


def test_an_oil_temperature_needs_a_machine_with_an_oil(tmp_path):
    bare = load_machine(_machine_file(tmp_path, ""))
    with pytest.raises(InputError, match=r"declares no oil.*\[oil\]"):
        ForwardChain(bare, 75.0, (6, 20), (parse_effect("oil_temperature:temperature_c=50"),),
                     tables=machine_tables(bare))


def test_a_diagnosis_does_not_fit_the_oil_temperature_twice():
    assert EFFECTS["oil_temperature"].diagnose_free == () and EFFECTS["viscosity"].diagnose_free == ("factor",)


# --- the record's reading ------------------------------------------------------------------------------------

def _record(**kw):
    t = np.arange(4000) / 1e4
    x = 1e-5 * np.cos(2 * math.pi * 75.0 * t)
    return record_from_arrays(x, 0.9 * x, 1.1 * x, x, speed_hz=75.0, sample_rate_hz=1e4, **kw)


@pytest.mark.parametrize("suffix", [".csv", ".npz", ".mat"])
def test_the_oil_temperature_round_trips_through_every_format(tmp_path, suffix):
    rec = _record(oil_temperature_c=52.5)
    back = read_record(write_record(rec, tmp_path / f"r{suffix}"))
    assert back.oil_temperature_c == 52.5 and back == rec and not back.warnings


@pytest.mark.parametrize("value, fragment", [(330.0, "outside -20..150"), (float("nan"), "not finite"),
                                             ("warm", "not a number")])
def test_a_bad_oil_temperature_is_refused(value, fragment):
    with pytest.raises(DataFormatError, match=f"oil_temperature_c.*{fragment}"):
        _record(oil_temperature_c=value)
