"""Unit conversions at the edges (SPEC §1).

Everything inside lubeviz is SI. The UI, the CLI and the file readers convert through this module
and nowhere else.
"""

from __future__ import annotations

M3S_PER_MLMIN = 1.0e-6 / 60.0  # 1 ml/min = 1e-6 m^3 / 60 s
MLMIN_PER_M3S = 6.0e7  # its inverse, exact: a flow in m^3/s times this is in ml/min

LENGTH_TO_M = {"m": 1.0, "mm": 1.0e-3, "um": 1.0e-6, "mils": 25.4e-6}


def mlmin_to_m3s(q_mlmin):
    """Oil flow from ml/min to m^3/s."""
    return q_mlmin * M3S_PER_MLMIN


def m3s_to_mlmin(q_m3s):
    """Oil flow from m^3/s to ml/min."""
    return q_m3s / M3S_PER_MLMIN


def mm_to_m(x):
    return x * 1.0e-3


def um_to_m(x):
    return x * 1.0e-6


def m_to_um(x):
    return x * 1.0e6


def length_factor(unit: str) -> float:
    """Metres per one `unit` (m, mm, um or mils); KeyError-free: raises ValueError naming the unit."""
    try:
        return LENGTH_TO_M[unit.strip().lower()]
    except KeyError:
        raise ValueError(
            f"unknown length unit {unit!r}; expected one of {', '.join(LENGTH_TO_M)}"
        ) from None
