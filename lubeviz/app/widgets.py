"""Widgets made from the model's own parameter declarations (STYLE: a parameter is declared once).

`quantity_slider(obj, "q1")` reads the `Quantity` declaration of `obj.q1` (its SI unit, display unit
and scale, bounds and doc) and returns a slider in display units (ml/min, mm, um) whose label carries
the unit and whose tooltip is the doc; the slider and the parameter are linked both ways, converting
at the edge. Bounds the declaration leaves open (a flow has no upper bound) are given by the page,
in SI, where it knows a sensible range (e.g. 25-200 % of Q_T).

`RecordDropper` is the record upload of the Identify and Diagnose pages: one file at a time, every drop
reported (the same file again too), a file the page rejects shown as failed, a file beyond its size limit
refused by the server as its chunks arrive (the browser's own limit can be bypassed by a scripted client).
"""

from __future__ import annotations

import re
from pathlib import Path

import panel as pn
import param

from ..model.quantity import Quantity
from .text import labels_as_words, plain, signs


def show_effect(name: str, machine, story, widgets):
    """`demo_effect(name, machine)` shown in the panes `story` (its physical story) and `widgets` (its
    parameters); None, with the reason in `story`, when the machine lacks what the effect needs (the Rotor
    page and the Diagnose page's sample choose effects this one way)."""
    from ..errors import LubevizError

    try:
        effect = demo_effect(name, machine)
    except LubevizError as exc:  # e.g. an oil temperature on a machine that declares no oil
        from ..effects import EFFECTS

        why = labels_as_words(re.sub(r"^effect ", "", str(exc).replace(str(machine.source), Path(str(machine.source)).name)))
        story.object = (f"**{plain(EFFECTS[name].kind().capitalize())}** is not available for this machine: "
                        f"{plain(why)}")
        widgets.objects = []
        return None
    names = (*effect.placement, *effect.continuous)

    def tell(*events):
        story.object = effect_story(effect, machine)

    tell()
    widgets.objects = [parameter_widget(effect, n, end=machine.n_nodes, choices=_places(effect, n, machine),
                                        sizing_mode="stretch_width") for n in names]
    effect.param.watch(tell, list(names))  # the story quotes the values set on the widgets
    return effect


def _places(effect, name: str, machine) -> list[int] | None:
    """The values of `effect`'s placement `name` that can act on the machine (`Effect.placeable`: a bow's span is one
    of the spans between the places the shaft is held, not any node number), or None for a parameter that is not
    a place left to the effect."""
    p = effect.param[name]
    if name not in effect.placement or not isinstance(p, param.Integer) or not p.allow_None:
        return None
    from . import resources

    rotor = resources.rotor(machine)
    lo = int((p.bounds or (1, None))[0] or 1)
    return [v for v in range(lo, machine.n_nodes + 1) if effect.copy(**{name: v}).placeable(rotor)]


def effect_story(effect, machine) -> str:
    """An effect's story for a page (Markdown): its title, what it is at the values set (`Effect.told`, with the
    declared values), and the rest of its description's first paragraph, every parameter in words (issue 38: no
    `clearance_um` on a page)."""
    from ..effects import quantity_words

    told = signs(effect.told(machine=machine))
    first, _, rest = " ".join(effect.describe().split()).partition(". ")
    rest = re.sub(r"`(\w+)`", lambda m: quantity_words(m.group(1)), rest)
    return f"**{plain(effect.title()[0].upper() + effect.title()[1:])}**: {plain(told)}" + (
        f" {plain(signs(rest))}" if rest else "")


def demo_effect(name: str, machine):
    """Effect `name` of the library bound to `machine`, at a strength a student sees (the Rotor page and the
    Diagnose page's sample; `Effect.demo`). Raises LubevizError when the machine lacks what the effect needs
    (an oil temperature without an [oil])."""
    from ..effects import EFFECTS

    return EFFECTS[name]().demo(machine)


def not_loaded_message(filename: str, problem: str, shown: str | None) -> str:
    """What a page says (Markdown) when `filename` was rejected: why, and which record (named) it still
    shows. The three texts are shown as written (`text.plain`): they come from the user's file."""
    still = (f"The page still shows the previous record, **{plain(shown)}**." if shown is not None
             else "No record is loaded.")
    return f"**{plain(filename)} was not loaded.** {plain(problem)}\n\n{still}"


def refused_message(name: str, received: int, limit_mb: float) -> str:
    """Why the server refused an upload (plain text; `not_loaded_message` shows it)."""
    return (f"The server stopped receiving it at {received / 1e6:.1f} MB: files up to {limit_mb:g} MB are "
            "taken (a larger record can be read from disk with the command line).")


