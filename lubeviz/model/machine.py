"""The machine: rotor description, bearings and operating data, loaded from a model file.

Model files are TOML under `models/` (the paper's machine: `models/paper_machine.toml`). Every
number carries its unit in its key (`length_mm`, `viscosity_pa_s`); this loader is the one place
where they become SI. Unknown keys are refused (they are usually typos), missing keys and wrong
types are named with the file, so a bad model file never turns into a silently wrong model.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass
from pathlib import Path

import param

from ..errors import ModelFileError
from .bearing import Bearing
from .oil import Oil, oil_from_table
from .quantity import Quantity, positive

MODELS_DIR = Path(__file__).resolve().parents[2] / "models"
DEFAULT_MACHINE = MODELS_DIR / "paper_machine.toml"


@dataclass(frozen=True)
class ShaftElement:
    """A uniform solid circular shaft segment between two consecutive nodes (SI)."""

    length: float
    diameter: float


@dataclass(frozen=True)
class Disc:
    """A rigid annular disc at a node (SI); bore = local shaft diameter."""

    node: int
    width: float
    outer_diameter: float
    bore_diameter: float


class Machine(param.Parameterized):
    """Rotor, discs, unbalance, bearings and operating data of one machine (SI inside)."""

    gravity = positive(9.81, "m/s^2", "Gravitational acceleration, acting along -Y")
    operating_speed = positive(75.0, "Hz", "Operating shaft speed")
    speed_min = positive(5.0, "Hz", "Lowest speed the model is meant for")
    speed_max = positive(150.0, "Hz", "Highest speed the model is meant for")
    young_modulus = positive(210e9, "Pa", "Young's modulus of shaft and discs")
    poisson_ratio = Quantity(0.3, bounds=(0.0, 0.5), inclusive_bounds=(True, False), unit="",
                             doc="Poisson's ratio of shaft and discs")
    density = positive(7850.0, "kg/m^3", "Density of shaft and discs")
    shaft_damping_beta = Quantity(2e-5, bounds=(0.0, None), unit="s",
                                  doc="Stiffness-proportional shaft damping: C_shaft = beta * K_shaft")
    unbalance_node = param.Integer(13, bounds=(1, None), doc="Node carrying the unbalance")
    unbalance_moment = Quantity(1.24e-2, bounds=(0.0, None), unit="kg*m",
                                doc="Unbalance moment m_u (Eq. 9)")
    unbalance_phase = Quantity(0.0, unit="rad", display_unit="deg", display_scale=180.0 / math.pi,
                               doc="Phase of the unbalance force at t = 0")
    elements = param.List([], item_type=ShaftElement, doc="Shaft elements from node 1 onwards")
    discs = param.List([], item_type=Disc, doc="Rigid discs")
    bearings = param.List([], item_type=Bearing, doc="Journal bearings (bearing 1 first)")
    center_nodes = param.List([6, 20], item_type=int, doc="Measurement nodes at the bearing centres")
    outside_nodes = param.List([5, 21], item_type=int, doc="Measurement nodes outside the bearings")
    oil = param.ClassSelector(class_=Oil, default=None, allow_None=True,
                              doc="The oil's grade and viscosity-temperature law (optional [oil] of the model file)")
    reference = param.Dict({}, doc="Figures the source publication reports (for checks)")
    source = param.String("", doc="File the machine was loaded from")

    @property
    def n_nodes(self) -> int:
        return len(self.elements) + 1

    @property
    def rotor_length(self) -> float:
        return sum(e.length for e in self.elements)

    @property
    def shear_modulus(self) -> float:
        return self.young_modulus / (2.0 * (1.0 + self.poisson_ratio))


# --- loading -------------------------------------------------------------------------------------

_SECTIONS = {
    "machine": {"name": str, "description": str, "gravity_m_s2": float, "operating_speed_hz": float,
                "speed_min_hz": float, "speed_max_hz": float},
    "material": {"name": str, "young_modulus_pa": float, "poisson_ratio": float, "density_kg_m3": float},
    "shaft": {"damping_beta_s": float, "elements_mm": list},
    "unbalance": {"node": int, "moment_kg_m": float, "phase_deg": float},
    "measurement": {"center_nodes": list, "outside_nodes": list},
    "paper": {"rotor_weight_n": float, "flooded_threshold_mlmin": float},
}
_OPTIONAL = {("machine", "description"), ("material", "name"), ("unbalance", "phase_deg"),
             ("machine", "speed_min_hz"), ("machine", "speed_max_hz")}
_OIL = {"iso_vg": int, "nu40_cst": float, "nu100_cst": float, "density_kg_m3": float, "temperature_c": float}
OIL_CONSISTENCY = 0.10  # the bearings' viscosity_pa_s and the [oil] law at temperature_c: ISO 3448's +-10 %
_DISC = {"node": int, "width_mm": float, "outer_diameter_mm": float, "bore_diameter_mm": float}
_BEARING = {"name": str, "node": int, "radius_mm": float, "length_mm": float, "clearance_um": float,
            "viscosity_pa_s": float, "groove_angle_deg": float, "groove_length_mm": float,
            "groove_width_mm": float, "mesh_circumferential": int, "mesh_axial": int,
            "mesh_groove_refinement": int}


def _typed(value, kind, where):
    if kind is float and isinstance(value, (int, float)) and not isinstance(value, bool):
        if not math.isfinite(value):
            raise ModelFileError(f"{where}: {value!r} is not a finite number")
        return float(value)
    if kind is int and isinstance(value, int) and not isinstance(value, bool):
        return value
    if kind in (str, list) and isinstance(value, kind):
        return value
    raise ModelFileError(f"{where}: expected {kind.__name__}, got {type(value).__name__} {value!r}")


def _table(data, spec, where, optional=()):
    if not isinstance(data, dict):
        raise ModelFileError(f"{where}: expected a table, got {type(data).__name__}")
    unknown = set(data) - set(spec)
    if unknown:
        raise ModelFileError(f"{where}: unknown key(s) {sorted(unknown)}; expected keys {sorted(spec)}")
    out = {}
    for key, kind in spec.items():
        if key not in data:
            if key in optional:
                continue
            raise ModelFileError(f"{where}: missing key {key!r} ({kind.__name__})")
        out[key] = _typed(data[key], kind, f"{where}.{key}")
    return out


def load_machine(path: str | Path | None = None) -> Machine:
    """Read and validate a machine model file (TOML, SPEC §2). Default: the paper's machine."""
    path = Path(DEFAULT_MACHINE if path is None else path)
    try:
        raw = tomllib.loads(path.read_text())
    except FileNotFoundError:
        raise ModelFileError(f"{path}: no such model file") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ModelFileError(f"{path}: not a valid TOML file ({exc})") from None
    where = str(path)
    unknown = set(raw) - set(_SECTIONS) - {"discs", "bearings", "oil"}
    if unknown:
        raise ModelFileError(f"{where}: unknown section(s) {sorted(unknown)}")
    sec = {}
    for name, spec in _SECTIONS.items():
        if name not in raw:
            if name == "paper":
                sec[name] = {}
                continue
            raise ModelFileError(f"{where}: missing section [{name}]")
        opt = {k for s, k in _OPTIONAL if s == name}
        sec[name] = _table(raw[name], spec, f"{where} [{name}]", opt)
    try:
        elements = []
        for k, item in enumerate(sec["shaft"]["elements_mm"], start=1):
            w = f"{where} [shaft].elements_mm[{k}]"
            if not (isinstance(item, list) and len(item) == 2):
                raise ModelFileError(f"{w}: expected [length_mm, diameter_mm], got {item!r}")
            length, diameter = (_typed(v, float, w) for v in item)
            if length <= 0 or diameter <= 0:
                raise ModelFileError(f"{w}: length and diameter must be positive, got {item!r}")
            elements.append(ShaftElement(length * 1e-3, diameter * 1e-3))
        if not elements:
            raise ModelFileError(f"{where} [shaft].elements_mm: expected at least one element")
        n_nodes = len(elements) + 1

        def node_ok(node, w):
            if not 1 <= node <= n_nodes:
                raise ModelFileError(f"{w}: node {node} outside 1..{n_nodes}")
            return node

        discs = []
        for k, d in enumerate(raw.get("discs", []), start=1):
            w = f"{where} [[discs]] #{k}"
            t = _table(d, _DISC, w)
            if not 0 < t["bore_diameter_mm"] < t["outer_diameter_mm"] or t["width_mm"] <= 0:
                raise ModelFileError(f"{w}: expected 0 < bore < outer diameter and a positive width")
            discs.append(Disc(node_ok(t["node"], w), t["width_mm"] * 1e-3, t["outer_diameter_mm"] * 1e-3,
                              t["bore_diameter_mm"] * 1e-3))
        bearings = []
        for k, b in enumerate(raw.get("bearings", []), start=1):
            w = f"{where} [[bearings]] #{k}"
            t = _table(b, _BEARING, w, {"name", "mesh_groove_refinement"})
            try:
                bearings.append(Bearing(
                    name=t.get("name", f"bearing {k}"), node=node_ok(t["node"], w),
                    radius=t["radius_mm"] * 1e-3, length=t["length_mm"] * 1e-3,
                    clearance=t["clearance_um"] * 1e-6, viscosity=t["viscosity_pa_s"],
                    groove_angle=math.radians(t["groove_angle_deg"]), groove_length=t["groove_length_mm"] * 1e-3,
                    groove_width=t["groove_width_mm"] * 1e-3, n_circumferential=t["mesh_circumferential"],
                    n_axial=t["mesh_axial"],
                    **({"groove_refinement": t["mesh_groove_refinement"]} if "mesh_groove_refinement" in t else {})))
            except ValueError as exc:
                raise ModelFileError(f"{w}: {exc}") from None
        if len(bearings) != 2:
            raise ModelFileError(f"{where}: expected exactly 2 [[bearings]], found {len(bearings)}")
        oil = None
        if "oil" in raw:
            w = f"{where} [oil]"
            try:
                oil = oil_from_table(_table(raw["oil"], _OIL, w, set(_OIL)), w)
            except ValueError as exc:
                raise ModelFileError(str(exc) if str(exc).startswith(where) else f"{w}: {exc}") from None
            mu = float(oil.dynamic_viscosity(oil.temperature_c))
            for k, b in enumerate(bearings, start=1):
                if abs(b.viscosity / mu - 1.0) > OIL_CONSISTENCY:
                    raise ModelFileError(
                        f"{w}: {oil.describe()} has mu = {mu:.4g} Pa*s at {oil.temperature_c:g} °C, but "
                        f"[[bearings]] #{k} viscosity_pa_s = {b.viscosity:g} (more than "
                        f"{OIL_CONSISTENCY:.0%} apart): correct temperature_c or the grade")
        m, mat, ub, meas = sec["machine"], sec["material"], sec["unbalance"], sec["measurement"]
        for key in ("center_nodes", "outside_nodes"):
            nodes = meas[key]
            if len(nodes) != 2 or not all(isinstance(n, int) for n in nodes):
                raise ModelFileError(f"{where} [measurement].{key}: expected two node numbers, got {nodes!r}")
            for n in nodes:
                node_ok(n, f"{where} [measurement].{key}")
        return Machine(
            name=m["name"], gravity=m["gravity_m_s2"], operating_speed=m["operating_speed_hz"],
            speed_min=m.get("speed_min_hz", 1.0), speed_max=m.get("speed_max_hz", 1e4),
            young_modulus=mat["young_modulus_pa"], poisson_ratio=mat["poisson_ratio"],
            density=mat["density_kg_m3"], shaft_damping_beta=sec["shaft"]["damping_beta_s"],
            unbalance_node=node_ok(ub["node"], f"{where} [unbalance].node"),
            unbalance_moment=ub["moment_kg_m"], unbalance_phase=math.radians(ub.get("phase_deg", 0.0)),
            elements=elements, discs=discs, bearings=bearings, center_nodes=list(meas["center_nodes"]),
            outside_nodes=list(meas["outside_nodes"]), oil=oil, reference=dict(sec["paper"]), source=str(path),
        )
    except ModelFileError:
        raise
    except ValueError as exc:  # a param bound (e.g. negative viscosity)
        raise ModelFileError(f"{where}: {exc}") from None


