"""Background work for the dashboard: run a computation off the server's event loop, show its
progress, let the user cancel it, and never block another browser session.

One thread pool serves all sessions (the numerics release the GIL: numba kernels are `nogil`, LAPACK
and sparse solves run in C). Each page owns a `JobPanel`, a small view with a progress bar, a label and
a Cancel button. `await panel.run(fn, *args)` calls `fn(*args, progress=callback)` in the pool and, while
it runs, copies the callback's (done, total, label) to the progress bar ten times a second from the
event loop (widgets are only touched from the loop, never from the worker). Cancel sets a flag that the
callback turns into `progress.Cancelled` at the computation's next step; a newer request on the same
panel cancels the older one ("latest wins": a slider dragged across ten flows computes only the last).
"""

from __future__ import annotations

import asyncio
import functools
import os
import threading
import time
import multiprocessing
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor

import panel as pn
import param

from ..progress import Cancelled
from .text import plain

_WORKERS = max(2, min(8, (os.cpu_count() or 2) * 2))
EXECUTOR = ThreadPoolExecutor(max_workers=_WORKERS, thread_name_prefix="lubeviz-job")
_PROCESSES: ProcessPoolExecutor | None = None
_PROCESS_LOCK = threading.Lock()


def process_pool() -> ProcessPoolExecutor:
    """Worker processes for long pure-Python work (film sweeps, Campbell diagrams): they hold the GIL, so
    in a thread they would slow the server's event loop and every other session; in a process they cannot.
    Spawned (forking the threaded server can deadlock), one per core, created on first use."""
    global _PROCESSES
    with _PROCESS_LOCK:
        if _PROCESSES is None:
            _PROCESSES = ProcessPoolExecutor(max_workers=max(1, min(4, os.cpu_count() or 1)),
                                             mp_context=multiprocessing.get_context("spawn"))
        return _PROCESSES


class Ticket:
    """One request: its cancel flag and its latest progress report (written by the worker thread)."""

    def __init__(self, label: str):
        self.label = label
        self.cancelled = threading.Event()
        self.state = (0, 0, label)
        self.started = time.perf_counter()

    def progress(self, done: int, total: int, label: str = "") -> None:
        if self.cancelled.is_set():
            raise Cancelled("cancelled by the user")
        self.state = (int(done), int(total), label or self.state[2])


class JobPanel(pn.viewable.Viewer):
    """Progress bar, status text and Cancel button of one page's background jobs."""

    busy = param.Boolean(False, doc="A job is running")
    status = param.String("", doc="What the last job did, or is doing")

    def __init__(self, **params):
        super().__init__(**params)
        self._ticket: Ticket | None = None
        # what the last job started here stopped (the label of the job it replaced), or None: a record read while
        # an identification or a diagnosis runs stops it, and the page says so (issue 38)
        self.stopped: str | None = None
        self._bar = pn.indicators.Progress(value=0, max=100, active=False, width=220, height=18,
                                           visible=False, bar_color="info")
        self._text = pn.pane.Markdown("", margin=(0, 10), styles={"font-size": "0.9em"},
                                      css_classes=["lubeviz-job-status"])
        self._cancel = pn.widgets.Button(name="Cancel", button_type="warning", width=80, visible=False,
                                         css_classes=["lubeviz-cancel"])
        self._cancel.on_click(lambda event: self.cancel())
        self._layout = pn.Row(self._bar, self._cancel, self._text, sizing_mode="stretch_width",
                              margin=(0, 5))
        # labels and statuses may quote a file's name or an error about it: shown as written (text.plain)
        self.param.watch(lambda e: setattr(self._text, "object", plain(e.new)), "status")

    def __panel__(self):
        return self._layout

    def cancel(self) -> None:
        if self._ticket is not None:
            self._ticket.cancelled.set()

    def _show(self, ticket: Ticket) -> None:
        done, total, label = ticket.state
        if total:
            self._bar.value = int(round(100 * min(done, total) / total))
            self._bar.active = False
        else:
            self._bar.active = True
        self._text.object = plain(f"{label} …")

    async def run(self, fn, *args, label: str = "working", quiet: bool = False, process: bool = False,
                  tell_stopped: bool = False, **kwargs):
        """`fn(*args, progress=..., **kwargs)` in the thread pool; returns its result.

        Raises progress.Cancelled if this request was cancelled or superseded. `quiet`: do not show the
        progress bar (for jobs expected to finish in well under a second), only the status text at the end.
        `process`: run `fn(*args, **kwargs)` (a picklable module-level function, no progress argument) in
        the process pool instead; its progress shows as indeterminate and Cancel discards its result.
        `tell_stopped`: the status at the end names the job this one stopped, if it stopped one (`stopped`).
        """
        self.stopped = None
        if self._ticket is not None:
            self._ticket.cancelled.set()  # latest wins
            self.stopped = self._ticket.label
        ticket = self._ticket = Ticket(label)
        loop = asyncio.get_running_loop()
        if process:
            future = asyncio.wrap_future(process_pool().submit(fn, *args, **kwargs))
        else:
            call = functools.partial(fn, *args, progress=ticket.progress, **kwargs)
            future = loop.run_in_executor(EXECUTOR, call)
        self.busy = True
        shown = False
        try:
            while True:
                done, _ = await asyncio.wait([future], timeout=0.1)
                if done:
                    break
                if ticket.cancelled.is_set():
                    if self._ticket is ticket:  # a superseded job never writes over its successor's status
                        self._text.object = plain(f"{label}: cancelling …")
                elif not quiet or time.perf_counter() - ticket.started > 0.3:
                    if not shown:
                        self._bar.visible = self._cancel.visible = shown = True
                    self._show(ticket)
            result = future.result()  # re-raises the worker's exception, Cancelled included
            if ticket.cancelled.is_set():
                raise Cancelled("superseded")
            self.status = f"{label}: done in {time.perf_counter() - ticket.started:.2f} s" + (
                f"; it stopped the job that was running ({self.stopped})" if tell_stopped and self.stopped else "")
            return result
        except Cancelled:
            if self._ticket is ticket:
                self.status = f"{label}: cancelled"
            raise
        except Exception as exc:  # noqa: BLE001 - shown on the page, re-raised for the caller
            self.status = f"{label}: failed: {exc}"
            raise
        finally:
            if self._ticket is ticket:
                self._ticket = None
                self.busy = False
                self._bar.visible = self._cancel.visible = False
                self._text.object = plain(self.status)


def stopped_words(jobs: JobPanel) -> str:
    """' Reading it stopped the job that was running (identification).' when the panel's last job (a record's read,
    to be called right after it) stopped one, else '': a refused file still stopped the job on the record before it
    (issue 38: no silent cancellation)."""
    return f" Reading it stopped the job that was running ({jobs.stopped})." if jobs.stopped else ""
