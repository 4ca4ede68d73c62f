"""Running a page's code from a test on a thread of its own: a browser test before a file in the same xdist worker
leaves Playwright's event loop running in the main thread, where `asyncio.run` refuses to start and the dashboard's
shell schedules a page instead of building it."""

from __future__ import annotations

import asyncio
import threading


def on_a_thread(fn):
    """`fn()` on a new thread with a fresh (not running) event loop set; its result, or its exception re-raised."""
    out = {}

    def target():
        asyncio.set_event_loop(asyncio.new_event_loop())  # not running: a page's start() is scheduled, not run
        try:
            out["value"] = fn()
        except BaseException as exc:  # noqa: BLE001 - raised again in the test's own thread
            out["error"] = exc

    thread = threading.Thread(target=target)
    thread.start()
    thread.join()
    if "error" in out:
        raise out["error"]
    return out.get("value")


def run_coro(coro):
    """Run `coro` to its end on a thread of its own (`asyncio.run` there)."""
    return on_a_thread(lambda: asyncio.run(coro))
