"""The machine a session works on: the start page's chooser (the shipped model files, or the user's own file
uploaded), the machine drawn from its file, and the commented template with its "describe your machine" guide.

The drawing is plain SVG made here from the model objects (no HoloViews: the start page must come up at once):
the shaft to scale (hollow sections lighter), discs (lumped ones sized from their inertias), fluid-film bearings
(orange), constant-coefficient supports (green), measurement planes (▼) and unbalances (★); beneath, each
bearing cut across with its grooves and each plane with its probes' directions (SPEC §1: X right, Y up; the
grooves at α from the top in the direction of rotation, the probes at their angle from +X). Every name in the
drawing comes from the user's file, so each is escaped.

An uploaded file is validated by the same loader as `--machine PATH`; a refused file leaves the session's
machine as it was. A valid one is kept by its content (the user cache's `machines/` folder, named by its hash):
worker processes load a machine by its path, and two sessions uploading the same file share its tables.
"""

from __future__ import annotations

import hashlib
import html
import math
import re
import tomllib
from pathlib import Path

from ..errors import LubevizError, ModelFileError
from ..model.files import load_machine, machine_from_toml
from ..model.parts import MODELS_DIR, Machine
from ..units import MLMIN_PER_M3S

TEMPLATE = Path(__file__).resolve().parents[2] / "assets" / "machine_template.toml"
MODEL_LIMIT_BYTES = 200_000  # a model file is a page of text; anything larger is not one

GUIDE = """
### Describe your machine
A model file (TOML) is a short text file: download the template below, edit it, upload it here.
1. **[machine]**: a name, the operating speed and the speed range the model is meant for.
2. **[shaft]**: the shaft as a row of sections from one end, `[length, outer diameter]` or
   `[length, outer, inner diameter]` in mm. Each section ends at a node: node 1 is the left end of the first.
   Put a node at every bearing, disc, probe and unbalance; sections of 50–150 mm are usually fine.
3. **[[discs]]**: impellers, wheels, coupling hubs, by geometry or by mass and inertias.
4. **[[unbalances]]**: where the residual unbalance sits (a balance grade gives its size).
5. **[[bearings]]**: each oil-film bearing: node, radius, length, radial clearance, oil, grooves, and its
   supply: `unknown` (lubeviz identifies it), `flooded`, or a known `supply_mlmin`.
6. **[[supports]]**: rolling-element bearings and seals, by stiffness and damping.
7. **[[planes]]**: where the proximity probes are, and their directions (e.g. 45° and 135°).

Every key carries its unit in its name. A file with a mistake is refused with a message naming the table,
its index and the key; the machine you had stays.
"""


def shipped_machines() -> dict[str, Path]:
    """The example model files shipped in `models/`: label -> path (the paper's rig first)."""
    out = {}
    for path in sorted(MODELS_DIR.glob("*.toml"), key=lambda p: (p.stem != "paper_machine", p.stem)):
        try:
            m = load_machine(path)
        except LubevizError:
            continue  # a broken example is the suite's business (tests/model), not a visitor's
        out[f"{m.name} ({len(m.bearings)} oil-film bearings)"] = path
    return out


