"""Residual -> candidate effects -> the effect added -> the flows re-identified, with honest outcomes.

1. Residual and its significance: the plain fit (flows only) on every feature the record(s) hold,
   whitened by noise + the model budget (`identify.forward.budget`); chi^2 at the stated `level` (1 %) decides
   "explained" or "something is missing".
2. Trace: every candidate effect in every placement (`Effect.placements`) is fitted jointly with the
   flows (`Effect.candidate`: its main parameters free, the rest at typical values; phases from three
   starts; again from the plain fit's flows when it ends above them, `_plain_start`), scored by AIC = chi^2 + 2 k
   (k free parameters: the penalty for what an effect adds) and by whether what it leaves is noise (p > level).
   Ranked by AIC.
   When no single candidate leaves noise, pairs of the best PAIR_FROM singles (different effects), of the
   best PAIR_LEAD with the best PAIR_PARTNERS placements of the other effects, those the linear screen ranks best
   (`pairs.screen`) and those short fits from the best single's answer rank best (`_lead_partners`) are fitted
   together; a pair is added to the ranking only when it passes and beats every single by more than
   `ambiguity_aic`, and is then named as the pair.
3. Outcomes, never forced:
   - the plain model passes and no candidate lowers chi2 beyond chance over all those tried (`_asked_for`: a
     likelihood ratio at 1 %, Bonferroni over the candidates): explained, nothing added; when one does, the record
     asks for an effect and the outcomes below apply;
   - one passing candidate is better than every other by more than `ambiguity_aic` (4, "considerably
     more support" in Burnham & Anderson's terms): it is named and added;
   - several pass within `ambiguity_aic`: ambiguous; the set, the flows each implies and the
     measurements that would separate them are reported, and the best is shown as "added" only
     provisionally (`ambiguous` non-empty);
   - none passes: unexplained, with the best candidate and what is left.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from ..errors import LubevizError
from ..identify.fit.least_squares import Z95, Fit, fit, whole_theta
from ..identify.fit.result import lubrication_verdict, parameter, union_interval
from ..identify.forward.chain import bearing_changes
from .pairs import node_picture, screen
from .scan import SCREEN_STRIDE, NodeSweep, family
from ..progress import ProgressFn, silent
from ..units import MLMIN_PER_M3S

AMBIGUITY_AIC = 4.0
OUTCOMES = ("explained", "effect added", "ambiguous", "unexplained", "effect added, still not explained",
            "measurement fault")
REFITS = 3  # passing candidates refined in turn until one still explains the record
PAIR_FROM = 4  # pairs are tried among this many of the best single candidates (different effects)
# ... and each of this many best singles with every placement of every other effect (a worn bearing and a probe
# gain on y1 when the best probe gain alone was on x1: the pair was never tried, issue 36 bench)
PAIR_LEAD = 2
PAIR_PARTNERS = 6  # ... among the best this many placements of the other effects (a set's pair fits cost 3 records)
PAIR_LINEAR = 6  # ... and this many more that the linear screen over every pair of singles ranks best (`pairs.screen`)
PAIR_FROM_LEAD = 3  # ... and this many more that short fits from the best single's answer rank best (`_lead_partners`)
# a pair is named only with this many degrees of freedom left: one record at one speed (6 features) minus two flows
# and a pair of 2 + 2 parameters leaves none, and with one left almost any pair fits it (measured: a worn bearing 2
# with a probe's gain error named as "a second unbalance + bearing 1 at 84 um", flows 64 % off, chi2 0.4 for 1 dof)
PAIR_DOF = 2
PAIR_LOOK_ALIKES = 4  # a named effect is fitted beside the best placements of this many other effects (look-alikes),
PAIR_PLACEMENTS = 3  # ... this many of each (oil thinner on every bearing ranked below on one bearing alone)
PAIR_ASKED = 0.95  # ... a look-alike when its chi2 is below the winner's by this likelihood-ratio quantile
RIVAL_PAIRS = 6  # a named effect's rivals: this many pairs of other singles the linear screen ranks best, fitted;
# ... a rival when its AIC is at most the winner's plus this (Burnham & Anderson: within 2, both have substantial
# support), with a flow outside the winner's interval: one no worse than the winner's makes the name an ambiguity;
# one up to RIVAL_AIC worse is told and widens the flows' interval, the name kept (two faults at once are less likely
# than one). At 0 a vertical load with oil 25 % thicker, AIC 0.5 above a horizontal load named alone at flows 9 and
# 25 % off, was no rival: outside their intervals (the compressor rehearsal's case 14, session 59)
RIVAL_AIC = 2.0
# the fewest parameters a second fault of another kind brings beside a named one when it acts at a place with a size
# and a phase (a 1X force, a second unbalance, a bow): a named effect that leaves fewer than this many degrees of
# freedom plus one cannot be tested against such a pair on its record (the fan's loop, case 29, session 59: a worn
# bearing with a second unbalance, 3 parameters for 3 flows on 6 features, read as one fault with the flows off)
PARTNER_PARAMS = 2


@dataclass(frozen=True)
class Candidate:
    """One effect in one placement, fitted with the flows."""

    label: str
    effect: object  # the Effect, its fitted values set
    fit: Fit | None
    error: str = ""
    defect: object = None  # large orbits: the balance's correction its fit used (`identify.forward.chain.ResponseDefect`)
    unbalance_scale: float | None = None  # large orbits: the unbalance's size the record's 1X implies (x declared)
    partners: tuple = ()  # a pair (`_try_pairs`): the other effect(s) fitted with `effect`

    @property
    def effects(self) -> tuple:
        """The effect(s) of this candidate: one, or a pair's two."""
        return (self.effect, *self.partners)

    @property
    def title(self) -> str:
        """The candidate in words (`Effect.title`: 'the clearance of bearing 1', a pair's two joined), for verdicts
        and pages; `label` is its key in code and JSON."""
        return " with ".join(e.title() for e in self.effects)

    @property
    def separated_by(self) -> tuple[str, ...]:
        return tuple(dict.fromkeys(type(e).separated_by for e in self.effects if type(e).separated_by))

    @property
    def forcing(self) -> bool:
        return all(type(e).forcing for e in self.effects)

    @property
    def aic(self) -> float:
        return math.inf if self.fit is None else self.fit.aic

    @property
    def passes(self) -> bool:
        return self.fit is not None and bool(self.fit.explained)

    def parameters(self) -> dict:
        """{name: value, name_std: std} of the fitted parameters besides the flows, then this effect's held ones
        as given (its placement), from the fit's `FitParameter`s."""
        if self.fit is None:
            return {}
        out = {}
        for p in self.fit.params:
            if p.free and not p.is_flow:
                out[p.name] = p.value
                out[p.name + "_std"] = p.std
        for e in self.effects:
            for p, v in e.values().items():
                out.setdefault(p, v)
        if self.unbalance_scale is not None:
            out["unbalance_scale"] = float(self.unbalance_scale)
        return out


@dataclass(frozen=True)
class Diagnosis:
    before: Fit
    candidates: tuple[Candidate, ...]  # ranked, best first
    added: Candidate | None
    after: Fit | None
    explained: bool
    ambiguous: tuple[str, ...]
    verdict: str
    separated_by: tuple[str, ...] = ()
    seconds: float = 0.0
    truth: dict = field(default_factory=dict)
    lines: tuple = ()  # lines beyond 1X present in the record(s) (`signals.lines`): no model or effect has them
    stability: object = None  # rotor.whirl.Stability at the flows found, when a sub-synchronous line calls for it
    bearings: tuple = ()  # (name, node, supply) of each fluid-film bearing in the model file's order (SPEC §8)
    # an ambiguity's flows: per flow (low, high or None) in m^3/s, the union over the set of each candidate's
    # 95 % interval (the winner's profile interval, the others' +-1.96 sigma): what the flows are known to be
    # until a measurement separates the causes. None when nothing is ambiguous.
    set_intervals: tuple | None = None
    findings: tuple = ()  # identify.fit.plausibility.Finding: the record(s) checked against the machine as declared
    # each bearing's flooded threshold Q_T (m^3/s) for the machine as diagnosed (a worn bearing's own, a hotter
    # oil's): what the verdicts and the advice judge the flows against. None: no flows are claimed.
    q_threshold: np.ndarray | None = None
    # the same for the machine as declared, with the record's declared effects (an oil temperature reading)
    q_threshold_plain: np.ndarray | None = None
    scans: tuple = ()  # diagnose.scan.NodeScan: each effect that acts at a node, fitted at every node it can
    asked: object = None  # `Asked`: the plain model passed, but this candidate lowered chi2 beyond chance
    not_seen: tuple = ()  # `NotSeen`: a fault of typical size the record (explained) cannot tell from none
    # pairs of other effects that fit nearly as well as the named one (`_rival_pairs`: AIC within RIVAL_AIC of it, no
    # lower) with other flows: told, and carried in the flows' interval (`set_intervals`), but not an ambiguity
    rivals: tuple[str, ...] = ()
    # the named effect leaves too few degrees of freedom to test a second fault beside it (`_untested_pair_words`)
    pair_untested: bool = False

    @property
    def q_threshold_declared(self) -> np.ndarray | None:
        """The declared machine's Q_T (with the record's declared effects, e.g. an oil temperature reading)."""
        return self.q_threshold_plain if self.q_threshold_plain is not None else getattr(self.before, "q_threshold",
                                                                                            None)

    def thresholds_for(self, f: Fit) -> np.ndarray | None:
        """The Q_T a fit's flows are judged against: the declared bearings' for the plain fit, the machine as
        diagnosed for the fit with the effect. One rule for the JSON, the report and the page."""
        if f is self.before or self.q_threshold is None:
            return self.q_threshold_declared
        return self.q_threshold

    def verdicts_for(self, f: Fit) -> list[str] | None:
        """'starved', 'normal' or 'over-supplied' per bearing for fit `f` (`thresholds_for`)."""
        qt = self.thresholds_for(f)
        return None if qt is None else [lubrication_verdict(q, t) for q, t in zip(fit_flows(f), qt)]

    @property
    def final(self) -> Fit:
        return self.after if self.after is not None else self.before

    @property
    def outcome(self) -> str:
        """The diagnosis in one of OUTCOMES: what the verdict, the report and the page each say, derived here once."""
        if any(f.fault for f in self.findings):
            return "measurement fault"
        if self.explained and self.added is None:
            return "explained"
        if self.added is not None and self.ambiguous:
            return "ambiguous"
        if self.added is not None:
            return "effect added" if self.explained else "effect added, still not explained"
        return "unexplained"


