"""The `lubeviz` console script (SPEC §7). Exit status 2 and one line on stderr for bad input."""

from __future__ import annotations

import sys
import warnings

from ..errors import LubevizError
from . import bench_cmd, diagnose_cmd, figures_cmd, film_cmd, identify_cmd, rotor_cmd
from .common import EXIT_BAD_INPUT, Parser, emit


def build_parser() -> Parser:
    parser = Parser(prog="lubeviz", description="Hydrodynamic-bearing lubrication from shaft vibration.")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=Parser)
    film_cmd.register(sub)
    rotor_cmd.register(sub)
    identify_cmd.register(sub)
    diagnose_cmd.register(sub)
    bench_cmd.register(sub)
    figures_cmd.register(sub)
    return parser


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        with warnings.catch_warnings():  # a warning (e.g. a cache that could not store) is one line, as errors are
            warnings.showwarning = _one_line(args.command)
            result = args.run(args)
    except (LubevizError, ValueError) as exc:
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        sys.stderr.write(f"lubeviz {args.command}: error: {msg}\n")
        return EXIT_BAD_INPUT
    if not getattr(args, "json_text_done", False):
        emit(result, args.json)
    return EXIT_BAD_INPUT if isinstance(result, dict) and result.get("failed") else 0


def _one_line(command: str):
    def show(message, category, filename, lineno, file=None, line=None):
        sys.stderr.write(f"lubeviz {command}: warning: {str(message).splitlines()[0] if str(message) else category.__name__}\n")
    return show


if __name__ == "__main__":
    sys.exit(main())
