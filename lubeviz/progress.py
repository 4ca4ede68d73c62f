"""One small progress protocol for long computations: the CLI draws a bar, the app a progress widget.

A progress callback is any callable `progress(done, total, label)`; it may raise `Cancelled`
to stop the computation cleanly between two steps.
"""

from __future__ import annotations

import sys
from typing import Callable, Protocol


class Cancelled(Exception):
    """Raised by a progress callback to stop a long computation between two steps."""


class Progress(Protocol):
    def __call__(self, done: int, total: int, label: str = "") -> None: ...


def silent(done: int, total: int, label: str = "") -> None:
    """The default: report nothing."""


class StderrBar:
    """A one-line text bar on stderr (never on stdout, which carries JSON)."""

    def __init__(self, stream=None, width: int = 30):
        self.stream = stream or sys.stderr
        self.width = width

    def __call__(self, done: int, total: int, label: str = "") -> None:
        frac = done / total if total else 1.0
        n = int(round(self.width * frac))
        end = "\n" if done >= total else ""
        self.stream.write(f"\r[{'#' * n}{'.' * (self.width - n)}] {done}/{total} {label}"[:120] + end)
        self.stream.flush()


ProgressFn = Callable[[int, int, str], None]
