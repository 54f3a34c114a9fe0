"""Resumable Monte Carlo studies, their statistics and the report (SPEC §9)."""
