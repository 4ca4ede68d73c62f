"""A measurement mixed up on its way from the probes to the record's columns."""

from __future__ import annotations

import re

import numpy as np
import param

from ..errors import InputError
from .base import Effect, register

# each fault as a permutation and signs of the 2P channels x1, y1, ..., xP, yP (probe a and b of each plane): column
# i of the record holds sign[i] x channel source[i]. Two planes' faults keep the paper's names (FAULTS); a record of
# P planes has every pair of planes exchanged (`planes{i}_{j}_swapped`; with two planes, `planes_swapped`), every
# plane's probes exchanged at once (`x_y_swapped`) or one plane's (`x{k}_y{k}_swapped`), a probe's polarity reversed
# (`x{k}_inverted`, `y{k}_inverted`) or both of a plane's (`plane{k}_inverted`): `fault_names(P)`.
MAX_WIRED_PLANES = 12  # as a record (lubeviz.signals.records.MAX_PLANES)


def fault_names(n_planes: int) -> list[str]:
    """Every mix-up of a record of `n_planes` planes, the two-plane names first in the paper's order."""
    pairs = [(i, j) for i in range(1, n_planes + 1) for j in range(i + 1, n_planes + 1)]
    out = ["planes_swapped" if n_planes == 2 else f"planes{i}_{j}_swapped" for i, j in pairs]
    out.append("x_y_swapped")
    out += [f"x{k}_y{k}_swapped" for k in range(1, n_planes + 1)]
    out += [f"{a}{k}_inverted" for k in range(1, n_planes + 1) for a in "xy"]
    out += [f"plane{k}_inverted" for k in range(1, n_planes + 1)]
    return out


def fault_map(fault: str, n_planes: int) -> tuple[tuple[int, ...], tuple[int, ...]]:
    """(source, sign) of `fault` on a record of `n_planes` planes; ValueError for a fault that record cannot have."""
    n = 2 * n_planes
    source, sign = list(range(n)), [1] * n
    if fault not in fault_names(n_planes):
        raise ValueError(f"wiring fault {fault!r}: a record of {n_planes} planes has "
                         + ", ".join(fault_names(n_planes)))
    if fault == "planes_swapped":
        fault = "planes1_2_swapped"
    if (m := re.fullmatch(r"planes(\d+)_(\d+)_swapped", fault)):
        i, j = int(m[1]) - 1, int(m[2]) - 1
        source[2 * i:2 * i + 2], source[2 * j:2 * j + 2] = [2 * j, 2 * j + 1], [2 * i, 2 * i + 1]
    elif fault == "x_y_swapped":
        source = [c ^ 1 for c in range(n)]
    elif (m := re.fullmatch(r"x(\d+)_y\1_swapped", fault)):
        k = int(m[1]) - 1
        source[2 * k], source[2 * k + 1] = 2 * k + 1, 2 * k
    elif (m := re.fullmatch(r"([xy])(\d+)_inverted", fault)):
        sign[2 * (int(m[2]) - 1) + "xy".index(m[1])] = -1
    elif (m := re.fullmatch(r"plane(\d+)_inverted", fault)):
        k = int(m[1]) - 1
        sign[2 * k] = sign[2 * k + 1] = -1
    return tuple(source), tuple(sign)


FAULTS = {name: fault_map(name, 2) for name in fault_names(2)}  # a two-plane record's (the paper's)


def fault_words(fault: str) -> str:
    """What `fault` means, in words."""
    if fault == "planes_swapped":
        return "the two planes' columns (or their node numbers) exchanged"
    if (m := re.fullmatch(r"planes(\d+)_(\d+)_swapped", fault)):
        return f"planes {m[1]} and {m[2]}'s columns (or their node numbers) exchanged"
    if fault == "x_y_swapped":
        return "every plane's two probes exchanged (columns in the order y, x)"
    if (m := re.fullmatch(r"x(\d+)_y\1_swapped", fault)):
        return f"plane {m[1]}'s two probes exchanged"
    if (m := re.fullmatch(r"([xy]\d+)_inverted", fault)):
        return f"probe {m[1]}'s polarity reversed"
    if (m := re.fullmatch(r"plane(\d+)_inverted", fault)):
        return f"both probes of plane {m[1]} reversed"
    return fault


def wiring_matrix(fault: str, n_planes: int = 2) -> np.ndarray:
    """(2P, 2P) matrix W with record columns = W @ channels (x1, y1, ..., xP, yP as the probes read them)."""
    source, sign = fault_map(fault, n_planes)
    n = 2 * n_planes
    W = np.zeros((n, n))
    W[np.arange(n), source] = sign
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
    kind_words = "a wiring mix-up"
    stage = "probes"
    continuous = ()
    placement = ("fault",)
    separated_by = "checking the channel map and the probes' polarity (a record of a known orbit, or a trial weight)"

    fault = param.Selector(default="planes_swapped",
                           objects=list(dict.fromkeys(n for p in range(2, MAX_WIRED_PLANES + 1) for n in fault_names(p))),
                           doc="The mix-up: planes exchanged, a plane's probes exchanged, or a probe's polarity reversed "
                               "(a record of P planes has `fault_names(P)`)")

    def rewire(self, d, static, probe_angles_deg):
        """The readings `d` (..., P planes, [x, y]) and static offsets (..., P, 2) as the mixed-up columns
        resolve them with the declared probe angles."""
        n = 2 * len(probe_angles_deg)
        P = np.zeros((n, n))
        for k, (a, b) in enumerate(probe_angles_deg):
            ra, rb = np.radians(a), np.radians(b)
            P[2 * k:2 * k + 2, 2 * k:2 * k + 2] = [[np.cos(ra), np.sin(ra)], [np.cos(rb), np.sin(rb)]]
        try:
            W = wiring_matrix(self.fault, n // 2)
        except ValueError as exc:
            raise InputError(f"effect {self.label()}: {exc}") from None
        M = np.linalg.inv(P) @ W @ P

        def apply(v):
            flat = v.reshape(v.shape[:-2] + (n,))
            return np.einsum("ij,...j->...i", M, flat).reshape(v.shape)

        return apply(d), (None if static is None else apply(static))

    def demo(self, machine) -> "Wiring":
        """On the pages: the mix-ups of the machine's own planes to choose from, the first of them shown."""
        names = fault_names(max(2, len(machine.measurement_planes)))
        new = self.copy(fault=self.fault if self.fault in names else names[0])
        new.param.fault.objects = names
        return new.bind(machine)

    def placements(self, *, n_planes: int, n_bearings: int, n_supports: int = 0):
        """Every mix-up of a record of `n_planes` planes (`fault_names`)."""
        return [self.copy(fault=f) for f in fault_names(n_planes)]

    def summary(self) -> str:
        return f"a measurement mix-up: {fault_words(self.fault)}"

    def title(self) -> str:
        return f"a wiring mix-up: {fault_words(self.fault)}"

    def told(self, std: dict | None = None, machine=None) -> str:
        return f"The record's columns are not the channels they are declared to be: {fault_words(self.fault)}."
