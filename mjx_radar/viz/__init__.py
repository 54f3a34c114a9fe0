"""Offscreen rendering, videos and the two-panel snapshot (host side)."""
