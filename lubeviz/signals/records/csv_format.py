"""CSV records: `# key: value` metadata, a header row, numeric rows, decoded and parsed in bounded memory."""

from __future__ import annotations

import difflib
import re
from collections.abc import Mapping
from pathlib import Path

import numpy as np
from .fields import _Origin, _ignored_warning
from .record import COLUMNS, FREE_PREFIXES, META_KEYS, MIN_SAMPLES, _fail


_CSV_CHUNK_BYTES = 1 << 20  # bytes decoded at a time


_CSV_BATCH_ROWS = 1 << 14  # data rows parsed at a time


def _text_lines(path: Path, where: str):
    """The file's lines, as `str.splitlines` splits them (any line ending), decoded chunk by chunk.

    A partial last line of a chunk (or a CR that a LF may follow) waits for the next chunk, so the lines
    and their numbers are those of the whole text; a byte that is not UTF-8 is named by its file offset.
    """
    import codecs

    decoder = codecs.getincrementaldecoder("utf-8-sig")()
    carry, offset = "", 0
    try:
        with open(path, "rb") as f:
            while True:
                chunk = f.read(_CSV_CHUNK_BYTES)
                try:
                    text = decoder.decode(chunk, final=not chunk)
                except UnicodeDecodeError as exc:
                    raise _fail(where, "file", f"is not UTF-8 text (byte {offset + exc.start})",
                                "a CSV text file") from None
                offset += len(chunk)
                parts = (carry + text).splitlines()
                if not chunk:
                    yield from parts
                    return
                # the last part may be cut: keep it, with its line ending, for the next round
                keep = (carry + text).splitlines(keepends=True)
                carry = keep.pop() if keep else ""
                yield from parts[:len(keep)]
    except OSError as exc:
        raise _fail(where, "file", f"cannot be read ({exc.strerror or exc})") from None


def _read_csv(path: Path, where: str):
    """Metadata and header line by line, then the data in batches of rows parsed by numpy's C parser
    straight into float arrays: the text is never held whole (a 200 MB file reads in a few times the
    memory of its numbers)."""
    lines = iter(_text_lines(path, where))
    meta, extra, seen, notes = {}, {}, {}, []
    i, header = 0, None
    for line in lines:
        s = line.strip()
        if s and not s.startswith("#"):
            header = line
            break
        body = s[1:].strip()
        if ":" not in body:  # a free comment, unless it looks like a known key without its colon
            word = re.split(r"[\s=]+", body, maxsplit=1)[0].lower()
            close = difflib.get_close_matches(word, META_KEYS, n=1, cutoff=0.8) if word else []
            if close:
                notes.append(f"{where}: line {i + 1}: '{s}' has no ':' and is read as a free"
                             f" comment; did you mean '# {close[0]}: ...'?")
        else:  # '# key: value'
            key, value = (p.strip() for p in body.split(":", 1))
            low = key.lower()
            if low in seen:
                raise _fail(where, f"metadata {key!r}", f"given twice (lines {seen[low]} and {i + 1})",
                            "each key once")
            seen[low] = i + 1
            if low in META_KEYS:
                meta[low] = value
            elif low in COLUMNS:
                raise _fail(where, f"metadata {key!r}, line {i + 1}", "is a column name",
                            f"'{low}' as a column, not as metadata")
            elif key:
                extra[key] = value
        i += 1
    if header is None:
        raise _fail(where, "header", "no header row and no data", "a header row such as 't,x1,y1,x2,y2'")
    header_line = i + 1
    delimiter = next((d for d in (",", ";", "\t") if d in header), None)
    names = [c.strip().strip("\"'").strip().lower() for c in header.split(delimiter)]
    if all(_is_number(c) for c in names):
        raise _fail(where, f"header, line {header_line}", "holds numbers, not column names",
                    "a header row such as 't,x1,y1,x2,y2' before the data (not commented out)")
    positions = {}
    for j, name in enumerate(names):
        if name in COLUMNS:
            if name in positions:
                raise _fail(where, f"column {name!r}", "appears twice in the header", "each column once")
            positions[name] = j
        elif name and not name.startswith(FREE_PREFIXES):
            notes.append(_ignored_warning(where, f"column {name!r}", name, COLUMNS))

    tables, numbers = [], []
    line_no = header_line
    batch: list[str] = []
    batch_lines: list[int] = []
    for line in lines:
        line_no += 1
        if line.strip():  # blank lines carry no sample: dropped, the line numbers kept right
            batch.append(line)
            batch_lines.append(line_no)
            if len(batch) == _CSV_BATCH_ROWS:
                tables.append(_csv_batch(batch, batch_lines, where, delimiter, names, positions, header_line))
                numbers.append(np.array(batch_lines, dtype=np.int64))
                batch, batch_lines = [], []
    if batch:
        tables.append(_csv_batch(batch, batch_lines, where, delimiter, names, positions, header_line))
        numbers.append(np.array(batch_lines, dtype=np.int64))
    del batch, batch_lines
    if not numbers:
        raise _fail(where, "data", f"no data rows after the header (line {header_line})",
                    f"at least {MIN_SAMPLES} rows of numbers")
    line_numbers = np.concatenate(numbers)
    columns = {}
    for k, name in enumerate(positions):  # one column at a time: the batches are let go as they are joined
        columns[name] = np.concatenate([table[k] for table in tables])
    del tables
    return columns, meta, extra, _Origin(where, line_numbers, tuple(n for n in names if n), tuple(notes))


