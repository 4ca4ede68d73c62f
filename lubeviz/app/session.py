"""What the pages of one browser session share: the uploaded record, its features, the last
identification. One instance per session (never module-level), so sessions cannot see each other's data."""

from __future__ import annotations

import param


class SessionState(param.Parameterized):
    """The Identify page writes these; the Maps page draws the last identification's search."""

    record = param.Parameter(None, doc="The uploaded record (signals.records.Record)")
    measured = param.Parameter(None, doc="Its measured features (identify.forward.measured.MeasuredFeatures)")
    identification = param.Parameter(None, doc="The last identification (identify.fit.result.Identification)")
    settings = param.Parameter(None, doc="The IdentificationSettings it was run with")
