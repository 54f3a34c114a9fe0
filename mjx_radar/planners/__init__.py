"""Planners behind one contract (:mod:`mjx_radar.planners.base`): MPPI, hold, registered ones."""

from mjx_radar.planners.base import (
    PLANNERS,
    ControlRecord,
    Observation,
    Planner,
    make,
    register_planner,
    unregister_planner,
)

__all__ = [
    "PLANNERS",
    "ControlRecord",
    "Observation",
    "Planner",
    "make",
    "register_planner",
    "unregister_planner",
]
