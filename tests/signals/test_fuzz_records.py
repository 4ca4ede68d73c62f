"""A fuzz corpus of malformed records (SPEC §6: bad input never crashes, never silently gives a number).

Several hundred files are made at test time from one valid record (CSV, .npz and .mat) by seeded
mutations: keys and columns deleted, misspelled, duplicated; NaN, inf, text and empty cells;
truncated lines and files; wrong or unknown units; zero and negative rates; time running backwards;
huge values; empty files, binary junk, byte-order marks, mixed delimiters; static/rest_position
inconsistencies; node1 = node2; path-like machine names. Each mutation says what it may do:

- "bad": it changes the meaning or breaks the format, so reading must raise `DataFormatError` naming
  the file, or succeed with at least one warning (an unknown key or column, said out loud);
- "same": it changes only the spelling (line endings, BOM, delimiter, case); reading must succeed
  and give the same record;
- "valid": it gives another well-formed record or cannot be told from one (an optional key removed,
  a file cut inside its last number, a flipped byte in a binary file without a checksum); reading
  may succeed or raise `DataFormatError`.

Never another exception type, and every message and warning names the file.
"""

from __future__ import annotations

import io
import math
import zipfile

import numpy as np
import pytest
import scipy.io

from lubeviz.errors import DataFormatError
from lubeviz.signals.records import write_record
from tests.records import read_record, record_from_arrays

SPEED, RATE, N = 75.0, 2000.0, 400  # 15 revolutions
SEED = 20261123


def base_record():
    t = np.arange(N) / RATE
    w = 2 * math.pi * SPEED * t
    chans = [a * np.cos(w + p) for a, p in ((20.0, 0.0), (15.0, 1.0), (10.0, 2.0), (8.0, 3.0))]  # µm
    return record_from_arrays(*chans, speed_hz=SPEED, sample_rate_hz=RATE, units="um", nodes=(5, 21),
                              probe_angles_deg=((45.0, 135.0), (30.0, 120.0)), machine="paper_machine.toml",
                              keyphasor=(np.cos(w) > 0.99).astype(float), set_name="coast",
                              metadata={"q1_mlmin": "450", "operator": "A. Lab"},
                              static_offset=[[10.0, 50.0], [0.0, 60.0]], rest_position=[1000, 1100, 900, 1050])


# --- the CSV mutations ----------------------------------------------------------------------------

REQUIRED = ("speed_hz", "units")
MEANINGFUL_OPTIONAL = ("node1", "node2", "probe_angles_deg", "machine", "set", "sample_rate_hz")
STATIC_KEYS = ("static", "rest_position")
RECORD_COLUMNS = ("x1", "y1", "x2", "y2")


def _typos(word: str, rng) -> list[str]:
    """Misspellings a person makes: a letter dropped, doubled, swapped, the separator changed, a plural."""
    out = set()
    for _ in range(12):
        i = int(rng.integers(len(word)))
        kind = int(rng.integers(5))
        if kind == 0 and len(word) > 1:
            out.add(word[:i] + word[i + 1:])
        elif kind == 1:
            out.add(word[:i] + word[i] + word[i:])
        elif kind == 2 and i + 1 < len(word):
            out.add(word[:i] + word[i + 1] + word[i] + word[i + 2:])
        elif kind == 3:
            out.add(word.replace("_", "-") if "_" in word else word + "_")
        else:
            out.add(word + "s")
    return sorted(t for t in out if t.lower() != word.lower())


class CsvDoc:
    """The base CSV split into metadata lines, header and data rows, to mutate and join again."""

    def __init__(self, text):
        lines = text.splitlines()
        k = next(i for i, line in enumerate(lines) if not line.startswith("#"))
        self.meta = lines[:k]
        self.header = lines[k].split(",")
        self.rows = [line.split(",") for line in lines[k + 1:]]

    def copy(self):
        c = CsvDoc.__new__(CsvDoc)
        c.meta, c.header, c.rows = list(self.meta), list(self.header), [list(r) for r in self.rows]
        return c

    def key_index(self, key):
        return next(i for i, line in enumerate(self.meta) if line.startswith(f"# {key}:"))

    def set_value(self, key, value):
        self.meta[self.key_index(key)] = f"# {key}: {value}"
        return self

    def column(self, name):
        return self.header.index(name)

    def text(self, sep=",", eol="\n"):
        return eol.join(self.meta + [sep.join(self.header)] + [sep.join(r) for r in self.rows]) + eol


