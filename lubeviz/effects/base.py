"""What every effect is: a small `param.Parameterized` class that changes one stage of the forward chain.

The forward chain (`lubeviz.identify.forward.chain.ForwardChain`) has fixed, named stages:

    bearings (K, C and journal position of each bearing)  ->  rotor (forces, supports)
    ->  probes (what the sensors read)  ->  features

An effect declares its `effect_name` (SPEC §7), the `stage` it changes, its parameters once (bounds, unit, doc),
which of them are *placement* (discrete: which bearing, plane, channel or node; always held) and which
are *continuous* (a fit may free them), and the hooks of its stage (declared on `Effect` with what "no
change" is). The chain calls the hooks with arrays of parameter values, so one call evaluates a whole batch of trial
points (a Jacobian, a map). An effect never reaches into a kernel: it transforms what a stage hands it.
"""

from __future__ import annotations

import difflib
import math
import re
from typing import ClassVar

import numpy as np
import param

from ..errors import InputError

SHOWN_CHOICES = 16  # a refused choice's message lists this many of the allowed ones (a wiring fault has 116)
STAGES = ("bearings", "rotor", "probes", "response")  # response: replaces the linear response (large_orbit)


class Effect(param.Parameterized):
    """Base of the effect library. Subclasses set `effect_name`, `stage`, `continuous`, `placement`, override
    the hooks of their stage (declared below with what "no change" is) and register with `@register`."""

    effect_name: ClassVar[str] = ""  # SPEC §7 name (param reserves `name`)
    stage: ClassVar[str] = ""
    continuous: ClassVar[tuple[str, ...]] = ()  # parameters a fit may free (real numbers)
    placement: ClassVar[tuple[str, ...]] = ()  # discrete parameters (which bearing/plane/channel/node)
    neutral: ClassVar[dict] = {}  # continuous values at which the effect changes nothing
    step: ClassVar[dict] = {}  # finite-difference step of each continuous parameter (its own unit)
    # further values of a continuous parameter at which a fit's global search over the flows also looks (besides
    # its start): a size the flows mimic from the start (hot oil as more oil) can leave the true size in another
    # basin. Machine-relative values: override `search_values`.
    search: ClassVar[dict] = {}
    diagnose_free: ClassVar[tuple[str, ...]] = ()  # what a diagnosis fits (the others held at defaults)
    diagnosed: ClassVar[bool] = True  # whether a diagnosis tries this effect (each placement)
    separated_by: ClassVar[str] = ""  # the measurement that tells this effect from look-alikes
    # True for an effect that acts as a synchronous (1X) force on the rotor with a free magnitude and
    # phase: at one speed it can stand for any other such force, including effects not in the library
    forcing: ClassVar[bool] = False
    # True for an effect that is the oil's viscosity (an oil temperature reading settles it)
    oil_viscosity: ClassVar[bool] = False
    # True for an effect that changes the bearings' static loads (the static position or several speeds settle it)
    static_load: ClassVar[bool] = False
    # The effect and its placement in an engineer's words, for pages, verdicts and reports (`title`): each
    # {placement} field is written as words ("bearing 1", "every bearing", "node 10"); `label` stays the key of code
    # and JSON.
    title_words: ClassVar[str] = ""
    kind_words: ClassVar[str] = ""  # what the effect is, without its placement ("a second unbalance")

    @classmethod
    def kind(cls) -> str:
        """What the effect is in words, without its placement: `kind_words`, else its name with spaces."""
        return cls.kind_words or cls.effect_name.replace("_", " ")

    def __init__(self, **params):
        super().__init__(**params)
        given = set(params)
        self._free = tuple(p for p in self.continuous if p not in given)

    @property
    def moves_weight_loads(self) -> bool:
        """Whether this effect, as placed, changes the bearings' static loads along the weight (so a diagnosis holds
        no other load change along it as an unknown beside it, `diagnose.loop._unpinned`): every `static_load`
        effect, unless it says it acts across the weight only (`SideLoad` with its direction given across it)."""
        return self.static_load

    # --- the machine ------------------------------------------------------------------------------
    def bind(self, machine) -> "Effect":
        """This effect ready for `machine` (most need nothing of it; an oil temperature needs its oil).
        Raises InputError when the machine lacks what the effect needs."""
        return self

    def shown(self, **values) -> "Effect":
        """The same effect at other `values`, the same parameters free (unlike `copy`, which holds them)."""
        new = self.copy(**values)
        new._free = self._free
        return new

    def demo(self, machine) -> "Effect":
        """This effect bound to `machine` at a strength a student sees on the pages (default: its defaults)."""
        return self.bind(machine)

    def declared(self, pname: str, machine) -> float:
        """The value of continuous parameter `pname` at which the machine is as declared (a fit's start
        when the parameter is None)."""
        return float(self.neutral.get(pname, 0.0))

    def search_values(self, pname: str, machine) -> tuple[float, ...]:
        """Values of continuous parameter `pname`, besides its start, where a fit's global search over the flows also
        looks (`search`; default none)."""
        return tuple(float(v) for v in self.search.get(pname, ()))

    # --- the stages' hooks: each declared here with "no change"; an effect overrides those of its stage ----
    # `values`: trial values of the free continuous parameters ({name: array of the batch `shape`}; see
    # `as_array`), so one call evaluates a whole batch of trial points.

    def typical_values(self, pname: str, chain) -> tuple[float, ...]:
        """Sizes of `pname` a fault of this kind typically has on `chain`'s machine (`search`'s by default): a
        diagnosis says when a record explained by the plain model cannot see the effect at such a size
        (`diagnose.loop._not_seen`)."""
        return tuple(float(v) for v in self.search.get(pname, ()))

    # bearings stage (and any effect that moves the bearings' static loads: the chain asks every stage)
    def bearing_change(self, k: int, values: dict, shape) -> dict:
        """What this effect changes of bearing `k` (0-based): {'viscosity_factor': x, 'clearance': m,
        'load_factor': x}, or {}."""
        return {}

    def static_load_change(self, values: dict, shape):
        """(..., N, 2) how much this effect changes every film's static load (N, the films held where the declared
        statics put them), or None. On 3+ supports the load shift then lets the films yield (`rotor.load_shift`):
        the loads' size and lean both follow."""
        return None

    def housing_sag(self, k: int, values: dict, shape):
        """(...,) how much more (m/N) the pedestal the model file declares under bearing `k` (0-based) yields to its
        static load than declared (1 / its stiffness now - 1 / the declared), or None; asked only of an effect that
        `changes_housing(k)`. On 3+ supports a softer pedestal sheds load onto the other supports
        (`ForwardChain._numpy_states`); two supports do not notice."""
        return None

    def bearing_offset(self, k: int, values: dict, shape):
        """How far bearing `k`'s (0-based) centre sits from its declared place, (..., 2) m (dX, dY), or None. On 3+
        supports it moves the static loads (`rotor.load_shift`); two supports do not notice."""
        return None

    # rotor stage: extra synchronous forcing
    def forcing_shapes(self, rotor, omega: float, machine) -> list:
        """Force vectors (rotor DOFs) whose weighted sum this effect adds to the unbalance's; [] for none."""
        return []

    def forcing_weights(self, values: dict, shape):
        """(..., n) complex weights of `forcing_shapes`."""
        raise NotImplementedError(f"{type(self).__name__} declares forcing shapes but no weights")

    # rotor stage: a support in series with a bearing's film
    def applies(self, k: int) -> bool:
        """Whether this effect puts a support under bearing `k` (0-based)."""
        return False

    def support(self, k: int, B, omega: float, values: dict, shape):
        """(B_eff, T) for bearing `k`: the film's dynamic stiffness B in series with the support, and the
        housing's motion per journal motion (the probes read the shaft relative to it); None: no support."""
        return None

    def housing(self, values: dict) -> tuple[float, float, float]:
        """(mass kg, stiffness N/m, damping N s/m) of the support's housing at `values`, for the direct check
        of the assembled system (`ForwardChain.direct_output`)."""
        raise NotImplementedError(f"{type(self).__name__} puts a support under a bearing but declares no housing")

    # rotor stage: a pedestal the model file declares under a fluid-film bearing, other than declared
    def changes_housing(self, k: int) -> bool:
        """Whether this effect changes the pedestal the model file declares under bearing `k` (0-based)."""
        return False

    def housing_change(self, k: int, omega: float, values: dict, shape):
        """(..., 2, 2) complex change of the dynamic stiffness to ground (k - Omega^2 m + i Omega c) of the pedestal
        declared under bearing `k`, or None."""
        return None

    # rotor stage: a constant support (the model file's [[supports]]) stiffer or softer than declared
    def changes_support(self, j: int) -> bool:
        """Whether this effect changes constant support `j` (0-based, in the model file's order)."""
        return False

    def support_change(self, j: int, omega: float, values: dict, shape):
        """(..., 2, 2) complex change of constant support `j`'s dynamic stiffness K + i Omega C (acting between its
        node and the ground, or the pedestal its file declares under it), or None."""
        return None

    # probes stage
    def probe_matrix(self, plane: int, angles_deg, values: dict, shape):
        """(..., 2, 2) matrix taking plane `plane`'s (0-based) displacement to what its probes, resolved with
        the declared angles, read; None when this effect does not change that plane."""
        return None

    def rewire(self, d, static, probe_angles_deg):
        """The readings of every plane `d` (..., planes, [x, y]) and their static offsets as the record's
        columns hold them (a measurement mixed up between planes or channels); applied after `probe_matrix`."""
        return d, static

    # --- fitting ---------------------------------------------------------------------------------
    @property
    def free(self) -> tuple[str, ...]:
        """Continuous parameters not given by the user: a fit varies them, a simulation uses the defaults."""
        return self._free

    def hold(self, *names: str) -> "Effect":
        """The same effect with `names` held at their current values (or all, without names)."""
        names = names or self.continuous
        new = self.copy()
        new._free = tuple(p for p in self._free if p not in names)
        return new

    def release(self, *names: str) -> "Effect":
        """The same effect with `names` (default: every continuous parameter) free in a fit."""
        names = names or self.continuous
        new = self.copy()
        new._free = tuple(p for p in self.continuous if p in names or p in self._free)
        return new

    def copy(self, **changes) -> "Effect":
        values = {k: getattr(self, k) for k in self.param if k != "name"}
        values.update(changes)
        new = type(self)(**values)
        new._free = tuple(p for p in self._free if p not in changes)
        new._limits = {k: v for k, v in getattr(self, "_limits", {}).items() if k not in changes}
        return new

    def limited(self, **limits) -> "Effect":
        """The same effect with narrower fitting bounds, e.g. `limited(factor=(0.75, 1.33))`: a plausible
        range for a nuisance parameter, inside the parameter's declared bounds."""
        new = self.copy()
        new._free = self._free
        new._limits = {**getattr(self, "_limits", {}), **limits}
        return new

    def bounds(self, pname: str) -> tuple[float, float]:
        if pname in getattr(self, "_limits", {}):
            return tuple(float(v) for v in self._limits[pname])
        lo, hi = self.param[pname].bounds
        return (-math.inf if lo is None else float(lo), math.inf if hi is None else float(hi))

    def values(self) -> dict:
        """Every parameter's current value (placement and continuous)."""
        return {p: getattr(self, p) for p in (*self.placement, *self.continuous)}

    def label(self) -> str:
        """'pedestals[bearing=1]': the name and its placement, what tells two candidates apart."""
        if not self.placement:
            return self.effect_name
        return f"{self.effect_name}[" + ",".join(f"{p}={getattr(self, p)}" for p in self.placement) + "]"

    def title(self) -> str:
        """'the clearance of bearing 1': the effect and its placement in words (`title_words`), what a page, a verdict
        and a report call it; the label where a class has no words."""
        if not self.title_words:
            return self.label()
        return self.title_words.format(**{p: place_words(p, getattr(self, p)) for p in self.placement})

    def spec(self) -> str:
        """SPEC §7 form, NAME:key=value,... with every parameter (round-trips through `parse_effect`)."""
        return self.effect_name + ":" + ",".join(f"{k}={_fmt(v)}" for k, v in self.values().items())

    def unit(self, pname: str) -> str:
        p = self.param[pname]
        return getattr(p, "unit", "") or ""

    def candidate(self) -> "Effect":
        """This effect as a diagnosis tries it: `diagnose_free` free, everything else held."""
        new = self.copy()
        new._free = tuple(p for p in self.continuous if p in self.diagnose_free)
        return new

    def placements(self, *, n_bearings: int, n_planes: int, n_supports: int = 0) -> list["Effect"]:
        """Every placement of this effect on a machine of `n_bearings` fluid-film bearings and `n_supports` constant
        supports measured at `n_planes` planes (each bearing, support, plane, channel...): the candidates to try."""
        return [self]

    def placeable(self, rotor) -> bool:
        """Whether this placement can act on `rotor` (True: the default): a constant support's change needs the
        support."""
        return True

    def scan_nodes(self, rotor) -> tuple[int, ...]:
        """The rotor nodes where this effect can act, when where it acts is a node a diagnosis should scan
        (`diagnose.scan`): every one is fitted and the profile kept. () (the default): no scan, `placements`."""
        return ()

    def summary(self) -> str:
        """What this effect in its placement is, in a few words, when its fitted values do not say it ('' then)."""
        return ""

    def describe(self) -> str:
        return (type(self).__doc__ or "").strip().split("\n\n")[0]

    def told(self, std: dict | None = None, machine=None) -> str:
        """The effect in an engineer's words: its story (the description's first sentence) with each parameter
        quoted there as `name` replaced by its value, +- its std where `std` has one, and the declared value
        where `machine` gives one: 'Bearing 1 has radial clearance 149.7 +- 1.3 um (declared 120 um) instead of
        the declared one.'"""
        std = std or {}
        first = self.describe().split(". ")[0].rstrip(".") + "."

        def value(m):
            name = m.group(1)
            if name not in self.param:
                return name
            v = getattr(self, name)
            if name in self.placement:  # "plane 1", but "Bearing 1" where the text already names it
                before = m.string[:m.start()].rstrip().rsplit(" ", 1)[-1].lower()
                return str(v) if before == name else f"{name} {v}"
            if v is None:
                return f"(declared {name})"
            unit = f" {self.unit(name)}" if self.unit(name) else ""
            s = std.get(name)
            text = f"{_told(v)}{'' if s is None else ' +- ' + format(s, '.2g')}{unit}"
            if machine is not None and name in self.continuous and type(self).declared is not Effect.declared:
                text += f" (declared {_told(self.declared(name, machine))}{unit})"  # the machine file's value
            return text

        return re.sub(r"`(\w+)`", value, first)


