"""The rate benches' long runs (`bench.loop`, `bench.records.bench_orbit`): worker processes of one BLAS / OpenMP /
numba thread each, so that N workers share N cores instead of each taking them all, and a rows file (JSON lines)
each finished case is appended to, so that a stopped run goes on where it ended."""

from __future__ import annotations

import contextlib
import json
import os

import numpy as np

THREAD_VARS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS", "NUMEXPR_NUM_THREADS",
               "VECLIB_MAXIMUM_THREADS", "NUMBA_NUM_THREADS")


def one_thread() -> None:
    """Every thread-count variable of THREAD_VARS set to 1 in this process's environment (a pool's initializer)."""
    for var in THREAD_VARS:
        os.environ[var] = "1"


@contextlib.contextmanager
def one_thread_each():
    """Within the block the environment asks for one thread (spawned workers take it as it is when they start:
    numpy reads it on import); after it, every variable as it was."""
    saved = {v: os.environ.get(v) for v in THREAD_VARS}
    one_thread()
    try:
        yield
    finally:
        for v, old in saved.items():
            if old is None:
                os.environ.pop(v, None)
            else:
                os.environ[v] = old


def read_saved(path, key_field: str, value_field: str) -> dict:
    """{item[key_field]: item[value_field]} of every whole line of the rows file `path` ({} when there is none); a
    line cut short by a stopped run is passed over."""
    if path is None or not os.path.exists(path):
        return {}
    out = {}
    with open(path, encoding="utf-8") as fh:
        for line in fh:
            try:
                item = json.loads(line)
            except ValueError:
                continue
            if isinstance(item, dict) and key_field in item and value_field in item:
                out[item[key_field]] = item[value_field]
    return out


def append_saved(path, key_field: str, key, value_field: str, value) -> None:
    """One line {key_field: key, value_field: value} appended to the rows file `path` (numpy scalars and arrays
    written as numbers and lists)."""
    with open(path, "a", encoding="utf-8") as fh:
        fh.write(json.dumps({key_field: key, value_field: value}, default=_plain) + "\n")


def _plain(v):
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, np.ndarray):
        return v.tolist()
    raise TypeError(f"{type(v).__name__} is not JSON")