def machine_from_upload(content: bytes, filename: str, store: Path) -> Machine:
    """Validate an uploaded model file and keep it under `store` by its content; the machine loaded from there.
    Raises LubevizError (ModelFileError) naming `filename`, the table and the key when the file is refused."""

    label = filename or "model file"
    if content is None or len(content) == 0:
        raise ModelFileError(f"{label}: the file is empty; expected a model file (TOML: the template on the start page shows one)")
    if len(content) > MODEL_LIMIT_BYTES:
        raise ModelFileError(f"{label}: {len(content) / 1e3:.0f} kB is too large for a model file "
                             f"(at most {MODEL_LIMIT_BYTES / 1e3:.0f} kB)")
    try:
        raw = tomllib.loads(content.decode("utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ModelFileError(f"{label}: not a valid TOML file ({exc})") from None
    machine_from_toml(raw, label)  # every message names the uploaded file, not the stored copy
    digest = hashlib.sha256(content).hexdigest()[:16]
    stem = re.sub(r"[^A-Za-z0-9_.-]", "_", Path(label).stem)[:40] or "machine"
    path = store / f"{stem}-{digest}.toml"
    if not path.exists():
        store.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(".tmp")
        tmp.write_bytes(content)
        tmp.replace(path)
    return load_machine(path)


def upload_store() -> Path:
    from ..identify.tables.cache import cache_dir

    return cache_dir() / "machines"


def summary_markdown(m: Machine) -> str:
    """What the machine is, in a few lines (every name from the file shown as text)."""
    from .text import plain

    n = len(m.bearings)
    unknown = [b.name or f"bearing {k + 1}" for k, b in enumerate(m.bearings) if b.supply == "unknown"]
    lines = [f"**{plain(m.name)}**", "",
             f"{m.n_nodes} nodes, {m.rotor_length * 1e3:.0f} mm of shaft; operating speed {m.operating_speed:g} Hz "
             f"({m.operating_speed * 60:.0f} rpm); {n} oil-film bearing{'s' if n != 1 else ''}"
             + (f", {len(m.supports)} other support{'s' if len(m.supports) != 1 else ''}" if m.supports else "")
             + f"; {len(m.measurement_planes)} measurement planes.", ""]
    for k, b in enumerate(m.bearings):
        supply = {"unknown": "supply identified", "flooded": "fed flooded (not identified)"}.get(
            b.supply, f"known supply {b.supply_flow * MLMIN_PER_M3S if b.supply_flow else 0:.0f} ml/min")
        lines.append(f"- Q{k + 1}: {plain(b.name or f'bearing {k + 1}')} at node {b.node}: D {b.diameter * 1e3:g} mm, "
                     f"L {b.length * 1e3:g} mm, c {b.clearance * 1e6:g} µm, {len(b.grooves)} groove"
                     f"{'s' if len(b.grooves) != 1 else ''}; {supply}{_pedestal_words(b.pedestal)}")
    if not unknown:
        lines += ["", "No bearing's supply is unknown: there is nothing to identify on this machine."]
    return "\n".join(lines)


def _pedestal_words(p) -> str:
    """'; on a pedestal (60 kg, 4e+08 N/m)', or '' without one."""
    return "" if p is None else f"; on a pedestal ({p.mass:g} kg, {p.stiffness:.3g} N/m): its probes ride the housing"


# --- the drawing -------------------------------------------------------------------------------------------
_W = 900.0  # the drawing's width in SVG units (it scales with the page)


def disc_box(d, xs) -> tuple[float, float, float]:
    """(centre x, half width, outer radius) of a disc in mm; a lumped disc from its inertias (thin disc:
    Ip = m r^2 / 2, Id = m (3 r^2 + w^2) / 12)."""
    if d.lumped:
        r = math.sqrt(2.0 * d.polar_inertia / d.mass) if d.polar_inertia and d.mass else 0.05
        w2 = 12.0 * (d.diametral_inertia or 0.0) / d.mass - 3.0 * r * r if d.mass else 0.0
        w = max(math.sqrt(w2) if w2 > 0 else 0.0, 0.2 * r, 0.01)
        return xs[d.node - 1], w * 500.0, r * 1e3
    return xs[d.node - 1], d.width * 500.0, d.outer_diameter * 500.0


def machine_svg(m: Machine) -> str:
    """The machine drawn from its file as an SVG element (see the module's doc)."""
    e = html.escape
    xs = [0.0]
    for el in m.elements:
        xs.append(xs[-1] + el.length * 1e3)
    discs = [disc_box(d, xs) for d in m.discs]
    r_max = max([el.diameter * 500.0 for el in m.elements] + [r for _, _, r in discs]
                + [b.radius * 1e3 + 25.0 for b in m.bearings])
    length = xs[-1]
    margin = 60.0
    s = (_W - 2 * margin) / length  # mm -> svg units, the same both ways (to scale)
    s = min(s, 150.0 / r_max)  # a short, fat machine keeps a sensible height
    cx0 = (_W - length * s) / 2.0
    top = 40.0
    axis = top + r_max * s + 10.0
    X = lambda x: cx0 + x * s  # noqa: E731
    Y = lambda y: axis - y * s  # noqa: E731
    parts = []
    for i, el in enumerate(m.elements):
        ro, ri = el.diameter * 500.0, el.inner_diameter * 500.0
        parts.append(f'<rect x="{X(xs[i]):.1f}" y="{Y(ro):.1f}" width="{(xs[i + 1] - xs[i]) * s:.1f}" '
                     f'height="{2 * ro * s:.1f}" fill="#9aa5b1" stroke="#333" stroke-width="0.6"/>')
        if ri > 0:
            parts.append(f'<rect x="{X(xs[i]):.1f}" y="{Y(ri):.1f}" width="{(xs[i + 1] - xs[i]) * s:.1f}" '
                         f'height="{2 * ri * s:.1f}" fill="#e3e7eb" stroke="none"/>')
    for (x, hw, r), d in zip(discs, m.discs):
        parts.append(f'<rect x="{X(x - hw):.1f}" y="{Y(r):.1f}" width="{2 * hw * s:.1f}" height="{2 * r * s:.1f}" '
                     f'fill="#51606f" stroke="#222" stroke-width="0.6"><title>{e(d.name or "disc")} '
                     f'(node {d.node})</title></rect>')
    labels = []

    def spring(x, y):  # a pedestal: a spring from the housing's foot (svg x, y) down to a ground line
        pts = " ".join(f"{x + (5 if i % 2 else -5) * (0 < i < 6):.1f},{y + 2.5 * i:.1f}" for i in range(7))
        parts.append(f'<polyline points="{pts}" fill="none" stroke="#555" stroke-width="1.2"/>'
                     f'<line x1="{x - 8:.1f}" y1="{y + 16:.1f}" x2="{x + 8:.1f}" y2="{y + 16:.1f}" stroke="#555" '
                     'stroke-width="1.5"/>')

    for k, b in enumerate(m.bearings):
        x, r, hl = xs[b.node - 1], b.radius * 1e3, max(b.length * 500.0, 3.0 / s)
        for y0 in (r, -r - 25.0):
            parts.append(f'<rect x="{X(x - hl):.1f}" y="{Y(y0 + 25.0):.1f}" width="{2 * hl * s:.1f}" '
                         f'height="{25.0 * s:.1f}" fill="#e8a33d" stroke="#333" stroke-width="0.6"/>')
        if b.pedestal is not None:
            spring(X(x), Y(-r - 25.0))
        labels.append((x, f"Q{k + 1}: {b.name or f'bearing {k + 1}'}", "#a0651a"))
    for sp in m.supports:
        x, r = xs[sp.node - 1], m.elements[min(sp.node - 1, len(m.elements) - 1)].diameter * 500.0
        for y0 in (r, -r - 25.0):
            parts.append(f'<rect x="{X(x) - 6:.1f}" y="{Y(y0 + 25.0):.1f}" width="12" height="{25.0 * s:.1f}" '
                         f'fill="#5a9e5a" stroke="#333" stroke-width="0.6"/>')
        if sp.pedestal is not None:
            spring(X(x), Y(-r - 25.0))
        labels.append((x, sp.name or "support", "#3c763d"))
    for j, p in enumerate(m.measurement_planes):
        x = X(xs[p.node - 1])
        parts.append(f'<path d="M{x - 6:.1f},{top - 14:.1f} L{x + 6:.1f},{top - 14:.1f} L{x:.1f},{top - 3:.1f} Z" '
                     f'fill="#2c5f8a"><title>plane {j + 1} at node {p.node}: probes at '
                     f'{p.probe_angles_deg[0]:g}° and {p.probe_angles_deg[1]:g}°</title></path>')
        parts.append(f'<text x="{x:.1f}" y="{top - 18:.1f}" font-size="11" text-anchor="middle" fill="#2c5f8a">'
                     f'P{j + 1}</text>')
    for u in _unbalances(m):
        parts.append(f'<text x="{X(xs[u - 1]):.1f}" y="{axis + 5:.1f}" font-size="16" text-anchor="middle" '
                     f'fill="#d62728">★</text>')
    base = Y(-r_max) + 16 + (18 if any(p.pedestal is not None for p in (*m.bearings, *m.supports)) else 0)
    for k, (x, text, colour) in enumerate(labels):
        parts.append(f'<text x="{X(x):.1f}" y="{base + 13 * (k % 2):.1f}" font-size="11" text-anchor="middle" '
                     f'fill="{colour}">{e(text)}</text>')
    # Cross-sections: each bearing with its grooves, each plane with its probes.
    row = base + 40
    sections = [("bearing", k, b) for k, b in enumerate(m.bearings)] + [
        ("plane", j, p) for j, p in enumerate(m.measurement_planes)]
    step = min(110.0, (_W - 20) / max(len(sections), 1))
    for i, (kind, k, obj) in enumerate(sections):
        cx, cy, rr = 10 + step * (i + 0.5), row + 34, 22.0
        parts.append(f'<circle cx="{cx:.1f}" cy="{cy:.1f}" r="{rr}" fill="none" stroke="#555" stroke-width="1"/>')
        if kind == "bearing":
            parts[-1] = parts[-1].replace('stroke="#555"', 'stroke="#e8a33d" stroke-width="3"')
            for g in obj.grooves:
                half = g.length / (2.0 * obj.radius)
                a0, a1 = g.angle - half, g.angle + half
                p0 = (cx - rr * math.sin(a0), cy - rr * math.cos(a0))
                p1 = (cx - rr * math.sin(a1), cy - rr * math.cos(a1))
                parts.append(f'<path d="M{p0[0]:.1f},{p0[1]:.1f} A{rr},{rr} 0 0 0 {p1[0]:.1f},{p1[1]:.1f}" '
                             f'fill="none" stroke="#1f77b4" stroke-width="6"/>')
            parts.append(f'<path d="M{cx + 8:.1f},{cy - 6:.1f} A10,10 0 1 0 {cx + 8:.1f},{cy + 6:.1f}" fill="none" '
                         f'stroke="#888" stroke-width="1" marker-end="url(#lv-arrow)"/>')
            caption = f"Q{k + 1}: {len(obj.grooves)} groove{'s' if len(obj.grooves) != 1 else ''}"
        else:
            for a in obj.probe_angles_deg:
                t = math.radians(a)
                parts.append(f'<line x1="{cx:.1f}" y1="{cy:.1f}" x2="{cx + (rr + 10) * math.cos(t):.1f}" '
                             f'y2="{cy - (rr + 10) * math.sin(t):.1f}" stroke="#2c5f8a" stroke-width="2"/>')
            caption = f"P{k + 1}: {obj.probe_angles_deg[0]:g}°/{obj.probe_angles_deg[1]:g}°"
        parts.append(f'<text x="{cx:.1f}" y="{cy + rr + 16:.1f}" font-size="10" text-anchor="middle">{e(caption)}'
                     "</text>")
    height = row + 34 + 22 + 26
    defs = ('<defs><marker id="lv-arrow" viewBox="0 0 10 10" refX="5" refY="5" markerWidth="5" markerHeight="5" '
            'orient="auto-start-reverse"><path d="M0,0 L10,5 L0,10 z" fill="#888"/></marker></defs>')
    title = e(f"{m.name}: the machine to scale (▼ probe planes, orange: oil-film bearings, green: other supports, "
              "a spring under one: its pedestal, ★ unbalances); below, each bearing's grooves (blue, rotation "
              "arrowed) and each plane's probes")
    return (f'<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 {_W:.0f} {height:.0f}" role="img" '
            f'class="lubeviz-machine-drawing"><title>{title}</title>{defs}{"".join(parts)}</svg>')


def _unbalances(m: Machine) -> list[int]:
    return [m.unbalance_node] + [u.node for u in m.other_unbalances]


class MachineChooser:
    """The start page's machine section: choose a shipped model file or upload one; the machine drawn from its
    file; the template and the guide. `on_machine(machine)` is called with each machine chosen; a refused
    upload shows its message and leaves the session's machine as it was."""

    def __init__(self, machine: Machine, on_machine):
        import panel as pn

        from . import resources

        self._on_machine = on_machine
        self._paths = dict(shipped_machines())
        current = next((k for k, p in self._paths.items() if str(p) == str(machine.source)), None)
        if current is None:
            current = f"{machine.name}"
            self._paths[current] = Path(machine.source)
        self.machine = machine
        self._resources = resources
        self.select = pn.widgets.Select(name="Machine", options=list(self._paths), value=current, width=330,
                                        css_classes=["lubeviz-machine-select"],
                                        description="The shipped example machines, and any model file uploaded "
                                                    "in this session")
        self.upload = pn.widgets.FileInput(accept=".toml", multiple=False, css_classes=["lubeviz-machine-upload"],
                                           width=330)
        self.message = pn.pane.Alert("", alert_type="danger", visible=False, sizing_mode="stretch_width",
                                     css_classes=["lubeviz-machine-error"])
        self.summary = pn.pane.Markdown(summary_markdown(machine), sizing_mode="stretch_width",
                                        css_classes=["lubeviz-machine-summary"])
        self.drawing = pn.pane.HTML(machine_svg(machine), sizing_mode="stretch_width",
                                    css_classes=["lubeviz-machine-drawing"])
        self.template = pn.widgets.FileDownload(file=str(TEMPLATE), filename="machine_template.toml",
                                                label="Download the model-file template", button_type="default",
                                                width=330, css_classes=["lubeviz-machine-template"])
        self.select.param.watch(self._on_select, "value")
        self.upload.param.watch(self._on_upload, "value")

    def panel(self):
        import panel as pn

        controls = pn.Column(self.select, pn.pane.Markdown("Or upload your own model file (.toml):", margin=(5, 10, 0, 10)),
                             self.upload, self.message, self.template, width=350)
        return pn.Column(pn.pane.Markdown("### The machine", sizing_mode="stretch_width"),
                         pn.FlexBox(controls, pn.Column(self.summary, sizing_mode="stretch_width", min_width=360,
                                                        styles={"flex": "1 1 360px"}), flex_wrap="wrap"),
                         self.drawing,
                         pn.Card(pn.pane.Markdown(GUIDE, sizing_mode="stretch_width"), title="Describe your machine",
                                 collapsed=True, sizing_mode="stretch_width", css_classes=["lubeviz-machine-guide"]),
                         sizing_mode="stretch_width", css_classes=["lubeviz-machine-section"])

    def _use(self, machine: Machine) -> None:
        self.machine = machine
        self.message.visible = False
        self.summary.object = summary_markdown(machine)
        self.drawing.object = machine_svg(machine)
        self._on_machine(machine)

    def _refuse(self, text: str) -> None:
        from .text import plain

        self.message.object = (f"**Not loaded.** {plain(text)}\n\nThe pages still use **{plain(self.machine.name)}**.")
        self.message.visible = True

    def _on_select(self, event):
        path = self._paths.get(event.new)
        if path is None or str(path) == str(self.machine.source):
            return
        try:
            machine = self._resources.machine(path)
        except LubevizError as exc:
            self._refuse(str(exc))
            self.select.value = event.old
            return
        self._use(machine)

    def _on_upload(self, event):
        from .text import file_label

        content = event.new
        if content is None:
            return
        filename = file_label(self.upload.filename or "model file")
        try:
            machine = machine_from_upload(content, filename, upload_store())
            machine = self._resources.machine(machine.source)
        except LubevizError as exc:
            self._refuse(str(exc))
            return
        except Exception as exc:  # noqa: BLE001 - a bad upload never stops the app
            self._refuse(f"{filename}: unexpected problem ({type(exc).__name__}): {exc}")
            return
        label = f"{machine.name} (uploaded: {filename})"
        self._paths[label] = Path(machine.source)
        self.select.options = list(self._paths)
        self.select.param.update(value=label)  # calls _on_select, which uses it
        if str(self.machine.source) != str(machine.source):
            self._use(machine)
