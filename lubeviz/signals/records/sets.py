"""Sets: records of one machine at several steady speeds (SPEC §6, `set: NAME`)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from ...errors import DataFormatError
from .files import _name, read_record
from .record import Record, SET_SPEED_RTOL, _fail


def read_set(paths, *, default_nodes=None, default_probe_angles=None) -> list[Record]:
    """The records of one `set:`, read and checked together (`check_set`), sorted by speed; the keywords as
    `read_record`'s (`Machine.record_defaults`)."""
    paths = [Path(p) for p in ([paths] if isinstance(paths, (str, Path)) else paths)]
    return check_set([read_record(p, default_nodes=default_nodes, default_probe_angles=default_probe_angles)
                      for p in paths])


def check_set(records: Sequence[Record]) -> list[Record]:
    """Records of one set, sorted by speed; refused unless they can be identified together.

    A set needs at least two records, each naming the same `set:`, with the same machine, the same
    nodes and the same probe angles, and no two at the same speed (within `SET_SPEED_RTOL`).
    """
    records = list(records)
    names = ", ".join(_name(r) for r in records) or "no files"
    if len(records) < 2:
        raise DataFormatError(f"{names}: set: a set needs at least 2 records at different speeds;"
                              f" got {len(records)}")
    first = records[0]
    for r in records:
        if r.set_name is None:
            raise _fail(_name(r), "set", "no '# set: NAME' line, so it is not part of a set",
                        f"'# set: {first.set_name or 'NAME'}' in every record of the set")
    for label, get in (("set", lambda r: r.set_name), ("machine", lambda r: r.machine),
                       ("nodes (node1, node2)", lambda r: r.nodes),
                       ("probe_angles_deg", lambda r: r.probe_angles_deg)):
        for r in records[1:]:
            if get(r) != get(first):
                raise DataFormatError(
                    f"{_name(r)}: {label}: {get(r)!r} disagrees with {get(first)!r} in {_name(first)};"
                    f" expected the records of one set to share the set name, machine, nodes and"
                    f" probe angles (set {first.set_name!r}: {names})")
    ordered = sorted(records, key=lambda r: r.speed_hz)
    for a, b in zip(ordered, ordered[1:]):
        if b.speed_hz - a.speed_hz <= SET_SPEED_RTOL * b.speed_hz:
            raise DataFormatError(
                f"{_name(b)}: speed_hz: {b.speed_hz:g} Hz is the speed of {_name(a)}"
                f" ({a.speed_hz:g} Hz, within {100 * SET_SPEED_RTOL:g} %); expected one record per"
                f" speed in set {first.set_name!r}")
    return ordered


def group_records(records: Sequence[Record]) -> list[list[Record]]:
    """Records grouped by `set_name`, groups in order of first appearance, records in input order.

    A record without a set is a group of its own. Nothing is checked here: pass a group of several
    records to `check_set`.
    """
    groups: list[list[Record]] = []
    by_name: dict[str, list[Record]] = {}
    for r in records:
        if r.set_name is None:
            groups.append([r])
        elif r.set_name in by_name:
            by_name[r.set_name].append(r)
        else:
            by_name[r.set_name] = [r]
            groups.append(by_name[r.set_name])
    return groups