def place_words(name: str, value) -> str:
    """A placement's value in words: bearing 1, every bearing, node 10, plane 2, support 1, span 2 (others as given)."""
    if name == "bearing":
        return "every bearing" if value in ("both", "all") else f"bearing {value}"
    if name in ("node", "plane", "support", "span"):
        return f"{name} {value}"
    return str(value)


def _told(v) -> str:
    return f"{v:.4g}" if isinstance(v, float) else str(v)


def _fmt(v) -> str:
    if isinstance(v, float):
        return f"{v:.10g}"
    return str(v)


class Registry(dict):
    """{name: Effect subclass}; parses SPEC §7's NAME:key=value,... and names the closest key on a typo.
    `register` is a class decorator: an effect module registers its class where it is written."""

    def register(self, cls):
        if not cls.effect_name or cls.stage not in STAGES:
            raise TypeError(f"effect class {cls.__name__} needs a name and a stage in {STAGES}")
        self[cls.effect_name] = cls
        return cls

    def parse(self, text: str, machine=None) -> Effect:
        """`machine` (optional): a bearing, plane or support may then be given by its name in the model file (SPEC
        §8), as well as by its number."""
        text = str(text).strip()
        name, _, rest = text.partition(":")
        name = name.strip()
        if name not in self:
            close = difflib.get_close_matches(name, list(self), n=1)
            hint = f"; did you mean {close[0]!r}?" if close else ""
            raise InputError(f"unknown effect {name!r}{hint} (known effects: {', '.join(sorted(self))})")
        cls = self[name]
        allowed = (*cls.placement, *cls.continuous)
        params = {}
        for item in filter(None, (s.strip() for s in rest.split(","))):
            key, eq, value = (s.strip() for s in item.partition("="))
            if not eq:
                raise InputError(f"effect {name}: {item!r} is not key=value (allowed keys: {', '.join(allowed)})")
            if key not in allowed:
                close = difflib.get_close_matches(key, allowed, n=1)
                hint = f"; did you mean {close[0]!r}?" if close else ""
                raise InputError(f"effect {name}: unknown parameter {key!r}{hint} "
                                 f"(allowed: {', '.join(allowed)})")
            if key in params:
                raise InputError(f"effect {name}: parameter {key!r} given twice")
            params[key] = _convert(cls, key, _part_number(machine, key, value, name), name)
        try:
            return cls(**params)
        except ValueError as exc:  # param's bound or selector message
            raise InputError(f"effect {name}: {exc}") from None


