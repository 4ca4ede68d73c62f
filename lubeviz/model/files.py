"""Model files (SPEC §2, §8): a TOML description of any machine, read into a `Machine`.

Every number carries its unit in its key (`length_mm`, `viscosity_pa_s`); this loader is the one place where
they become SI. The paper's file (`models/paper_machine.toml`) is one model file among others and stays valid
unchanged. A bad file never becomes a silently wrong model: unknown keys are refused (usually typos), and every
message names the file, the table and its index (`[[bearings]] 3`), the key, and what was expected.
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

from ..errors import ModelFileError
from ..units import MLMIN_PER_M3S
from .bearing import SUPPLIES, Bearing, Groove, Pedestal
from .parts import (DEFAULT_MACHINE, OIL_CONSISTENCY, Disc, Machine, Plane, ShaftElement, Support,
                    UnbalanceMass)
from .oil import oil_from_table

MAX_BEARINGS = 6  # fluid-film bearings a model file may declare (SPEC §8)

_MACHINE = {"name": str, "description": str, "gravity_m_s2": float, "operating_speed_hz": float,
            "speed_min_hz": float, "speed_max_hz": float}
_MATERIAL = {"name": str, "young_modulus_pa": float, "poisson_ratio": float, "density_kg_m3": float}
_SHAFT = {"damping_beta_s": float, "elements_mm": list}
_UNBALANCE = {"name": str, "node": int, "moment_kg_m": float, "phase_deg": float}
_MEASUREMENT = {"center_nodes": list, "outside_nodes": list}
_PAPER = {"rotor_weight_n": float, "flooded_threshold_mlmin": float}
_OIL = {"iso_vg": int, "nu40_cst": float, "nu100_cst": float, "density_kg_m3": float, "temperature_c": float}
_DISC_GEOMETRY = {"width_mm": float, "outer_diameter_mm": float, "bore_diameter_mm": float}
_DISC_LUMPED = {"mass_kg": float, "polar_inertia_kg_m2": float, "diametral_inertia_kg_m2": float}
_DISC = {"name": str, "node": int, **_DISC_GEOMETRY, **_DISC_LUMPED}
_PEDESTAL = {"pedestal_mass_kg": float, "pedestal_stiffness_n_m": float, "pedestal_damping_ns_m": float}
_GROOVE = {"angle_deg": float, "length_mm": float, "width_mm": float}
_SHORT_GROOVE = {"groove_angle_deg": float, "groove_length_mm": float, "groove_width_mm": float}
_BEARING = {"name": str, "node": int, "radius_mm": float, "length_mm": float, "clearance_um": float,
            "viscosity_pa_s": float, **_SHORT_GROOVE, "grooves": list, "mesh_circumferential": int,
            "mesh_axial": int, "mesh_groove_refinement": int, "supply": str, "supply_mlmin": float,
            "offset_um": list, **_PEDESTAL}
_SUPPORT = {"name": str, "node": int, "stiffness_n_m": list, "damping_ns_m": list, **_PEDESTAL}
_PLANE = {"name": str, "node": int, "probe_angles_deg": list}
_TOP = {"machine", "material", "shaft", "unbalance", "unbalances", "discs", "bearings", "supports", "planes",
        "measurement", "paper", "oil"}
_KINDS = {float: "a number", int: "an integer", str: "a string", list: "a list"}


def _typed(value, kind, where):
    if kind is float and isinstance(value, (int, float)) and not isinstance(value, bool):
        if not math.isfinite(value):
            raise ModelFileError(f"{where}: {value!r} is not a finite number")
        return float(value)
    if kind is int and isinstance(value, int) and not isinstance(value, bool):
        return value
    if kind in (str, list) and isinstance(value, kind):
        return value
    raise ModelFileError(f"{where}: expected {kind.__name__} ({_KINDS[kind]}), got {type(value).__name__} {value!r}")


def _table(data, spec, where, required=()):
    """The table `data` typed by `spec` (key -> type); `required` keys must be there, the rest may be."""
    if not isinstance(data, dict):
        raise ModelFileError(f"{where}: expected a table, got {type(data).__name__}")
    unknown = set(data) - set(spec)
    if unknown:
        raise ModelFileError(f"{where}: unknown key(s) {sorted(unknown)}; expected keys {sorted(spec)}")
    for key in required:
        if key not in data:
            raise ModelFileError(f"{where}: missing key {key!r} ({spec[key].__name__}: {_KINDS[spec[key]]})")
    return {key: _typed(data[key], spec[key], f"{where}: {key}") for key in data}


def _positive(t, key, where, scale=1.0, zero=False):
    v = t[key]
    if not (v > 0 or (zero and v == 0)):
        raise ModelFileError(f"{where}: {key}: expected a {'non-negative' if zero else 'positive'} number, got {v!r}")
    return v * scale


def _array_of_tables(raw, key, where):
    items = raw.get(key, [])
    if isinstance(items, dict):  # [key] written instead of [[key]]
        raise ModelFileError(f"{where}: [{key}] is a single table; expected an array of tables, [[{key}]]")
    if not isinstance(items, list):
        raise ModelFileError(f"{where}: {key}: expected an array of tables [[{key}]], got {type(items).__name__}")
    return items


def _numbers(value, n, where, what):
    if not (isinstance(value, list) and len(value) == n):
        raise ModelFileError(f"{where}: expected {what}, got {value!r}")
    return [_typed(v, float, where) for v in value]


def _matrix(value, where):
    if not (isinstance(value, list) and len(value) == 2):
        raise ModelFileError(f"{where}: expected [[XX, XY], [YX, YY]], got {value!r}")
    return tuple(tuple(_numbers(row, 2, where, "[[XX, XY], [YX, YY]]")) for row in value)


def _pedestal(t, where):
    keys = [k for k in _PEDESTAL if k in t]
    if not keys:
        return None
    if len(keys) != len(_PEDESTAL):
        missing = sorted(set(_PEDESTAL) - set(keys))
        raise ModelFileError(f"{where}: a pedestal needs {sorted(_PEDESTAL)}; missing {missing}")
    return Pedestal(_positive(t, "pedestal_mass_kg", where), _positive(t, "pedestal_stiffness_n_m", where),
                    _positive(t, "pedestal_damping_ns_m", where, zero=True))


class _Nodes:
    def __init__(self, n_nodes: int):
        self.n = n_nodes

    def __call__(self, node, where):
        if not 1 <= node <= self.n:
            raise ModelFileError(f"{where}: node {node} outside 1..{self.n} (the shaft's nodes)")
        return node


def _elements(shaft, where):
    elements = []
    rows = shaft["elements_mm"]
    for k, item in enumerate(rows, start=1):
        w = f"{where} [shaft]: elements_mm {k}"
        if not (isinstance(item, list) and len(item) in (2, 3)):
            raise ModelFileError(f"{w}: expected [length_mm, outer_diameter_mm] or [length_mm, outer_diameter_mm, "
                                 f"inner_diameter_mm], got {item!r}")
        values = [_typed(v, float, w) for v in item]
        length, outer, inner = values[0], values[1], values[2] if len(values) == 3 else 0.0
        if length <= 0 or outer <= 0 or not 0 <= inner < outer:
            raise ModelFileError(f"{w}: expected a positive length and outer diameter and 0 <= inner < outer, "
                                 f"got {item!r}")
        elements.append(ShaftElement(length * 1e-3, outer * 1e-3, inner * 1e-3))
    if not elements:
        raise ModelFileError(f"{where} [shaft]: elements_mm: expected at least one element")
    return elements


def _discs(raw, where, node_ok):
    discs = []
    for k, d in enumerate(_array_of_tables(raw, "discs", where), start=1):
        w = f"{where} [[discs]] {k}"
        t = _table(d, _DISC, w, ("node",))
        geometry, lumped = set(_DISC_GEOMETRY) & set(t), set(_DISC_LUMPED) & set(t)
        if geometry and lumped:
            raise ModelFileError(f"{w}: give the disc by geometry {sorted(_DISC_GEOMETRY)} or lumped "
                                 f"{sorted(_DISC_LUMPED)}, not both")
        node = node_ok(t["node"], w)
        if lumped:
            missing = sorted(set(_DISC_LUMPED) - lumped)
            if missing:
                raise ModelFileError(f"{w}: a lumped disc needs {sorted(_DISC_LUMPED)}; missing {missing}")
            discs.append(Disc(node, mass=_positive(t, "mass_kg", w),
                              polar_inertia=_positive(t, "polar_inertia_kg_m2", w, zero=True),
                              diametral_inertia=_positive(t, "diametral_inertia_kg_m2", w, zero=True),
                              name=t.get("name", "")))
            continue
        missing = sorted(set(_DISC_GEOMETRY) - geometry)
        if missing:
            raise ModelFileError(f"{w}: missing key(s) {missing} (a disc by geometry; or give {sorted(_DISC_LUMPED)})")
        if not 0 < t["bore_diameter_mm"] < t["outer_diameter_mm"] or t["width_mm"] <= 0:
            raise ModelFileError(f"{w}: expected 0 < bore_diameter_mm < outer_diameter_mm and a positive width_mm, got "
                                 f"bore {t['bore_diameter_mm']:g}, outer {t['outer_diameter_mm']:g}, width "
                                 f"{t['width_mm']:g} mm")
        discs.append(Disc(node, t["width_mm"] * 1e-3, t["outer_diameter_mm"] * 1e-3, t["bore_diameter_mm"] * 1e-3,
                          name=t.get("name", "")))
    return discs


def _unbalances(raw, where, node_ok):
    if "unbalance" in raw and "unbalances" in raw:
        raise ModelFileError(f"{where}: give [unbalance] (one) or [[unbalances]] (one or more), not both")
    if "unbalance" in raw:
        items, label = [raw["unbalance"]], "[unbalance]"
    else:
        items, label = _array_of_tables(raw, "unbalances", where), "[[unbalances]]"
    if not items:
        raise ModelFileError(f"{where}: missing [unbalance] or [[unbalances]] (at least one unbalance)")
    out = []
    for k, u in enumerate(items, start=1):
        w = f"{where} {label}" + (f" {k}" if label == "[[unbalances]]" else "")
        t = _table(u, _UNBALANCE, w, ("node", "moment_kg_m"))
        moment = _positive(t, "moment_kg_m", w, zero=True)
        out.append(UnbalanceMass(node_ok(t["node"], w), moment, math.radians(t.get("phase_deg", 0.0)),
                                 t.get("name", "")))
    return out


def _angle(deg: float) -> float:
    """A groove angle (deg, any turn) in rad within (-pi, pi] (270 deg and -90 deg are the same place)."""
    a = math.remainder(math.radians(deg), 2.0 * math.pi)
    return math.pi if a == -math.pi else a


def _grooves(t, w):
    short = set(_SHORT_GROOVE) & set(t)
    if "grooves" in t:
        if short:
            raise ModelFileError(f"{w}: give grooves = [...] or the one-groove keys {sorted(_SHORT_GROOVE)}, not both")
        items = t["grooves"]
        if not items:
            raise ModelFileError(f"{w}: grooves: expected at least one groove {{angle_deg, length_mm, width_mm}}")
        out = []
        for j, g in enumerate(items, start=1):
            gt = _table(g, _GROOVE, f"{w}: grooves {j}", tuple(_GROOVE))
            out.append(Groove(_angle(gt["angle_deg"]), _positive(gt, "length_mm", f"{w}: grooves {j}", 1e-3),
                              _positive(gt, "width_mm", f"{w}: grooves {j}", 1e-3)))
        return out
    missing = sorted(set(_SHORT_GROOVE) - short)
    if missing:
        raise ModelFileError(f"{w}: missing key(s) {missing} (the groove; or grooves = [{{angle_deg, length_mm, "
                             f"width_mm}}, ...])")
    return [Groove(_angle(t["groove_angle_deg"]), _positive(t, "groove_length_mm", w, 1e-3, zero=True),
                   _positive(t, "groove_width_mm", w, 1e-3, zero=True))]


def _supply(t, w):
    supply = t.get("supply", "unknown" if "supply_mlmin" not in t else "known")
    if supply not in SUPPLIES:
        raise ModelFileError(f"{w}: supply: expected one of {list(SUPPLIES)} (or supply_mlmin = Q), got {supply!r}")
    if "supply_mlmin" in t:
        if supply != "known":
            raise ModelFileError(f"{w}: supply_mlmin with supply = {supply!r}: a given flow is a known supply")
        return "known", _positive(t, "supply_mlmin", w) / MLMIN_PER_M3S
    if supply == "known":
        raise ModelFileError(f"{w}: supply = 'known' needs supply_mlmin")
    return supply, None


def _bearings(raw, where, node_ok, viscosity_default):
    required = ("node", "radius_mm", "length_mm", "clearance_um") + (() if viscosity_default else ("viscosity_pa_s",))
    bearings = []
    items = _array_of_tables(raw, "bearings", where)
    if not 1 <= len(items) <= MAX_BEARINGS:
        raise ModelFileError(f"{where}: expected 1 to {MAX_BEARINGS} [[bearings]] (fluid-film bearings), "
                             f"found {len(items)}")
    for k, b in enumerate(items, start=1):
        w = f"{where} [[bearings]] {k}"
        t = _table(b, _BEARING, w, required)
        grooves = _grooves(t, w)
        supply, flow = _supply(t, w)
        offset = _numbers(t.get("offset_um", [0.0, 0.0]), 2, f"{w}: offset_um", "[dX_um, dY_um]")
        node, pedestal = node_ok(t["node"], w), _pedestal(t, w)
        radius, length = _positive(t, "radius_mm", w, 1e-3), _positive(t, "length_mm", w, 1e-3)
        clearance = _positive(t, "clearance_um", w, 1e-6)
        if clearance >= 0.1 * radius:
            raise ModelFileError(f"{w}: clearance_um: {t['clearance_um']:g} um against radius_mm {t['radius_mm']:g}: "
                                 "expected a thin film, c well below R (typically c/R 0.001-0.003)")
        viscosity = t.get("viscosity_pa_s", viscosity_default)
        if not viscosity > 0:
            raise ModelFileError(f"{w}: viscosity_pa_s: expected a positive number, got {viscosity!r}")
        _check_grooves(t, grooves, radius, length, w)
        mesh = {}
        for key, name, low, high, default in _MESH:
            value = t.get(key, default)
            if value is not None and not low <= value <= high:
                raise ModelFileError(f"{w}: {key}: expected an integer from {low} to {high}, got {value!r}")
            if value is not None:
                mesh[name] = value
        try:
            bearings.append(Bearing(
                name=t.get("name", f"bearing {k}"), node=node, radius=radius, length=length, clearance=clearance,
                viscosity=viscosity, groove_angle=grooves[0].angle, groove_length=grooves[0].length,
                groove_width=grooves[0].width, other_grooves=grooves[1:], supply=supply, supply_flow=flow,
                offset=(offset[0] * 1e-6, offset[1] * 1e-6), pedestal=pedestal, **mesh))
        except ValueError as exc:
            raise ModelFileError(f"{w}: {exc}") from None
    for k, b in enumerate(bearings, start=1):
        first = next(j for j, other in enumerate(bearings, start=1) if other.name == b.name)
        if first != k:
            raise ModelFileError(f"{where} [[bearings]] {k}: name {b.name!r} is already [[bearings]] {first}'s; "
                                 "expected each bearing its own name (texts and effects refer to it)")
    return bearings


_MESH = (("mesh_circumferential", "n_circumferential", 8, 4000, 100), ("mesh_axial", "n_axial", 2, 4000, 100),
         ("mesh_groove_refinement", "groove_refinement", 1, 16, None))


def _check_grooves(t, grooves, radius, length, w):
    """Each groove inside the bearing, named by the keys the file used (short form or `grooves j`)."""
    short = "grooves" not in t
    for j, g in enumerate(grooves, start=1):
        at = f"{w}: groove_" if short else f"{w}: grooves {j}: "
        if g.width > length:
            raise ModelFileError(f"{at}width_mm: {g.width * 1e3:g} mm is wider than the bearing (length_mm "
                                 f"{length * 1e3:g}); expected a groove inside the bearing")
        if g.length >= 2 * math.pi * radius:
            raise ModelFileError(f"{at}length_mm: {g.length * 1e3:g} mm is not shorter than the circumference "
                                 f"{2 * math.pi * radius * 1e3:.4g} mm")


def _supports(raw, where, node_ok):
    out = []
    for k, s in enumerate(_array_of_tables(raw, "supports", where), start=1):
        w = f"{where} [[supports]] {k}"
        t = _table(s, _SUPPORT, w, ("node", "stiffness_n_m"))
        K = _matrix(t["stiffness_n_m"], f"{w}: stiffness_n_m")
        C = _matrix(t.get("damping_ns_m", [[0.0, 0.0], [0.0, 0.0]]), f"{w}: damping_ns_m")
        if K[0][0] <= 0 or K[1][1] <= 0:
            raise ModelFileError(f"{w}: stiffness_n_m: expected positive direct stiffnesses kXX, kYY, got "
                                 f"{[list(r) for r in K]}")
        if C[0][0] < 0 or C[1][1] < 0:
            raise ModelFileError(f"{w}: damping_ns_m: expected non-negative direct damping cXX, cYY, got "
                                 f"{[list(r) for r in C]}")
        out.append(Support(t.get("name", f"support {k}"), node_ok(t["node"], w), K, C, _pedestal(t, w)))
    return out


def _planes(raw, where, node_ok):
    out = []
    for k, p in enumerate(_array_of_tables(raw, "planes", where), start=1):
        w = f"{where} [[planes]] {k}"
        t = _table(p, _PLANE, w, ("node",))
        a, b = _numbers(t.get("probe_angles_deg", [0.0, 90.0]), 2, f"{w}: probe_angles_deg", "[a_deg, b_deg]")
        if abs(math.sin(math.radians(b - a))) < math.sin(math.radians(10.0)):
            raise ModelFileError(f"{w}: probe_angles_deg {[a, b]}: the two probes are (nearly) parallel; expected "
                                 "two directions at least 10 deg apart (usually 90)")
        out.append(Plane(node_ok(t["node"], w), (a, b), t.get("name", f"plane {k}")))
    return out


def _oil(raw, where):
    """The [oil] and its viscosity (Pa s) at its temperature, or (None, None)."""
    if "oil" not in raw:
        return None, None
    w = f"{where} [oil]"
    t = _table(raw["oil"], _OIL, w)
    if "density_kg_m3" in t and not t["density_kg_m3"] > 0:
        raise ModelFileError(f"{w}: density_kg_m3: expected a positive number, got {t['density_kg_m3']!r}")
    for key in ("nu40_cst", "nu100_cst"):
        if key in t and not t[key] > 1.0:  # the Walther law (ASTM D341) holds above ~2 cSt
            raise ModelFileError(f"{w}: {key}: {t[key]!r} cSt is below the range of the viscosity-temperature law "
                                 "(ASTM D341, above about 2 cSt); expected a lubricating oil's viscosity")
    try:
        oil = oil_from_table(t, w)
        mu = float(oil.dynamic_viscosity(oil.temperature_c))
    except ValueError as exc:
        raise ModelFileError(str(exc) if str(exc).startswith(where) else f"{w}: {exc}") from None
    if not (math.isfinite(mu) and mu > 0):
        raise ModelFileError(f"{w}: the oil's viscosity at temperature_c {oil.temperature_c:g} °C is {mu!r}; "
                             "expected a positive number (check nu40_cst, nu100_cst)")
    return oil, mu


def _read(path: Path) -> dict:
    try:
        return tomllib.loads(path.read_bytes().decode("utf-8"))
    except FileNotFoundError:
        raise ModelFileError(f"{path}: no such model file") from None
    except IsADirectoryError:
        raise ModelFileError(f"{path}: is a folder, not a model file") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ModelFileError(f"{path}: not a valid TOML file ({exc})") from None


def load_machine(path: str | Path | None = None) -> Machine:
    """Read and validate a model file (TOML, SPEC §2 and §8). Default: the paper's machine."""
    path = Path(DEFAULT_MACHINE if path is None else path)
    return machine_from_toml(_read(path), str(path))


