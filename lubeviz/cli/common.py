"""Shared CLI plumbing: one-line errors with exit status 2, JSON on stdout, logs on stderr."""

from __future__ import annotations

import argparse
import json
import math
import sys

import numpy as np

EXIT_BAD_INPUT = 2


class CliError(Exception):
    """Bad input detected by the CLI itself."""


class Parser(argparse.ArgumentParser):
    """argparse that reports a usage error as one line on stderr and exits 2."""

    def error(self, message):
        sys.stderr.write(f"{self.prog}: error: {message}\n")
        sys.exit(EXIT_BAD_INPUT)


def add_common(p: argparse.ArgumentParser) -> None:
    p.add_argument("--machine", metavar="FILE", default=None,
                   help="machine model file (default: the paper's machine, models/paper_machine.toml)")
    p.add_argument("--json", action="store_true", help="print one JSON object on stdout and nothing else")


def finite_float(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not math.isfinite(v):
        raise argparse.ArgumentTypeError(f"{text!r} is not a finite number")
    return v


def mesh_arg(text: str) -> tuple[int, int]:
    """'NxM' -> (N circumferential, M axial)."""
    try:
        n, m = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"mesh {text!r} is not of the form NxM (e.g. 100x100)") from None
    return n, m


def to_jsonable(obj):
    if isinstance(obj, dict):
        return {k: to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return to_jsonable(obj.tolist())
    if isinstance(obj, (np.floating, float)):
        v = float(obj)
        return v if math.isfinite(v) else None
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    return obj


def emit(result: dict, as_json: bool, text_lines: list[str] | None = None) -> None:
    if as_json:
        sys.stdout.write(json.dumps(to_jsonable(result)) + "\n")
    else:
        for line in text_lines if text_lines is not None else [f"{k}: {v}" for k, v in result.items()]:
            print(line)