def _part_number(machine, key: str, value: str, name: str) -> str:
    """A placement on a bearing, plane or support of `machine` by its number or its name (`Machine.part_number`);
    any other key's value, or any value without a machine, as given."""
    if machine is None or key not in ("bearing", "plane", "support"):
        return value
    return machine.part_number(key, value, f"effect {name}: {key}", words=EVERY_BEARING if key == "bearing" else ())


def _convert(cls, key: str, value: str, name: str):
    p = cls.param[key]
    if isinstance(p, param.Selector):
        for obj in p.objects:
            if str(obj) == value:
                return obj
        shown = [str(o) for o in p.objects][:SHOWN_CHOICES]
        more = f", ... ({len(p.objects)} in all)" if len(p.objects) > SHOWN_CHOICES else ""
        raise InputError(f"effect {name}: {key}={value!r}; expected one of {', '.join(shown)}{more}")
    try:
        if isinstance(p, param.Integer):
            return int(value)
        v = float(value)
    except ValueError:
        raise InputError(f"effect {name}: {key}={value!r} is not a number") from None
    if not math.isfinite(v):
        raise InputError(f"effect {name}: {key}={value!r} is not finite")
    lo, hi = p.bounds or (None, None)
    if (lo is not None and v < lo) or (hi is not None and v > hi):
        unit = getattr(p, "unit", "") or ""
        raise InputError(f"effect {name}: {key}={value} is out of bounds [{lo}, {hi}] {unit}".rstrip())
    return v


