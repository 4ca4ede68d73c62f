"""The library's words as a person reads them: its messages and verdicts are ASCII (the command line prints them), and a
page or a report writes the units' own signs (`signs`). Headless: the pages (`app.text`) and the report
(`diagnose.report`) both use it."""

from __future__ import annotations

import re

_SIGNS = ((re.compile(r"(?<=\d) um\b"), " µm"), (re.compile(r"(?<=\d) deg\b"), "°"), (re.compile(r" \+- "), " ± "), (re.compile(r"\+-(?=\d)"), "±"),
          (re.compile(r"(?<=\d) x (?=as|the)"), " × "), (re.compile(r"\bchi2\b"), "χ²"),
          (re.compile(r"(?<=\d)-(?=\d)"), "–"), (re.compile(r"(?<=\()x(?=\d)"), "×"),
          (re.compile(r" -> "), " → "))


def signs(text: str) -> str:
    """`text` with '150 um', '5 deg', '+-', 'chi2', 'x0.75-1.33' written as a page shows them: 150 µm, 5°, ±, χ²,
    ×0.75–1.33."""
    for pattern, shown in _SIGNS:
        text = pattern.sub(shown, text)
    return text
