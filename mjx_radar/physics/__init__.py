"""The paper's process model: MJCF scene, MJX plant, unicycle and CV motion (SPEC §2, §3).

``mjx_radar.physics`` re-exports the plant API (SPEC §11: ``physics.rollout_radars``).
The names are resolved on first use (PEP 562): importing a light submodule such as
``physics.target_motion`` or ``physics.kinematics`` does not import MJX, so a warm start
from the export cache never loads it.
"""

import importlib

_FROM = {
    "Plant": "plant",
    "contact_envelope": "plant",
    "init_data": "plant",
    "make_plant": "plant",
    "obstacle_contacts": "plant",
    "planner_plant": "plant",
    "radar_state": "plant",
    "step": "plant",
    "target_state": "plant",
    "truth_plant": "plant",
    "radar_rollout": "rollout",
    "rollout_radars": "rollout",
}

__all__ = sorted(_FROM)


def __getattr__(name: str):
    if name in _FROM:
        value = getattr(importlib.import_module(f"mjx_radar.physics.{_FROM[name]}"), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'mjx_radar.physics' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_FROM))