def as_array(values: dict, effect: Effect, pname: str, shape) -> np.ndarray:
    """A continuous parameter as an array broadcast to the batch `shape` (its value, or the trial values)."""
    v = np.asarray(values[pname] if pname in values else getattr(effect, pname), dtype=float)  # (a param read
    return v if v.shape == tuple(shape) else np.broadcast_to(v, shape)  # and numpy's broadcast_to cost microseconds)


EFFECTS = Registry()  # the library: every registered effect, by SPEC §7 name
register = EFFECTS.register


# Placements over a machine's own parts (SPEC §8: bearing = 1..N, or "both"/"all"; plane = 1..P; channel = x1..yP)
MAX_BEARINGS = 6  # SPEC §8: 1 to 6 fluid-film bearings
MAX_PLANES = 12
EVERY_BEARING = ("both", "all")  # either word: every fluid-film bearing
BEARING_CHOICES = ["both", "all", *range(1, MAX_BEARINGS + 1)]
PLANE_CHOICES = list(range(1, MAX_PLANES + 1))
CHANNEL_CHOICES = [f"{a}{p}" for p in PLANE_CHOICES for a in "xy"]


def on_bearing(choice, k: int) -> bool:
    """Whether a `bearing` choice (1..N, "both", "all") covers bearing k (0-based)."""
    return choice in EVERY_BEARING or choice == k + 1


def every_bearing_word(n_bearings: int) -> str:
    """How every bearing is called: "both" for two, "all" otherwise."""
    return "both" if n_bearings == 2 else "all"


def first_bearing(choice) -> int:
    """The (0-based) bearing a choice names, the first one for every bearing."""
    return 0 if choice in EVERY_BEARING else int(choice) - 1


def check_bearing_choice(choice, machine, what: str) -> None:
    from ..errors import InputError

    n = len(machine.bearings)
    if choice not in EVERY_BEARING and not 1 <= int(choice) <= n:
        raise InputError(f"effect {what}: bearing {choice!r}, but the machine has {n} fluid-film bearings (1..{n}, "
                         f"or {every_bearing_word(n)})")

