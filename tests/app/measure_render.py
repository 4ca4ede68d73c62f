"""Time to first render of the dashboard's start page in a real browser; prints one JSON object.

    .venv/bin/python tests/app/measure_render.py [--loads 5] [--plots 0] [--rotor] [--bearing] [--slider 0]
        [--script app.py]

Starts `panel serve app.py` (timed from launch to /liveness: `server_start_s`), launches the system Chromium,
then loads the start page `--loads` times, each in a new browser context (a new Panel session, no cache).
A load is timed from `page.goto` to Panel's first render (every Bokeh document idle), and with `--plots N`
also to the N-th plot drawn. The first load after server start also pays the server's imports and caches,
so it is reported on its own (`first_load_s`) besides the median of all loads.

With `--bearing`, each load then clicks the Bearing tab and times from the click to the film plots drawn
(the pressure field titled with its flow: `bearing_fields_s`), to the mid-plane profiles (drawn last of the
film plots: `bearing_films_s`) and to the sweep over Q done ("flows ready": `bearing_sweep_s`). The first
visit after server start computes Q_T, the films and the sweep; later visits find them in the server's cache.

With `--rotor`, each load first clicks the Rotor tab and times from the click to its full spectrum drawn
(`rotor_spectrum_s`: the response's plots, the flows known) and to four plots drawn (`rotor_plots_s`).
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

if __package__ in (None, ""):  # run as a script: make `tests.app.harness` importable from the repo root
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from playwright.sync_api import sync_playwright

from tests.app.harness import (
    APP_SCRIPT,
    chromium_launch_args,
    serve_app,
    slider,
    slider_value,
    wait_for_panel,
    wait_for_plot_title,
    wait_for_plots,
)


def slider_redraws(page, moves: int) -> list[float]:
    """Seconds from one step of the Bearing page's supply slider (a key press: one change event) until the
    pressure field is redrawn at the new flow, and until the last of the page's 7 plots (the mid-plane
    profile) is, as (fields, all) pairs for `moves` steps over flows whose film is already cached."""
    page.locator(".bk-tab", has_text="Bearing").first.click()
    page.locator(".lubeviz-pages").get_by_text("flows ready", exact=False).first.wait_for(timeout=600_000)
    handle = slider(page, "Supply flow Q1").locator(".noUi-handle").first
    out = []
    for k in range(moves):
        key = "ArrowLeft" if k % 2 == 0 else "ArrowRight"
        q = slider_value(page, "Supply flow Q1")
        target = q - 10 if key == "ArrowLeft" else q + 10
        t0 = time.perf_counter()
        handle.press(key)
        wait_for_plot_title(page, f"Pressure p(α, z) at Q = {target:.0f} ml/min")
        t1 = time.perf_counter()
        wait_for_plot_title(page, f"Mid-plane pressure at Q = {target:.0f} ml/min")  # drawn last
        out.append((t1 - t0, time.perf_counter() - t0))
    return out


def bearing_tab(page) -> tuple[float, float, float]:
    """Seconds from the click on the Bearing tab until the pressure field, the mid-plane profiles and the
    sweep over Q ("flows ready") are drawn."""
    t0 = time.perf_counter()
    page.locator(".bk-tab", has_text="Bearing").first.click()
    wait_for_plot_title(page, "Pressure p(α, z) at Q = ", timeout_ms=600_000)
    t1 = time.perf_counter()
    wait_for_plot_title(page, "Mid-plane pressure at Q = ", timeout_ms=600_000)
    t2 = time.perf_counter()
    page.locator(".lubeviz-pages").get_by_text("flows ready", exact=False).first.wait_for(timeout=600_000)
    return t1 - t0, t2 - t0, time.perf_counter() - t0


def rotor_tab(page) -> tuple[float, float]:
    """Seconds from the click on the Rotor tab until its full spectrum is drawn with the flows (the response's
    plots: orbit, signals, spectrum, modes, centrelines) and until its first four plots are drawn."""
    t0 = time.perf_counter()
    page.locator(".bk-tab", has_text="Rotor").first.click()
    wait_for_plot_title(page, "Full spectrum at node", timeout_ms=600_000)
    t1 = time.perf_counter()
    wait_for_plots(page, count=4, timeout_ms=600_000)
    return t1 - t0, time.perf_counter() - t0


def measure(script: Path = APP_SCRIPT, loads: int = 5, plots: int = 0, moves: int = 0,
            bearing: bool = False, rotor: bool = False) -> dict:
    """Server start and first-render times (seconds) of `script`'s page over `loads` fresh page loads."""
    started = time.perf_counter()
    with serve_app(script) as base_url:
        server_start_s = time.perf_counter() - started
        url = f"{base_url}/{Path(script).stem}"
        render_s, plots_s, redraw_s, bearing_s, rotor_s = [], [], [], [], []
        with sync_playwright() as pw:
            browser = pw.chromium.launch(**chromium_launch_args())
            try:
                for _ in range(loads):
                    context = browser.new_context(viewport={"width": 1280, "height": 900})
                    page = context.new_page()
                    t0 = time.perf_counter()
                    page.goto(url)
                    wait_for_panel(page)
                    render_s.append(time.perf_counter() - t0)
                    if rotor:
                        rotor_s.append(rotor_tab(page))
                    if bearing:
                        bearing_s.append(bearing_tab(page))
                    elif plots:  # the plots of the Bearing page, opened from the start page
                        page.locator(".bk-tab", has_text="Bearing").first.click()
                        wait_for_plots(page, plots)
                        plots_s.append(time.perf_counter() - t0)
                    if moves and _ == loads - 1:
                        redraw_s = slider_redraws(page, moves)
                    context.close()
                chromium_version = browser.version
            finally:
                browser.close()
    result = {
        "script": Path(script).name,
        "loads": loads,
        "server_start_s": round(server_start_s, 3),
        "first_load_s": round(render_s[0], 3),
        "first_render_median_s": round(statistics.median(render_s), 3),
        "first_render_s": [round(t, 3) for t in render_s],
        "chromium": chromium_version,
    }
    if redraw_s:
        fields, whole = zip(*redraw_s)
        result.update({"slider_moves": moves, "slider_redraw_median_s": round(statistics.median(fields), 3),
                       "slider_redraw_s": [round(t, 3) for t in fields],
                       "slider_redraw_all_plots_median_s": round(statistics.median(whole), 3),
                       "slider_redraw_all_plots_s": [round(t, 3) for t in whole]})
    if bearing_s:
        fields, films, sweep = ([round(t, 3) for t in col] for col in zip(*bearing_s))
        result.update({"bearing_fields_s": fields, "bearing_films_s": films, "bearing_sweep_s": sweep})
    if rotor_s:
        spectrum, four = ([round(t, 3) for t in col] for col in zip(*rotor_s))
        result.update({"rotor_spectrum_s": spectrum, "rotor_spectrum_median_s": round(statistics.median(spectrum), 3),
                       "rotor_plots_s": four})
    if plots:
        result.update({"plots": plots, "plots_drawn_median_s": round(statistics.median(plots_s), 3),
                       "plots_drawn_s": [round(t, 3) for t in plots_s]})
    return result


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--loads", type=int, default=5, help="page loads, each in a new browser context")
    parser.add_argument("--plots", type=int, default=0, help="also time until this many plots are drawn")
    parser.add_argument("--bearing", action="store_true",
                        help="after each load, time the Bearing tab: click -> fields, profiles, sweep done")
    parser.add_argument("--slider", type=int, default=0,
                        help="then step the Bearing page's supply slider this many times (cached flows) and time "
                             "each redraw")
    parser.add_argument("--rotor", action="store_true",
                        help="after each load, time the Rotor tab: click -> its full spectrum drawn (before --bearing)")
    parser.add_argument("--script", type=Path, default=APP_SCRIPT, help="the Panel script to serve")
    args = parser.parse_args(argv)
    if args.loads < 1:
        parser.error(f"--loads must be at least 1, got {args.loads}")
    print(json.dumps(measure(args.script, args.loads, args.plots, args.slider, args.bearing, args.rotor)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