def csv_cases(text, rng):
    doc = CsvDoc(text)
    cases = []

    def add(name, kind, new):
        data = new.text() if isinstance(new, CsvDoc) else new
        name = f"csv-{name}" + (f"-{len(cases)}" if any(c[0] == f"csv-{name}" for c in cases) else "")
        cases.append((name, ".csv", kind, data.encode("utf-8") if isinstance(data, str) else data))

    keys = [line[2:].split(":", 1)[0] for line in doc.meta]
    # keys deleted
    for key in keys:
        d = doc.copy()
        del d.meta[d.key_index(key)]
        kind = "bad" if key in REQUIRED + STATIC_KEYS else "valid"
        add(f"delete-key-{key}", kind, d)
    # keys misspelled, in capitals, duplicated, without their colon
    for key in keys:
        for typo in _typos(key, rng):
            d = doc.copy()
            i = d.key_index(key)
            d.meta[i] = d.meta[i].replace(f"# {key}:", f"# {typo}:", 1)
            add(f"typo-{key}-{typo}", "bad", d)
        d = doc.copy()
        i = d.key_index(key)
        d.meta[i] = d.meta[i].replace(f"# {key}:", f"# {key.upper()}:", 1)
        add(f"capitals-{key}", "same" if key in REQUIRED + MEANINGFUL_OPTIONAL + STATIC_KEYS else "valid", d)
        d = doc.copy()
        d.meta.append(d.meta[d.key_index(key)])
        add(f"duplicate-key-{key}", "bad", d)
        d = doc.copy()
        d.meta.insert(0, f"# {key.title()}: 1")
        add(f"duplicate-key-other-case-{key}", "bad", d)
        if key in REQUIRED + MEANINGFUL_OPTIONAL + STATIC_KEYS:
            d = doc.copy()
            i = d.key_index(key)
            d.meta[i] = d.meta[i].replace(f"# {key}:", f"# {key}", 1)
            add(f"no-colon-{key}", "bad", d)
    # bad values
    bad_values = {
        "speed_hz": ["nan", "inf", "-inf", "", "fast", "0", "-75", "1e400", "1e300", "75 # Hz", "75,0", "1000"],
        "sample_rate_hz": ["nan", "", "0", "-2000", "1e400", "4000", "1000", "150", "2 kHz"],
        "units": ["inch", "", "µm", "m", "mm", "um (micrometre)", "metres"],
        "node1": ["0", "-5", "2.5", "five", "", "1e3", "nan", "21"],
        "node2": ["0", "-1", "6.5", "", "5"],
        "probe_angles_deg": ["nan", "", "45", "45, 46", "0, 90, 0", "45, 135, 30", "45, 135, 30, 120, 0",
                             "a, b", "inf, 90"],
        "machine": ["", "../paper_machine.toml", "/etc/passwd", "models/paper_machine.toml", "C:\\m.toml",
                    "paper_machine.txt", ".."],
        "set": ["", "\t"],
        "static": ["relative", "", "abs", "true", "1", "absolute absolute"],
        "rest_position": ["", "1000, 1100, 900", "1000, 1100, 900, 1050, 7", "nan, 1100, 900, 1050",
                          "1000, inf, 900, 1050", "gap, 1100, 900, 1050", "1e12, 1100, 900, 1050",
                          "1000 1100 900"],
    }
    for key, values in bad_values.items():
        for value in values:
            add(f"value-{key}-{value!r}", "bad", doc.copy().set_value(key, value))
    add("units-mils", "valid", doc.copy().set_value("units", "mils"))  # 25 µm vs 25.4 µm: undetectable
    add("units-capitals", "same", doc.copy().set_value("units", "UM"))
    add("static-capitals", "same", doc.copy().set_value("static", "Absolute"))
    add("rest-brackets", "same", doc.copy().set_value(
        "rest_position", "[" + doc.meta[doc.key_index("rest_position")].split(":", 1)[1].strip() + "]"))

    # columns deleted, misspelled, duplicated, swapped, in capitals
    for name in doc.header:
        d = doc.copy()
        j = d.column(name)
        del d.header[j]
        for r in d.rows:
            del r[j]
        add(f"delete-column-{name}", "bad" if name in RECORD_COLUMNS else "valid", d)
        for typo in _typos(name, rng)[:3]:
            d = doc.copy()
            d.header[d.column(name)] = typo
            add(f"typo-column-{name}-{typo}", "bad", d)
        d = doc.copy()
        j = d.column(name)
        d.header.append(name)
        for r in d.rows:
            r.append(r[j])
        add(f"duplicate-column-{name}", "bad", d)
    d = doc.copy()
    d.header = [h.upper() for h in d.header]
    add("columns-capitals", "same", d)
    d = doc.copy()
    d.header[d.column("x1")], d.header[d.column("y1")] = "y1", "x1"
    add("columns-swapped", "valid", d)
    d = doc.copy()
    d.header.append("temperature")
    for r in d.rows:
        r.append("41.5")
    add("extra-column", "bad", d)  # unknown column: warned

    # cells: NaN, inf, text, empty, huge
    record_cols = ["t", *RECORD_COLUMNS, "keyphasor"]
    for value in ["nan", "NaN", "inf", "-inf", "abc", "", "1e400", "--1", "1.2.3", "0x1F", "1,5", "#",
                  "\x00", "1e5"]:
        for _ in range(2):
            d = doc.copy()
            name = record_cols[int(rng.integers(len(record_cols)))]
            if value == "1e5" and name == "keyphasor":
                name = "x2"  # a keyphasor may hold any finite number
            i = int(rng.integers(len(d.rows)))
            d.rows[i][d.column(name)] = value
            add(f"cell-{name}-{i}-{value!r}", "bad", d)
    # whole channels constant or zero
    for name in RECORD_COLUMNS:
        for value in ("0", "1000.0"):
            d = doc.copy()
            for r in d.rows:
                r[d.column(name)] = value
            add(f"constant-{name}-{value}", "bad", d)

    # lines truncated or padded, rows dropped, files cut
    for _ in range(8):
        d = doc.copy()
        i = int(rng.integers(len(d.rows)))
        d.rows[i] = d.rows[i][:int(rng.integers(1, len(d.header)))]
        add(f"ragged-short-{i}", "bad", d)
    for _ in range(3):
        d = doc.copy()
        i = int(rng.integers(len(d.rows)))
        d.rows[i] = d.rows[i] + ["1.0"]
        add(f"ragged-long-{i}", "bad", d)
    for _ in range(4):
        d = doc.copy()
        i = int(rng.integers(1, len(d.rows) - 1))
        del d.rows[i]
        add(f"dropped-row-{i}", "bad", d)  # a time gap
    for rows in (0, 1, 20, 200):
        d = doc.copy()
        d.rows = d.rows[:rows]
        add(f"only-{rows}-rows", "bad", d)
    d = doc.copy()
    d.rows = d.rows[:300]
    add("only-300-rows", "valid", d)
    full = doc.text()
    for _ in range(10):
        cut = int(rng.integers(1, len(full)))
        add(f"cut-at-{cut}", "valid", full[:cut])
    for lines in range(len(doc.meta) + 2):
        add(f"first-{lines}-lines", "bad", "\n".join(full.splitlines()[:lines]) + "\n")

    # time axis
    tcol = doc.column("t")
    for _ in range(3):
        d = doc.copy()
        i = int(rng.integers(1, len(d.rows) - 1))
        d.rows[i][tcol], d.rows[i + 1][tcol] = d.rows[i + 1][tcol], d.rows[i][tcol]
        add(f"time-swapped-{i}", "bad", d)
        d = doc.copy()
        d.rows[i][tcol] = d.rows[i - 1][tcol]
        add(f"time-repeated-{i}", "bad", d)
        d = doc.copy()
        d.rows[i][tcol] = repr(float(d.rows[i][tcol]) + 0.3 / RATE)
        add(f"time-jitter-{i}", "bad", d)
    d = doc.copy()
    for r, s in zip(d.rows, reversed([r[tcol] for r in doc.rows])):
        r[tcol] = s
    add("time-reversed", "bad", d)
    d = doc.copy()
    for r in d.rows:
        r[tcol] = repr(float(r[tcol]) * 1000.0)
    add("time-in-ms", "bad", d)

    # empty, junk, encodings, delimiters, line endings
    add("empty", "bad", "")
    add("blank-lines", "bad", "\n\n\n")
    add("header-only", "bad", "t,x1,y1,x2,y2\n")
    add("metadata-only", "bad", "\n".join(doc.meta) + "\n")
    for k in range(8):
        junk = rng.integers(0, 256, size=int(rng.integers(1, 400)), dtype=np.uint8).tobytes() + b"\xff"
        add(f"binary-junk-{k}", "bad", junk)
        raw = full.encode()
        at = int(rng.integers(len("\n".join(doc.meta + [",".join(doc.header)])) + 1, len(raw)))
        add(f"binary-junk-inside-{k}", "bad", raw[:at] + junk + raw[at:])
    for k in range(4):
        d = doc.copy()
        i = int(rng.integers(len(d.rows)))
        j = int(rng.integers(len(d.header)))
        d.rows[i][j] = d.rows[i][j][:2] + "@!" + d.rows[i][j][2:]
        add(f"text-junk-{i}-{j}", "bad", d)
    add("utf16", "bad", full.encode("utf-16"))
    add("bom", "same", b"\xef\xbb\xbf" + full.encode())
    d = doc.copy()
    d.header[0] = "\ufeff" + d.header[0]
    add("bom-before-header", "bad", d)  # the 't' column is not found by name: warned
    add("crlf", "same", doc.text(eol="\r\n"))
    add("cr", "same", doc.text(eol="\r"))
    add("semicolons", "same", doc.text(sep=";"))
    add("tabs", "same", doc.text(sep="\t"))
    add("spaces", "same", doc.text(sep="  "))
    add("trailing-blank-lines", "same", full + "\n\n  \n")
    add("blank-lines-in-data", "same", full.replace("\n0.01,", "\n\n0.01,", 1))
    d = doc.copy()
    d.rows = [[f" {c} " for c in r] for r in d.rows]
    add("padded-cells", "same", d)
    for _ in range(4):
        d = doc.copy()
        i = int(rng.integers(len(d.rows)))
        body = d.text().splitlines()
        line = len(d.meta) + 1 + i
        body[line] = body[line].replace(",", ";", int(rng.integers(1, 4)))
        add(f"mixed-delimiters-row-{i}", "bad", "\n".join(body) + "\n")
    body = doc.text(sep=";").splitlines()
    body[len(doc.meta)] = ",".join(doc.header)
    add("header-commas-data-semicolons", "bad", "\n".join(body) + "\n")
    body = full.splitlines()
    body.insert(len(doc.meta) + 5, "# units: mm")
    add("comment-after-header", "bad", "\n".join(body) + "\n")
    body = full.splitlines()
    del body[len(doc.meta)]
    add("no-header", "bad", "\n".join(body) + "\n")
    body = full.splitlines()
    body[len(doc.meta)] = "# " + body[len(doc.meta)]
    add("header-commented-out", "bad", "\n".join(body) + "\n")
    return cases


