"""Node scans: an effect that acts at a place (a second unbalance, a bow) fitted at every node where it can act.

A record at one or two planes often cannot say where along the shaft a 1X force sits: near a mode's antinode the
response barely changes from one node to the next, and a fit at the node a library happens to list would name a
place the record does not support (issue 36: second unbalances at nodes 4 and 8 named at 10 or 15). So each
node where the effect can act (`Effect.scan_nodes`) is fitted, the nodes warm-started from their neighbour's
answer (the profile is smooth in the node), and the profile of the fit's chi2 over the nodes is kept. The nodes
whose best fit lies within SCAN_DCHI2 of the best node's (chi2 with 1 dof at 95 %: the place is one more unknown)
fit the record as well; when they reach beyond the best node's neighbours, the verdict says the location is not
identifiable from this record and which nodes fit.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from ..effects import EFFECTS

SCAN_DCHI2 = 3.84  # chi2 quantile, 1 dof, 95 %
SPIKE, SPIKE_DCHI2 = 3.0, 10 * SCAN_DCHI2  # a node this much worse than both neighbours is fitted from its own starts
PICTURED = 2  # the nodes the linear picture ranks best that a scan fits from their own starts (`_pictured_nodes`)
SCREEN_STRIDE = 2  # a diagnosis screens a scanned effect at every 2nd node (and the last); the effects its verdict
# names or keeps in an ambiguity are then fitted at every node: the profile the verdict quotes is whole


@dataclass(frozen=True)
class NodeScan:
    """The profile of one effect's fit over the nodes where it can act."""

    effect_name: str
    nodes: tuple[int, ...]
    chi2: tuple[float, ...]  # of each node's fit (inf: no fit there)
    family: str = ""  # the candidates' label without the node (`family`): one effect may be scanned in two forms

    @property
    def best(self) -> int:
        return self.nodes[min(range(len(self.nodes)), key=lambda i: self.chi2[i])]

    @property
    def fitting(self) -> tuple[int, ...]:
        """The nodes whose fit is within SCAN_DCHI2 of the best one's."""
        low = min(self.chi2)
        return tuple(n for n, c in zip(self.nodes, self.chi2) if c - low <= SCAN_DCHI2)

    @property
    def identifiable(self) -> bool:
        """Whether the nodes that fit are the best one and its neighbours at most."""
        return all(abs(n - self.best) <= 1 for n in self.fitting)

    def words(self) -> str:
        """Where the effect acts, as far as this record says."""
        fit = _ranges(self.fitting)
        kind = EFFECTS[self.effect_name].kind() if self.effect_name in EFFECTS else self.effect_name
        if self.family and self.family != self.effect_name:  # 'a static side load (direction fitted)'
            kind += f" ({self.family.split('[', 1)[1].rstrip(']').replace('=', ' ').replace('_deg', '')})"
        if self.identifiable:
            return (f"{kind} fits best at node {self.best} (nodes {fit} within chi2 + {SCAN_DCHI2:g} of "
                    "it)")
        return (f"the location of {kind} is not identifiable from this record: node {self.best} fits "
                f"best, but nodes {fit} fit as well (within chi2 + {SCAN_DCHI2:g}) of the {len(self.nodes)} where it "
                "can act")

    def as_dict(self) -> dict:
        return {"effect": self.effect_name, "family": self.family or self.effect_name, "nodes": list(self.nodes),
                "chi2": [None if not math.isfinite(c) else c for c in self.chi2], "best_node": self.best,
                "fitting_nodes": list(self.fitting), "identifiable": self.identifiable, "delta_chi2": SCAN_DCHI2}


def family(label: str) -> str:
    """A candidate's label without its node: 'side_load[node=5,direction=fitted]' -> 'side_load[direction=fitted]',
    'unbalance2[node=3]' -> 'unbalance2' (the sweep a scanned candidate belongs to)."""
    out = re.sub(r"node=[^,\]]*,?", "", label.strip()).replace(",]", "]")
    return out[:-2] if out.endswith("[]") else out