def _fit_candidate(base_chain, measured, effect, names, budget, level, starts_phase, start=None,
                   screening: bool = True) -> Candidate:
    """One effect in one placement fitted with the flows: from each of three phases when it has one (and
    `starts_phase`), or from `start` (a parameter vector: a node scan's neighbour) once."""
    cand = effect.candidate()
    label = cand.label()
    chains = [c.adding(cand) for c in base_chain]
    best = None
    phases = [p for p in cand.free if p.endswith("phase_deg")]
    trials = [0.0, 120.0, 240.0] if (phases and starts_phase and start is None) else [None]
    try:
        for ph in trials:
            trial = cand if ph is None else cand.copy(**{phases[0]: ph})
            if ph is not None:
                trial._free = cand.free
                chains = [c.adding(trial) for c in base_chain]
            res = fit(chains, measured, names=names, budget=budget, level=level, intervals=False, start=start,
                      screening=screening)
            if best is None or res.chi2 < best[1].chi2:
                best = (trial, res)
    except LubevizError as exc:
        return Candidate(label=label, effect=cand, fit=None, error=str(exc))
    trial, res = best
    fitted = trial.copy(**{p.name: p.value for p in res.params if p.free and not p.is_flow})
    return Candidate(label=label, effect=fitted, fit=res)


def _start_at(chains, at: Fit, *effects) -> np.ndarray:
    """The parameter vector of `chains` with `effects` added: the flows of the fit `at`, each effect at its current
    values (a fitted one's, or its declared or default ones)."""
    theta = chains[0].adding(*effects).start()
    q = at.flow_values()
    theta[:q.size] = q
    return theta


def _plain_start(chains, effect, before: Fit) -> np.ndarray:
    """The parameter vector at the plain fit's flows with `effect` at its start (its declared or default values).

    An effect nests the plain model (at its start it changes nothing, or little), so its best fit cannot lie above
    the plain one: a candidate whose fit from the global search ends there found another basin of the flows, and is
    fitted again from this point (`diagnose`). The fan loop's case 45 (a turned probe on plane 2 with bearing 1
    worn): the turned probe alone ended at chi2 1347 against the plain fit's 968, its direction of the features then
    misled the pair screen (`pairs.screen`), and the true pair (chi2 0.6 for 5 dof) was never fitted."""
    return _start_at(chains, before, effect.candidate())


def diagnose(chain, measured, *, candidates=None, names=None, budget=None, level: float = 0.01,
             ambiguity_aic: float = AMBIGUITY_AIC, progress: ProgressFn = silent, truth: dict | None = None,
             phase_starts: bool = True, lines=(), findings=()) -> Diagnosis:
    """Diagnose a record (or the records of one set: sequences of chains and measured features).

    `chain`: the plain forward chain(s) (no effects); `candidates`: Effect instances or classes to try in
    every placement (default: the whole library); `lines`: the record's lines beyond 1X
    (`signals.lines.present_lines`), which the linear model and every effect lack: named in the verdict;
    `findings`: what is impossible or suspicious in the record(s) as declared (`identify.fit.plausibility`), which
    the verdict leads with. A measurement fault (copied channels, one plane in other units) gets no effect
    fitted: the effect would describe the fault."""
    t0 = time.perf_counter()
    chains = list(chain) if isinstance(chain, (list, tuple)) else [chain]
    meas = list(measured) if isinstance(measured, (list, tuple)) else [measured]
    before = fit(chains, meas, names=names, budget=budget, level=level)
    findings, lines = tuple(findings), tuple(lines)
    from ..identify.batch import bearing_names

    common = dict(before=before, seconds=0.0, truth=dict(truth or {}), lines=lines, findings=findings,
                  bearings=bearing_names(chains[0].machine))
    broken = [f for f in findings if f.fault]
    if broken:  # the orbit is not the shaft's: an effect fitted to it would describe the fault, not the machine
        return Diagnosis(**{**common, "seconds": time.perf_counter() - t0}, candidates=(), added=None, after=None,
                         explained=False, ambiguous=(), verdict=_fault_words(before, broken))
    oil_known = _oil_declared(chains)
    rich = len(chains) > 1 or any(getattr(m, "static_names", ()) for m in meas)
    pool, orbit = _candidate_pool(candidates, oil_known, chains[0].rotor, n_planes=len(chains[0].nodes), rich=rich)
    tried, scans = [], []
    total, done = sum(len(e) if isinstance(e, list) else 1 for e in pool), 0
    for e in pool:
        def fit_one(effect, start=None, screening=True):
            nonlocal done
            done += 1
            progress(min(done, total), total, effect.title())
            c = _fit_candidate(chains, meas, effect, names, budget, level, phase_starts, start, screening)
            if start is None and c.fit is not None and c.fit.chi2 > before.chi2 * (1 + 1e-6) + 1e-9:
                again = _fit_candidate(chains, meas, effect, names, budget, level, phase_starts,
                                       _plain_start(chains, effect, before), screening)
                if again.fit is not None and again.fit.chi2 < c.fit.chi2:
                    c = again
            return c

        if isinstance(e, list):  # where along the shaft: every 2nd node now, all of them if the verdict names it
            sweep = NodeSweep(e, fit_one, picture=lambda nodes: node_picture(chains, meas, names, before, nodes))
            best, profile = sweep.run(SCREEN_STRIDE)
            tried.append(best)
            scans.append((sweep, profile))
        else:
            tried.append(fit_one(e))
    orbit_tried = orbit is not None and bool(_two_x(lines)) and len(chains) == 1 and not before.explained
    if orbit_tried:
        tried.append(_fit_orbit(chains[0], meas[0], orbit, names, budget, level, progress))
    tried.sort(key=lambda c: c.aic)
    unnamed = []
    if not before.explained and not any(c.passes for c in tried):
        tried += _try_pairs(chains, meas, tried, names, budget, level, ambiguity_aic, progress, before=before,
                            unnamed=unnamed)
        tried.sort(key=lambda c: c.aic)
    passing = [c for c in tried if c.passes]
    asked = _asked_for(before, tried, sum(len(profile.nodes) - 1 for _, profile in scans)) if before.explained \
        else None
    plain = before.explained and asked is None  # the plain model passes and no effect is asked for beyond chance
    best, after, refused = (None, None, []) if plain else _refine(chains, meas, passing, names, budget, level)
    passing = [c for c in passing if c not in (r for r, _ in refused)]
    if plain or (asked is not None and best is None):  # (asked for, but no candidate still passes once refined)
        asked = None
        out = _explained_outcome(chains, meas, before, names, budget, level, passing)
    elif best is not None:
        out = _added_outcome(chains, before, best, after, passing, ambiguity_aic)
        if asked is not None:
            out["verdict"] = _asked_words(before, asked) + out["verdict"]
        if best.defect is None:
            _unpinned_after_effect(out, chains, meas, best, passing, names, budget, level)
            _pairs_after_effect(out, chains, meas, best, tried, names, budget, level, before)
            _rival_pairs(out, chains, meas, best, tried, names, budget, level, before)
            _untested_pair_words(out, best, after, meas)
    else:
        out = _unexplained_outcome(before, tried, refused)
        out["verdict"] += _unnamed_pair_words(before, unnamed, len(chains))
    added = out["added"]
    # an ambiguity's members change the machine differently: the flows are judged against the declared bearings
    named = added is not None and added.defect is None and not out["ambiguous"]
    changes = tuple(e for e, _ in fitted_effects(added, out["after"])) if named else ()
    plain_qt = diagnosed_thresholds(chains[0])
    thresholds = diagnosed_thresholds(chains[0], changes) if changes else plain_qt
    verdict = out.pop("verdict") + _threshold_words(thresholds, plain_qt) + _line_words(lines, orbit_tried)
    stability = None
    sub = [line for line in lines if line.kind == "sub"]
    if sub:  # what the model's own stability at the flows found says of it
        final = out["after"] if out["after"] is not None else before
        stability, words = _whirl_words(chains[0], out["added"], final, max(sub, key=lambda ln: ln.amplitude_m))
        verdict += f" The model's stability: {words}."
        if stability.unstable:
            verdict += (" Above the threshold the machine is not in a steady state (the whirl grows on top of the "
                        "unbalance orbit): the flows above rest on the 1X part of a transient and on a steady model, "
                        "so take them as indicative; their intervals do not carry this.")
    verdict += _past_tables_words(out["after"] if out["after"] is not None else before)
    completed = _complete_scans(scans, out["added"], out["ambiguous"])
    verdict += _scan_words(completed, out["added"], out["ambiguous"]) + _widen_over_places(out, scans, completed)
    scans = completed
    return Diagnosis(**{**common, "seconds": time.perf_counter() - t0}, candidates=tuple(tried),
                     verdict=_finding_words(findings) + verdict, stability=stability, q_threshold=thresholds,
                     q_threshold_plain=plain_qt, scans=tuple(scans), asked=asked, **out)


def _named_families(added, ambiguous) -> set:
    """The scanned sweeps (`scan.family`: a label without its node) the verdict names or keeps in an ambiguity: a
    side load along the weight and one of fitted direction are two sweeps of one effect."""
    labels = ([added.label] if added is not None else []) + list(ambiguous)
    return {family(part) for label in labels for part in label.split(" + ")}


def _complete_scans(scans, added, ambiguous) -> list:
    """Each scan's profile; at every node for the sweeps the verdict names or keeps in an ambiguity."""
    named = _named_families(added, ambiguous)
    return [sweep.run(1, screening=False)[1] if profile.family in named else profile for sweep, profile in scans]