def _model_file(name: str) -> str:
    """'paper_machine.toml' and 'paper_machine' alike: the model file's name without '.toml'."""
    name = str(name).strip()
    return name[:-5] if name.lower().endswith(".toml") else name


def record_warnings(record, machine) -> list[str]:
    """What a page warns of after loading `record` (plain text): what the reader ignored in its file
    (`Record.warnings`: unknown keys, ignored columns, lines beyond 1X) and, when the record's `machine:`
    names another model file than the page's `machine`, that the page keeps its own machine."""
    out = list(record.warnings)
    named = getattr(record, "machine", None)
    if named:
        ours = Path(machine.source).name if machine.source else machine.name
        if _model_file(named) != _model_file(ours):
            out.append(f"the record names the machine {named!r}, but this page uses {ours} (the machine the "
                       "dashboard was started with): the record is read and identified with the page's machine")
    return out


def record_warnings_markdown(record, machine) -> str:
    """`record_warnings` as the Markdown of a page's warning box ('' when there is none), each shown as
    written (`text.plain`)."""
    lines = record_warnings(record, machine)
    if not lines:
        return ""
    return "**Read with warnings:**\n\n" + "\n".join(f"- {plain(w)}" for w in lines)


def _label(p: param.Parameter) -> str:
    unit = getattr(p, "display_unit", None) or getattr(p, "unit", "")
    return f"{p.label} ({unit})" if unit else p.label


def quantity_slider(obj: param.Parameterized, name: str, *, start: float | None = None,
                    end: float | None = None, step: float | None = None, editable: bool = False,
                    label: str | None = None, **kwargs) -> pn.widgets.Widget:
    """A slider for the Quantity `obj.name`. `start`, `end`, `step` in SI override the declaration."""
    p = obj.param[name]
    if not isinstance(p, Quantity):
        raise TypeError(f"{type(obj).__name__}.{name} is not a Quantity")
    scale = p.display_scale
    lo, hi = p.softbounds or (None, None)
    b_lo, b_hi = p.bounds or (None, None)
    lo = start if start is not None else (lo if lo is not None else b_lo)
    hi = end if end is not None else (hi if hi is not None else b_hi)
    if lo is None or hi is None:
        raise ValueError(f"{type(obj).__name__}.{name} has no upper or lower bound; give start and end")
    value = min(max(getattr(obj, name), lo), hi)
    common = dict(name=label or _label(p), start=lo * scale, end=hi * scale,
                  step=(step if step is not None else (hi - lo) / 200.0) * scale, value=value * scale, **kwargs)
    # Panel 1.9 sliders take no `description`; the doc is kept on the widget for the page to show.
    w = (pn.widgets.EditableFloatSlider if editable else pn.widgets.FloatSlider)(**common)
    link(obj, name, w, scale)
    w.doc = p.doc
    return w


def link(obj: param.Parameterized, name: str, widget: pn.widgets.Widget, scale: float = 1.0,
         event: str = "value") -> None:
    """Keep `widget.value` (display units) and `obj.name` (SI) equal, both ways, without echo loops."""
    busy = [False]

    def to_obj(e):
        if busy[0]:
            return
        busy[0] = True
        try:
            setattr(obj, name, e.new if scale == 1.0 else e.new / scale)  # keeps ints and choices as they are
        finally:
            busy[0] = False

    def to_widget(e):
        if busy[0]:
            return
        busy[0] = True
        try:
            widget.value = e.new if scale == 1.0 else e.new * scale
        finally:
            busy[0] = False

    widget.param.watch(to_obj, event)
    obj.param.watch(to_widget, name)


def selector(obj: param.Parameterized, name: str, **kwargs) -> pn.widgets.Widget:
    """A widget for a non-Quantity parameter (Selector, Integer, Boolean), linked to it."""
    return pn.Param(obj.param, parameters=[name], show_name=False, **kwargs)


_UNIT_SUFFIXES = {"_um": "µm", "_deg": "°", "_kg": "kg", "_ns_m": "N·s/m", "_n_m": "N/m", "_hz": "Hz",
                  "_mlmin": "ml/min"}