# --- the binary mutations -------------------------------------------------------------------------

def _npz_arrays(data: bytes) -> dict:
    with np.load(io.BytesIO(data), allow_pickle=False) as z:
        return {k: z[k] for k in z.files}


def _npz_bytes(arrays: dict) -> bytes:
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_STORED) as archive:
        for key, value in arrays.items():
            with archive.open(key + ".npy", "w") as f:
                np.lib.format.write_array(f, np.asanyarray(value), allow_pickle=True)
    return buf.getvalue()


def _mat_bytes(arrays: dict) -> bytes:
    buf = io.BytesIO()
    scipy.io.savemat(buf, arrays, oned_as="column")
    return buf.getvalue()


def array_cases(suffix, data, rng):
    if suffix == ".npz":
        base, pack = _npz_arrays(data), _npz_bytes
    else:
        base = {k: v for k, v in scipy.io.loadmat(io.BytesIO(data), squeeze_me=True).items()
                if not k.startswith("__")}
        pack = _mat_bytes
    cases = []
    tag = suffix[1:]

    def add(name, kind, arrays_or_bytes):
        raw = arrays_or_bytes if isinstance(arrays_or_bytes, bytes) else pack(arrays_or_bytes)
        cases.append((f"{tag}-{name}", suffix, kind, raw))

    def changed(**kw):
        out = dict(base)
        for k, v in kw.items():
            if v is None:
                out.pop(k)
            else:
                out[k] = v
        return out

    for key in base:
        kind = "bad" if key in RECORD_COLUMNS + REQUIRED + STATIC_KEYS else "valid"
        add(f"delete-{key}", kind, changed(**{key: None}))
        for typo in _typos(key, rng)[:2]:
            if typo[0].isalpha() and typo.replace("_", "").isalnum():
                add(f"typo-{key}-{typo}", "bad", {(typo if k == key else k): v for k, v in base.items()})
    add("capital-X1", "same", {("X1" if k == "x1" else k): v for k, v in base.items()})
    add("case-clash", "bad", changed(X2=base["x2"]))
    for name in ("x1", "y2", "t", "keyphasor"):
        for value in (np.nan, np.inf):
            col = np.array(base[name], dtype=float)
            col[int(rng.integers(col.size))] = value
            add(f"{name}-{value}", "bad", changed(**{name: col}))
    add("x1-text", "bad", changed(x1=np.array(["a"] * N)))
    add("x1-2d", "bad", changed(x1=np.zeros((3, N))))
    add("y1-short", "bad", changed(y1=np.asarray(base["y1"])[:-1]))
    add("columns-empty", "bad", changed(**{c: np.zeros(0) for c in ("t", *RECORD_COLUMNS, "keyphasor")}))
    add("columns-few", "bad", changed(**{c: np.asarray(base[c])[:5] for c in ("t", *RECORD_COLUMNS, "keyphasor")}))
    add("x2-constant", "bad", changed(x2=np.full(N, 900.0)))
    add("y2-huge", "bad", changed(y2=np.asarray(base["y2"]) * 1e4))
    add("speed-two-values", "bad", changed(speed_hz=np.array([75.0, 76.0])))
    add("speed-text", "bad", changed(speed_hz="fast"))
    add("speed-negative", "bad", changed(speed_hz=-75.0))
    add("speed-as-text-number", "same", changed(speed_hz="75"))
    add("rate-zero", "bad", changed(sample_rate_hz=0.0))
    add("units-inch", "bad", changed(units="inch"))
    add("units-number", "bad", changed(units=3.0))
    add("rest-three", "bad", changed(rest_position=np.array([1000.0, 1100.0, 900.0])))
    add("rest-nan", "bad", changed(rest_position=np.array([[np.nan, 1.0], [2.0, 3.0]])))
    add("rest-text", "bad", changed(rest_position="gap"))
    add("static-relative", "bad", changed(static="relative"))
    add("static-number", "bad", changed(static=1.0))
    add("nodes-equal", "bad", changed(node2=np.int64(5)))
    add("node-fraction", "bad", changed(node1=2.5))
    add("machine-path", "bad", changed(machine="../../etc/passwd"))
    add("machine-number", "bad", changed(machine=7.0))
    add("angles-parallel", "bad", changed(probe_angles_deg=np.array([45.0, 46.0])))
    add("angles-five", "bad", changed(probe_angles_deg=np.arange(5.0)))
    add("extra-array", "bad", changed(temperature=np.ones(N)))
    add("extra-note", "valid", changed(x_note="fine"))  # kept in metadata, silently
    if suffix == ".npz":
        add("pickled-object", "bad", changed(machine=np.array([{"evil": 1}], dtype=object)))
        add("single-npy", "bad", _npy_bytes(np.asarray(base["x1"])))
    add("empty", "bad", b"")
    add("text-file", "bad", b"speed_hz,75\n" * 20)
    full = pack(base)
    for k in range(6):
        cut = int(rng.integers(1, len(full)))
        add(f"cut-at-{cut}", "bad", full[:cut])
    for k in range(6):
        flipped = bytearray(full)
        for i in rng.integers(0, len(full), size=3):
            flipped[i] ^= 0xFF
        add(f"flipped-bytes-{k}", "valid", bytes(flipped))
    for k in range(3):
        add(f"junk-{k}", "bad", rng.integers(0, 256, size=int(rng.integers(1, 2000)), dtype=np.uint8).tobytes())
    if suffix == ".mat":
        # a data-type code out of range made scipy's reader index past a C array and kill the process
        at = full.index(b"x1\x00\x00") + 4  # the tag of x1's data follows its 8-byte name element
        for code in (0, 8, 10, 11, 19, 20, 0x5809, 0xFFFF):
            patched = bytearray(full)
            patched[at:at + 4] = code.to_bytes(4, "little")
            add(f"type-code-{code}", "bad", bytes(patched))
        zipped = io.BytesIO()
        scipy.io.savemat(zipped, {**base, "x_info": {"rig": "B"}}, do_compression=True)
        zipped = zipped.getvalue()
        add("compressed", "same", zipped)
        for k in range(6):
            cut = int(rng.integers(129, len(zipped)))
            add(f"compressed-cut-at-{cut}", "bad", zipped[:cut])
            flipped = bytearray(zipped)
            flipped[int(rng.integers(128, len(zipped)))] ^= 0x55
            add(f"compressed-flipped-{k}", "valid", bytes(flipped))
    return cases