def _widen_over_places(out: dict, sweeps, profiles) -> str:
    """A named effect that acts at a node fits as well at each node its profile keeps (`NodeScan.fitting`), each with
    flows of its own: the flows' intervals are given over those places (with the winner's, and an ambiguity's set),
    and the words that say so ('' when no other place fits or nothing was named). A side load on the fan named at
    node 17 where it sat at node 25 gave Q1 41 % low, the interval of node 17's fit alone missing it (the fan loop,
    session 48)."""
    after = out["after"]
    if after is None or out["added"] is None or out["added"].defect is not None:
        return ""
    named = _named_families(out["added"], out["ambiguous"])
    members = []
    for (sweep, _), profile in zip(sweeps, profiles):
        if profile.family not in named:
            continue
        places = set(profile.fitting)
        members += [c for i, c in sweep.found[False].items() if int(sweep.effects[i].node) in places
                    and c.fit is not None and c.defect is None and c is not out["added"]]
    if not members:
        return ""
    iv = _set_intervals(after, members)
    old = out["set_intervals"]
    joined = iv if old is None else tuple(None if a is None else union_interval(a, b) for a, b in zip(old, iv))
    out["set_intervals"] = joined
    return f" Over the places that fit, the flows are known only within {interval_words(joined)}."


def _scan_words(scans, added, ambiguous) -> str:
    """Where a named (or ambiguous) effect that acts at a node sits, as far as the record says."""
    named = _named_families(added, ambiguous)
    words = [s.words() for s in scans if s.family in named]
    return "".join(f" Where: {w}." for w in words)


def _fault_words(before: Fit, broken) -> str:
    return ("Measurement fault: " + ". ".join(f.text for f in broken) + f". The plain fit ({_flows_text(before)}, "
            f"chi2 = {before.chi2:.1f} for "
            f"{before.dof} dof) describes the fault, not the machine, and no effect was fitted: correct the "
            "record (or leave that plane out) and diagnose again.")


def _candidate_pool(candidates, oil_known: bool, rotor, *, n_planes: int, rich: bool = False) -> tuple[list, object]:
    """Every placement of every candidate a diagnosis fits (an effect scanned over nodes, `Effect.scan_nodes`: a
    list of it at each node), and the response-model candidate (large orbits, tried only when the record shows
    their 2X), or None. `rich`: the records hold the static shaft position or several speeds (an effect may fit
    more of itself there: a side load's direction)."""
    from ..effects import EFFECTS

    pool, orbit = [], None
    for c in (EFFECTS.values() if candidates is None else candidates):
        e = c() if isinstance(c, type) else c
        if e.stage == "response":
            orbit = e
            continue
        if not e.diagnosed:  # not fitted by a diagnosis (oil_temperature: `viscosity` told in °C)
            continue
        if oil_known and e.oil_viscosity:  # an oil temperature reading settles the viscosity
            continue
        nodes = e.scan_nodes(rotor)
        if nodes:  # each placement scanned on its own (a side load along the weight, one across it)
            pool.extend([p.copy(node=n) for n in nodes] for p in _placements(e, rotor, n_planes, rich)
                        if p.placeable(rotor))
        else:
            pool.extend(p for p in _placements(e, rotor, n_planes, rich) if p.placeable(rotor))
    return pool, orbit


def _placements(e, rotor, n_planes: int, rich: bool = False) -> list:
    """`e.placements` over the machine's parts, given the counts its signature takes (an effect written before
    `n_supports` was one takes the bearings and planes only; `rich` goes to those that take it)."""
    import inspect

    counts = {"n_bearings": len(rotor.bearing_nodes), "n_planes": n_planes, "n_supports": len(rotor.supports),
              "rich": rich}
    params = inspect.signature(e.placements).parameters
    if not any(p.kind == p.VAR_KEYWORD for p in params.values()):
        counts = {k: v for k, v in counts.items() if k in params}
    return e.placements(**counts)


def _try_pairs(chains, meas, tried, names, budget, level, ambiguity_aic, progress=silent, before=None,
               unnamed: list | None = None) -> list:
    """Pairs of the best PAIR_FROM single candidates (different effects; not large orbits), of the best
    PAIR_LEAD with the best PAIR_PARTNERS placements of the other effects, and the PAIR_LINEAR others the linear
    screen over every pair of singles ranks best (`pairs.screen`, from the plain fit `before`), fitted together;
    returned (to join the ranking) only when the best passes with PAIR_DOF degrees of freedom left and beats every
    single by more than `ambiguity_aic`: a pair has more freedom, and is named only when the record asks for it. With
    it come the pairs within `ambiguity_aic` of it, those the record cannot name among them (`rivals`). `unnamed`, when
    given, receives every pair that passes with too few degrees of freedom to be named (for the verdict's words)."""
    import itertools

    usable = [c for c in tried if c.fit is not None and c.defect is None and not c.partners]
    tops, seen = [], set()
    for c in usable:
        if c.effect.effect_name in seen:
            continue
        seen.add(c.effect.effect_name)
        tops.append(c)
        if len(tops) == PAIR_FROM:
            break
    pairs = list(itertools.combinations(tops, 2))
    labels = {frozenset((a.label, b.label)) for a, b in pairs}
    for lead in tops[:PAIR_LEAD]:
        partners = [c for c in usable if c.effect.effect_name != lead.effect.effect_name][:PAIR_PARTNERS]
        for c in partners:
            key = frozenset((lead.label, c.label))
            if key not in labels:
                labels.add(key)
                pairs.append((lead, c))
    ranked = screen(chains, meas, names, before, usable, dof_min=1, skip=labels)
    pairs += [(a, b) for a, b, dof in ranked if dof >= PAIR_DOF][:PAIR_LINEAR]
    if tops:
        labels |= {frozenset((a.label, b.label)) for a, b in pairs}
        pairs += _lead_partners(chains, meas, tops[0], usable, labels, names, budget, level)
    found = _fit_pairs(chains, meas, pairs, names, budget, level, progress)
    best_single = min((c.aic for c in tried), default=math.inf)
    good = sorted((c for c in found if c.passes and c.aic < best_single - ambiguity_aic
                   and c.fit.dof >= PAIR_DOF and not _at_bound(c.fit)), key=lambda c: c.aic)
    # a pair the record cannot name (a degree of freedom left, fewer than PAIR_DOF) that fits as well is a rival all
    # the same: a second unbalance and a turned probe (3 parameters, 1 dof left on one record of two planes) read as
    # a turned probe and a worn bearing, Q2 53 % off (the paper's loop, case 53, session 51)
    if good or unnamed is not None:
        found += _fit_pairs(chains, meas, [(a, b) for a, b, dof in ranked if dof < PAIR_DOF][:PAIR_LINEAR], names,
                            budget, level, progress)
    rivals = sorted((c for c in found if c.passes and 1 <= c.fit.dof < PAIR_DOF and not _at_bound(c.fit)),
                    key=lambda c: c.aic)
    if unnamed is not None:
        unnamed.extend(rivals)
    if not good:
        return []
    # every pair within `ambiguity_aic` of the best: several pairs that fit are an ambiguity, not a name
    return sorted((c for c in good + rivals if c.aic - good[0].aic < ambiguity_aic), key=lambda c: c.aic)


def _unnamed_pair_words(before: Fit, unnamed, records: int = 1) -> str:
    """For an unexplained record: the pairs that fit it but leave too few degrees of freedom to be named
    (`_try_pairs`' `unnamed`), and, on a record too thin for a pair of 3 parameters, what would add features."""
    k = len(before.values)
    n = before.dof + k
    words = ""
    if unnamed:
        c = unnamed[0]
        words += (f" Two effects at once fit it: {c.title} (chi2 {c.fit.chi2:.1f} for {c.fit.dof} dof), but with so "
                  f"few degrees of freedom left almost any pair fits, so none is named.")
    if unnamed or before.dof - 3 < PAIR_DOF:
        held = "This record holds" if records == 1 else f"These {records} records hold"
        words += (f" {held} {n} features for {k} unknown flows: a pair of effects with 3 parameters or "
                  f"more (a 1X force beside another effect) leaves fewer than {PAIR_DOF} degrees of freedom to test "
                  "it. The static shaft position (the probes' DC gap) or records at a second speed add the features "
                  "that would.")
    return words


def _lead_partners(chains, meas, lead, usable, skip, names, budget, level) -> list:
    """[(lead, b)]: the PAIR_FROM_LEAD other singles b (of other effects, pairs not in `skip`) that lower the best
    single's chi2 most when fitted beside it for a few steps from its own answer (b at its own single fit's values).

    The linear screen (`pairs.screen`) reads every effect's direction at the plain fit; far from it (chi2 968 for 7
    dof on the fan loop's case 45, a turned probe on plane 2 with bearing 1 worn) those directions mislead: the true
    pair ranked 23rd there, while from the worn bearing's answer (chi2 64) it fell to 13 in a few steps, first of 35
    partners, and fitted to 0.6 for 5 dof. Each short fit costs 10-60 ms."""
    ea = lead.effect.candidate()
    scored = []
    for b in usable:
        if b.effect.effect_name == lead.effect.effect_name or frozenset((lead.label, b.label)) in skip:
            continue
        eb = b.effect.candidate()
        try:
            res = fit([c.adding(ea, eb) for c in chains], meas, names=names, budget=budget, level=level,
                      intervals=False, screening=True, start=_start_at(chains, lead.fit, ea, eb))
        except LubevizError:
            continue
        if res.dof >= PAIR_DOF and res.chi2 < lead.fit.chi2:
            scored.append((res.chi2, b))
    scored.sort(key=lambda t: t[0])
    return [(lead, b) for _, b in scored[:PAIR_FROM_LEAD]]


def _fit_pairs(chains, meas, pairs, names, budget, level, progress=silent) -> list:
    """Each pair (a, b) of single candidates fitted together (a screening fit): a Candidate of the pair."""
    found = []
    for n, (a, b) in enumerate(pairs, start=1):
        label = f"{a.label} + {b.label}"
        progress(n, len(pairs), label)
        ea, eb = a.effect.candidate(), b.effect.candidate()
        try:
            res = fit([c.adding(ea, eb) for c in chains], meas, names=names, budget=budget, level=level,
                      intervals=False, screening=True)
        except LubevizError as exc:
            found.append(Candidate(label=label, effect=ea, partners=(eb,), fit=None, error=str(exc)))
            continue
        pair = Candidate(label=label, effect=ea, partners=(eb,), fit=res)
        (ea, _), (eb, _) = fitted_effects(pair, res)
        found.append(Candidate(label=label, effect=ea, partners=(eb,), fit=res))
    return found


def _at_bound(f: Fit) -> bool:
    """Whether a fitted effect parameter stopped at its bound (a pair that needs oil 2.5 x as viscous, the edge
    of the search, is pressed there by a misfit, not found)."""
    for p in f.params:
        if not p.free or p.is_flow:
            continue
        for b in p.bounds:
            if b is not None and abs(p.value - b) <= 1e-6 * max(abs(b), 1.0):
                return True
    return False


