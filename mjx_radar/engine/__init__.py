"""Batched trial execution: compiled programs, their caches, devices and memory (SPEC §8)."""
