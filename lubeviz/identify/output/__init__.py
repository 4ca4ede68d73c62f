"""The identification as a person and a script read it: JSON, text and CSV, all from one summary."""