def _two_x(lines) -> list:
    from ..signals.lines import LINE_NOTICE

    return [line for line in lines if "2X" in line.kind and line.relative_to_1x > LINE_NOTICE]


def _refine(chains, meas, passing, names, budget, level):
    """The winner: the best passing candidate whose refined fit (its parameters free again, refined from the
    screening fit, with intervals) still explains the record; the outcome is that result's, never the
    screening's. (winner or None, its refined fit, [(candidate, refined fit) refused])."""
    refused = []
    for cand in passing[:REFITS]:
        try:
            refit = cand.fit if cand.defect is not None else fit(
                [c.adding(*(e.candidate() for e in cand.effects)) for c in chains], meas, names=names, budget=budget,
                level=level, start=cand.fit.values)
        except LubevizError:  # its intervals reach where the model cannot go: never named on its screening fit
            continue
        if refit.explained:
            return cand, refit, refused
        refused.append((cand, refit))
    return None, None, refused


def fit_flows(f: Fit) -> np.ndarray:
    """Every bearing's flow of fit `f` (m^3/s, file order; a known supply's held value among them)."""
    return np.asarray(f.flow_values(), dtype=float)


def fit_flows_std(f: Fit) -> np.ndarray:
    return np.asarray(f.flow_stds(), dtype=float)


def _flow_names(f: Fit) -> tuple[str, ...]:
    return tuple(f"q{k + 1}" for k in range(len(fit_flows(f))))


def _flows_words(f: Fit) -> str:
    return ", ".join(f"{q * MLMIN_PER_M3S:.0f}" for q in fit_flows(f))


def _flow_labels(f: Fit) -> str:
    return ", ".join(f"Q{k + 1}" for k in range(len(fit_flows(f))))


def _flows_text(f: Fit) -> str:
    """'Q1, Q2 = 420, 600 ml/min' for any number of flows."""
    return ", ".join(f"Q{k + 1}" for k in range(len(fit_flows(f)))) + f" = {_flows_words(f)} ml/min"


def _explained_outcome(chains, meas, before, names, budget, level, passing=()) -> dict:
    out = dict(added=None, after=None, explained=True, ambiguous=(), separated_by=(), set_intervals=None,
               verdict=(f"Explained: the model fits the record within noise and model uncertainty "
                        f"(chi2 = {before.chi2:.1f} for {before.dof} dof); no effect is needed."))
    others = _look_alikes(before, passing)
    ivs = []
    if others:  # the plain model passes, but an effect fits better with other flows: its interval alone would lie
        separated = tuple(dict.fromkeys(w for c in others for w in c.separated_by))
        ivs.append(_set_intervals(before, others))
        out.update(ambiguous=tuple(c.label for c in others), set_intervals=ivs[0], separated_by=separated)
        shown = others[:LOOK_ALIKES_TOLD]
        more = f" and {len(others) - len(shown)} more" if len(others) > len(shown) else ""
        out["verdict"] += (" But " + "; ".join(f"{c.title} ({_flows_text(c.fit)})" for c in shown) + more
                           + f" fit{'s' if len(others) == 1 else ''} it as well (chi2 "
                           + ", ".join(f"{c.fit.chi2:.1f}" for c in shown) + f" against the plain model's "
                           f"{before.chi2:.1f}) with other flows: until a measurement tells them apart the flows are "
                           "known only within "
                           f"{interval_words(ivs[0])}. To tell them apart: {'; or '.join(separated)}.")
    unseen = _not_seen(chains, meas, before, passing, names, budget, level)
    if unseen:
        out["not_seen"] = tuple(unseen)
        out["verdict"] += _not_seen_words(before, unseen)
        moved = [u for u in unseen if _outside(before, fit_flows(u.fit))]
        if moved:  # a fault the record cannot see, with other flows: the flows are known only over both
            ivs[:] = [_set_intervals(before, [*moved, *others])]
            out.update(set_intervals=ivs[0])
    free = _unpinned(chains, meas)
    look_alike = _unpinned_look_alike(chains, meas, before, free, names, budget, level)
    if look_alike is not None:
        joined = tuple(union_interval(*(iv[k] for iv in (*ivs, look_alike))) for k in range(len(look_alike)))
        separated = tuple(dict.fromkeys((*out["separated_by"], *(type(e).separated_by for e in free))))
        labels = tuple(e.label() for e in free if e.label() not in out["ambiguous"])
        out.update(ambiguous=out["ambiguous"] + labels, set_intervals=joined, separated_by=separated)
        out["verdict"] += (f" {'And' if ivs else 'But'} this record does not pin {_unpinned_words(free)}: within "
                           f"that range it is explained as well at other flows, so they are known only within "
                           f"{interval_words(joined)}. To pin {'them' if len(free) > 1 else 'it'}: {_pinned_by(free)}.")
    return out


# a typical fault fits "as well" as none when its chi2 is within this of the plain fit's (95 %, one parameter)
UNSEEN_CHI2 = 3.84


@dataclass(frozen=True)
class NotSeen:
    """An effect at the size of a typical fault (its class's `search` value) that a record explained by the plain
    model cannot tell from none: with it held at that size and the flows refitted, chi2 stays within UNSEEN_CHI2 of
    the plain fit's."""

    candidate: Candidate  # the effect's own fit (free), which passed
    effect: object  # the effect at the typical fault's size
    fit: Fit  # the flows fitted with it held there

    @property
    def label(self) -> str:
        return self.candidate.label

    def as_dict(self) -> dict:
        return {"label": self.label, "title": self.effect.title(),
                "values": {p: float(getattr(self.effect, p)) for p in type(self.effect).diagnose_free},
                "chi2": float(self.fit.chi2), "dof": int(self.fit.dof),
                **{f"q{k + 1}_mlmin": float(v * MLMIN_PER_M3S) for k, v in enumerate(fit_flows(self.fit))}}


def _not_seen(chains, meas, before: Fit, passing, names, budget, level) -> list:
    """The faults a record the plain model explains cannot see (issue 37: a rolling-element support worn loose to
    half its stiffness, with no probe plane beside it, passes for the declared one on the fan's records of two
    planes, and a verdict that says only "explained" lets the engineer think the support was checked). For each
    passing candidate of one parameter whose class gives a typical fault's size (`Effect.typical_values`: a support
    worn loose to 0.5, a probe's gain 12-15 % off, its pair turned 6 deg, a pedestal as stiff as its film): when that size lies inside the candidate's
    95 % interval, the flows are fitted again with the effect held there, and it is "not seen" when chi2 stays
    within UNSEEN_CHI2 of the plain fit's. The oil's viscosity is left to `_unpinned` (its range there)."""
    out = []
    for c in passing:
        e = c.effect
        cls = type(e)
        free = tuple(cls.diagnose_free)
        if c.fit is None or c.defect is not None or c.partners or len(free) != 1 or e.oil_viscosity:
            continue
        sizes = e.typical_values(free[0], chains[0])
        p = parameter(c.fit.params, f"{cls.effect_name}.{free[0]}")
        if not sizes or p is None or not p.std > 0:
            continue
        for size in sizes:
            if abs(size - p.value) > Z95 * p.std:
                continue
            held = e.copy(**{free[0]: float(size)}).hold(free[0])
            try:
                # (no profile intervals: the set's interval takes a member's flows +- 1.96 sigma, `_set_intervals`)
                f = fit([ch.adding(held) for ch in chains], meas, names=names, budget=budget, level=level,
                        intervals=False)
            except LubevizError:
                continue
            if f.explained and f.chi2 <= before.chi2 + UNSEEN_CHI2:
                out.append(NotSeen(candidate=c, effect=held, fit=f))
                break
    return out


def _past_tables_words(f: Fit) -> str:
    """The fit's sentences on flows past their tables' ends, films past the grid and loads turned far
    (`least_squares._past_tables_text`, each ending "not to be trusted"), for the verdict."""
    said = [w for w in f.warnings if w.endswith("not to be trusted")]
    return "".join(f" {w[:1].upper()}{w[1:]}." for w in said)


def not_seen_words(u: NotSeen) -> str:
    """'constant support 1 has 0.5 times its declared stiffness and damping': the fault in words (its story's first
    sentence)."""
    text = u.effect.told().split(". ")[0].rstrip(".")
    return text[:1].lower() + text[1:]


def not_seen_sentence(unseen, said=not_seen_words) -> str:
    """'it fits as well if <fault>; or if <fault>. To see it: <measurement>.': the faults a record cannot see
    (`NotSeen`), each told by `said`, and what would see them; one text for the verdict, the page and the report."""
    separated = tuple(dict.fromkeys(w for u in unseen for w in u.candidate.separated_by))
    return ("it fits as well if " + "; or if ".join(said(u) for u in unseen)
            + f". To see {'it' if len(unseen) == 1 else 'them'}: " + "; or ".join(separated) + ".")


def _not_seen_words(before: Fit, unseen) -> str:
    """The verdict's sentence on the faults the record cannot see (`_not_seen`), with each one's chi2 and flows."""
    def said(u):
        flows = ("with other flows, " + _flows_text(u.fit)) if _outside(before, fit_flows(u.fit)) else \
            "with flows inside their intervals"
        return f"{not_seen_words(u)} (chi2 {u.fit.chi2:.1f}, {flows})"

    return (f" This record cannot see {'a fault' if len(unseen) == 1 else 'faults'} of typical size (the machine as "
            f"declared: chi2 {before.chi2:.1f}): " + not_seen_sentence(unseen, said))


