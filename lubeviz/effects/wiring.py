"""A measurement mixed up on its way from the probes to the record's columns."""

from __future__ import annotations

import numpy as np
import param

from .base import Effect, register

# each fault as a permutation and signs of the four channels x1, y1, x2, y2 (probe a and b of each plane):
# column i of the record holds sign[i] x channel source[i]
FAULTS = {
    "planes_swapped": ((2, 3, 0, 1), (1, 1, 1, 1)),  # the planes' columns (or the node numbers) exchanged
    "x_y_swapped": ((1, 0, 3, 2), (1, 1, 1, 1)),  # every plane's two probes exchanged (column order y, x)
    "x1_y1_swapped": ((1, 0, 2, 3), (1, 1, 1, 1)),
    "x2_y2_swapped": ((0, 1, 3, 2), (1, 1, 1, 1)),
    "x1_inverted": ((0, 1, 2, 3), (-1, 1, 1, 1)),  # one probe's polarity reversed (gap vs displacement)
    "y1_inverted": ((0, 1, 2, 3), (1, -1, 1, 1)),
    "x2_inverted": ((0, 1, 2, 3), (1, 1, -1, 1)),
    "y2_inverted": ((0, 1, 2, 3), (1, 1, 1, -1)),
    "plane1_inverted": ((0, 1, 2, 3), (-1, -1, 1, 1)),  # both probes of a plane reversed
    "plane2_inverted": ((0, 1, 2, 3), (1, 1, -1, -1)),
}


WORDS = {
    "planes_swapped": "the two planes' columns (or their node numbers) exchanged",
    "x_y_swapped": "every plane's two probes exchanged (columns in the order y, x)",
    "x1_y1_swapped": "plane 1's two probes exchanged",
    "x2_y2_swapped": "plane 2's two probes exchanged",
    "x1_inverted": "probe x1's polarity reversed", "y1_inverted": "probe y1's polarity reversed",
    "x2_inverted": "probe x2's polarity reversed", "y2_inverted": "probe y2's polarity reversed",
    "plane1_inverted": "both probes of plane 1 reversed", "plane2_inverted": "both probes of plane 2 reversed",
}


def wiring_matrix(fault: str) -> np.ndarray:
    """(4, 4) matrix W with record columns = W @ channels (x1, y1, x2, y2 as the probes read them)."""
    source, sign = FAULTS[fault]
    W = np.zeros((4, 4))
    W[np.arange(4), source] = sign
    return W


@register
class Wiring(Effect):
    """The record's columns are not the channels they are declared to be: `fault` names the mix-up.

    Channels reach a record through cables, a monitoring system's channel map and a spreadsheet: two
    planes' columns (or the node numbers) exchanged, a plane's X and Y probes exchanged, or a probe's
    polarity reversed (a gap signal taken as a displacement) happen often and look like the machine:
    exchanged planes read as exchanged flows, an exchanged or reversed probe mirrors the orbit (forward
    whirl reads backward). The probes' readings r = P d (P: rows along the declared probe directions)
    reach the columns as W r; resolving with the declared angles gives P^-1 W P d. Changes the probes stage,
    after the probes' own errors (rotation, gain). No continuous parameter: a diagnosis tries every fault.
    """

    effect_name = "wiring"
    stage = "probes"
    continuous = ()
    placement = ("fault",)
    separated_by = "checking the channel map and the probes' polarity (a record of a known orbit, or a trial weight)"

    fault = param.Selector(default="planes_swapped", objects=list(FAULTS),
                           doc="The mix-up: planes exchanged, a plane's probes exchanged, or a probe's polarity reversed")

    def rewire(self, d, static, probe_angles_deg):
        """The readings `d` (..., 2 planes, [x, y]) and static offsets (..., 2, 2) as the mixed-up columns
        resolve them with the declared probe angles."""
        P = np.zeros((4, 4))
        for k, (a, b) in enumerate(probe_angles_deg):
            ra, rb = np.radians(a), np.radians(b)
            P[2 * k:2 * k + 2, 2 * k:2 * k + 2] = [[np.cos(ra), np.sin(ra)], [np.cos(rb), np.sin(rb)]]
        M = np.linalg.inv(P) @ wiring_matrix(self.fault) @ P

        def apply(v):
            flat = v.reshape(v.shape[:-2] + (4,))
            return np.einsum("ij,...j->...i", M, flat).reshape(v.shape)

        return apply(d), (None if static is None else apply(static))

    def placements(self, *, n_planes: int, n_bearings: int, n_supports: int = 0):
        """Its mix-ups are those of two planes' four channels (SPEC §6 records): none on another machine's planes."""
        return [self.copy(fault=f) for f in FAULTS] if n_planes == 2 else []

    def summary(self) -> str:
        return f"a measurement mix-up: {WORDS[self.fault]}"