def machine_from_toml(raw: dict, where: str) -> Machine:
    """The Machine a parsed model file describes; `where` (the file) leads every message."""
    unknown = set(raw) - _TOP
    if unknown:
        raise ModelFileError(f"{where}: unknown section(s) {sorted(unknown)}; expected {sorted(_TOP)}")
    for name in ("machine", "material", "shaft"):
        if name not in raw:
            raise ModelFileError(f"{where}: missing section [{name}]")
    m = _table(raw["machine"], _MACHINE, f"{where} [machine]", ("name", "gravity_m_s2", "operating_speed_hz"))
    mat = _table(raw["material"], _MATERIAL, f"{where} [material]",
                 ("young_modulus_pa", "poisson_ratio", "density_kg_m3"))
    shaft = _table(raw["shaft"], _SHAFT, f"{where} [shaft]", ("damping_beta_s", "elements_mm"))
    paper = _table(raw.get("paper", {}), _PAPER, f"{where} [paper]")
    for table, t, key, low, high in (("machine", m, "gravity_m_s2", 0.0, None),
                                     ("machine", m, "operating_speed_hz", 0.0, None),
                                     ("material", mat, "young_modulus_pa", 0.0, None),
                                     ("material", mat, "density_kg_m3", 0.0, None),
                                     ("material", mat, "poisson_ratio", -1e-12, 0.5),
                                     ("shaft", shaft, "damping_beta_s", -1e-300, None)):
        v = t[key]
        if not (v > low and (high is None or v < high)):
            expect = ("a number from 0 to below 0.5" if high is not None else
                      "a non-negative number" if low < 0 else "a positive number")
            raise ModelFileError(f"{where} [{table}]: {key}: expected {expect}, got {v!r}")
    try:
        elements = _elements(shaft, where)
        node_ok = _Nodes(len(elements) + 1)
        discs = _discs(raw, where, node_ok)
        unbalances = _unbalances(raw, where, node_ok)
        oil, mu = _oil(raw, where)
        bearings = _bearings(raw, where, node_ok, mu)
        if oil is not None:
            for k, b in enumerate(bearings, start=1):
                if abs(b.viscosity / mu - 1.0) > OIL_CONSISTENCY:
                    raise ModelFileError(
                        f"{where} [oil]: {oil.describe()} has mu = {mu:.4g} Pa*s at {oil.temperature_c:g} °C, but "
                        f"[[bearings]] {k} viscosity_pa_s = {b.viscosity:g} (more than {OIL_CONSISTENCY:.0%} "
                        "apart): correct temperature_c or the grade")
        supports = _supports(raw, where, node_ok)
        planes = _planes(raw, where, node_ok)
        measurement = _measurement(raw, where, node_ok) or {
            "center_nodes": [p.node for p in planes] or [b.node for b in bearings], "outside_nodes": []}
        places = ([(f"[[bearings]] {k}", b.node) for k, b in enumerate(bearings, start=1)]
                  + [(f"[[supports]] {k}", s.node) for k, s in enumerate(supports, start=1)])
        for i, (label, node) in enumerate(places):
            before = next((other for other, n in places[:i] if n == node), None)
            if before is not None:
                raise ModelFileError(f"{where} {label}: node {node} already holds {before}; expected one bearing or "
                                     "support per node")
        if len(places) < 2:
            raise ModelFileError(f"{where}: {len(places)} support(s); a free rotor needs at least two ([[bearings]] "
                                 "and [[supports]] together)")
        first = unbalances[0]
        speed_min, speed_max = m.get("speed_min_hz", 1.0), m.get("speed_max_hz", 1e4)
        if not 0 < speed_min < speed_max:
            raise ModelFileError(f"{where} [machine]: speed_min_hz, speed_max_hz: expected 0 < speed_min_hz < "
                                 f"speed_max_hz, got {speed_min!r}, {speed_max!r}")
        if not speed_min <= m["operating_speed_hz"] <= speed_max:
            raise ModelFileError(f"{where} [machine]: operating_speed_hz: {m['operating_speed_hz']:g} Hz is outside "
                                 f"the file's own speed range {speed_min:g}-{speed_max:g} Hz")
        return Machine(
            name=m["name"], gravity=m["gravity_m_s2"], operating_speed=m["operating_speed_hz"],
            speed_min=speed_min, speed_max=speed_max, young_modulus=mat["young_modulus_pa"],
            poisson_ratio=mat["poisson_ratio"], density=mat["density_kg_m3"],
            shaft_damping_beta=shaft["damping_beta_s"], unbalance_node=first.node, unbalance_moment=first.moment,
            unbalance_phase=first.phase, other_unbalances=unbalances[1:], elements=elements, discs=discs,
            bearings=bearings, supports=supports, planes=planes, oil=oil, reference=paper, source=where,
            **measurement)
    except ModelFileError:
        raise
    except ValueError as exc:  # a param bound (e.g. a negative viscosity or gravity)
        raise ModelFileError(f"{where}: {exc}") from None


def _measurement(raw, where, node_ok) -> dict:
    """The paper's [measurement] table (bearing centres and outside planes), when the file has one."""
    if "measurement" not in raw:
        return {}
    w = f"{where} [measurement]"
    t = _table(raw["measurement"], _MEASUREMENT, w, tuple(_MEASUREMENT))
    for key in _MEASUREMENT:
        nodes = t[key]
        if len(nodes) != 2 or not all(isinstance(n, int) and not isinstance(n, bool) for n in nodes):
            raise ModelFileError(f"{w}: {key}: expected two node numbers, got {nodes!r}")
        for n in nodes:
            node_ok(n, f"{w}: {key}")
    return {"center_nodes": list(t["center_nodes"]), "outside_nodes": list(t["outside_nodes"])}
