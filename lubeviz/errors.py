"""The package's own exception types: raised where the bad value is first seen."""

from __future__ import annotations


class LubevizError(Exception):
    """Base of every error lubeviz raises on purpose."""


class InputError(LubevizError, ValueError):
    """A value given by the user (API, CLI, UI) is out of its physical or numerical range."""


class ModelFileError(LubevizError, ValueError):
    """A machine model file is missing a field, has a mistyped one, or holds an impossible value."""


class DataFormatError(LubevizError, ValueError):
    """A measured-data record cannot be read or does not hold what SPEC §6 requires."""


class ConvergenceError(LubevizError, RuntimeError):
    """An iterative solve did not reach its tolerance; the message says how far it got."""
