"""Directional (full-spectrum) view of a synchronous orbit: Eq. 10 and SPEC §1.

For x(t) = Re(X e^{iwt}), y(t) = Re(Y e^{iwt}) the complex signal Z = x + i y (Eq. 10) is

    Z = (X e^{iwt} + conj(X) e^{-iwt})/2 + i (Y e^{iwt} + conj(Y) e^{-iwt})/2
      = Zf e^{iwt} + Zb e^{-iwt},   Zf = (X + iY)/2,   Zb = (conj(X) + i conj(Y))/2 = conj((X - iY)/2).

With Zf = |Zf| e^{ia}, Zb = |Zb| e^{ib}: Z = e^{i(a+b)/2} (|Zf| e^{i(wt+(a-b)/2)} + |Zb| e^{-i(wt+(a-b)/2)}),
an ellipse with semi-axes |Zf| + |Zb| and ||Zf| - |Zb|| whose major axis is inclined by (a + b)/2.
"""

from __future__ import annotations

import numpy as np


def directional_components(x_amp, y_amp):
    """(Zf, Zb): forward and backward phasors of the orbit with complex amplitudes X, Y."""
    x_amp, y_amp = np.asarray(x_amp), np.asarray(y_amp)
    return 0.5 * (x_amp + 1j * y_amp), np.conj(0.5 * (x_amp - 1j * y_amp))


def forward_backward_ratio(zf, zb):
    """fb = |Zf| / |Zb| (inf for a circular forward orbit)."""
    with np.errstate(divide="ignore"):
        return np.abs(zf) / np.abs(zb)


def orbit_angle(zf, zb):
    """Inclination of the orbit's major axis, phi = (arg Zf + arg Zb)/2, on the branch (-pi/2, pi/2] (rad)."""
    phi = 0.5 * (np.angle(zf) + np.angle(zb))
    phi = phi - np.pi * np.round(phi / np.pi)  # [-pi/2, pi/2]
    return np.where(phi <= -0.5 * np.pi, phi + np.pi, phi)


def unwrap_orbit_angle(phi, axis: int = -1):
    """Unwrap an orbit angle along a sweep; the angle is defined modulo pi (SPEC §1)."""
    return 0.5 * np.unwrap(2.0 * np.asarray(phi), axis=axis)
