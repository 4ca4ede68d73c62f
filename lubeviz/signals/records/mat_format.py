"""MAT-file records (v5/v7): walked element by element before scipy reads them."""

from __future__ import annotations

import dataclasses
import io
import math
import re
import struct
import zlib
from pathlib import Path
import scipy.io
from scipy.io.matlab import MatReadError
from .fields import _split_entries
from .record import _fail
from . import record as _record  # its MAX_RECORD_BYTES read at call time


_MATLAB_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]{0,62}\Z")


def _read_mat(path: Path, where: str):
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise _fail(where, "file", f"cannot be read ({exc.strerror or exc})") from None
    readable, notes = _check_mat5(data, where)
    try:
        entries = scipy.io.loadmat(io.BytesIO(data), squeeze_me=True, chars_as_strings=True,
                                   variable_names=readable)
    except NotImplementedError:
        raise _fail(where, "file", "is a MATLAB v7.3 (HDF5) file",
                    "a v5/v7 MAT-file (save(..., '-v7'))") from None
    except (MatReadError, ValueError, TypeError, OSError, EOFError, IndexError, KeyError,
            zlib.error) as exc:
        raise _fail(where, "file", f"is not a readable MAT-file ({exc})") from None
    columns, meta, extra, origin = _split_entries({k: v for k, v in entries.items()
                                                   if not k.startswith("__")}, where)
    return columns, meta, extra, dataclasses.replace(origin, notes=tuple(notes) + origin.notes)


class _MatUnsupported(Exception):
    """A MAT-file variable of a class a record cannot hold (sparse, object, function handle)."""


# MAT v5 data types: bytes per value of the numeric and text ones (miINT8 ... miUTF32)
_MAT_VALUE_BYTES = {1: 1, 2: 1, 3: 2, 4: 2, 5: 4, 6: 4, 7: 4, 9: 8, 12: 8, 13: 8, 16: 1, 17: 2, 18: 4}


_MI_INT32, _MI_UINT32, _MI_MATRIX, _MI_COMPRESSED, _MI_UTF8 = 5, 6, 14, 15, 16


_MAT_ARRAYS = {4: "char", **{c: "numeric" for c in range(6, 16)}}  # mxCHAR, mxDOUBLE ... mxUINT64


_MAT_CLASS_NAMES = {3: "object", 5: "sparse", 16: "function handle", 17: "opaque"}  # not read