def parameter_widget(obj: param.Parameterized, name: str, *, end: float | None = None,
                     label: str | None = None, choices=None, **kwargs) -> pn.widgets.Widget:
    """A widget for any declared parameter of `obj` (an effect's, a model's), linked both ways.

    Quantity: `quantity_slider`; Selector: a Select of its objects; Integer: an IntSlider over its bounds
    (`end` closes an open upper bound, e.g. the machine's number of nodes), a Select whose first choice is None
    (in the doc's words) when None is allowed, then `choices` (default: every value in the bounds); Number: a slider over its
    bounds, or a number box when they span more than four decades (a stiffness from 1e5 to 1e12 N/m).
    The label carries the unit (`obj.unit(name)` when the object has one) and the tooltip the doc.
    """
    p = obj.param[name]
    text, unit = p.label, getattr(p, "unit", "") or ""
    for suffix, shown in _UNIT_SUFFIXES.items():  # clearance_um -> "Clearance (µm)"
        if name.endswith(suffix):
            text, unit = name[:-len(suffix)].replace("_", " ").capitalize(), unit or shown
    if name in getattr(obj, "continuous", ()) and hasattr(obj, "unit"):  # an effect's own unit
        unit = obj.unit(name) or unit
    unit = {"um": "µm", "deg": "°"}.get(unit, unit)
    title = label or (f"{text} ({unit})" if unit else text)
    if isinstance(p, Quantity) and p.bounds and None not in p.bounds:
        w = quantity_slider(obj, name, label=title, **kwargs)
        w.description = p.doc
        return w
    if isinstance(p, param.Selector):
        options = {str(o): o for o in p.objects}
        w = pn.widgets.Select(name=title, options=options, value=getattr(obj, name), description=p.doc, **kwargs)
    elif isinstance(p, param.Integer):
        lo, hi = p.bounds or (None, None)
        hi = end if hi is None else hi
        if lo is None or hi is None:
            raise ValueError(f"{type(obj).__name__}.{name} has an open bound; give end")
        if p.allow_None:  # None means a place the object chooses itself (a bow's node midway along its span)
            values = range(int(lo), int(hi) + 1) if choices is None else choices
            options = {_none_words(p.doc): None, **{str(k): k for k in values}}
            w = pn.widgets.Select(name=title, options=options, value=getattr(obj, name), description=p.doc, **kwargs)
        else:
            w = pn.widgets.IntSlider(name=title, start=int(lo), end=int(hi), value=int(getattr(obj, name)), **kwargs)
    elif isinstance(p, param.Number):
        lo, hi = p.bounds or (None, None)
        value = getattr(obj, name)
        if lo is not None and hi is not None and (lo <= 0 or hi / lo < 1e4):
            w = pn.widgets.FloatSlider(name=title, start=float(lo), end=float(hi), step=(hi - lo) / 200.0,
                                       value=float(lo if value is None else value), **kwargs)
        else:
            w = pn.widgets.FloatInput(name=title, start=lo, end=hi, value=value, description=p.doc, **kwargs)
    elif isinstance(p, param.Boolean):
        w = pn.widgets.Checkbox(name=title, value=getattr(obj, name), **kwargs)
    else:
        raise TypeError(f"{type(obj).__name__}.{name}: no widget for a {type(p).__name__}")
    link(obj, name, w)
    w.doc = p.doc
    return w


def _none_words(doc: str) -> str:
    """What None stands for, from a parameter's doc ("...; None: the node nearest midway ..." -> "the node nearest
    midway ..."), for the first choice of its Select."""
    m = re.search(r"\bNone[:,]\s*([^;.]+)", doc or "")
    return m.group(1).strip() if m else "chosen by the effect"


def parameter_widgets(obj: param.Parameterized, names, **kwargs) -> list[pn.widgets.Widget]:
    """`parameter_widget` for each of `names` (same keyword arguments)."""
    return [parameter_widget(obj, n, **kwargs) for n in names]


# FilePond (the dropper's browser side) marks a file "Upload complete" in green once its bytes are sent,
# before the page has read them; these rules show the last file dropped in its own error colours when the
# page rejected it (the dropper's host carries REJECTED_CLASS then).
REJECTED_CLASS = "lubeviz-upload-rejected"
_DONE = f":host(.{REJECTED_CLASS}) .filepond--item[data-filepond-item-state='processing-complete']"
_REJECTED_CSS = f"""
{_DONE} .filepond--item-panel {{ background-color: #c44e47; }}
{_DONE} .filepond--processing-complete-indicator, {_DONE} .filepond--file-status-main {{ display: none; }}
{_DONE} .filepond--file-status::before {{ content: "Not loaded (see the message)"; font-size: 0.75em; font-weight: 600; }}
"""


# An upload crosses the websocket in chunks of UPLOAD_CHUNK_BYTES; the server takes no websocket message
# larger than WEBSOCKET_MAX_MESSAGE_BYTES (`panel serve app.py --websocket-max-message-size 8388608`, the
# README's command and the tests' server: bokeh's default is 20 MiB), room for a chunk even base64-encoded.
UPLOAD_CHUNK_BYTES = 2_000_000
WEBSOCKET_MAX_MESSAGE_BYTES = 8 * 1024 * 1024

_SIZE = re.compile(r"^\s*([0-9.]+)\s*([KMG]?B)\s*$", re.IGNORECASE)
_SIZE_UNITS = {"B": 1, "KB": 1_000, "MB": 1_000_000, "GB": 1_000_000_000}  # FilePond's units (base 1000)