def _ranges(nodes) -> str:
    """'4-8, 12' for (4, 5, 6, 7, 8, 12)."""
    out, run = [], []
    for n in sorted(nodes):
        if run and n != run[-1] + 1:
            out.append(run)
            run = []
        run.append(n)
    if run:
        out.append(run)
    return ", ".join(f"{r[0]}-{r[-1]}" if len(r) > 1 else f"{r[0]}" for r in out)


class NodeSweep:
    """The fits of one effect over the nodes where it can act, made as they are asked for (`run`): each node
    refined from its nearest fitted neighbour's answer (the profile is smooth in the node), the first from its
    own starts; a node that fits worse than a neighbour by more than SCAN_DCHI2 (a warm start that strayed into
    a poorer basin) again from that neighbour's answer; the best node again from its own starts.

    `fit_one(effect, start, screening)`: a `Candidate` (start None: its own starts; `screening`: the fit that only
    ranks, `identify.fit.least_squares.fit`). A profile the verdict quotes is made with full fits: a screening
    fit stops early, and a node it leaves short of its optimum would look like a node that does not fit."""

    def __init__(self, effects, fit_one, progress=lambda name: None, picture=None):
        self.effects = list(effects)  # one effect at each node, in node order
        self.fit_one = fit_one
        self.progress = progress
        self.picture = picture  # effects -> the chi2 the linear picture leaves at each (`pairs.node_picture`)
        self._pictured = None
        self.found: dict = {True: {}, False: {}}  # screening -> {index: Candidate}
        self.own: dict = {True: set(), False: set()}  # screening -> indices fitted from their own starts

    def _fit(self, i, start, screening):
        self.progress(self.effects[i].title())
        c = self.fit_one(self.effects[i], start, screening)
        found = self.found[screening]
        if start is None:
            self.own[screening].add(i)
        if i not in found or c.aic < found[i].aic:
            found[i] = c

    def _own_started(self) -> set:
        """The nodes fitted from their own starts in either pass: a node's fit in one pass starts from the other's
        answer there too (`_starts`), so the full pass need not search again where the screening one did (the fan's
        complete scans: ~0.5 s of a diagnosis, session 52)."""
        return self.own[True] | self.own[False]

    def _values(self, i, screening):
        c = self.found[screening].get(i)
        return None if c is None or c.fit is None else c.fit.values

    def _starts(self, i, screening):
        """Where node i's fit starts: the answers of its nearest fitted neighbour on each side in this pass and of
        the node itself and its neighbours in the other (`fit` refines the one the model fits best there), or None
        (its own starts). A force's size that a node barely feels is a long flat valley: the answer one node
        further on can be far from the next node's (a side load on the fan carried from node 5 to 6, beside a
        support: chi2 6 after 200 steps, 0.14 from its screening answer at node 7)."""
        near = [j for j in self.found[screening] if self._values(j, screening) is not None]
        picks = [min((j for j in near if j < i), key=lambda j: i - j, default=None),
                 min((j for j in near if j > i), key=lambda j: j - i, default=None)]
        rows = [self._values(j, screening) for j in picks if j is not None]
        rows += [self._values(j, not screening) for j in (i, i - 1, i + 1)]
        rows = [r for r in rows if r is not None]
        return np.array(rows) if rows else None

    def _pictured_nodes(self, keep, screening) -> list:
        """`keep` and the PICTURED nodes the linear picture (`picture`) ranks best, each fitted from its own starts
        where the picture says it would fit better than the best node found by more than SCAN_DCHI2. Warm starts
        carried from node to node can all stay in a poorer basin, and the nodes between those screened are not
        fitted at all: a second unbalance at the fan's node 4 (chi2 2.0 from its own starts, 5.2 at node 5) was
        scanned to node 1 at 21.6, and the record named a bow (the fan's loop, case 96, session 63). Only where no
        node found passes the fit's test: elsewhere the picture (~0.2 s of a fan's diagnosis) would change nothing."""
        found = self.found[screening]
        if self.picture is None or any(getattr(found[i], "passes", False) for i in keep):
            return keep  # a node found already explains the record: the picture would change no verdict
        if self._pictured is None:
            self._pictured = np.asarray(self.picture(self.effects), dtype=float)
        low = min(found[i].fit.chi2 for i in keep if found[i].fit is not None) if any(
            found[i].fit is not None for i in keep) else math.inf
        order = [i for i in np.argsort(self._pictured, kind="stable") if math.isfinite(self._pictured[i])]
        added = []
        for i in order[:PICTURED]:
            i = int(i)
            if self._pictured[i] + SCAN_DCHI2 >= low:
                break
            if i not in self._own_started():
                self._fit(i, None, screening)
            added.append(i)
        return sorted(set(keep) | set(added))

    def _lift_spikes(self, keep, screening) -> None:
        """A node that fits far worse than both its neighbours (SPIKE x their chi2 and SPIKE_DCHI2 more), after both
        their answers were tried there, sits in a basin of its own: it is fitted from its own starts. The profile is
        smooth in the node (a side load on the fan between nodes 17 at chi2 305 and 21 at 82 left node 19 at 4596,
        where its own starts find 5.0 and the truth, node 18, sits: the loop's case 168, session 57). After the gaps
        (`_reach_gaps`): node 21 was at 3741 before its own starts there."""
        found = self.found[screening]
        for a, i, b in zip(keep, keep[1:], keep[2:]):
            if i in self._own_started() or found[i].fit is None:
                continue
            near = max(found[a].aic, found[b].aic)
            if math.isfinite(near) and found[i].aic > SPIKE * near and found[i].aic > near + SPIKE_DCHI2:
                self._fit(i, None, screening)

    def _reach_gaps(self, keep, screening) -> None:
        """A run of nodes that do not fit may be warm starts that could not cross a node where the effect can do
        little (its size at its bound): the run's middle node is fitted from its own starts, and a fit found there
        is carried to the run's other nodes. A node the profile says does not fit has then been tried from its
        own starts or from a neighbour that fits."""
        found = self.found[screening]
        for _ in range(len(keep)):
            low = min(found[i].aic for i in keep)
            runs, run = [], []
            for i in keep:
                if found[i].aic > low + SCAN_DCHI2:
                    run.append(i)
                elif run:
                    runs.append(run)
                    run = []
            if run:
                runs.append(run)
            todo = [r for r in runs if r[len(r) // 2] not in self._own_started()]
            if not todo:
                return
            for r in todo:
                mid = r[len(r) // 2]
                self._fit(mid, None, screening)
                if found[mid].aic <= low + SCAN_DCHI2:
                    at = r.index(mid)
                    for order in (r[at + 1:], r[:at][::-1]):
                        prev = mid
                        for i in order:
                            self._fit(i, self._values(prev, screening), screening)
                            prev = i

    def run(self, stride: int = 1, screening: bool = True):
        """(the best node's candidate, NodeScan) over every `stride`-th node and the last."""
        n = len(self.effects)
        keep = sorted(set(range(0, n, max(1, int(stride)))) | {n - 1})
        found = self.found[screening]
        other = self.found[not screening]
        seed = min(other, key=lambda i: other[i].aic) if other else keep[0]  # outwards from the best node known
        for i in sorted(keep, key=lambda i: (abs(i - seed), i)):
            if i in found:
                continue
            self._fit(i, self._starts(i, screening), screening)
        for order in (keep, keep[::-1]):
            for a, b in zip(order, order[1:]):
                if self._values(a, screening) is not None and found[b].aic > found[a].aic + SCAN_DCHI2:
                    self._fit(b, self._values(a, screening), screening)
        best = min(keep, key=lambda i: found[i].aic)
        if math.isfinite(found[best].aic) and best not in self._own_started():
            self._fit(best, None, screening)
        self._reach_gaps(keep, screening)
        self._lift_spikes(keep, screening)
        keep = self._pictured_nodes(keep, screening)
        best = min(keep, key=lambda i: found[i].aic)
        nodes = tuple(int(self.effects[i].node) for i in keep)
        chi2 = tuple(found[i].fit.chi2 if found[i].fit is not None else math.inf for i in keep)
        return found[best], NodeScan(self.effects[0].effect_name, nodes, chi2, family(self.effects[0].label()))
