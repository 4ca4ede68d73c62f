"""Estimation: the fit of flows and effect parameters to a record's features, its result and verdicts."""
