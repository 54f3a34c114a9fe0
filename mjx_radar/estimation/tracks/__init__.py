"""Tracks: the managed track table, its update and births, multilateration, and the track metrics
(GOSPA / OSPA, continuity)."""