def _unpinned(chains, meas, effects=()) -> list:
    """The constants the model takes from the model file and the record does not pin, each as a nuisance effect free
    within its plausible range (issue 36): from one record at one speed without the static position, the oil's
    viscosity (unless the record or `effects` declare it: OIL_RANGE) and the bearings' static loads (unless `effects`
    change them: a vertical force and a couple that move each bearing's load by up to LOAD_RANGE of its declared
    share, a belt's pull or a coupling out of line nobody declared). A side load of 7 % of a bearing's load passed
    for the plain machine at flows 3-5 % off, outside their intervals (the issue-36 bench, seed 7). Whatever the
    records, the clearance of a bearing no probe plane of theirs watches (`_unmeasured_clearances`)."""
    from ..effects import SideLoad, Viscosity

    out = _unmeasured_clearances(chains[0], (*effects, *chains[0].effects))
    if len(chains) > 1 or any(getattr(m, "static_names", ()) for m in meas):
        return out
    effects = (*effects, *chains[0].effects)  # what the record declares (an oil temperature reading) counts too
    if not any(e.oil_viscosity for e in effects):
        from ..effects.base import every_bearing_word

        every = every_bearing_word(len(chains[0].sources))
        out.insert(0, Viscosity(bearing=every).release("factor").limited(factor=OIL_RANGE))
    if not any(e.moves_weight_loads for e in effects):  # a horizontal side load leaves them unpinned
        side = SideLoad().bind(chains[0].machine)
        shares, loads = side._bound()
        reach = [LOAD_RANGE / max(np.max(np.abs(shares[:, j]) / loads), 1e-300) for j in range(2)]
        out.insert(1 if out and out[0].oil_viscosity else 0,
                   side.release("force_n", "moment_nm").limited(force_n=(-reach[0], reach[0]),
                                                                moment_nm=(-reach[1], reach[1])))
    return out


def unmeasured_bearings(chain) -> tuple[int, ...]:
    """The bearings (0-based) no measurement plane of `chain` is nearer to than to any other bearing: the record
    sees them only through the shaft (the fan's bearing C in a record of planes A and B)."""
    watched = {chain.plane_housing(p) for p in range(len(chain.nodes))}
    return tuple(k for k in range(len(chain.sources)) if k not in watched)


def _unmeasured_clearances(chain, effects) -> list:
    """The clearance of each bearing the record does not watch (`unmeasured_bearings`), free from the declared to
    UNMEASURED_CLEARANCE times it (worn; unless `effects` change it): such a bearing's film reaches the probes only
    through the shaft, where its clearance and its flow trade against each other. A fan record of planes A and B
    with bearing C worn to 1.37 x its clearance was explained by the plain model with Q3 at 30 % of the truth and an
    interval [37, 53] ml/min (truth 125; the fan loop, session 47)."""
    from ..effects import Clearance

    out = []
    for k in unmeasured_bearings(chain):
        if any(e.effect_name == "clearance" and (e.bearing == k + 1 or isinstance(e.bearing, str)) for e in effects):
            continue
        c = 1e6 * chain.sources[k].bearing.clearance
        out.append(Clearance(bearing=k + 1, clearance_um=c).release("clearance_um")
                   .limited(clearance_um=(c, UNMEASURED_CLEARANCE * c)))
    return out


def _pinned_by(free) -> str:
    worn = [e for e in free if e.effect_name == "clearance"]
    words = [] if len(worn) == len(free) else [type(free[0]).separated_by if len(free) - len(worn) == 1
                                                   else UNPINNED_SEPARATION]
    if worn:
        words.append("probes at " + " and ".join(f"bearing {e.bearing}" for e in worn))
    return "; ".join(words)


def _unpinned_words(free) -> str:
    words = []
    for e in free:
        if e.oil_viscosity:
            words.append(f"the oil's viscosity (x{OIL_RANGE[0]:g}-{OIL_RANGE[1]:.2f} of the declared)")
        elif e.static_load:
            words.append(f"the bearings' static loads (each within +-{LOAD_RANGE:.0%} of its declared share: a belt, "
                         "a radial hydraulic force or a coupling out of line nobody declared)")
        elif e.effect_name == "clearance":
            words.append(f"bearing {e.bearing}'s clearance (no probe watches it: from the declared to "
                         f"x{UNMEASURED_CLEARANCE:g}, worn)")
    return " or ".join(words)


def _unpinned_after_effect(out: dict, chains, meas, best, passing, names, budget, level) -> None:
    """A named effect's flows rest on the declared oil and loads as much as the plain model's do: from one record
    without the static position, oil of another viscosity or another static load with the same effect fits as well
    at other flows (the hot oil and turned probe pair the issue measured: the probe alone explained it, flows 20 %
    low). When the flows' intervals with those free (`_unpinned`) are more than twice as wide, the verdict gives
    them, over the range and the declared values; for an ambiguity, over its members (OIL_MEMBERS of them) with
    them free too (hot oil and a turned probe read as three probe errors, each at flows 33 % off, in the issue-36
    bench)."""
    free = _unpinned(chains, meas, best.effects)
    if not free:
        return
    wide = _unpinned_look_alike([c.adding(*(e.candidate() for e in best.effects)) for c in chains], meas,
                                out["after"], free, names, budget, level)
    if wide is None:
        return
    ivs = [wide, out["set_intervals"]]
    members = [c for c in passing if c is not best and c.label in out["ambiguous"] and c.fit is not None
               and c.defect is None]
    for c in members[:OIL_MEMBERS]:
        own = _unpinned(chains, meas, c.effects)
        # all free at once when the record has the degrees of freedom, else each alone (`_unpinned_look_alike`): a
        # worn bearing beside a side load on the fan (6 features, 3 flows) had no room for the oil, the loads and the
        # unwatched bearing's clearance together, and its widening was dropped: Q2 68 % off outside the set's
        # interval (the fan loop's case 142, session 56)
        groups = [own] if c.fit is not None and sum(len(e.free) for e in own) <= c.fit.dof else [[e] for e in own]
        for group in groups:
            try:
                res = fit([ch.adding(*(e.candidate() for e in c.effects), *group) for ch in chains], meas,
                          names=names, budget=budget, level=level)
            except LubevizError:
                continue
            ivs.append(tuple(res.intervals.get(n) for n in _flow_names(res)))
    joined = tuple(union_interval(*(iv[k] for iv in ivs if iv is not None)) for k in range(len(wide)))
    out["set_intervals"] = joined
    out["separated_by"] = tuple(dict.fromkeys((*out["separated_by"], *(type(e).separated_by for e in free))))
    who = f"with {best.title}" if not out["ambiguous"] else "with any of these explanations"
    out["verdict"] += (f" But this record does not pin {_unpinned_words(free)}: {who}, within that range it is "
                       f"explained as well at other flows, so they are known only within {interval_words(joined)}. "
                       f"To pin {'them' if len(free) > 1 else 'it'}: {_pinned_by(free)}.")


def _pairs_after_effect(out: dict, chains, meas, best, tried, names, budget, level, before=None) -> None:
    """A named effect with a second one beside it: a record one effect explains is often explained as well by it and
    another at other flows (oil 28 % thinner with a turned probe, read as the probe alone with the flows 18 % low
    and intervals that missed them: the fan loop, session 48). The PAIR_PLACEMENTS best placements of each of the
    PAIR_LOOK_ALIKES best other effects are fitted together with the winner. A pair the record asks for (its chi2
    below the winner's by the likelihood ratio's PAIR_ASKED point for its added parameters, a degree of freedom
    left, no parameter at its bound) that puts a flow outside the winner's interval is a look-alike: the flows'
    interval takes its in and the pair joins the ambiguity. It is never named for it (the information criterion and
    PAIR_DOF decide that). The PAIR_LINEAR other singles the linear screen ranks best beside the winner
    (`pairs.screen`, from the plain fit `before`) are fitted with it too (a gain on y1 beside a worn bearing when
    three other gains rank above it alone: the fan loop's case 9, session 51). Fitting only as well is not enough
    here, unlike a single effect against the plain model (`_look_alikes`): every pair holds its single effect, and a
    second effect of free size (a worn bearing beside a pedestal) trades with the flows wherever the record leaves
    it unpinned. A load moved (a side load, a misaligned bearing) is no partner: at any size it trades with the
    flows, and its plausible size is already carried (`_unpinned_after_effect`, LOAD_RANGE)."""
    if best.partners:  # a pair already: a third effect is not tried
        return
    after = out["after"]
    own = {e.effect_name for e in best.effects}
    partners, per = [], {}
    for c in tried:
        name = c.effect.effect_name
        if c.fit is None or c.defect is not None or c.partners or name in own or per.get(name, 0) == PAIR_PLACEMENTS \
                or c.effect.static_load:  # a load moved: its plausible range is the unpinned loads' (LOAD_RANGE)
            continue
        if name not in per and len(per) == PAIR_LOOK_ALIKES:
            continue
        per[name] = per.get(name, 0) + 1
        partners.append(c)
    others = [c for c in tried if c.fit is not None and c.defect is None and not c.partners and c not in partners
              and c.effect.effect_name not in own and not c.effect.static_load]
    partners += [b for _a, b, _dof in screen(chains, meas, names, before, others, dof_min=1, lead=best,
                                             gain_min=0.5 * stats.chi2.ppf(PAIR_ASKED, 1))[:PAIR_LINEAR]]
    found = []
    for pair in _fit_pairs(chains, meas, [(best, c) for c in partners], names, budget, level):
        res = pair.fit
        if res is None:
            continue
        asks = stats.chi2.ppf(PAIR_ASKED, max(after.dof - res.dof, 1))  # the record asks for the second effect
        if res.dof >= 1 and res.chi2 <= after.chi2 - asks and not _at_bound(res) and _outside(after, fit_flows(res)):
            found.append(pair)
    if found:
        _join_pairs(out, after, sorted(found, key=lambda c: c.fit.chi2), " But with a second effect beside it, ",
                    f" the record at least as well (chi2 {after.chi2:.1f} alone) with other flows")


