"""`lubeviz bench read`: the record reader's peak memory on large files (issue 34, item 9).

A record of about `size_mb` MB is written as CSV and as .npz (a 75 Hz shaft at 10 kHz, 1X plus noise,
metres), then each file is read by `read_record` in a fresh Python process, which reports its peak
resident memory (VmHWM of /proc/self/status; ru_maxrss where /proc is missing) and its resident memory
once lubeviz is imported, so the growth is what reading costs. The files live in a temporary folder.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from ..signals.records import MAX_RECORD_BYTES, record_from_arrays, write_record

SPEED_HZ, RATE_HZ = 75.0, 1.0e4
NODES = (6, 20)  # the planes a synthetic record names (the reader's cost does not depend on them)
CSV_BYTES_PER_ROW = 105  # 't,x1,y1,x2,y2' of shortest-repr floats, about
NPZ_BYTES_PER_ROW = 5 * 8

_CHILD = r"""
import json, resource, sys, time
def status(key):
    try:
        with open('/proc/self/status') as f:
            for line in f:
                if line.startswith(key + ':'):
                    return int(line.split()[1]) * 1024
    except OSError:
        return None
from lubeviz.signals.records import read_record
import lubeviz.signals.speed_check, scipy.fft
base = status('VmRSS')
try:
    with open('/proc/self/clear_refs', 'w') as f:  # reset VmHWM to the current RSS
        f.write('5')
except OSError:
    pass
t0 = time.perf_counter()
rec = read_record(sys.argv[1])
seconds = time.perf_counter() - t0
peak = status('VmHWM') or resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
print(json.dumps({'peak_rss_bytes': peak, 'rss_after_import_bytes': base, 'seconds': seconds,
                  'n_samples': rec.n_samples, 'warnings': len(rec.warnings)}))
"""


def synthetic_large_record(n_samples: int, rng: np.random.Generator):
    """A plain record of `n_samples`: forward 1X orbits at both planes plus white noise, metres."""
    t = np.arange(n_samples) / RATE_HZ
    w = 2 * math.pi * SPEED_HZ * t
    chans = [a * np.cos(w + p) + 1e-6 * rng.standard_normal(n_samples)
             for a, p in ((20e-6, 0.0), (18e-6, -1.5), (15e-6, 0.4), (14e-6, -1.2))]
    return record_from_arrays(*chans, speed_hz=SPEED_HZ, nodes=NODES, sample_rate_hz=RATE_HZ)


def write_large_record(path: Path, size_mb: float, rng: np.random.Generator) -> Path:
    """A record file of about `size_mb` MB (never above MAX_RECORD_BYTES)."""
    target = min(size_mb * 1e6, 0.99 * MAX_RECORD_BYTES)
    per_row = CSV_BYTES_PER_ROW if path.suffix == ".csv" else NPZ_BYTES_PER_ROW
    n = int(target / per_row)
    while True:
        write_record(synthetic_large_record(n, rng), path)
        size = path.stat().st_size
        if size <= target:
            return path
        n = int(n * target / size * 0.995)


def read_peak_memory(path: Path) -> dict:
    """Read `path` in a fresh process: its peak RSS, the RSS once imported, the time."""
    proc = subprocess.run([sys.executable, "-c", _CHILD, str(path)], capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        raise RuntimeError(f"reading {path} in a child process failed: {proc.stderr.strip()[-2000:]}")
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    size = path.stat().st_size
    growth = out["peak_rss_bytes"] - (out["rss_after_import_bytes"] or 0)
    return {"file_bytes": size, "file_mb": size / 1e6, "peak_rss_mb": out["peak_rss_bytes"] / 1e6,
            "rss_after_import_mb": (out["rss_after_import_bytes"] or 0) / 1e6, "growth_mb": growth / 1e6,
            "growth_over_file_size": growth / size, "seconds": out["seconds"], "n_samples": out["n_samples"],
            "warnings": out["warnings"]}


def bench_read(size_mb: float = 195.0, seed: int = 2026, folder: Path | None = None) -> dict:
    """Peak memory of reading a ~`size_mb` MB CSV and .npz record, each in a fresh process."""
    rng = np.random.default_rng(seed)
    t0 = time.perf_counter()
    out = {"size_mb_requested": size_mb, "limit_mb": 1000.0}
    with tempfile.TemporaryDirectory(prefix="lubeviz-bench-read-", dir=folder) as tmp:
        for suffix in (".csv", ".npz"):
            path = write_large_record(Path(tmp) / f"large{suffix}", size_mb, rng)
            out[suffix.lstrip(".")] = read_peak_memory(path)
    out["seconds"] = time.perf_counter() - t0
    return out
