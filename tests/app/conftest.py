"""Fixtures for real-browser tests of the dashboard (marker `browser`).

- `app_server`: base URL of `panel serve app.py`, one server for the whole session.
- `app_page`: pytest-playwright's `page` (fresh browser context per test) at the start page, first render done.
- `screenshot(page, name)`: saves a PNG of the whole page under test-artifacts/app/ and returns its path.
- `browser_type_launch_args`: launches the system Chromium; skips (or fails in CI) when it is missing.

Helpers to wait for plots and drive widgets are in `tests/app/harness.py` (`wait_for_plots`, `set_slider`, …).
"""

from __future__ import annotations

import os
import re

import pytest
from playwright.sync_api import expect

from .harness import (
    APP_SCRIPT,
    ARTIFACTS,
    CHROMIUM,
    REQUIRE_BROWSER_ENV,
    chromium_launch_args,
    save_screenshot,
    serve_app,
    wait_for_panel,
)

# A server callback may run a film solve on a loaded 2-core machine: wait longer than Playwright's 5 s.
expect.set_options(timeout=30_000)

_BROWSER_FIXTURES = {"page", "context", "browser", "app_page", "app_server", "screenshot"}
# one server per test worker (pytest-xdist), each with its own log
_WORKER = os.environ.get("PYTEST_XDIST_WORKER", "")
SERVER_LOG = ARTIFACTS / (f"panel-serve-{_WORKER}.log" if _WORKER else "panel-serve.log")
_log_offset = pytest.StashKey[int]()


def pytest_collection_modifyitems(config, items):
    # A test that opens the browser or the server is a browser test even if its module forgot the marker,
    # so that `-m "not browser"` always leaves them all out.
    for item in items:
        if _BROWSER_FIXTURES.intersection(getattr(item, "fixturenames", ())):
            item.add_marker(pytest.mark.browser)


def pytest_runtest_setup(item):
    item.stash[_log_offset] = SERVER_LOG.stat().st_size if SERVER_LOG.exists() else 0


# A callback that raises on the server is only logged: the page keeps what it showed, and a test that waits for
# something else may pass (the Diagnose page's bow once raised in its widgets while its story was updated). Every
# such failure in the log fails the test that was running; a websocket closed under a message is a browser
# context closing, not an error of the app.
_FAILED = re.compile(r"Callback failed|Exception in callback|Task exception was never retrieved")
_CLOSED = ("WebSocketClosedError", "StreamClosedError")


def server_failures(text: str) -> list[str]:
    """The callback failures in a part of the server's log, each with its last exception line."""
    out = []
    for block in re.split(r"(?m)^(?=\d{4}-\d\d-\d\d \d\d:\d\d:\d\d,\d+ )", text):
        if _FAILED.search(block) and not any(name in block for name in _CLOSED):
            errors = [line for line in block.splitlines() if re.match(r"^[A-Za-z_.]+(Error|Exception)\b", line)]
            out.append(block.splitlines()[0][:300] + ("\n" + errors[-1][:300] if errors else ""))
    return out


@pytest.fixture(autouse=True)
def _no_server_callback_failed(request):
    yield
    if "app_server" not in request.fixturenames or not SERVER_LOG.exists():
        return
    offset = request.node.stash.get(_log_offset, 0)
    with open(SERVER_LOG, "rb") as log:
        log.seek(offset if offset <= SERVER_LOG.stat().st_size else 0)
        failures = server_failures(log.read().decode(errors="replace"))
    assert not failures, "a server callback failed during this test:\n" + "\n".join(failures)


@pytest.hookimpl(wrapper=True)
def pytest_runtest_makereport(item, call):
    # A failing page test shows what the server printed meanwhile: a callback's traceback is only there.
    report = yield
    if report.failed and "app_server" in item.fixturenames and SERVER_LOG.exists():
        offset = item.stash.get(_log_offset, 0)
        with open(SERVER_LOG, "rb") as log:
            log.seek(offset if offset <= SERVER_LOG.stat().st_size else 0)  # 0: the server (re)started
            text = log.read().decode(errors="replace")
        report.sections.append(("panel serve output during this test", text[-6000:] or "(nothing)"))
    return report


@pytest.fixture(scope="session")
def browser_type_launch_args(browser_type_launch_args):
    """pytest-playwright's launch options (e.g. --headed, --slowmo) on the system Chromium with our flags."""
    if not CHROMIUM.exists():
        reason = (f"{CHROMIUM} is missing: browser tests need Debian's Chromium "
                  "(`apt-get install -y chromium`; .ci/run installs it)")
        if os.environ.get(REQUIRE_BROWSER_ENV) == "1":
            pytest.fail(f"{reason}, and {REQUIRE_BROWSER_ENV}=1 requires the browser tests to run")
        pytest.skip(reason)
    headless = browser_type_launch_args.get("headless", True)
    return {**browser_type_launch_args, **chromium_launch_args(headless=headless)}


@pytest.fixture(scope="session")
def browser_context_args(browser_context_args):
    """A fixed desktop viewport, so screenshots of one page compare across runs."""
    return {**browser_context_args, "viewport": {"width": 1280, "height": 900}}


@pytest.fixture(scope="session")
def app_server():
    """Base URL ("http://127.0.0.1:PORT") of app.py served by `panel serve` for the session.

    The server's output is kept in test-artifacts/app/panel-serve[-gwN].log (look there for a callback's traceback).
    The paper machine's coefficient tables are put in the user cache first, so page timeouts measure the app,
    not a cold table build (about a minute on 2 cores).
    """
    from lubeviz.identify.tables.cache import machine_tables
    from lubeviz.model.machine import load_machine

    machine_tables(load_machine())
    with serve_app(APP_SCRIPT, log_path=SERVER_LOG) as url:
        yield url


@pytest.fixture
def app_page(page, app_server):
    """A page showing the dashboard's start page, its first render done (plots may still be drawing)."""
    page.goto(app_server + "/app")
    wait_for_panel(page)
    return page


@pytest.fixture
def screenshot():
    """`screenshot(page, name, whole_page=True)`: save test-artifacts/app/NAME.png; returns its path."""
    return save_screenshot