def _rival_pairs(out: dict, chains, meas, best, tried, names, budget, level, before) -> None:
    """Two other effects together that fit the record about as well as the named one by the information criterion
    (AIC, which charges the pair its extra parameters: within RIVAL_AIC) and put a flow outside its interval: the
    record cannot say one fault from two, so the name is not confident. A pedestal under bearing 2 with oil 18 %
    thinner read as a pedestal under bearing 1 alone, flows 9 and 17 % low and outside their intervals (the pump's
    loop, case 24, session 56). The RIVAL_PAIRS pairs of the singles tried, without the winner, that the linear
    screen (`pairs.screen`, from the plain fit) ranks best are fitted; a moved load is left out, as beside the winner
    (`_pairs_after_effect`), unless the winner is a moved load itself: then a load elsewhere or in another direction
    is no nuisance the unpinned loads carry but another reading of the named cause (a horizontal load named alone, the
    truth a vertical one with thicker oil: the compressor rehearsal's case 14, session 59). A rival no worse than the
    winner by AIC joins the ambiguity; one up to RIVAL_AIC worse is told and kept in `rivals`, the name kept (two
    faults at once are less likely than one); both widen the flows' interval, and neither is ever named. One record
    only: over a set of speeds the model's small differences from the machine add up, and a pair's extra parameter
    takes up enough of them to pass the criterion (hot oil over the pump's three speeds had five rivals, each with
    Q2 22 % off, session 56)."""
    if best.partners or best.defect is not None or len(chains) > 1:
        return
    after = out["after"]
    singles = [c for c in tried if c.fit is not None and c.defect is None and not c.partners and c is not best
               and (best.effect.static_load or not c.effect.static_load)]
    ranked = [(a, b) for a, b, _dof in screen(chains, meas, names, before, singles, dof_min=1)[:RIVAL_PAIRS]]
    found = [c for c in _fit_pairs(chains, meas, ranked, names, budget, level)
             if c.fit is not None and c.fit.dof >= 1 and c.fit.explained and not _at_bound(c.fit)
             and c.fit.aic <= after.aic + RIVAL_AIC and _outside(after, fit_flows(c.fit))]
    found.sort(key=lambda c: c.fit.aic)
    close = [c for c in found if c.fit.aic <= after.aic]  # as well counting its parameters: the record cannot tell
    near = [c for c in found if c.fit.aic > after.aic]
    if close:
        _join_pairs(out, after, close, " Or two faults at once: ",
                    f" the record as well, counting {'its' if len(close) == 1 else 'their'} extra parameters (AIC), "
                    "with other flows")
    if near:
        _join_pairs(out, after, near, " Two faults at once are less likely than one, but ",
                    f" the record nearly as well, counting {'its' if len(near) == 1 else 'their'} extra parameters "
                    f"(AIC within {RIVAL_AIC:g} of it), with other flows", join=False)


def _untested_pair_words(out: dict, best, after: Fit, meas) -> None:
    """When the named effect leaves too few degrees of freedom to test a second fault of PARTNER_PARAMS parameters
    beside it (`_rival_pairs` fits only pairs with one left), the verdict says that two faults at once are not ruled
    out by the record(s) `meas` and which measurement they lack would test them; `out["pair_untested"]` records it."""
    if best.partners or after.dof - PARTNER_PARAMS >= 1:
        return
    k = len(_flow_names(after))
    n = after.dof + len(after.values)
    held = "This record holds" if len(meas) == 1 else f"These {len(meas)} records hold"
    lacking = ([] if any(getattr(m, "static_names", ()) for m in meas)
               else ["the static shaft position (the probes' DC gap)"]) + (["records at a second speed"]
                                                                          if len(meas) == 1 else [])
    would = " or ".join(lacking) if lacking else "records at more speeds or more measurement planes"
    out["pair_untested"] = True
    out["verdict"] += (f" {held} {n} features for {k} flows and {best.title}: a second fault beside it with "
                       f"{PARTNER_PARAMS} parameters (a 1X force, a second unbalance) would leave no degree of "
                       "freedom, so two faults at once are not ruled out, and with a second one the flows could lie "
                       "outside the intervals above: they hold if this is the only fault. "
                       f"{would[0].upper()}{would[1:]} would test them.")


def _join_pairs(out: dict, after: Fit, found, lead: str, how: str, join: bool = True) -> None:
    """Pairs that fit as well as the named effect (`found`, best first) join its ambiguity (with `join`; else its
    `rivals`) and widen the flows' interval (their +-1.96 sigma, `_set_intervals`); the verdict tells the best
    LOOK_ALIKES_TOLD of them: `lead`, each pair with its flows and chi2, "fit(s)" + `how`, and the interval."""
    own = out["set_intervals"] or tuple(after.intervals.get(n) for n in _flow_names(after))
    pairs = _set_intervals(after, found)
    joined = tuple(None if own[k] is None and pairs[k] is None else union_interval(own[k], pairs[k])
                   for k in range(len(pairs)))
    if join:
        out["ambiguous"] = out["ambiguous"] + tuple(c.label for c in found)
    else:
        out["rivals"] = out.get("rivals", ()) + tuple(c.label for c in found)
    out["set_intervals"] = joined
    out["separated_by"] = tuple(dict.fromkeys((*out["separated_by"], *(w for c in found for w in c.separated_by))))
    shown = found[:LOOK_ALIKES_TOLD]
    more = f" and {len(found) - len(shown)} more" if len(found) > len(shown) else ""
    out["verdict"] += (lead + "; ".join(f"{c.title} ({_flows_text(c.fit)}, chi2 {c.fit.chi2:.1f})" for c in shown)
                       + more + f" fit{'s' if len(found) == 1 else ''}{how}: until a measurement tells them apart the "
                       f"flows are known only within {interval_words(joined)}.")


def _outside(f: Fit, flows) -> bool:
    """Whether some flow lies outside `f`'s 95 % interval of it."""
    for k, n in enumerate(_flow_names(f)):
        lo, hi = f.intervals.get(n) or (-math.inf, math.inf)
        if not lo <= flows[k] <= (math.inf if hi is None else hi):
            return True
    return False


def _look_alikes(before: Fit, passing) -> list:
    """The passing candidates that fit a record the plain model explains at least as well as it does (chi2 no
    larger) and put a flow outside its 95 % interval: a side load, a worn bearing or thin oil can pass for the plain
    machine at other flows (issue 36), and the plain interval alone would then miss them. Each holds the plain model
    (its effect at no size), so the record cannot prefer the plain flows to its: the information criterion, which
    charges the effect's parameters, says which to name, not which flows the record allows. (With "a lower AIC" here
    a fan bearing raised by 24 % of its clearance, whose candidate fitted as well with Q2 20 % higher, was explained
    with the plain interval missing the truth: the fan loop, session 48.)"""
    out = []
    for c in passing:
        if c.fit is None or c.defect is not None or not c.fit.chi2 <= before.chi2:
            continue
        if _outside(before, fit_flows(c.fit)):
            out.append(c)
    return out


def _load_alikes(best, c) -> bool:
    """Whether `c` moves the bearings' static loads as the single winner `best` does, by another cause (a side load
    and a bearing out of line): what the films see of either is their loads, so a passing one is an alternative
    whatever its AIC. On three supports a force and a couple shift the loads every way a bearing's move does, so
    the side load's extra parameter takes up the model's small differences from the machine: a bearing lowered by
    22 um on the fan read as a side load of AIC 5.9 lower, the move passing too with flows nearer the truth (the fan
    loop's case 149, session 56)."""
    return (not best.partners and not c.partners and best.effect.static_load and c.effect.static_load
            and c.effect.effect_name != best.effect.effect_name)


def _added_outcome(chains, before, best, after, passing, ambiguity_aic) -> dict:
    close = [c for c in passing if c is not best and (c.aic - best.aic < ambiguity_aic or _load_alikes(best, c))]
    ambiguous = tuple(c.label for c in close)
    separated = tuple(dict.fromkeys(w for c in [best, *close] for w in c.separated_by))
    set_intervals = None
    if len(chains) == 1 and all(c.forcing for c in [best, *close]):
        # one speed: a fitted 1X force stands for any 1X force, also one from an effect not in the library
        ambiguous = ambiguous + (OTHER_FORCE,)
        separated = separated + (FORCE_SEPARATION,)
        flows = "; ".join(f"{c.title}: {_flows_words(c.fit)}" for c in [best, *close])
        set_intervals = _set_intervals(after, close)
        verdict = (f"Ambiguous cause: a synchronous (1X) force on the rotor explains the record "
                   f"({', '.join(c.title for c in [best, *close])}), or an effect not in the library that acts "
                   f"as one ({OTHER_FORCE_EXAMPLES}). At one speed these are the same force, so the flows hardly "
                   f"depend on which: {_flow_labels(before)} = {flows} ml/min (plain model: {_flows_words(before)}). To tell the "
                   f"causes apart: {'; or '.join(separated)}.")
    elif close:
        flows = "; ".join(f"{c.title}: {_flows_text(c.fit)}" for c in [best, *close])
        set_intervals = _set_intervals(after, close)
        verdict = (f"Ambiguous: {len(close) + 1} effects explain the record equally well ({flows}). "
                   f"Until a measurement tells them apart the flows are known only within "
                   f"{interval_words(set_intervals)}. To tell them apart: {'; or '.join(separated)}.")
    else:
        verdict = (f"{_story(best, after, chains[0].machine)}{_oil_words(chains, best, after)}: this explains the "
                   f"record (chi2 {before.chi2:.1f} -> {after.chi2:.1f} for {after.dof} dof). Flows re-identified "
                   f"with it: {', '.join(f'Q{k + 1} = {q * MLMIN_PER_M3S:.0f}' for k, q in enumerate(fit_flows(after)))}"
                   f" ml/min (plain model: {_flows_words(before)})."
                   + (ORBIT_REFINE if best.defect is not None else ""))
    return dict(added=best, after=after, explained=True, ambiguous=ambiguous, separated_by=separated,
                set_intervals=set_intervals, verdict=verdict)


ASKED_LEVEL = 0.01  # an effect is asked for when its chi2 drop beats the likelihood ratio's point at this level over
# the n single candidates tried (Bonferroni: level / n each)


@dataclass(frozen=True)
class Asked:
    """The single candidate that lowers a passing plain fit's chi2 beyond chance (`_asked_for`)."""

    candidate: Candidate
    drop: float  # chi2 of the plain fit less the candidate's
    k: int  # the parameters the candidate adds
    point: float  # the likelihood ratio's point: chi2 with k dof at 1 - ASKED_LEVEL / n
    n: int  # the single candidates tried and the further nodes their scans fitted


def _asked_for(before: Fit, tried, scanned: int = 0, level: float = ASKED_LEVEL) -> Asked | None:
    """The single candidate whose drop in chi2 against the plain fit most exceeds the likelihood ratio's point at
    `level` / n, or None when none does: n the single candidates tried and the `scanned` further nodes their node
    scans fitted (each a candidate the best of a scan was picked from). The plain model can pass its own test and still
    leave something an effect takes up beyond chance: a set of three speeds of hot oil on the fan passed (chi2 17.1
    for 15 dof) with its flows 13-24 % low, and thinner oil lowered chi2 by 15.0 for one parameter against a point of
    13.3 (1 % over 37 candidates). Over the loops' clean records (session 52) it asked once in 120: the paper's 40 and
    the pump's 40 never, the fan's #103 for pedestals (drop 17.5 against 14.5), an ambiguity whose flows hold."""
    singles = [c for c in tried if c.fit is not None and not c.partners and c.defect is None]
    n = len(singles) + int(scanned)
    best = None
    for c in singles:
        k = max(len(c.fit.values) - len(before.values), 1)
        drop = before.chi2 - c.fit.chi2
        point = float(stats.chi2.ppf(1.0 - level / n, k))
        if drop > point and (best is None or drop / point > best.drop / best.point):
            best = Asked(c, drop, k, point, n)
    return best


