"""Leaf file helpers: atomic writes, directory locks, value rules, terrain files, cache folders."""
