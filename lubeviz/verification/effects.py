"""The effects of the independent record source, declared here on their own (SPEC §7 names).

Deliberately NOT `lubeviz.effects`: a test record whose effect were built by the code the diagnosis
uses would only test that code against itself. Each effect is a name and a parameter table; the
physics lives where the record is built (`independent.py`), each hook a few lines long:

- `viscosity` (factor = true/declared viscosity, bearing both|1|2|..., both: every fluid-film bearing): the film
  is solved at mu * factor.
- `clearance` (clearance_um, bearing both|1|2|...): the film is solved with that radial clearance; the
  rest reading of the static position is then (0, -c_true).
- `unbalance2` (node, ratio, phase_deg): a second unbalance at `node`, moment ratio * m_u, phase =
  main phase + phase_deg.
- `pedestals` (mass_kg, stiffness_n_m, damping_ns_m, bearing both|1|2|...): each chosen housing is a point
  mass on an isotropic spring and damper to ground (x, y DOFs); the film K, C act between journal and
  housing, and the probes of plane k read the shaft relative to housing k.
- `probe_rotation` (plane 1|2|..., angle_deg, + from +X to +Y): that probe pair is turned by the angle but
  declared at its nominal angles, so the resolved reading is R(-angle) d.
- `probe_gain` (channel x1|y1|x2|y2|..., gain): that probe's raw reading (gap included) times gain.
- `bow` (node, amplitude_um, phase_deg, from_node = 0, to_node = 0): a residual bow
  sin(pi (z - z_a)/(z_b - z_a)) between nodes from_node and to_node (0, 0: the outermost bearing centres),
  |bow(node)| = amplitude, turning with the shaft at phase_deg from the unbalance; it loads the rotor with the
  rotating force K_shaft q_bow(t).
- `seal` (node, kxy_n_m, kxx_n_m = 0): an effect NOT in the diagnosis library (for "unexplained" tests):
  a seal or a rub at a node, with cross-coupled stiffness K[x, y] += kxy, K[y, x] -= kxy and direct
  stiffness K[x, x] += kxx, K[y, y] += kxx. (Cross-coupling alone destabilizes the whirl mode before it
  shows in 1X; the direct part moves the critical speed, which 1X shows.)
- `side_load` (node, force_n, moment_nm = 0, angle_deg = 0): a static force of force_n at `node`, pointing
  angle_deg from straight down towards +X (0: along the weight), and a couple of moment_nm in the vertical plane
  made of two opposite vertical forces at the node and its neighbour on the finer rotor (> 0: the one that loads
  bearing 1 more). The bearings' static loads are the reactions of the finer rotor pinned at its journals, each
  film solved at its own load, in its own direction (a horizontal part turns the film's load line: the
  diagnosis's tables hold vertical loads only, so such a record is outside its library).

- `misalignment` (bearing 1|2|..., dx_um = 0, dy_um = 0): that bearing's centre moved from where the model file
  puts it (its offset_um plus these), the housing and its probes with it: on 3+ supports the shaft held at the
  journals' new places shares its weight otherwise (a statically determinate machine does not notice).

Nodes are given in the machine's own numbering (the paper's 1..21), whatever the independent rotor's
finer mesh. Effects compose: a list of them is applied in order (gains multiply, rotations add,
unbalances and bows add; a bearing's pedestal can be given once).
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from types import MappingProxyType

from ..errors import InputError

REQUIRED = object()

# name -> {parameter: default (REQUIRED when it must be given)}
EFFECTS: dict[str, dict[str, object]] = {
    "viscosity": {"factor": REQUIRED, "bearing": "both"},
    "clearance": {"clearance_um": REQUIRED, "bearing": "both"},
    "unbalance2": {"node": REQUIRED, "ratio": REQUIRED, "phase_deg": 0.0},
    "pedestals": {"mass_kg": REQUIRED, "stiffness_n_m": REQUIRED, "damping_ns_m": 0.0, "bearing": "both"},
    "probe_rotation": {"plane": REQUIRED, "angle_deg": REQUIRED},
    "probe_gain": {"channel": REQUIRED, "gain": REQUIRED},
    "bow": {"node": REQUIRED, "amplitude_um": REQUIRED, "phase_deg": 0.0, "from_node": 0, "to_node": 0},
    "seal": {"node": REQUIRED, "kxy_n_m": REQUIRED, "kxx_n_m": 0.0},
    "side_load": {"node": REQUIRED, "force_n": REQUIRED, "moment_nm": 0.0, "angle_deg": 0.0},
    "misalignment": {"bearing": REQUIRED, "dx_um": 0.0, "dy_um": 0.0},
    "support_stiffness": {"support": REQUIRED, "factor": REQUIRED},
}


def channel_index(channel: str) -> int | None:
    """xK -> 2 (K - 1), yK -> 2 (K - 1) + 1 (K from 1: plane K's probes), None for anything else."""
    m = re.fullmatch(r"([xy])([1-9][0-9]*)", str(channel).strip().lower())
    return None if m is None else 2 * (int(m.group(2)) - 1) + (m.group(1) == "y")


def _number(name, key, value, *, positive=False, non_negative=False) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(f"effect {name}: {key} = {value!r} is not a number") from None
    if isinstance(value, bool) or not math.isfinite(v):
        raise InputError(f"effect {name}: {key} = {value!r}; expected a finite number")
    if positive and v <= 0.0:
        raise InputError(f"effect {name}: {key} = {value!r}; expected a positive number")
    if non_negative and v < 0.0:
        raise InputError(f"effect {name}: {key} = {value!r}; expected a non-negative number")
    return v


def _integer(name, key, value) -> int:
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = math.nan
    if isinstance(value, bool) or not (math.isfinite(v) and v == int(v)):
        raise InputError(f"effect {name}: {key} = {value!r}; expected an integer")
    return int(v)


def _bearing(name, value):
    """`both` (every fluid-film bearing) or a bearing's number from 1 (the machine's count is checked where the
    record is made)."""
    if isinstance(value, str) and value.strip().lower() == "both":
        return "both"
    v = _integer(name, "bearing", value)
    if v < 1:
        raise InputError(f"effect {name}: bearing = {value!r}; expected both or a bearing's number (1, 2, ...)")
    return v


def _check(name: str, p: dict) -> dict:
    """Typed, range-checked parameters of one effect."""
    if name == "viscosity":
        p["factor"] = _number(name, "factor", p["factor"], positive=True)
        p["bearing"] = _bearing(name, p["bearing"])
    elif name == "clearance":
        p["clearance_um"] = _number(name, "clearance_um", p["clearance_um"], positive=True)
        p["bearing"] = _bearing(name, p["bearing"])
    elif name == "side_load":
        p["node"] = _integer(name, "node", p["node"])
        for key in ("force_n", "moment_nm", "angle_deg"):
            p[key] = _number(name, key, p[key])
    elif name in ("unbalance2", "bow", "seal"):
        p["node"] = _integer(name, "node", p["node"])
        if name == "unbalance2":
            p["ratio"] = _number(name, "ratio", p["ratio"], non_negative=True)
        if name == "bow":
            p["amplitude_um"] = _number(name, "amplitude_um", p["amplitude_um"], non_negative=True)
            p["from_node"] = _integer(name, "from_node", p["from_node"])
            p["to_node"] = _integer(name, "to_node", p["to_node"])
            if (p["from_node"] == 0) != (p["to_node"] == 0) or (p["from_node"] and p["from_node"] >= p["to_node"]):
                raise InputError(f"effect bow: from_node {p['from_node']}, to_node {p['to_node']}: expected both 0 "
                                 "(the outermost bearings) or from_node < to_node")
        if name == "seal":
            p["kxy_n_m"] = _number(name, "kxy_n_m", p["kxy_n_m"])
            p["kxx_n_m"] = _number(name, "kxx_n_m", p["kxx_n_m"], non_negative=True)
        if "phase_deg" in p:
            p["phase_deg"] = _number(name, "phase_deg", p["phase_deg"])
    elif name == "pedestals":
        p["mass_kg"] = _number(name, "mass_kg", p["mass_kg"], positive=True)
        p["stiffness_n_m"] = _number(name, "stiffness_n_m", p["stiffness_n_m"], positive=True)
        p["damping_ns_m"] = _number(name, "damping_ns_m", p["damping_ns_m"], non_negative=True)
        p["bearing"] = _bearing(name, p["bearing"])
    elif name == "misalignment":
        p["bearing"] = _bearing(name, p["bearing"])
        for key in ("dx_um", "dy_um"):
            p[key] = _number(name, key, p[key])
    elif name == "support_stiffness":
        p["support"] = _integer(name, "support", p["support"])
        if p["support"] < 1:
            raise InputError(f"effect {name}: support = {p['support']!r}; expected a support's number (1, 2, ...)")
        p["factor"] = _number(name, "factor", p["factor"], positive=True)
    elif name == "probe_rotation":
        p["plane"] = _integer(name, "plane", p["plane"])
        if p["plane"] < 1:
            raise InputError(f"effect {name}: plane = {p['plane']!r}; expected a plane's number (1, 2, ...)")
        p["angle_deg"] = _number(name, "angle_deg", p["angle_deg"])
    elif name == "probe_gain":
        ch = str(p["channel"]).strip().lower()
        if channel_index(ch) is None:
            raise InputError(f"effect {name}: channel = {p['channel']!r}; expected x1, y1, x2, y2, ... (a probe "
                             "of a plane, numbered from 1)")
        p["channel"] = ch
        p["gain"] = _number(name, "gain", p["gain"], positive=True)
    return p


def effect(name: str, params: Mapping | None = None) -> tuple[str, Mapping]:
    """One validated effect (name, read-only params with defaults filled in)."""
    if not isinstance(name, str) or name.strip().lower() not in EFFECTS:
        raise InputError(f"unknown effect {name!r}; expected one of {', '.join(EFFECTS)}")
    name = name.strip().lower()
    table = EFFECTS[name]
    params = dict(params or {})
    unknown = sorted(set(params) - set(table))
    if unknown:
        raise InputError(f"effect {name}: unknown parameter(s) {unknown}; allowed: {', '.join(table)}")
    missing = [k for k, v in table.items() if v is REQUIRED and k not in params]
    if missing:
        raise InputError(f"effect {name}: missing parameter(s) {missing}; allowed: {', '.join(table)}")
    full = {k: params.get(k, v) for k, v in table.items()}
    return name, MappingProxyType(_check(name, full))


def parse_effect(text: str) -> tuple[str, Mapping]:
    """'NAME:key=value,key=value' (SPEC §7) -> a validated effect."""
    if not isinstance(text, str):
        raise InputError(f"effect {text!r}; expected 'NAME:key=value,...'")
    name, _, rest = text.partition(":")
    params = {}
    for item in filter(None, (s.strip() for s in rest.split(","))):
        key, eq, value = item.partition("=")
        if not eq or not key.strip():
            raise InputError(f"effect {text!r}: {item!r} is not key=value")
        params[key.strip()] = value.strip()
    return effect(name, params)


def normalize_effects(effects) -> tuple[tuple[str, Mapping], ...]:
    """A tuple of validated effects from (name, params) pairs, 'NAME:k=v' strings, or a mix."""
    out = []
    for e in effects or ():
        if isinstance(e, str):
            out.append(parse_effect(e))
        else:
            try:
                name, params = e
            except (TypeError, ValueError):
                raise InputError(f"effect {e!r}; expected (name, {{params}}) or 'NAME:key=value,...'") from None
            out.append(effect(name, params))
    return tuple(out)
