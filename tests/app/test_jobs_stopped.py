"""A record read while an identification or a diagnosis runs stops it, and says so (issue 38: the pages cancelled a
running job silently when a new record was read, "latest wins")."""

from __future__ import annotations

import asyncio
import threading
import time

import pytest

from lubeviz.app.jobs import JobPanel, stopped_words
from tests.app.threads import run_coro
from lubeviz.progress import Cancelled


def _long(started: threading.Event, progress):
    started.set()
    for k in range(2000):  # ~20 s unless cancelled
        progress(k, 2000)
        time.sleep(0.01)
    return "finished"


def _quick(progress):
    return "read"


def test_a_read_that_stops_a_running_identification_names_it_in_its_status():
    panel = JobPanel()

    async def scenario():
        started = threading.Event()
        long = asyncio.ensure_future(panel.run(_long, started, label="identification"))
        while not started.is_set():
            await asyncio.sleep(0.01)
        read = await panel.run(_quick, label="reading b.csv", quiet=True, tell_stopped=True)
        with pytest.raises(Cancelled):
            await long
        return read

    assert run_coro(scenario()) == "read"
    assert panel.stopped == "identification"
    assert "reading b.csv: done in" in panel.status
    assert "it stopped the job that was running (identification)" in panel.status
    assert stopped_words(panel) == " Reading it stopped the job that was running (identification)."


def test_a_read_with_nothing_running_says_nothing_of_a_stop():
    panel = JobPanel()
    assert run_coro(panel.run(_quick, label="reading a.csv", quiet=True, tell_stopped=True)) == "read"
    assert panel.stopped is None and "stopped" not in panel.status and stopped_words(panel) == ""