def _asked_words(before: Fit, asked: Asked) -> str:
    return (f"The plain model passes its test (chi2 = {before.chi2:.1f} for {before.dof} dof), but "
            f"{asked.candidate.title} lowers chi2 by {asked.drop:.1f} for {asked.k} parameter"
            f"{'s' if asked.k > 1 else ''}, more than chance allows over the {asked.n} candidates tried (a drop of "
            f"{asked.point:.1f} at {100 * ASKED_LEVEL:g} % over them): the record asks for an effect. ")


def _unexplained_outcome(before, tried, refused) -> dict:
    closest = tried[0] if tried and tried[0].fit is not None else None
    left = "" if closest is None else (f" The closest candidate, {closest.title}, still leaves chi2 = "
                                       f"{closest.fit.chi2:.1f} for {closest.fit.dof} dof.")
    if refused:
        left = " " + "; ".join(
            f"{c.title} passed the screening fit (chi2 = {c.fit.chi2:.1f}) but not once refined with its "
            f"intervals (chi2 = {r.chi2:.1f} for {r.dof} dof)" for c, r in refused) + "."
    verdict = ("Unexplained: the model does not fit the record and no effect in the library brings the "
               f"residual back to noise (plain chi2 = {before.chi2:.1f} for {before.dof} dof)." + left +
               " Do not trust the flows; check the machine and the measurement.")
    return dict(added=None, after=None, explained=False, ambiguous=(), separated_by=(), set_intervals=None,
                verdict=verdict)


def _threshold_words(diagnosed, declared) -> str:
    """' ... bearing 1's is Q_T = 992 ml/min (declared bearing: 545).' where the diagnosed machine's Q_T differs
    from the declared one's: the flows are judged against it."""
    if declared is None:
        return ""
    words = [f"bearing {k + 1}'s is Q_T = {a * MLMIN_PER_M3S:.0f} ml/min (declared bearing: {b * MLMIN_PER_M3S:.0f})"
             for k, (a, b) in enumerate(zip(diagnosed, declared)) if abs(a / b - 1) > 0.01]
    return (" The flooded thresholds the flows are judged against are those of the machine as diagnosed: "
            + "; ".join(words) + ".") if words else ""


def _line_words(lines, orbit_tried: bool) -> str:
    """What the verdict adds for the record's lines beyond 1X: mains pickup named apart, the others with their
    usual causes (the flows rest on the 1X line)."""
    from ..signals.lines import CAUSES, LINE_NOTICE

    words = ""
    pickup = [line for line in lines if line.kind == "mains" and line.relative_to_1x > LINE_NOTICE]
    if pickup:  # not the machine: named apart from the lines the model lacks
        words += (" The record also holds " + "; ".join(line.describe() for line in pickup) + ": " +
                  CAUSES["mains"] + ". The flows rest on the 1X line, which it does not touch.")
    big = [line for line in lines if line.relative_to_1x > LINE_NOTICE and line.kind != "mains"]
    if big:
        words += (" Beyond 1X the record also holds " + "; ".join(line.describe() for line in big) +
                  ", which the linear model does not produce" +
                  ((" (the library's large_orbit effect, the film solved along the orbit, makes 2X lines: it "
                    "was fitted, see the candidates)" if orbit_tried else
                    " (the library's large_orbit effect, the film solved along the orbit, makes 2X lines; a "
                    "diagnosis fits it on a single record the plain model does not explain)")
                   if any("2X" in line.kind for line in big) else "") +
                  " (usual causes: " +
                  "; ".join(dict.fromkeys(CAUSES[line.kind] for line in big)) + "): the flows rest on the 1X part.")
    return words


def _finding_words(findings) -> str:
    """What the verdict leads with when the record is impossible or suspicious as declared."""
    if not findings:
        return ""
    impossible = [f.text for f in findings if f.impossible]
    odd = [f.text for f in findings if not f.impossible]
    return ((("The record cannot be what it declares: " + ". ".join(impossible) + ". ") if impossible else "") +
            (("Check the record: " + ". ".join(odd) + ". ") if odd else "") +
            "The flows below rest on amplitude ratios and angles, which a scale error does not change. ")


def _whirl_words(chain, added, final: Fit, line):
    """The machine's least stable mode on the films at the flows found (the winner's bearing changes, a
    viscosity or a clearance, included), and what it says of a sub-synchronous `line` (`rotor.whirl`)."""
    from ..rotor.whirl import mode_stability, whirl_reading

    c = chain
    if added is not None and added.defect is None and any(e.stage == "bearings" for e in added.effects):
        c = chain.adding(*(e.candidate() for e in added.effects if e.stage == "bearings"))
    theta = whole_theta(c, final)
    coefficients = []
    for k, src in enumerate(c.sources):
        K, C, _ = src.evaluate(theta[k], *c.bearing_changes(k, theta))
        coefficients.append((K, C))
    stab = mode_stability(c.rotor, c.omega, coefficients)
    return stab, whirl_reading(stab, abs(line.order) * c.omega / (2 * np.pi))


def _fit_orbit(chain, measured, effect, names, budget, level, progress) -> Candidate:
    """Large orbits as a candidate: the flows fitted with the film force along the orbit (`identify.fit.large_orbit`,
    a harmonic balance per round: tens of seconds), no parameter added."""
    from ..identify.fit.large_orbit import check_orbit_chain, fit_large_orbit

    try:
        check_orbit_chain(chain)
        of = fit_large_orbit(chain, measured, names=names, budget=budget, level=level,
                             progress=lambda i, n, t: progress(i, n, f"{effect.title()}: {t}"))
    except LubevizError as exc:
        return Candidate(label=effect.label(), effect=effect, fit=None, error=str(exc))
    return Candidate(label=effect.label(), effect=effect, fit=of.fit, defect=of.defect,
                     unbalance_scale=of.unbalance_scale)


def _set_intervals(after: Fit, others) -> tuple:
    """Per flow, the union of the winner's 95 % profile interval and the other candidates' +-1.96 sigma (None for
    a known supply), within the search's box: a member's linearized interval past the box's lower edge ends there
    (as a profile interval does), past its upper edge it is open (a flow the record hardly constrains, such as an
    unmeasured bearing's, had "Q3 in [-46081, open] ml/min" on the fan, session 45)."""
    box = {p.key: tuple(None if b is None else b / MLMIN_PER_M3S for b in p.bounds)  # the parameters' ml/min
           for p in getattr(after, "params", ()) if getattr(p, "bounds", None) and p.key in _flow_names(after)}
    out = []
    for k, n in enumerate(_flow_names(after)):
        v, s = fit_flows(after)[k], fit_flows_std(after)[k]
        if n not in after.intervals and not s > 0:  # a known supply: held, no interval
            out.append(None)
            continue
        low, high = after.intervals.get(n) or (v - Z95 * s, v + Z95 * s)
        for c in others:
            v, s = fit_flows(c.fit)[k], fit_flows_std(c.fit)[k]
            low = min(low, v - Z95 * s)
            high = None if high is None else max(high, v + Z95 * s)
        edge_lo, edge_hi = box.get(n, (None, None))
        if edge_lo is not None:
            low = max(low, float(edge_lo))
        if high is not None and edge_hi is not None and high > float(edge_hi):
            high = None
        out.append((float(low), None if high is None else float(high)))
    return tuple(out)


def interval_words(iv) -> str:
    """'Q1 in [429, 509] ml/min and Q2 in [...]' for per-bearing intervals (m^3/s; None for a held supply, which
    is left out)."""
    return " and ".join(f"Q{k + 1} in [{v[0] * MLMIN_PER_M3S:.0f}, "
                        f"{'open' if v[1] is None else format(v[1] * MLMIN_PER_M3S, '.0f')}] ml/min"
                        for k, v in enumerate(iv) if v is not None)



OIL_RANGE = (0.75, 1.0 / 0.75)
# each bearing's static load: the model file's share of the weight, within this fraction when nothing measures it
# (the static position does): a belt's pull or a coupling out of line moves 5-10 % of a bearing's load (the issue-36
# bench draws 150-350 N against the paper's 3270 N per bearing)
LOAD_RANGE = 0.1
UNMEASURED_CLEARANCE = 1.5  # a bearing no probe watches may be worn up to this many times its declared clearance
UNWATCHED_WIDER = 1.2  # its flow's interval is widened with the constants free when that makes it this much wider (the
# others' when twice as wide): the shaft alone carries its film to the probes (bench-loop case 100, session 49: with
# its clearance free Q2's interval was 1.45 x as wide and held the truth, the named probe's alone missed it by 2 %)
UNPINNED_SEPARATION = ("the static shaft position (the probes' DC gap), records at a second speed, or, for the oil "
                       "alone, an oil temperature reading")
LOOK_ALIKES_TOLD = 4  # an explained record's look-alikes the verdict names with their flows (the JSON has them all)
OIL_MEMBERS = 3  # an ambiguity's members refitted with the constants free besides the winner (a second each, about)
OTHER_FORCE = "another 1X force (not in the library)"
OTHER_FORCE_EXAMPLES = "a seal's or a rub's cross-coupling, a misaligned coupling, a loose disc"
FORCE_SEPARATION = ("records at a second speed (an unbalance's force grows with the speed squared, a bow's and "
                    "a seal's do not)")


def _oil_declared(chains) -> bool:
    """Whether the chains already declare the oil (a record's temperature reading, or a viscosity effect)."""
    return any(e.oil_viscosity for c in chains for e in c.effects)


