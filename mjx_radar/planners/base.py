"""The planner contract: what a planner sees, what it returns, and how it is found by name.

A planner moves the radars of one environment (:class:`mjx_radar.env.RadarEnv`), like
hydrax's controllers and brax's policies. It is made once per environment and is then
pure (jit-able, vmap-able over trials)::

    planner = PLANNERS.get("mppi")(env)      # static settings, read from env.scenario
    carry = planner.init()                   # its state: a warm start, filters, ...
    action, carry = planner.plan(carry, obs, key)   # action [N, 2]: [a, alpha] per radar

``obs`` is an :class:`Observation`: what the radars know (their own states, the track
estimate and its covariance, the last scan's detections), never the truth. The
environment clips actions to ``env.action_bounds``; a planner that scores candidate
sequences with the method's information objective calls ``env.objective(obs)``.
``record(carry, action)`` says what the run files show of the plan (the planned
positions and the kept samples of a sampling planner; zeros by default).

Planners register by name (:data:`PLANNERS`, :func:`register_planner`); a registered
planner's code is part of the program cache key, so editing it recompiles.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import jax
import jax.numpy as jnp

from mjx_radar.contracts import placeholder
from mjx_radar.registry import PLANNERS


class Observation(NamedTuple):
    """What the radars know at a control instant (a pytree of arrays).

    Attributes:
        radar_state: ``[N, 6]`` the radars' own states ``[x, y, z, θ, v, ω]``.
        mean: ``[6M]`` the track estimate to plan from: at the radars' instant
            (``mpc.aligned``) or, as in the paper's code, predicted one filter step ahead.
        cov: ``[6M, 6M]`` its covariance P.
        target_weight: ``[M]`` 1 for targets present at this instant, else 0.
        detections: ``[N, M]`` bool, the pairs detected at the last scan (line of sight
            and detection; all False before the first scan).
        time: ``[]`` the control instant [s].
        period: ``[]`` int32, the control period index j (time = j * dt_control).
        nonfinite_action: ``[]`` bool, the last period's action held NaN or inf (inside
            ``jit`` each such control is applied as 0; outside it ``step`` refuses it);
            None in an observation made by hand.
    """

    radar_state: jax.Array
    mean: jax.Array
    cov: jax.Array
    target_weight: jax.Array
    detections: jax.Array
    time: jax.Array
    period: jax.Array
    nonfinite_action: jax.Array | None = None


class ControlRecord(NamedTuple):
    """What a control step records (leading axis: control steps, after a scan)."""

    control: jax.Array  # [N, 2] applied control
    plan_xy: jax.Array  # [H, N, 2] planned radar positions of the mean sequence
    sample_xy: jax.Array  # [S_keep, H, N, 2] sampled radar trajectories
    sample_weight: jax.Array  # [S_keep] their weights
    sample_cost: jax.Array  # [S_keep] their costs


N_KEEP_SAMPLES = 32  # sampled sequences kept per control step for plots and video (at most)


def kept_samples(scenario) -> int:
    """Samples recorded per control step: ``min(32, mppi.samples)``."""
    return min(N_KEEP_SAMPLES, scenario.mppi.samples)


def idle_record(scenario, control) -> ControlRecord:
    """The record of a control step without a plan to show (``control`` [N, 2])."""
    n, h, s = scenario.n_radars, scenario.mpc.horizon, kept_samples(scenario)
    return ControlRecord(
        control,
        jnp.zeros((h, n, 2)),
        jnp.zeros((s, h, n, 2)),
        jnp.zeros(s),
        jnp.zeros(s),
    )


class Planner:
    """Base class of planners (subclass it and register it, or duck-type the three methods).

    Args:
        env: the environment whose radars it moves (``env.scenario``, ``env.task``,
            ``env.params``, ``env.action_bounds``, ``env.objective``).
    """

    #: the name it is registered under (set by :func:`register_planner`)
    name: str = ""

    def __init__(self, env):
        self.env = env

    def init(self) -> Any:
        """The planner's initial carry (a pytree; ``()`` if it keeps none)."""
        return ()

    @placeholder  # a subclass defines it (refused at registration otherwise)
    def plan(self, carry, obs: Observation, key) -> tuple[jax.Array, Any]:
        """``(action [N, 2], carry)``: the controls for the next control period."""
        raise NotImplementedError(f"planner {type(self).__name__} has no plan()")

    def record(self, carry, action) -> ControlRecord:
        """What the run files show of the last plan (default: the action alone)."""
        return idle_record(self.env.scenario, action)


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