def _npy_bytes(a):
    buf = io.BytesIO()
    np.save(buf, a)
    return buf.getvalue()


def _npy_with_header(shape, descr="<f8", data=b"\0" * 64):
    """An .npy member whose header claims `shape` whatever data follows (issue 34, item 6)."""
    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(buf, {"descr": descr, "fortran_order": False, "shape": shape})
    return buf.getvalue() + data


def _replace_member(npz: bytes, member: str, data: bytes) -> bytes:
    src = zipfile.ZipFile(io.BytesIO(npz))
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w") as z:
        for info in src.infolist():
            z.writestr(info.filename, data if info.filename == member else src.read(info))
        if member not in src.namelist():
            z.writestr(member, data)
    return out.getvalue()


def _mat4_huge() -> bytes:
    """A MAT v4 file whose header claims a 10^6 x 10^6 double matrix and holds 8 bytes."""
    import struct

    name = b"x1\0"
    return struct.pack("<5i", 0, 1_000_000, 1_000_000, 0, len(name)) + name + b"\0" * 8


def hostile_cases(text: str, npz: bytes, mat: bytes) -> list:
    """Issue 34: headers claiming huge sizes, wrong speed labels and rates, epoch times (items 6, 7)."""
    cases = []
    for member, shape, descr in (("x1.npy", (10**12,), "<f8"), ("x1.npy", (2**62,), "<f8"),
                                 ("y2.npy", (1000, 1000, 1000), "<f8"), ("t.npy", (10**9,), "<c16"),
                                 ("probe_angles_deg.npy", (10**10, 2), "<f8"), ("x_extra.npy", (10**11,), "<f8"),
                                 ("x1.npy", (401,), "<f8"), ("x1.npy", (20, 20), "<f8"),
                                 ("x1.npy", (400,), "<M8[s]"), ("probe_angles_deg.npy", (3, 3), "<f8")):
        data = b"\0" * (400 * 8) if shape in ((401,), (20, 20), (400,), (3, 3)) else b"\0" * 64
        label = "x".join(str(d) for d in shape)
        cases.append((f"npz-header-{member[:-4]}-{label}-{descr.strip('<[]')}", ".npz", "bad",
                      _replace_member(npz, member, _npy_with_header(shape, descr, data))))
    structured = io.BytesIO()
    np.save(structured, np.zeros(400, dtype=[("a", "<f8"), ("b", "<f8")]))
    cases.append(("npz-structured-x1", ".npz", "bad", _replace_member(npz, "x1.npy", structured.getvalue())))
    cases.append(("mat4-huge-header", ".mat", "bad", _mat4_huge()))

    def relabel(key, factor):
        out = []
        for line in text.splitlines():
            if line.startswith(f"# {key}:"):
                line = f"# {key}: {float(line.split(':', 1)[1]) * factor!r}"
            out.append(line)
        return "\n".join(out) + "\n"

    for factor in (1.05, 0.9, 2.0, 60.0):  # beyond half a bin of the 0.2 s record's 5 Hz resolution
        cases.append((f"csv-speed-label-x{factor:g}", ".csv", "bad", relabel("speed_hz", factor).encode()))
    cases.append(("csv-speed-label-x1.01", ".csv", "bad", relabel("speed_hz", 1.01).encode()))  # read at its 1X, warned
    lines = text.splitlines()
    head = [ln for ln in lines if ln.startswith("#")]
    body = lines[len(head):]
    no_t = [",".join(r.split(",")[1:]) for r in body]
    rate = [f"# sample_rate_hz: {2000.0 * 1.05!r}" if ln.startswith("# sample_rate_hz") else ln for ln in head]
    cases.append(("csv-sample-rate-x1.05-no-t", ".csv", "bad", "\n".join(rate + no_t).encode()))
    epoch = [",".join([repr(1.7e15 + float(r.split(",")[0]))] + r.split(",")[1:]) for r in body[1:]]
    cases.append(("csv-t-column-epoch", ".csv", "bad", "\n".join(head + body[:1] + epoch).encode()))
    t0 = [ln for ln in head] + ["# t0_s: 1.7e15"]
    cases.append(("csv-t0-epoch-no-t", ".csv", "valid", "\n".join(t0 + no_t).encode()))
    return cases


