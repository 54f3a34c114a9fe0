"""The paper's process model: MJCF scene, MJX plant, unicycle and CV motion (SPEC §2, §3).

``mjx_radar.physics`` re-exports the plant API (SPEC §11: ``physics.rollout_radars``).
"""

from mjx_radar.physics.plant import (
    Plant,
    contact_envelope,
    init_data,
    make_plant,
    obstacle_contacts,
    planner_plant,
    radar_rollout,
    radar_state,
    rollout_radars,
    step,
    target_state,
    truth_plant,
)

__all__ = [
    "Plant",
    "contact_envelope",
    "init_data",
    "make_plant",
    "obstacle_contacts",
    "planner_plant",
    "radar_rollout",
    "radar_state",
    "rollout_radars",
    "step",
    "target_state",
    "truth_plant",
]
