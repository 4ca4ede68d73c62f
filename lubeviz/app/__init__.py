"""Panel views of lubeviz (display only: every number comes from the headless package)."""