def _unpinned_look_alike(chains, meas, before: Fit, free, names, budget, level):
    """For a record explained with the constants as declared: do they explain it as well elsewhere in their
    plausible range (`free`, from `_unpinned`) with other flows? Per flow the union of the intervals with them
    free and `before`'s (never an interval that leaves out the answer) when, for some flow, the free one is more
    than twice as wide, or for the flow of a bearing no probe watches UNWATCHED_WIDER as wide; None otherwise.

    All of them free at once when the record has the degrees of freedom for it, else each alone (the union of their
    intervals): a fan record of two planes without the static position has 6 features for 3 flows and a turned
    probe, none left for the oil, a load and the unwatched bearing's clearance together, and the widening was dropped
    while the clearance alone carried the truth (bench-loop case 125, session 49: Q1 -3 % outside [332, 346])."""
    if not free:
        return None
    groups = [free] if sum(len(e.free) for e in free) <= before.dof else [[e] for e in free]
    wides = []
    for group in groups:
        try:
            wides.append(fit([c.adding(*group) for c in chains], meas, names=names, budget=budget, level=level))
        except LubevizError:
            continue
    if not wides:
        return None
    unwatched = unmeasured_bearings(chains[0])
    wider, ivs = False, []
    for k, n in enumerate(_flow_names(before)):
        if n not in before.intervals or any(n not in w.intervals for w in wides):  # a known supply: held
            ivs.append(None)
            continue
        joined = union_interval(before.intervals[n], *(w.intervals[n] for w in wides))
        top = chains[0].bounds()[1][k]
        width = [(top if iv[1] is None else iv[1]) - iv[0] for iv in (joined, before.intervals[n])]
        wider |= width[0] > (UNWATCHED_WIDER if k in unwatched else 2.0) * width[1]
        ivs.append(joined)
    return tuple(ivs) if wider else None


# a diagnosis fits large orbits with the 5-harmonic balance; identification's default is 16 (more time a record)
ORBIT_REFINE = (" These flows come from a 5-harmonic balance, coarser than identify's default (their sigma carries the "
                "difference); `lubeviz identify --effect large_orbit` gives them with 16 harmonics, or 8 where 16 do "
                "not settle on the machine's films (the error of each: BENCHMARKS.md \"Rates over time-integration "
                "records\").")


def fitted_effect(c: Candidate, f: Fit):
    """The candidate's (first) effect at the values of fit `f` (the winner's refined fit), and their std."""
    return fitted_effects(c, f)[0]


def fitted_effects(c: Candidate, f: Fit) -> list:
    """[(effect at the values of fit `f`, {parameter: std})] for each of the candidate's effects (a pair's two)."""
    out = []
    for e in c.effects:
        owners = {e.effect_name, e.label()}
        free = {p.name: p for p in f.params
                if p.free and not p.is_flow and p.name in e.continuous and (len(c.effects) == 1 or p.owner in owners)}
        out.append((e.copy(**{n: p.value for n, p in free.items()}), {n: p.std for n, p in free.items()}))
    return out


def _story(c: Candidate, f: Fit, machine) -> str:
    """What the winner says of the machine, in an engineer's words with its fitted values (`Effect.told`)."""
    if c.defect is not None:
        size = ("" if c.unbalance_scale is None else
                f"; the orbit's size implies {c.unbalance_scale:.2f} x the declared unbalance")
        return f"Large orbits: the film force along the orbit, not its linearization{size}"
    told = [effect.told(std, machine).rstrip(".") or effect.title() for effect, std in fitted_effects(c, f)]
    if len(told) == 1:
        return told[0]
    return "Two effects at once: " + "; and ".join(t[0].lower() + t[1:] for t in told)


def diagnosed_thresholds(chain, effects=()) -> np.ndarray:
    """Each bearing's flooded threshold Q_T (m^3/s) for the machine as diagnosed: the chain's declared effects
    and `effects` at their values change a bearing's viscosity, clearance or static load, and with them its Q_T (a worn
    bearing needs more oil to fill its larger gap: Q_T ~ c). The declared bearings' Q_T without them."""
    effects = tuple(chain.effects) + tuple(e.bind(chain.machine) for e in effects)
    out = []
    for k, src in enumerate(chain.sources):
        out.append(src.view(*bearing_changes(effects, k, src.bearing.clearance).as_floats()).q_threshold)
    return np.array(out)


def _oil_words(chains, c: Candidate, f: Fit) -> str:
    """', i.e. oil at about 49 °C instead of the declared 38 °C (ISO VG 100)' for a viscosity factor, when
    the model file declares its oil; '' otherwise."""
    oil = getattr(chains[0].machine, "oil", None)
    factor = getattr(fitted_effect(c, f)[0], "factor", None)
    if c.effect.effect_name != "viscosity" or c.partners or oil is None or factor is None:
        return ""
    t = float(oil.temperature_for_factor(float(factor)))
    return (f", i.e. oil at about {t:.0f} °C instead of the declared {oil.temperature_c:g} °C"
            f"{' (' + oil.grade + ')' if oil.grade else ''}")


def diagnosis_dict(d: Diagnosis, *, file=None) -> dict:
    """The JSON form (SPEC §7 keys: before, effects, added, after, explained, ambiguous, verdict)."""
    def fit_dict(f: Fit | None):
        if f is None:
            return None
        s = f.summary()
        flows = [p for p in f.params if p.is_flow]
        out = {f"{p.key}_mlmin": p.value for p in flows}
        out.update({f"{p.key}_std_mlmin": p.std for p in flows})
        out.update({"chi2": s["chi2"], "dof": s["dof"], "p_value": s["p_value"], "model_explains_data": s["explained"],
                    "aic": f.aic, "features": s["features"], "residual_sigma": s["residual"],
                    "parameters": {p.key: {"value": p.value, "std": p.std} for p in f.params
                                   if p.free and not p.is_flow},
                    "warnings": s["warnings"]})
        for p in flows:
            out[f"{p.key}_interval_mlmin"] = None if p.interval is None else list(p.interval)
        from ..identify.output.export import flow_objects

        out["flows"] = flow_objects(flows, d.bearings, d.thresholds_for(f), d.verdicts_for(f))  # SPEC §8
        return out

    effects = [{"name": " + ".join(e.effect_name for e in c.effects), "label": c.label, "parameters": c.parameters(),
                "residual_after": None if c.fit is None else c.fit.chi2,
                "evidence": None if c.fit is None else {"aic": c.fit.aic, "delta_aic": c.aic - d.candidates[0].aic,
                                                         "dof": c.fit.dof, "p_value": c.fit.p_value,
                                                         "passes": c.passes,
                                                         **{f"q{k + 1}_mlmin": v * MLMIN_PER_M3S
                                                            for k, v in enumerate(fit_flows(c.fit))}},
                "error": c.error or None} for c in d.candidates]
    out = {"before": fit_dict(d.before), "effects": effects,
           "added": None if d.added is None else d.added.label,
           "after": fit_dict(d.after), "explained": d.explained, "ambiguous": list(d.ambiguous),
           "rivals": list(d.rivals), "pair_untested": bool(d.pair_untested),
           "separated_by": list(d.separated_by), "verdict": d.verdict, "seconds": d.seconds,
           "lines_beyond_1x": [line.as_dict() for line in d.lines],
           "record_findings": [f.as_dict() for f in d.findings],
           "q_threshold_mlmin": None if d.q_threshold is None else (d.q_threshold * MLMIN_PER_M3S).tolist(),
           "q_threshold_declared_mlmin": None if d.q_threshold_declared is None else
           (np.asarray(d.q_threshold_declared) * MLMIN_PER_M3S).tolist(),
           "verdicts": None if d.q_threshold is None else d.verdicts_for(d.final),
           "node_scans": [s.as_dict() for s in d.scans],
           # faults of a typical size the record (explained by the plain model) cannot tell from none
           "not_seen": [u.as_dict() for u in d.not_seen],
           # the plain model passed, but one candidate lowered chi2 beyond chance over all those tried
           "asked_for": None if d.asked is None else {
               "label": d.asked.candidate.label, "chi2_drop": d.asked.drop, "parameters": d.asked.k,
               "point": d.asked.point, "level": ASKED_LEVEL, "candidates": d.asked.n},
           "stability_at_flows": None if d.stability is None else {
               "text": d.stability.describe(), "unstable": d.stability.unstable,
               "least_stable_mode_hz": d.stability.frequency_hz, "growth_per_s": d.stability.growth,
               "damping_ratio": d.stability.damping_ratio}}
    for k, n in enumerate(_flow_names(d.before)):  # an ambiguity: the flows over the whole set (None: not ambiguous)
        iv = None if d.set_intervals is None else d.set_intervals[k]
        out[f"{n}_interval_set_mlmin"] = None if iv is None else [iv[0] * MLMIN_PER_M3S,
                                                                  None if iv[1] is None else iv[1] * MLMIN_PER_M3S]
    if file is not None:
        out["file"] = file
    if d.truth:
        out["truth"] = d.truth
        q = d.truth.get("q_mlmin")
        if q is not None:
            out["flow_error_pct_before"] = [100 * (v * MLMIN_PER_M3S / t - 1) for v, t in zip(fit_flows(d.before), q)]
            out["flow_error_pct_after"] = [100 * (v * MLMIN_PER_M3S / t - 1) for v, t in zip(fit_flows(d.final), q)]
    return out


def cost_map(chain, measured, *, effect=None, names=None, budget=None, n: int = 60, lower: float = 0.25,
             upper: float = 2.0, candidate: Candidate | None = None, pair: tuple[int, int] = (0, 1), flows=None):
    """chi^2 over the box of two flows `pair` (0-based; the effect's parameters at `effect`'s values, the other
    flows at `flows`, default their Q_T), for drawing the search: returns (qi (n,), qj (n,), chi2 (n, n)),
    flows in m^3/s; the same whitening as the fit at Q_T.
    `candidate`: a diagnosis's candidate instead of `effect` (large orbits: the chain with its correction,
    which holds near its fit and is drawn over the whole box as the fit saw it)."""
    if candidate is not None:
        if candidate.defect is not None:
            chain = [c.with_defect(candidate.defect) for c in (chain if isinstance(chain, (list, tuple)) else [chain])]
        else:
            effect = candidate.effect
    from ..identify.fit.maps import chi2_grid, pair_grid

    chains = list(chain) if isinstance(chain, (list, tuple)) else [chain]
    if effect is not None:
        chains = [c.adding(effect.hold()) for c in chains]
    held = chains[0].start()
    if flows is not None:
        held[:chains[0].n_flows] = np.asarray(flows, dtype=float)
    q1, q2, pts = pair_grid(chains, pair, held, n=n, lower=lower, upper=upper)
    return q1, q2, chi2_grid(chains, measured, pts, names=names, budget=budget)
