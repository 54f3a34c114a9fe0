"""mjx_radar: mobile radars re-positioned by MPPI over MuJoCo-MJX rollouts."""

from mjx_radar.config import (
    MPCConfig,
    MPPIConfig,
    Obstacle,
    RadarEquation,
    RadarLimits,
    Scenario,
    Timing,
)
from mjx_radar.io.scenario import ScenarioError, load_scenario
from mjx_radar.task.method import METHODS as _METHODS
from mjx_radar.task.method import Method, parse_method

METHODS = tuple(_METHODS)  # method names (SPEC §9)

__all__ = [
    "METHODS",
    "MPCConfig",
    "Method",
    "MPPIConfig",
    "Obstacle",
    "RadarEquation",
    "RadarLimits",
    "Scenario",
    "ScenarioError",
    "Timing",
    "load_scenario",
    "parse_method",
]
__version__ = "0.1.0"
