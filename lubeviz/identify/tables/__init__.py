"""Coefficient tables: the film solved once per geometry over (Sommerfeld number, Q/Q_T), cached on disk."""
