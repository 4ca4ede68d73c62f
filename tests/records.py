"""Records of the paper's machine as the tests read and build them: lubeviz's own readers with that machine's
planes (nodes 6, 20, probes along X and Y) standing in for what a record does not name, as `lubeviz identify`
reads a record with no --machine. lubeviz itself assumes no machine's nodes (tests/signals/test_records.py,
"a record names its planes")."""

import functools

from lubeviz.model.machine import load_machine
from lubeviz.signals import records as _records

PAPER_PLANES = load_machine().record_defaults()  # {"default_nodes": (6, 20), "default_probe_angles": ...}
PAPER_NODES = PAPER_PLANES["default_nodes"]


def _with_paper_planes(reader):
    @functools.wraps(reader)
    def read(*args, **kwargs):
        return reader(*args, **{**PAPER_PLANES, **kwargs})
    return read


read_record = _with_paper_planes(_records.read_record)
read_record_bytes = _with_paper_planes(_records.read_record_bytes)
read_set = _with_paper_planes(_records.read_set)


@functools.wraps(_records.record_from_arrays)
def record_from_arrays(*channels, **kwargs):
    """lubeviz's `record_from_arrays`, its planes the paper's (nodes 6, 20) unless `nodes` is given."""
    kwargs.setdefault("nodes", PAPER_NODES)
    return _records.record_from_arrays(*channels, **kwargs)
