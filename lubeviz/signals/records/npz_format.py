"""`.npz` records: each member's header read first, arrays read into their own buffers."""

from __future__ import annotations

import math
import struct
import zipfile
import zlib
from pathlib import Path

import numpy as np

from ...errors import DataFormatError
from .fields import _split_entries
from .record import COLUMNS, MAX_PLANES, META_KEYS, RESERVED, _fail
from . import record as _record  # its MAX_RECORD_BYTES read at call time


def _write_npz(path: Path, arrays: dict) -> None:
    """np.savez without its keyword arguments (a metadata key 'file' must not collide)."""
    with zipfile.ZipFile(path, "w", zipfile.ZIP_STORED, allowZip64=True) as archive:
        for key, value in arrays.items():
            with archive.open(key + ".npy", "w", force_zip64=True) as f:
                np.lib.format.write_array(f, np.asanyarray(value), allow_pickle=False)


def _read_npz(path: Path, where: str):
    """Members one by one, each .npy header read first (`_npz_member`): no header can make us allocate
    more than the member holds or `MAX_RECORD_BYTES`, and each array is read straight into its own buffer."""
    entries = {}
    try:
        with open(path, "rb") as f:
            if f.read(6) == b"\x93NUMPY":  # a .npy file named .npz
                raise _fail(where, "file", "holds a single array", "an .npz archive of named arrays")
        with zipfile.ZipFile(path) as archive:
            infos = archive.infolist()
            unpacked = sum(info.file_size for info in infos)
            if unpacked > _record.MAX_RECORD_BYTES:  # a small archive may inflate to anything: ask first
                raise _fail(where, "file", f"unpacks to {unpacked / 1e6:.1f} MB",
                            f"at most {_record.MAX_RECORD_BYTES / 1e6:g} MB (lubeviz.signals.records.MAX_RECORD_BYTES)")
            for info in infos:
                if info.is_dir():
                    continue
                key = info.filename[:-4] if info.filename.endswith(".npy") else info.filename
                entries[key] = _npz_member(archive, info, key, where)
    except (ValueError, OSError, EOFError, zipfile.BadZipFile, zlib.error, struct.error,
            NotImplementedError, RuntimeError) as exc:  # zipfile: unknown versions, encryption
        if isinstance(exc, DataFormatError):
            raise
        raise _fail(where, "file", f"is not a readable .npz archive ({exc})") from None
    return _split_entries(entries, where)


_NPZ_SMALL = 2 * MAX_PLANES  # values a metadata array may hold (probe angles, rest readings, nodes: 2 per plane)


_READ_CHUNK = 1 << 20  # bytes read from a member at a time (zipfile copies each read once)


def _npz_member(archive: zipfile.ZipFile, info: zipfile.ZipInfo, key: str, where: str):
    """One .npz member as an array, its header checked before anything is allocated.

    Refused (naming the member): a header numpy cannot read, Python objects, structured or other
    non-numeric, non-text data, a shape whose bytes exceed what the member holds or _record.MAX_RECORD_BYTES, a
    record column that is not a vector, a metadata field of more than a few values. A large array under
    a name the record format does not use is not read at all: an empty stand-in, reported as ignored.
    """
    member = f"member {info.filename!r}"
    low = key.lower()
    with archive.open(info) as f:
        try:
            version = np.lib.format.read_magic(f)
            if version == (1, 0):
                shape, fortran, dtype = np.lib.format.read_array_header_1_0(f)
            elif version == (2, 0):
                shape, fortran, dtype = np.lib.format.read_array_header_2_0(f)
            else:  # (3, 0): utf-8 field names, i.e. structured data, which a record never holds
                raise ValueError(f"format version {version[0]}.{version[1]}")
        except (ValueError, TypeError, SyntaxError, EOFError) as exc:
            raise _fail(where, member, f"is not a readable .npy array ({exc})",
                        "arrays saved by numpy.savez") from None
        if dtype.hasobject:
            raise _fail(where, repr(key), "holds Python objects (pickled data)", "numbers or text")
        if dtype.fields is not None or dtype.kind not in "biufcUS":
            raise _fail(where, member, f"holds {dtype} values", "numbers or text")
        count = math.prod(shape)
        nbytes = count * dtype.itemsize
        held = info.file_size - f.tell()  # bytes after the header (uncompressed)
        if nbytes > held or nbytes > _record.MAX_RECORD_BYTES:
            raise _fail(where, member, f"its header claims shape {shape} of {dtype} ({nbytes / 1e6:.6g} MB)"
                        f" but the member holds {max(held, 0)} bytes of data",
                        f"a header that agrees with its data, at most {_record.MAX_RECORD_BYTES / 1e6:g} MB")
        spread = sum(1 for d in shape if d != 1)
        if low in COLUMNS and (spread > 1 or dtype.kind not in "biuf"):
            if dtype.kind not in "biuf":
                raise _fail(where, repr(key), f"holds {dtype} values", "real numbers")
            raise _fail(where, repr(key), f"shape {shape}", "a vector of samples")
        if low in META_KEYS and count > _NPZ_SMALL:
            raise _fail(where, repr(key), f"array of shape {shape}", "a single value, a text or a few numbers")
        if low not in RESERVED and count > 1:
            return np.empty((0, 0))  # not used by a record: not read (reported as ignored)
        flat = np.empty(count, dtype=dtype)
        view = memoryview(flat.view(np.uint8)) if nbytes else memoryview(bytearray())
        pos = 0
        while pos < nbytes:
            got = f.readinto(view[pos:pos + _READ_CHUNK])
            if not got:
                raise _fail(where, member, f"data cut short after {pos} of {nbytes} bytes",
                            "a complete .npz archive")
            pos += got
        f.read(1)  # to the member's end, so zipfile checks its CRC
        return flat.reshape(shape, order="F" if fortran else "C")