def _corpus():
    import tempfile
    from pathlib import Path

    rng = np.random.default_rng(SEED)
    with tempfile.TemporaryDirectory() as tmp:
        rec = base_record()
        text = write_record(rec, Path(tmp) / "base.csv", units="um").read_text()
        npz = write_record(rec, Path(tmp) / "base.npz", units="um").read_bytes()
        mat = write_record(rec, Path(tmp) / "base.mat", units="um").read_bytes()
    return (csv_cases(text, rng) + array_cases(".npz", npz, rng) + array_cases(".mat", mat, rng)
            + hostile_cases(text, npz, mat))


CORPUS = _corpus()


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The unmutated record as each format reads it back (µm text rounds in the last digit)."""
    folder = tmp_path_factory.mktemp("fuzz-reference")
    rec = base_record()
    return {s: read_record(write_record(rec, folder / f"base{s}", units="um")) for s in (".csv", ".npz", ".mat")}


def test_the_corpus_is_large_and_covers_every_format_and_outcome():
    assert len(CORPUS) >= 250
    ids = [c[0] for c in CORPUS]
    assert len(set(ids)) == len(ids)
    for suffix in (".csv", ".npz", ".mat"):
        assert {c[2] for c in CORPUS if c[1] == suffix} == {"bad", "same", "valid"}
    assert sum(c[2] == "bad" for c in CORPUS) >= 200


def test_the_unmutated_base_reads_cleanly(reference):
    for rec in reference.values():
        assert rec.warnings == () and rec.is_static and rec.set_name == "coast" and rec.nodes == (5, 21)


@pytest.mark.parametrize("name,suffix,kind,data", CORPUS, ids=[c[0] for c in CORPUS])
def test_malformed_record_is_refused_or_warned_never_crashes(tmp_path, reference, name, suffix, kind, data):
    path = tmp_path / f"fuzzed{suffix}"
    path.write_bytes(data)
    try:
        rec = read_record(path)
    except DataFormatError as exc:
        assert str(path) in str(exc), f"message does not name the file: {exc}"
        assert kind != "same", f"a spelling-only change was refused: {exc}"
        return
    assert all(str(path) in w for w in rec.warnings), rec.warnings
    if kind == "bad":
        assert rec.warnings, "a mutation that changes the meaning was read silently"
    if kind == "same":
        assert rec == reference[suffix]
