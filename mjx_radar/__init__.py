"""mjx_radar: mobile radars re-positioned by MPPI over MuJoCo-MJX rollouts."""

from mjx_radar.config import (
    METHODS,
    MPCConfig,
    MPPIConfig,
    Obstacle,
    RadarEquation,
    RadarLimits,
    Scenario,
    Timing,
)
from mjx_radar.io.scenario import ScenarioError, load_scenario

__all__ = [
    "METHODS",
    "MPCConfig",
    "MPPIConfig",
    "Obstacle",
    "RadarEquation",
    "RadarLimits",
    "Scenario",
    "ScenarioError",
    "Timing",
    "load_scenario",
]
__version__ = "0.1.0"
