"""Package-level contracts: the numerics import without the UI stack; the app page builds."""

import subprocess
import sys

import pytest


def test_numerics_import_without_the_ui_stack():
    code = ("import sys, lubeviz, lubeviz.film.equilibrium, lubeviz.film.sweep, lubeviz.film.explore, "
            "lubeviz.cli.main, lubeviz.bench, lubeviz.identify.maps, lubeviz.identify.batch, "
            "lubeviz.signals.records, lubeviz.signals.synthesize, lubeviz.rotor.stability, lubeviz.effects, "
            "lubeviz.identify.chain, lubeviz.identify.fit, lubeviz.diagnose, lubeviz.diagnose.report, "
            "lubeviz.verification, lubeviz.cli.diagnose_cmd; "
            "bad = [m for m in ('panel', 'bokeh', 'holoviews') if m in sys.modules]; "
            "assert not bad, bad")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr


def test_app_page_builds():
    pytest.importorskip("panel")
    from lubeviz.app.shell import build

    page = build()
    assert page.title.startswith("lubeviz")
    tabs = page.main[0]
    assert [name for name in tabs._names] == ["Start", "Bearing", "Rotor", "Maps", "Identify", "Diagnose"]
