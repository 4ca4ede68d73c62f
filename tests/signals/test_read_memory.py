"""Reading a large record costs a few times its size in memory, not tens (issue 34, item 9): a ~20 MB CSV
and .npz, each read in a fresh process (`lubeviz bench read` at 195 MB: BENCHMARKS.md)."""

from pathlib import Path

import numpy as np
import pytest

from lubeviz.bench.read import read_peak_memory, write_large_record


@pytest.mark.parametrize("suffix", [".csv", ".npz"])
def test_reading_a_20_mb_record_grows_memory_by_less_than_3x_its_size(tmp_path, suffix):
    path = write_large_record(Path(tmp_path) / f"large{suffix}", 20.0, np.random.default_rng(5))
    got = read_peak_memory(path)
    assert got["file_bytes"] > 15e6 and got["n_samples"] > 150_000
    assert got["warnings"] == 0
    # growth of the reader's peak RSS over its RSS once lubeviz is imported (before: ~16x for CSV, ~44x for npz)
    assert got["growth_mb"] * 1e6 < 3.0 * got["file_bytes"], got
