"""What the pages of one browser session share: the session's one record (uploaded or simulated on any page),
its features, the last identification, and a page another page asks to open. One instance per session (never
module-level), so sessions cannot see each other's data.

A record is loaded once, on the Identify or the Diagnose page, and every page uses it: Identify identifies it,
Diagnose diagnoses it, Maps draws its error functions (issue 38: "one record, three uploads")."""

from __future__ import annotations

import param


class SessionState(param.Parameterized):
    """The pages write these through `use`; each page watches `record` and shows the session's record."""

    record = param.Parameter(None, doc="The session's record (signals.records.Record)")
    measured = param.Parameter(None, doc="Its measured features (identify.forward.measured.MeasuredFeatures)")
    record_name = param.String(None, allow_None=True, doc="What the pages call the record (its file, or the sample)")
    loaded_on = param.String(None, allow_None=True, doc="The page the record was loaded on")
    truth = param.Dict(None, allow_None=True,
                       doc="The true flows and effect of a sample a page simulated (never a file's claims)")
    identification = param.Parameter(None, doc="The last identification (identify.fit.result.Identification)")
    settings = param.Parameter(None, doc="The IdentificationSettings it was run with")
    open_page = param.String(None, allow_None=True, doc="A page another page asks the dashboard to show")
    diagnosis_asked = param.Boolean(False, doc="The Identify page asked the Diagnose page to diagnose the record")

    def use(self, record, measured, name: str, loaded_on: str, truth: dict | None = None) -> None:
        """Make `record` the session's: every page shows it, and any identification of the one before is
        dropped. One update, so a page's watcher sees the record, its name and its truth together."""
        self.param.update(identification=None, settings=None, measured=measured, record_name=name,
                          loaded_on=loaded_on, truth=truth, diagnosis_asked=False, record=record)

    def ask(self, page: str) -> None:
        """Ask the dashboard to show `page` (the shell switches its tab)."""
        self.open_page = None  # the same page asked twice is two events
        self.open_page = page
