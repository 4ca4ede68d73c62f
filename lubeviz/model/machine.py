"""The machine: its parts (`lubeviz.model.parts`) read from a model file (`lubeviz.model.files`: TOML, SPEC §2 and
§8; the paper's machine `models/paper_machine.toml` is one example among others), and the model names records use.
"""

from __future__ import annotations

from pathlib import Path

from ..errors import ModelFileError
from .files import load_machine
from .parts import (DEFAULT_MACHINE, MODELS_DIR, OIL_CONSISTENCY, Disc, Machine, Plane, ShaftElement, Support,
                    UnbalanceMass)

__all__ = ["DEFAULT_MACHINE", "MODELS_DIR", "OIL_CONSISTENCY", "Disc", "Machine", "Plane", "ShaftElement", "Support",
           "UnbalanceMass", "available_model_names", "load_machine", "model_name_problem", "resolve_machine_name"]


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
