"""`lubeviz bench film` (SPEC §7): performance figures as JSON."""

from __future__ import annotations

from ..bench import bench_film
from ..progress import StderrBar
from .common import add_common


def register(sub) -> None:
    p = sub.add_parser("bench", help="performance figures of BENCHMARKS.md")
    add_common(p)
    p.add_argument("what", choices=("film",), help="which benchmark")
    p.add_argument("--repeat", type=int, default=5, help="repetitions (the median is reported)")
    p.set_defaults(run=run_bench)


def run_bench(args) -> dict:
    if args.repeat < 1:
        raise ValueError(f"--repeat {args.repeat}: expected at least 1")
    return bench_film(args.machine, repeat=args.repeat, progress=StderrBar())
