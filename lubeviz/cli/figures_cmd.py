"""`lubeviz figures`: the data of the paper's Figs. 4-11, one file per figure (CSV or JSON).

Every file is one table in the units of the edges (ml/min, um, deg, s). CSV: `# key: value` comment
lines (figure, title, nodes, ...) then a header row, as the records of SPEC §6. JSON: {"figure",
"title", "meta", "columns": {name: [values]}}, the same table column by column. Figs. 9-11 mix maps,
curves and paths, so their tables are "long": one row per point, with `layer` (grid, root_eps_fb1 ...,
path, start, reference, identified), `curve` (the root curve's number, or the start's number in order
of attempt) and `point` (the index along it); the grid rows hold every eps and eps_T, path rows eps_T.
"""

from __future__ import annotations

import csv
import json
import math
import time
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..progress import StderrBar
from ..units import m3s_to_mlmin, m_to_um
from .common import add_common, to_jsonable

EPS_COLUMNS = ("eps_fb1", "eps_fb2", "eps_phi1", "eps_phi2", "eps_T")


def register(sub) -> None:
    p = sub.add_parser("figures", help="the data of the paper's Figs. 4-11, one CSV (or JSON) file per figure")
    add_common(p)
    p.add_argument("--out", metavar="DIR", default="paper-figures",
                   help="directory for the files (created; default ./paper-figures)")
    p.add_argument("--grid", type=int, default=101,
                   help="points per axis of the Q1 x Q2 maps and of the sweeps (3-2001, default 101)")
    p.add_argument("--format", choices=("csv", "json"), default="csv", help="file format (default csv)")
    p.add_argument("--seed", type=int, default=2024, help="seed of the noise of the reference records")
    p.set_defaults(run=run_figures)


def _deg(rad):
    return np.degrees(rad)


def _sweep_table(fig: dict, key: str, unit: str, convert) -> dict:
    cols = {"q_mlmin": m3s_to_mlmin(fig["q"])}
    for n, v in fig[key].items():
        cols[f"{key}_node{n}{unit}"] = convert(v)
    return cols


def _fig4(fig):
    cols = {"q_mlmin": m3s_to_mlmin(fig["q"])}
    for key, short in (("forward", "zf"), ("backward", "zb")):
        for n, v in fig[key].items():
            cols[f"{short}_node{n}_um"] = m_to_um(v)
    return cols


def _fig7(fig):
    q1, q2 = np.meshgrid(fig["q1"], fig["q2"])  # [i_q2, j_q1], raveled with Q1 fastest
    return {"q1_mlmin": m3s_to_mlmin(q1.ravel()), "q2_mlmin": m3s_to_mlmin(q2.ravel()),
            "fb1": fig["fb1"].ravel(), "fb2": fig["fb2"].ravel(),
            "phi1_deg": _deg(fig["phi1"]).ravel(), "phi2_deg": _deg(fig["phi2"]).ravel()}


def _fig8(fig):
    return {"t_s": fig["t"], "x_clean_um": m_to_um(fig["clean"]["x"]), "y_clean_um": m_to_um(fig["clean"]["y"]),
            "x_noisy_um": m_to_um(fig["noisy"]["x"]), "y_noisy_um": m_to_um(fig["noisy"]["y"])}


def _long_table(fig, layers) -> dict:
    rows: list[tuple] = []
    blank = (None,) * len(EPS_COLUMNS)

    def points(layer, curve, pts, values=None):
        for k, (a, b) in enumerate(pts):
            rows.append((layer, curve, k, a, b) + (blank if values is None else values[k]))

    if "grid" in layers:
        q1, q2 = np.meshgrid(fig["q1"], fig["q2"])
        eps = [fig["eps"][n].ravel() for n in ("fb1", "fb2", "phi1", "phi2")] + [fig["eps_total"].ravel()]
        points("grid", 0, zip(q1.ravel(), q2.ravel()), list(zip(*eps)))
    for name, curves in fig["roots"].items():
        for c, line in enumerate(curves, start=1):
            points(f"root_eps_{name}", c, line)
    if "path" in layers:
        for s, (path, total) in enumerate(zip(fig["paths"], fig["paths_total_error"]), start=1):
            points("path", s, path, [(None,) * 4 + (float(e),) for e in total])
        points("start", 0, fig["starts"])
    points("reference", 0, [fig["q_ref"]])
    points("identified", 0, [fig["q_identified"]])
    names = ("layer", "curve", "point", "q1_mlmin", "q2_mlmin") + EPS_COLUMNS
    cols = {n: [r[k] for r in rows] for k, n in enumerate(names)}
    for n in ("q1_mlmin", "q2_mlmin"):
        cols[n] = [m3s_to_mlmin(v) for v in cols[n]]
    return cols


