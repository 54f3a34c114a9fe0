"""The closed loop as a pure environment: ``make``, ``RadarEnv``, ``State`` (docs/extending.md).

env = mjx_radar.env.make("smoke", method="ddr-sfim")
state = env.reset(env.trial_key(seed, trial))     # jit-able, vmap over keys
state = env.step(state, action)                   # action [N, 2]; lax.scan over time
"""

from mjx_radar.env.environment import METRICS, RadarEnv, make
from mjx_radar.env.state import LoopState, State
from mjx_radar.planners.base import Observation

__all__ = ["METRICS", "LoopState", "Observation", "RadarEnv", "State", "make"]
