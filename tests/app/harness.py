"""Real-browser harness for the dashboard: serve a Panel script in a subprocess, drive the system Chromium.

Used by the fixtures in `conftest.py` and by the `measure_render.py` benchmark. Playwright cannot download
its own browser on our machines, so everything runs on Debian's `/usr/bin/chromium` (`.ci/run` installs it).
"""

from __future__ import annotations

import contextlib
import os
import socket
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.request
from collections.abc import Iterator
from pathlib import Path

from playwright.sync_api import TimeoutError as PlaywrightTimeoutError

REPO = Path(__file__).resolve().parents[2]
APP_SCRIPT = REPO / "app.py"
ARTIFACTS = REPO / "test-artifacts" / "app"  # screenshots kept as test artifacts (test-artifacts/ is git-ignored)

CHROMIUM = Path("/usr/bin/chromium")
# Without the background-networking flags Chromium floods the closed network with refused connections.
CHROMIUM_FLAGS = [
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
]
REQUIRE_BROWSER_ENV = "LUBEVIZ_REQUIRE_BROWSER"  # set to 1 by .ci/run: a missing Chromium fails, not skips

SERVER_START_TIMEOUT_S = 90.0  # imports panel/bokeh (~1 s idle, far more on a busy 2-core machine); the
#                               app script itself runs per session, at the first page load
PLOT_TIMEOUT_MS = 60_000  # a page's first render or plot may wait on a film solve


class AppServerError(RuntimeError):
    """`panel serve` exited or never answered on /liveness; the message carries its output."""


def chromium_launch_args(headless: bool = True) -> dict:
    """Playwright `launch()` keyword arguments for the system Chromium."""
    flags = [f for f in CHROMIUM_FLAGS if headless or f != "--headless"]
    return {"executable_path": str(CHROMIUM), "args": flags, "headless": headless}


