"""The planner contract: what a planner sees, what it returns, and how it is found by name.

A planner moves the radars of one environment (:class:`mjx_radar.env.RadarEnv`), like
hydrax's controllers and brax's policies. It is made once per environment and is then
pure (jit-able, vmap-able over trials)::

    planner = PLANNERS.get("mppi")(env)      # static settings, read from env.task
    carry = planner.init()                   # its state: a warm start, filters, ...
    action, carry = planner.plan(carry, obs, key)   # action [N, 2]: [a, alpha] per radar

``obs`` is an :class:`~mjx_radar.env.state.Observation` (the environment's type,
re-exported here): what the radars know (their own states, the track
estimate and its covariance, the last scan's detections), never the truth. The
environment clips actions to ``env.action_bounds``; a planner that scores candidate
sequences with the method's information objective calls ``env.objective(obs)``.
``record(carry, action)`` says what the run files show of the plan (the planned
positions and the kept samples of a sampling planner; zeros by default).

Planners register by name (:data:`PLANNERS`, :func:`register_planner`); a registered
planner's code is part of the program cache key, so editing it recompiles.
"""

from __future__ import annotations

from typing import Any

import jax

from mjx_radar.contracts import placeholder
from mjx_radar.env.records import ControlRecord
from mjx_radar.env.state import Observation
from mjx_radar.planners.records import N_KEEP_SAMPLES, idle_record, kept_samples, record_shape
from mjx_radar.registry import PLANNERS

__all__ = [  # noqa: RUF022 (the contract first)
    "N_KEEP_SAMPLES",
    "PLANNERS",
    "ControlRecord",
    "Observation",
    "Planner",
    "idle_record",
    "kept_samples",
    "make",
    "register_planner",
    "unregister_planner",
]


class Planner:
    """Base class of planners (subclass it and register it, or duck-type the three methods).

    Args:
        env: the environment whose radars it moves (``env.task``: its tables and world,
            ``env.params``, ``env.action_bounds``, ``env.objective``).
    """

    #: the name it is registered under (set by :func:`register_planner`)
    name: str = ""

    def __init__(self, env):
        self.env = env

    @property
    def record_shape(self) -> tuple[int, int]:
        """``(horizon, kept samples)`` of its records (``[mpc] horizon``, ``[mppi] samples``)."""
        return record_shape(self.env.task.mpc, self.env.task.mppi)

    def init(self) -> Any:
        """The planner's initial carry (a pytree; ``()`` if it keeps none)."""
        return ()

    @placeholder  # a subclass defines it (refused at registration otherwise)
    def plan(self, carry, obs: Observation, key) -> tuple[jax.Array, Any]:
        """``(action [N, 2], carry)``: the controls for the next control period."""
        raise NotImplementedError(f"planner {type(self).__name__} has no plan()")

    def record(self, carry, action) -> ControlRecord:
        """What the run files show of the last plan (default: the action alone)."""
        return idle_record(action, *self.record_shape)


def register_planner(name: str, planner=None):
    """Registers a planner class (or factory ``env -> planner``) under ``name``.

    Usable as a decorator. The planner runs from Python (``simulate(..., planner=name)``)
    and the command line (``mjx-radar run SCENARIO --planner name``, with the script that
    registers it given as ``--plugin FILE``). Its code is part of the program cache key.

    Example:
        >>> @register_planner("still")
        ... class Still(Planner):
        ...     def plan(self, carry, obs, key):
        ...         return jnp.zeros((self.env.n_radars, 2)), carry
    """

    def add(obj):
        PLANNERS.register(name, obj)
        if isinstance(obj, type) and not obj.name:
            obj.name = name
        return obj

    return add if planner is None else add(planner)


def unregister_planner(name: str) -> None:
    """Removes a registered planner (built-ins stay)."""
    PLANNERS.unregister(name)


def make(name: str, env):
    """The planner ``name`` made for ``env`` (one-line ``ValueError`` for an unknown name),
    its outputs checked where they are traced (:mod:`mjx_radar.planners.guard`)."""
    from mjx_radar.planners.guard import guarded

    return guarded(name, env)
