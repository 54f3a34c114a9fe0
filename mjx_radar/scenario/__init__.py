"""Scenarios: the typed schema, its rules, the TOML and map-file readers, bundled data."""