def _csv_batch(body: list[str], line_numbers: list[int], where: str, delimiter, names, positions,
               header_line: int) -> list[np.ndarray]:
    """The used columns of a batch of non-blank data rows, each a float64 array; every bad row named by line."""
    stripped = [line.strip() for line in body]
    comments = [k for k, s in enumerate(stripped) if s[0] == "#"]
    if comments:
        raise _fail(where, f"line {line_numbers[comments[0]]}", "comment after the header",
                    "metadata comments only before the header row")
    widths = np.array([len(line.split()) for line in body] if delimiter is None
                      else [line.count(delimiter) + 1 for line in body])
    bad = np.flatnonzero(widths != len(names))
    if bad.size:
        k = int(bad[0])
        heads = ", ".join(n or "(unnamed)" for n in names)
        raise _fail(where, f"line {line_numbers[k]}", f"this row has {widths[k]} cells",
                    f"one number per column of the header row (line {header_line}: {heads}), "
                    f"{len(names)} cells on every row")
    if not positions:
        return []
    try:  # fast path: numpy's C parser on the columns we use
        table = np.loadtxt(body, delimiter=delimiter, usecols=list(positions.values()),
                           comments=None, ndmin=2, dtype=np.float64)
    except ValueError:  # slow path, only to name the first bad cell
        rows = [line.split(delimiter) for line in body]
        table = np.array([[_cell(r[j], where, name, n) for name, j in positions.items()]
                          for r, n in zip(rows, line_numbers)])
    return [np.ascontiguousarray(table[:, k]) for k in range(table.shape[1])]


def _write_csv(path: Path, columns: dict, meta: dict, extra: Mapping[str, str]) -> None:
    head = []
    for key, value in {**meta, **extra}.items():
        if key == "probe_angles_deg":
            flat = value[0] if all(v == value[0] for v in value) else tuple(a for pair in value for a in pair)
            value = ", ".join(repr(float(a)) for a in flat)
        elif key == "rest_position":
            value = ", ".join(repr(float(a)) for a in np.ravel(value))
        elif isinstance(value, float):
            value = repr(value)
        head.append(f"# {key}: {value}")
    head.append(",".join(columns))
    table = np.column_stack(list(columns.values())).tolist()
    body = [",".join(map(repr, row)) for row in table]
    with open(path, "w", encoding="utf-8", newline="\n") as f:
        f.write("\n".join(head + body) + "\n")


def _cell(cell: str, where: str, name: str, line: int) -> float:
    try:
        return float(cell)
    except ValueError:
        problem = "empty cell" if not cell.strip() else f"{cell.strip()!r} is not a number"
        raise _fail(where, f"column {name!r}, line {line}", problem, "a number") from None


def _is_number(cell: str) -> bool:
    try:
        float(cell)
    except ValueError:
        return False
    return True