def _check_mat5(data: bytes, where: str) -> tuple[list[str] | None, list[str]]:
    """Walk the data elements of a MAT v5 (v6/v7) file before scipy reads it.

    scipy's v5 reader is not hardened against corrupt files (its `loadmat` docs say so): an element
    type code out of range is used as an index into a C array and crashes the whole process (scipy
    PR #25349), which a record upload must never do. So every element is checked here first: a
    known type code, a size that fits its container, dimensions that agree with the number of
    values. Returns the names of the variables scipy may read (None: all, for other MAT versions,
    v4 and v7.3, which are left to scipy) and a warning for each variable skipped because a record
    cannot hold it (sparse, object, function handle; scipy then never parses it).
    """
    if len(data) < 128 or data[126:128] not in (b"IM", b"MI") or 0 in data[:4]:
        return None, []  # not a v5 header: scipy decides (v4, v7.3 or not a MAT-file)
    order = "<" if data[126:128] == b"IM" else ">"
    budget = [_record.MAX_RECORD_BYTES]  # decompressed bytes allowed over the whole file

    def bad(problem: str):
        return _fail(where, "file", f"is not a readable MAT-file ({problem})",
                     "a MAT-file of numeric arrays and text, saved with save(..., '-v7')")

    def tag(buf: bytes, pos: int, limit: int):
        """(type, byte count, data start, data end, next element) of the element at `pos`."""
        if pos + 8 > limit:
            raise bad(f"element cut short at byte {pos}")
        first, second = struct.unpack_from(order + "II", buf, pos)
        if first >> 16:  # small data element: type, size and up to 4 bytes in 8
            mdtype, nbytes = first & 0xFFFF, first >> 16
            if nbytes > 4:
                raise bad(f"small element of {nbytes} bytes at byte {pos}")
            return mdtype, nbytes, pos + 4, pos + 4 + nbytes, pos + 8
        end = pos + 8 + second
        if end > limit:
            raise bad(f"element at byte {pos} ({second} bytes) runs past its end")
        return first, second, pos + 8, end, pos + 8 + second + (-second) % 8

    def values(buf: bytes, pos: int, limit: int, count: int | None) -> int:
        mdtype, nbytes, _, _, after = tag(buf, pos, limit)
        size = _MAT_VALUE_BYTES.get(mdtype)
        if size is None:
            raise bad(f"unknown data type code {mdtype} at byte {pos}")
        if nbytes % size or (count is not None and nbytes // size != count):
            raise bad(f"{nbytes} bytes of type {mdtype} at byte {pos} where {count} values are declared")
        return after

    def matrix(buf: bytes, pos: int, limit: int, names: list[str] | None = None, depth: int = 0) -> int:
        if depth > 32:
            raise _MatUnsupported("cells or structs nested more than 32 deep")
        mdtype, nbytes, start, end, after = tag(buf, pos, limit)
        if mdtype != _MI_MATRIX:
            raise bad(f"array expected at byte {pos}, found type code {mdtype}")
        if nbytes == 0:  # an empty cell element
            return after
        fmd, fn, fs, _, p = tag(buf, start, end)
        if fmd != _MI_UINT32 or fn != 8:
            raise bad(f"array flags at byte {start}")
        flags, = struct.unpack_from(order + "I", buf, fs)
        cls, is_complex = flags & 0xFF, bool(flags & 0x0800)
        dmd, dn, ds, _, p = tag(buf, p, end)
        if dmd not in (_MI_INT32, _MI_UINT32) or dn % 4 or dn < 8:
            raise bad(f"array dimensions at byte {ds - 8}")
        dims = struct.unpack_from(order + f"{dn // 4}i", buf, ds)
        if min(dims) < 0 or math.prod(dims) > _record.MAX_RECORD_BYTES:
            raise bad(f"array dimensions {dims} at byte {ds - 8}")
        count = math.prod(dims)
        nmd, nn, ns, ne, p = tag(buf, p, end)
        if nmd not in (1, 2, _MI_UTF8):
            raise bad(f"array name at byte {ns - 8}")
        name = bytes(buf[ns:ne]).decode("latin-1")
        if names is not None:
            names.append(name)
        if cls in _MAT_ARRAYS:  # text may be stored in fewer values (UTF-8, empty): count not checked
            p = values(buf, p, end, count if _MAT_ARRAYS[cls] == "numeric" else None)
            if is_complex:
                p = values(buf, p, end, count)
        elif cls == 1:
            for _ in range(count):
                p = matrix(buf, p, end, depth=depth + 1)
        elif cls == 2:
            lmd, ln, ls, _, p = tag(buf, p, end)
            if lmd != _MI_INT32 or ln != 4:
                raise bad(f"struct field name length at byte {ls - 8}")
            field_len, = struct.unpack_from(order + "i", buf, ls)
            _, names_bytes, _, _, p = tag(buf, p, end)
            if field_len <= 0 or names_bytes % field_len:
                raise bad(f"struct field names at byte {p}")
            for _ in range(count * (names_bytes // field_len)):
                p = matrix(buf, p, end, depth=depth + 1)
        elif cls in _MAT_CLASS_NAMES:
            raise _MatUnsupported(f"a MATLAB {_MAT_CLASS_NAMES[cls]} array")
        else:
            raise bad(f"unknown array class code {cls} at byte {start}")
        if p > after:
            raise bad(f"array {name!r} overruns its element")
        return after

    readable, notes = [], []
    pos = 128
    while pos < len(data):
        mdtype, _, start, end, _ = tag(data, pos, len(data))
        names: list[str] = []
        try:
            if mdtype == _MI_COMPRESSED:
                inflate = zlib.decompressobj()
                try:
                    raw = inflate.decompress(data[start:end], budget[0] + 1)
                except zlib.error as exc:
                    raise bad(f"compressed variable at byte {pos}: {exc}") from None
                if len(raw) > budget[0]:
                    raise bad(f"decompresses to more than {_record.MAX_RECORD_BYTES / 1e6:g} MB")
                budget[0] -= len(raw)
                matrix(raw, 0, len(raw), names)
            elif mdtype == _MI_MATRIX:
                matrix(data, pos, len(data), names)
            else:
                raise bad(f"unexpected element type code {mdtype} at byte {pos}")
            readable.append(names[0])
        except _MatUnsupported as exc:
            notes.append(f"{where}: variable {names[0]!r} ignored; {exc}, which a record cannot hold")
        pos = end
    return readable, notes
