"""Identification: each bearing's supply flow (and free effect parameters) from a record's orbit features.

The rooms follow the data's path:
- `tables`: coefficient tables over the supply flow (dimensionless, over Sommerfeld number and Q/Q_T), their
  disk cache and their accuracy against direct film solves;
- `forward`: the forward model (flows -> features), the chain with a machine's effects, the measured features
  and the model's own uncertainty;
- `fit`: the estimation (global search, Levenberg-Marquardt, profile intervals), its result and verdicts,
  settings, the record checks, large orbits;
- `output`: the result as JSON, text and CSV;
- `paper`: the paper's Newton search, its 64-case protocol and its sensitivity maps;
- `batch`: records and files in, results out (what the CLI and the app run).
"""
