"""Obstacles and maps: footprint signed distance and line of sight."""