# --- model names in records ------------------------------------------------------------------------

def model_name_problem(name: str) -> str | None:
    """Why `name` is not a plain model file name (None when it is one).

    A record names its machine by file name only (SPEC §6: "a model file name under `models/`"):
    `NAME` or `NAME.toml`, no folder, no `..`, so a record file can never point the program at an
    arbitrary file on the disk.
    """
    if not isinstance(name, str) or not name.strip():
        return "is empty"
    if any(sep in name for sep in ("/", "\\", ":")):
        return "is a path, not a plain file name (no '/', '\\' or ':')"
    if ".." in name or name.startswith("."):
        return "holds '..' or starts with '.'"
    if not name.isprintable() or name != name.strip():
        return "holds control characters or surrounding spaces"
    suffix = Path(name).suffix
    if suffix and suffix.lower() != ".toml":
        return f"ends in {suffix!r}, not '.toml' (or a bare model name)"
    return None


def available_model_names() -> list[str]:
    """The model files under `models/`, by name (`paper_machine`, ...)."""
    return sorted(p.stem for p in MODELS_DIR.glob("*.toml") if p.is_file())


def resolve_machine_name(name: str, where: str) -> Path:
    """models/<name> (`.toml` added to a bare name) for a record's `machine: NAME`.

    `where` names the record file in the message. Raises ModelFileError when `name` is not a plain
    model file name or no such model exists, listing the models that do.
    """
    available = ", ".join(available_model_names()) or "none"
    problem = model_name_problem(name)
    if problem:
        raise ModelFileError(f"{where}: machine: {name!r} {problem}; expected one of the models under"
                             f" {MODELS_DIR}: {available}")
    path = MODELS_DIR / (name if Path(name).suffix else name + ".toml")
    if not path.is_file():
        raise ModelFileError(f"{where}: machine: {name!r} is not a model under {MODELS_DIR};"
                             f" available: {available}")
    return path