def free_port() -> int:
    """A TCP port free on 127.0.0.1 right now (the OS picks it; a tiny race with other processes remains)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _tail(path: Path, n_chars: int = 4000) -> str:
    text = path.read_text(errors="replace")
    return text if len(text) <= n_chars else "…" + text[-n_chars:]


@contextlib.contextmanager
def serve_app(script: Path = APP_SCRIPT, log_path: Path | None = None,
              timeout_s: float = SERVER_START_TIMEOUT_S, extra_args: tuple[str, ...] = ()) -> Iterator[str]:
    """Serve `script` with `panel serve` in a subprocess; yield its base URL ("http://127.0.0.1:PORT").

    Runs with this interpreter (`sys.executable`) so the served app imports the same installed `lubeviz`,
    waits on `/liveness` rather than sleeping, and stops the server on exit. The server's output goes to
    `log_path` (kept) or, when None, to a temporary file removed on exit. Raises `AppServerError` with that
    output if the server exits early or does not answer within `timeout_s`.
    """
    script = Path(script).resolve()
    port = free_port()
    base_url = f"http://127.0.0.1:{port}"
    from lubeviz.app.widgets import WEBSOCKET_MAX_MESSAGE_BYTES

    cmd = [sys.executable, "-m", "panel", "serve", script.name, "--address", "127.0.0.1", "--port", str(port),
           "--allow-websocket-origin", f"127.0.0.1:{port}", "--liveness", "--warm",
           "--websocket-max-message-size", str(WEBSOCKET_MAX_MESSAGE_BYTES), *extra_args]
    keep_log = log_path is not None
    if keep_log:
        log_path.parent.mkdir(parents=True, exist_ok=True)
    else:
        fd, name = tempfile.mkstemp(prefix="panel-serve-", suffix=".log")
        os.close(fd)
        log_path = Path(name)
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    # Output to a file, not a pipe: a chatty server must never block on a full pipe nobody reads.
    with open(log_path, "wb") as log:
        proc = subprocess.Popen(cmd, cwd=script.parent, stdout=log, stderr=subprocess.STDOUT, env=env)
    try:
        _wait_for_liveness(proc, f"{base_url}/liveness", timeout_s, log_path, cmd)
        yield base_url
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(timeout=10)
        if not keep_log:
            log_path.unlink(missing_ok=True)


def _wait_for_liveness(proc: subprocess.Popen, url: str, timeout_s: float, log_path: Path, cmd: list) -> None:
    deadline = time.monotonic() + timeout_s
    while True:
        if proc.poll() is not None:
            raise AppServerError(f"`{' '.join(cmd)}` exited with code {proc.returncode} before answering "
                                 f"{url}; its output:\n{_tail(log_path)}")
        try:
            with urllib.request.urlopen(url, timeout=2) as response:
                if response.status == 200:
                    return
        except (urllib.error.URLError, ConnectionError, TimeoutError):
            pass
        if time.monotonic() > deadline:
            raise AppServerError(f"`{' '.join(cmd)}` did not answer {url} within {timeout_s:.0f} s; "
                                 f"its output so far:\n{_tail(log_path)}")
        time.sleep(0.1)


# --- waiting for Panel/Bokeh to render -------------------------------------------------------------------
# Panel builds the page in the browser after the HTML arrives (Bokeh document over the websocket, views
# rendered lazily, plots drawn on <canvas> inside shadow roots). Playwright's CSS locators pierce open
# shadow roots, so plain selectors such as ".bk-Canvas canvas" or ".noUi-handle" find Bokeh's elements.

# True once BokehJS has a document whose root views have all finished their first render (Bokeh's
# `Document.is_idle`, the moment it logs "document idle at N ms"); it does not go false again afterwards.
_BOKEH_IDLE_JS = """() => {
  const B = window.Bokeh;
  if (!B || !B.documents || B.documents.length === 0) return false;
  return B.documents.every(doc => doc.roots().length > 0 && doc.is_idle);
}"""


def wait_for_panel(page, timeout_ms: float = PLOT_TIMEOUT_MS) -> None:
    """Wait until every Bokeh document on the page is built and idle (Panel's first render is done)."""
    try:
        page.wait_for_function(_BOKEH_IDLE_JS, timeout=timeout_ms)
    except PlaywrightTimeoutError:
        raise AssertionError(f"Panel did not render {page.url} within {timeout_ms / 1000:.0f} s (no idle Bokeh "
                             "document); an exception in the app shows in the server log") from None


def wait_for_plots(page, count: int = 1, timeout_ms: float = PLOT_TIMEOUT_MS) -> None:
    """Wait until at least `count` Bokeh plots are drawn (a visible canvas each), then until Bokeh is idle.

    One plot is one ".bk-Canvas" element (it stacks several <canvas> layers); a colour bar drawn as its own
    figure counts as a plot too.
    """
    page.locator(".bk-Canvas").nth(count - 1).locator("canvas").first.wait_for(state="visible",
                                                                              timeout=timeout_ms)
    wait_for_panel(page, timeout_ms)


# Plot titles, axis labels and legends are drawn on the canvas, not in the DOM: text locators cannot see
# them. Read them from BokehJS's models instead.
_PLOT_TITLES_JS = """() => {
  const titles = [];
  for (const doc of (window.Bokeh ? Bokeh.documents : []))
    for (const model of doc.all_models)
      if (model.type === "Title" && typeof model.text === "string" && model.text !== "") titles.push(model.text);
  return titles;
}"""


def plot_titles(page) -> list[str]:
    """The non-empty titles of the Bokeh plots on the page (HoloViews' `title=` lands there too)."""
    return page.evaluate(_PLOT_TITLES_JS)


def wait_for_plot_title(page, text: str, timeout_ms: float = PLOT_TIMEOUT_MS) -> None:
    """Wait until some plot's title contains `text` (a plot redrawn for a new input changes its title)."""
    try:
        page.wait_for_function(f"text => ({_PLOT_TITLES_JS})().some(t => t.includes(text))", arg=text,
                               timeout=timeout_ms)
    except PlaywrightTimeoutError:
        raise AssertionError(f"no plot title contains {text!r} after {timeout_ms / 1000:.0f} s; "
                             f"the titles: {plot_titles(page)}") from None


def screenshot_path(name: str) -> Path:
    """Where the screenshot `name` goes (a ".png" suffix is added when missing)."""
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    return ARTIFACTS / (name if name.endswith(".png") else f"{name}.png")


# Panel's templates scroll inside #main, not the document, so Playwright's `full_page=True` alone stops at
# the viewport's bottom edge: grow the viewport by #main's hidden height for the picture, then restore it.
_HIDDEN_HEIGHT_JS = "() => { const m = document.querySelector('#main'); return m ? m.scrollHeight - m.clientHeight : 0; }"
_TWO_FRAMES_JS = "() => new Promise(done => requestAnimationFrame(() => requestAnimationFrame(done)))"


def save_screenshot(page, name: str, whole_page: bool = True) -> Path:
    """Save a PNG of the page under test-artifacts/app/ (all of a template's scrolled content when
    `whole_page`) and return its path."""
    path = screenshot_path(name)
    viewport = page.viewport_size
    hidden = page.evaluate(_HIDDEN_HEIGHT_JS) if whole_page and viewport else 0
    if hidden > 0:
        page.set_viewport_size({"width": viewport["width"], "height": viewport["height"] + hidden})
        page.evaluate(_TWO_FRAMES_JS)  # let Bokeh lay out and repaint at the new size
    try:
        page.screenshot(path=str(path), full_page=whole_page)
    finally:
        if hidden > 0:
            page.set_viewport_size(viewport)
    return path


# --- driving Panel widgets ------------------------------------------------------------------------------
# Panel 1.9 / Bokeh 3.9 DOM (all inside shadow roots, which Playwright's CSS and text locators pierce):
#   slider        host ".bk-Slider" holding ".bk-slider-title" ("Name: value") and noUiSlider's
#                 ".noUi-base" track and ".noUi-handle" (role=slider, aria-valuenow; no accessible name)
#   text input    "input.bk-input", found by its title: page.get_by_label("Name"); sent on Enter or blur
#   select        "select.bk-input": page.get_by_label("Name").select_option("B2")
#   button        page.get_by_role("button", name="Run")
#   tab header    page.get_by_text("Title", exact=True).click()   (no role=tab in Panel's Tabs)
#   plot          ".bk-Canvas canvas" (a Bokeh figure; HoloViews panes render to the same)


def slider(page, title: str):
    """The locator of the Panel slider whose title (its `name`) contains `title`."""
    return page.locator(".bk-Slider", has_text=title)


def slider_value(page, title: str) -> float:
    """The slider's current value as the browser shows it (the index for a DiscreteSlider)."""
    return float(slider(page, title).locator(".noUi-handle").first.get_attribute("aria-valuenow"))


def set_slider(page, title: str, value: float, max_key_presses: int = 100) -> None:
    """Move the slider titled `title` to `value` as a user would: one click on the track at the value's
    position (one change event), then arrow keys for the last steps the pixel grid could not hit.

    `value` must lie on the slider's step grid; raises ValueError if the slider steps over it.
    """
    target = slider(page, title)
    handle = target.locator(".noUi-handle").first
    lo, hi = (float(handle.get_attribute(a)) for a in ("aria-valuemin", "aria-valuemax"))
    if not lo <= value <= hi:
        raise ValueError(f"slider {title!r}: value {value} outside its range [{lo}, {hi}]")
    track = target.locator(".noUi-base")
    box = track.bounding_box()
    track.click(position={"x": (value - lo) / (hi - lo) * box["width"], "y": box["height"] / 2})
    tolerance = 1e-9 * max(abs(hi - lo), 1.0)
    for _ in range(max_key_presses):
        now = slider_value(page, title)
        if abs(now - value) <= tolerance:
            return
        key = "ArrowRight" if now < value else "ArrowLeft"
        handle.press(key)
        after = slider_value(page, title)
        if (after - value) * (now - value) < 0:
            raise ValueError(f"slider {title!r}: value {value} is not on its step grid ({now} -> {after})")
    raise ValueError(f"slider {title!r}: did not reach {value} in {max_key_presses} key presses")


# --- layout -------------------------------------------------------------------------------------------------
# Panel's template scrolls and clips inside its own containers, so `document.documentElement.scrollWidth` stays
# at the window's width even when a plot is cut at the right edge: look at every rendered element's box instead,
# shadow roots included.
_PAST_RIGHT_EDGE_JS = """(slack) => {
  const out = [];
  const limit = window.innerWidth + slack;
  const visit = root => {
    for (const el of root.querySelectorAll("*")) {
      if (el.shadowRoot) visit(el.shadowRoot);
      const r = el.getBoundingClientRect();
      if (r.width === 0 || r.height === 0 || r.right <= limit) continue;
      const style = getComputedStyle(el);
      if (style.visibility === "hidden" || style.display === "none") continue;
      const cls = typeof el.className === "string" ? el.className : "";
      out.push(`${el.tagName.toLowerCase()}${cls ? "." + cls.trim().split(/\\s+/).join(".") : ""} ` +
               `(${Math.round(r.left)}-${Math.round(r.right)} px)`);
    }
  };
  visit(document);
  return out;
}"""


def elements_past_right_edge(page, slack_px: float = 1.0) -> list[str]:
    """Rendered elements whose box reaches past the window's right edge (by more than `slack_px`), described
    as "tag.classes (left-right px)"; an empty list when the page fits the window's width."""
    return page.evaluate(_PAST_RIGHT_EDGE_JS, slack_px)


def text(locator) -> str:
    """The text a Panel pane shows (it renders into a shadow root, which `inner_text` does not read)."""
    return locator.evaluate("e => (e.shadowRoot || e).textContent")


def open_tab(page, name: str) -> None:
    """Click the dashboard's tab `name`."""
    page.locator(".bk-tab", has_text=name).first.click()
