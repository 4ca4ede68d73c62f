"""Fixtures shared by the identification tests."""

import pytest

from lubeviz.identify.tables import dimensionless


@pytest.fixture
def builds(monkeypatch):
    """Counts calls of dimensionless.build_slice (the in-process builder the cache uses), by slice S."""
    calls = []
    original = dimensionless.build_slice

    def counting(*args, **kwargs):
        calls.append(args[1])
        return original(*args, **kwargs)

    monkeypatch.setattr(dimensionless, "build_slice", counting)
    return calls
