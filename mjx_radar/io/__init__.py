"""Scenario files in, result files out."""
