"""Text from a user's file on the pages: shown as typed, never as markup (issue 34, item 1).

The pages render Markdown panes (`pn.pane.Markdown`, `pn.pane.Alert`) whose Markdown allows raw HTML, so
a record's metadata value, a column or file name, a machine name or an error message quoting one of them
could carry `<img src=x onerror=...>` or a Markdown link into the browser. Every such text passes through
`plain` where the page puts it into its markup: each character that HTML or Markdown could read as syntax
becomes a numeric character reference, which Markdown shows as that very character (CommonMark: entity
references are literal text, never structure). Tables of such text are made by `table_html`, which escapes every cell.

`file_label` is what a page calls an uploaded file: its base name only (never a server path), printable,
at most FILE_LABEL_CHARS characters. `without_upload_dirs` takes the server's temporary upload folder out
of a message.
"""

from __future__ import annotations

import re
import tempfile
from pathlib import PurePosixPath, PureWindowsPath

FILE_LABEL_CHARS = 80
_FILE_LABEL_BYTES = 200  # under the 255-byte name limit of common file systems, whatever the characters
# Everything HTML or Markdown (with its tables, emphasis, links, code, math, footnotes, emoji) reads as syntax.
_SYNTAX = "&<>\"'`*_[]()!#|\\$~{}:=+-^@"
_REFERENCES = {ord(c): f"&#{ord(c)};" for c in _SYNTAX}
_LINE_BREAKS = re.compile(r"[\r\n\t\f\v\u2028\u2029\x85]+")


def plain(value) -> str:
    """`value` as text for a Markdown pane: shown exactly as written (line breaks as spaces), nothing in it
    read as HTML or Markdown."""
    text = _LINE_BREAKS.sub(" ", str(value))
    text = "".join(c if c.isprintable() else "\N{REPLACEMENT CHARACTER}" for c in text)
    return text.translate(_REFERENCES)


def file_label(filename) -> str:
    """An uploaded file's name as the page shows it and passes it to the reader: the base name (a browser
    may send a path), unprintable characters replaced, shortened in the middle to FILE_LABEL_CHARS
    characters (and _FILE_LABEL_BYTES UTF-8 bytes) keeping its suffix. Not escaped: give it to `plain`."""
    text = str(filename or "")
    name = PureWindowsPath(PurePosixPath(text).name).name.strip() or "upload"
    name = "".join(c if c.isprintable() else "?" for c in name)
    if len(name) <= FILE_LABEL_CHARS and len(name.encode("utf-8")) <= _FILE_LABEL_BYTES:
        return name
    suffix = PurePosixPath(name).suffix
    tail = suffix if len(suffix) <= 12 else ""
    head = name[:len(name) - len(tail)]
    keep = FILE_LABEL_CHARS - 1 - len(tail)
    head = head[:keep]
    while len((head + "…" + tail).encode("utf-8")) > _FILE_LABEL_BYTES:
        head = head[:-1]
    return head + "…" + tail


def without_upload_dirs(message: str) -> str:
    """`message` without the server's temporary upload folders (`<tmp>/lubeviz-upload-XXXX/`), leaving the
    file's own name."""
    tmp = re.escape(tempfile.gettempdir().rstrip("/\\"))
    return re.sub(tmp + r"[/\\]lubeviz-upload-[^/\\\s'\"]*[/\\]", "", str(message))


TABLE_CSS = """
table.lubeviz-table { border-collapse: collapse; width: 100%; font-size: 0.9em; }
table.lubeviz-table th, table.lubeviz-table td { border: 1px solid #c8ced6; padding: 3px 8px; text-align: left; }
table.lubeviz-table th { background: #eef1f5; }
table.lubeviz-table tr.beyond td { background: #f8d7da; color: #58151c; }
"""


def table_html(frame, *, marked=(), css_class: str = "") -> str:
    """`frame` (a pandas DataFrame) as an HTML table, every header and cell escaped (text from a file is shown,
    never run); rows whose index is in `marked` get the class "beyond" (TABLE_CSS colours them). A plain table,
    not a Tabulator: a Tabulator drawn after the Rotor page had been shown put Chromium's renderer in a loop at
    100 % CPU (the identification's result never appeared)."""
    import html as _html

    def cell(v) -> str:
        if isinstance(v, float) and v != v:
            return ""
        return _html.escape(str(v), quote=True)

    head = "".join(f"<th>{cell(c)}</th>" for c in frame.columns)
    rows = []
    for i, (_, row) in enumerate(frame.iterrows()):
        cls = ' class="beyond"' if i in set(marked) else ""
        rows.append(f"<tr{cls}>" + "".join(f"<td>{cell(v)}</td>" for v in row) + "</tr>")
    klass = f"lubeviz-table {_html.escape(css_class, quote=True)}".strip()
    return f'<table class="{klass}"><thead><tr>{head}</tr></thead><tbody>{"".join(rows)}</tbody></table>'


# A lubrication verdict as a coloured badge (issue 38: emoji circles showed as empty boxes without an emoji font).
# The Okabe-Ito colours a colour-blind reader tells apart; the word is always written, the colour only repeats it.
BADGE_COLOURS = {"starved": ("#E69F00", "#000000"), "normal": ("#009E73", "#ffffff"),
                 "over-supplied": ("#0072B2", "#ffffff")}


def badge(verdict: str) -> str:
    """'starved', 'normal' or 'over-supplied' as an inline HTML badge for a Markdown pane (the word as plain text
    for anything else)."""
    if verdict not in BADGE_COLOURS:
        return plain(verdict)
    background, colour = BADGE_COLOURS[verdict]
    return (f'<span class="lubeviz-badge" style="background:{background};color:{colour};border-radius:3px;'
            f'padding:0 5px;white-space:nowrap">{verdict}</span>')


from ..words import signs  # noqa: E402,F401 - the pages' name for it

_LABEL = re.compile(r"\b[a-z_0-9]+\[[a-z_]+=[^\]]*\](?: \+ [a-z_0-9]+\[[a-z_]+=[^\]]*\])*")


def labels_as_words(text: str) -> str:
    """`text` with every candidate label in it (`clearance[bearing=1]`) written in words (`effects.label_title`)."""
    from ..effects import label_title

    return _LABEL.sub(lambda m: label_title(m.group(0)), str(text))


def effect_words(spec: str, machine=None) -> str:
    """An effect given in its command-line form (`clearance:bearing=1,clearance_um=150`) in an engineer's words
    (`Effect.told`: 'Bearing 1 has radial clearance 150 µm (declared 120 µm) instead of the declared one.'), as
    plain text; the form itself when it does not parse."""
    from ..effects import parse_effect

    try:
        return plain(signs(parse_effect(spec).told(machine=machine)))
    except Exception:  # noqa: BLE001 - a sample's effect always parses; anything else is shown as written
        return plain(spec)


def truth_words(truth: dict, machine=None) -> str:
    """The truth of a sample a page simulated (Markdown): its flows and, in words, its effect."""
    text = "**Truth** (this sample was simulated here): " + ", ".join(
        f"Q{k + 1} = {v:.0f}" for k, v in enumerate(truth["q_mlmin"])) + " ml/min"
    if truth.get("effect"):
        text += ". " + effect_words(truth["effect"], machine)
    return text
