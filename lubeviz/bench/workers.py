"""The rate benches' worker processes: one BLAS / OpenMP / numba thread each, so that N workers share N cores
instead of each taking them all (`bench.loop`, `bench.records.bench_orbit`)."""

from __future__ import annotations

import contextlib
import os

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
