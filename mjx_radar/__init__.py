"""mjx_radar: mobile radars re-positioned by MPPI over MuJoCo-MJX rollouts."""

from mjx_radar.scenario.edit import validate
from mjx_radar.scenario.reader import ScenarioError, bundled_scenarios, load_scenario
from mjx_radar.scenario.schema import (
    MovingObstacle,
    MPCConfig,
    MPPIConfig,
    Obstacle,
    RadarEquation,
    RadarLimits,
    RadarOverride,
    Scenario,
    TargetMotion,
    Timing,
)
from mjx_radar.scenario.shipped import bundled_files, bundled_path
from mjx_radar.task.method import METHODS as _METHODS
from mjx_radar.task.method import Method, parse_method
from mjx_radar.version import __version__ as __version__

METHODS = tuple(_METHODS)  # method names (SPEC §9)

# The scripting API (docs/api.md), imported on first use: ``import mjx_radar`` stays light.
_LAZY = {
    "simulate": "mjx_radar.api.simulate",
    "Run": "mjx_radar.api.run",
    "run_study": "mjx_radar.api.study",
    "Study": "mjx_radar.api.study",
    "register_cost_term": "mjx_radar.task.cost_plugins",
    "unregister_cost_term": "mjx_radar.task.cost_plugins",
    "Planner": "mjx_radar.planners.base",
    "register_planner": "mjx_radar.planners.base",
    "unregister_planner": "mjx_radar.planners.base",
    "register_tracker": "mjx_radar.env.trackers",
    "unregister_tracker": "mjx_radar.env.trackers",
    "register_associator": "mjx_radar.env.trackers",
    "unregister_associator": "mjx_radar.env.trackers",
    "register_sensor": "mjx_radar.estimation.sensor.sensors",
    "unregister_sensor": "mjx_radar.estimation.sensor.sensors",
}
_SUBPACKAGES = ("env", "planners")  # mjx_radar.env.make(...), mjx_radar.planners.PLANNERS


def __getattr__(name: str):
    import importlib

    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    if name in _SUBPACKAGES:
        return importlib.import_module(f"mjx_radar.{name}")
    raise AttributeError(f"module 'mjx_radar' has no attribute {name!r}")


__all__ = [
    "METHODS",
    "MPCConfig",
    "Method",
    "MPPIConfig",
    "Planner",
    "MovingObstacle",
    "Obstacle",
    "RadarEquation",
    "Run",
    "Study",
    "RadarLimits",
    "RadarOverride",
    "Scenario",
    "TargetMotion",
    "ScenarioError",
    "Timing",
    "bundled_files",
    "bundled_path",
    "bundled_scenarios",
    "load_scenario",
    "parse_method",
    "register_associator",
    "register_cost_term",
    "register_planner",
    "register_sensor",
    "register_tracker",
    "run_study",
    "simulate",
    "unregister_associator",
    "unregister_cost_term",
    "unregister_planner",
    "unregister_sensor",
    "unregister_tracker",
    "validate",
]