def size_bytes(text: str) -> int:
    """'50MB', '750KB' (FileDropper's `max_file_size`) in bytes."""
    match = _SIZE.match(str(text))
    if match is None:
        raise ValueError(f"file size {text!r}: expected a number and KB, MB or GB, e.g. '50MB'")
    return int(float(match.group(1)) * _SIZE_UNITS[match.group(2).upper()])


class RecordDropper(pn.widgets.FileDropper):
    """A file dropper for one record at a time that reports every upload, the same file again included.

    Watch `upload`: it is set to (name, content) each time a file has arrived, whether or not a file of
    that name and content came before in the session. (FileDropper's own `value` cannot tell: it keeps the
    files in a dict updated in place, so a second drop of the same file leaves it as it was, and a file
    removed from the dropper triggers it too.) One file at a time: a new drop replaces the one shown, and
    the dropper keeps no other file nor the chunks of an earlier unfinished upload.
    The page sets `rejected` when it could not load the file dropped last; the dropper then shows that
    file as failed instead of FilePond's green "Upload complete". A new drop clears it.

    The size limit (`limit_bytes`, default `max_file_size`) holds on the server too: the bytes of an upload
    are counted as its chunks arrive, and the chunk that would pass the limit is not kept; the chunks held
    so far are dropped, the rest of that upload is ignored, `refused` is set to (name, bytes received) and
    the file shown as failed. A malformed chunk message (no name, a chunk number out of range, data that
    are not bytes) is refused the same way.
    """

    upload = param.Parameter(default=None, doc="(name, content) of the file dropped last; set on every upload")
    rejected = param.Boolean(default=False, doc="The page could not load the file dropped last")
    refused = param.Parameter(default=None, doc="(name, bytes received) of the upload the server refused "
                                                "last (beyond `limit_bytes`, or malformed); set on every refusal")
    limit_bytes = param.Integer(default=None, bounds=(1, None), allow_None=True,
                                doc="The largest upload the server keeps (bytes); None: `max_file_size`")

    _rename = {"upload": None, "rejected": None, "refused": None, "limit_bytes": None}

    def __init__(self, **params):
        # Single file: a new drop reverts the last file (a delete event) and uploads itself; the dropper
        # shows just the file the page last took or refused.
        params.setdefault("multiple", False)
        params.setdefault("chunk_size", UPLOAD_CHUNK_BYTES)
        params["stylesheets"] = [*params.get("stylesheets", []), _REJECTED_CSS]
        super().__init__(**params)
        if self.limit_bytes is None and self.max_file_size:
            self.limit_bytes = size_bytes(self.max_file_size)
        self._received: dict[str, int] = {}  # bytes received so far of the upload under way, by name
        self.param.watch(self._show_rejected, "rejected")

    def _process_event(self, event):
        data = event.data if isinstance(event.data, dict) else {}
        if event.event_name != "upload_event":
            if isinstance(data.get("name"), str):
                super()._process_event(event)  # a file removed from the dropper
            return
        name, chunk, total, payload = (data.get(k) for k in ("name", "chunk", "total_chunks", "data"))
        if chunk == 1:  # a new file is arriving: forget any other, and the last one's verdict
            self._file_buffer.clear()
            self._received.clear()
            self.value.clear()
            self.mime_type.clear()
            self.rejected = False
        elif name not in self._file_buffer:
            return  # the rest of a refused upload (or of one never started): not kept
        well_formed = (isinstance(name, str) and isinstance(chunk, int) and isinstance(total, int)
                       and 1 <= chunk <= total and isinstance(payload, (bytes, bytearray, memoryview))
                       and isinstance(data.get("type", ""), str))
        if not well_formed:
            self._refuse(name, self._received.get(name, 0))
            return
        size = self._received.get(name, 0) + len(payload)
        if self.limit_bytes is not None and size > self.limit_bytes:
            self._refuse(name, size)
            return
        self._received[name] = size
        data.setdefault("type", "")
        super()._process_event(event)
        if chunk == total and name in self.value:
            self._received.clear()
            # Set anew even when equal to the last upload: param calls watchers only on a change.
            with param.discard_events(self):
                self.upload = None
            self.upload = (name, self.value[name])

    def _refuse(self, name, size: int) -> None:
        self._file_buffer.clear()
        self._received.clear()
        with param.discard_events(self):
            self.refused = None
        self.refused = (name if isinstance(name, str) else "upload", int(size))
        self.rejected = True

    def _show_rejected(self, event):
        others = [c for c in self.css_classes if c != REJECTED_CLASS]
        self.css_classes = [*others, REJECTED_CLASS] if event.new else others
