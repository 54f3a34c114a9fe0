"""The closed loop as a pure environment: ``make``, ``RadarEnv``, ``State`` (docs/extending.md).

    env = mjx_radar.env.make("smoke", method="ddr-sfim")
    state = env.reset(env.trial_key(seed, trial))     # jit-able, vmap over keys
    state = env.step(state, action)                   # action [N, 2]; lax.scan over time

Names resolve on first use: ``mjx_radar.env.records`` (what the runner and the live view
read) stays importable without the loop, and with it MuJoCo and MJX.
"""

import importlib

_LAZY = {
    "METRICS": "mjx_radar.env.environment",
    "RadarEnv": "mjx_radar.env.environment",
    "make": "mjx_radar.env.environment",
    "LoopState": "mjx_radar.env.state",
    "State": "mjx_radar.env.state",
    "Observation": "mjx_radar.env.state",
}

__all__ = sorted(_LAZY)


def __getattr__(name: str):
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'mjx_radar.env' has no attribute {name!r}")