def _meta(fid, fig) -> dict:
    meta = {"figure": fid, "title": fig["title"]}
    if "nodes" in fig:
        nodes = fig["nodes"]
        meta["nodes"] = (", ".join(f"{k} " + ", ".join(str(n) for n in v) for k, v in nodes.items())
                         if isinstance(nodes, dict) else ", ".join(str(n) for n in nodes))
    if "q_threshold" in fig:
        meta["q_threshold_mlmin"] = ", ".join(f"{m3s_to_mlmin(q):.2f}" for q in fig["q_threshold"])
    if fid == "fig7":
        meta["layout"] = "one row per grid point, Q1 varying fastest"
    if fid == "fig8":
        meta.update(node=fig["node"], snr_db=fig["snr_db"],
                    flows_mlmin=", ".join(f"{m3s_to_mlmin(q):g}" for q in fig["flows"]))
    if "q_ref" in fig:
        meta.update(q_ref_mlmin=", ".join(f"{m3s_to_mlmin(q):g}" for q in fig["q_ref"]),
                    q_identified_mlmin=", ".join(f"{m3s_to_mlmin(q):.2f}" for q in fig["q_identified"]),
                    converged=fig["converged"], iterations=fig["iterations"], starts_tried=fig["starts_tried"],
                    phi_scale_deg=f"{math.degrees(fig['phi_scale']):g}",
                    reference_features=", ".join(f"{k}_deg {math.degrees(v):.6g}" if k.startswith("phi") else
                                                 f"{k} {v:.6g}" for k, v in fig["reference_features"].items()))
    return meta


def figure_table(fid: str, fig: dict) -> tuple[dict, dict]:
    """(meta, columns) of one figure in edge units: the content of its file."""
    builders = {
        "fig4": _fig4,
        "fig5": lambda f: _sweep_table(f, "fb", "", lambda v: v),
        "fig6": lambda f: _sweep_table(f, "phi", "_deg", _deg),
        "fig7": _fig7,
        "fig8": _fig8,
        "fig9": lambda f: _long_table(f, ("grid", "path")),
        "fig10": lambda f: _long_table(f, ("grid",)),
        "fig11": lambda f: _long_table(f, ("path",)),
    }
    return _meta(fid, fig), builders[fid](fig)


def _cell(v):
    if v is None:
        return ""
    if isinstance(v, (float, np.floating)):
        return "" if not math.isfinite(v) else f"{float(v):.9g}"
    return str(v)


def write_figure(path: Path, fid: str, fig: dict, fmt: str) -> None:
    meta, cols = figure_table(fid, fig)
    if fmt == "json":
        path.write_text(json.dumps(to_jsonable({"figure": fid, "title": fig["title"], "meta": meta,
                                                "columns": cols})) + "\n")
        return
    names = list(cols)
    with path.open("w", newline="") as fh:
        for k, v in meta.items():
            fh.write(f"# {k}: {v}\n")
        w = csv.writer(fh)
        w.writerow(names)
        for row in zip(*(cols[n] for n in names)):
            w.writerow([_cell(v) for v in row])


def run_figures(args) -> dict:
    from ..identify.paper.maps import paper_figures
    from ..model.machine import load_machine

    t_start = time.perf_counter()
    if not 3 <= args.grid <= 2001:
        raise InputError(f"--grid {args.grid}: expected 3 to 2001 points per axis")
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise InputError(f"--out {out}: exists and is not a directory")
    machine = load_machine(args.machine)
    figs = paper_figures(machine, grid=args.grid, seed=args.seed, progress=StderrBar())
    try:
        out.mkdir(parents=True, exist_ok=True)
        files, seconds = {}, {}
        for fid, fig in figs.items():
            path = out / f"{fid}.{args.format}"
            write_figure(path, fid, fig, args.format)
            files[fid], seconds[fid] = str(path), fig["seconds"]
    except OSError as exc:
        raise InputError(f"--out {out}: cannot write the figure files ({exc.strerror or exc})") from None
    result = {"out": str(out), "format": args.format, "grid": args.grid, "files": files,
              "figure_seconds": seconds, "seconds": time.perf_counter() - t_start}
    if not args.json:
        for fid, path in files.items():
            print(f"{fid}: {path}")
        print(f"total {result['seconds']:.1f} s")
        args.json_text_done = True
    return result
