"""Radar sensing: the radar equation, measurement models and sensors, noise, detection and
clutter."""
