"""The closed loop of paper Algorithm 1 (SPEC §8): a planner driving the environment.

A trial is a ``lax.scan`` over control periods of::

    action, planner_carry = planner.plan(planner_carry, state.obs, key_j)
    state, steps = env.transition(state, action)

(:class:`~mjx_radar.env.environment.RadarEnv`, :mod:`mjx_radar.planners`), vmappable
over trials. The planner's key of period j is ``fold_in(planner stream, j)`` of the
trial's streams (:mod:`~mjx_radar.env.streams`), so every method sees the same
truth, placement and noise draws, and the paper's MPPI its own fixed draws. The
runner's compiled programs (:mod:`~mjx_radar.engine.programs`) are
:func:`init_carry` and :func:`advance` of this module.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import jax

from mjx_radar import precision
from mjx_radar.env.environment import RadarEnv
from mjx_radar.env.records import (  # noqa: F401 (re-exported)
    ControlRecord,
    StepRecord,
    TrialResult,
)
from mjx_radar.env.state import State
from mjx_radar.env.streams import streams_of
from mjx_radar.planners import base as planners
from mjx_radar.planners.records import (  # noqa: F401 (re-exported)
    N_KEEP_SAMPLES,
    complete,
    kept_samples,
    record_shape,
)


class LoopCarry(NamedTuple):
    """State of a trial between control periods (a pytree; vmappable)."""

    state: State  # the environment's state
    planner: Any  # the planner's carry


def make_env(task, params, planner: str = "mppi"):
    """``(env, planner)`` of a task, its runtime parameters and a planner name."""
    env = RadarEnv(task, params)
    return env, planners.make(planner, env)


@precision.pinned  # full float32 dots, also on GPUs (mjx_radar.precision)
def init_carry(task, params, trial, planner: str = "mppi") -> tuple[LoopCarry, jax.Array]:
    """Initial loop state of a trial and whether its radars could be placed."""
    env, plan = make_env(task, params, planner)
    state = env.reset(env.trial_key(params.seed, trial))
    return LoopCarry(state, plan.init()), state.info["placement_ok"]


def rollout(env: RadarEnv, planner, carry: LoopCarry, periods: int):
    """Scans ``periods`` control periods of ``planner`` driving ``env`` from ``carry``.

    Returns:
        ``(carry, steps, controls)``: :class:`StepRecord` with leading size
        ``periods * control_every``, :class:`ControlRecord` with leading size ``periods``.
    """

    shape = record_shape(env.task.mpc, env.task.mppi)

    def control_period(lc: LoopCarry, _):
        state = lc.state
        key = jax.random.fold_in(streams_of(state.info["key"]).planner, state.info["period"])
        action, pc = planner.plan(lc.planner, state.obs, key)
        action = env.clip_action(action)  # what the radars apply (and the records show)
        crec = complete(planner.record(pc, action), *shape)  # the run files' layout
        state, srec = env.transition(state, action, keep_nonfinite=True)
        return LoopCarry(state, pc), (srec, crec)

    carry, (srec, crec) = jax.lax.scan(control_period, carry, None, length=periods)
    every = env.every
    srec = jax.tree_util.tree_map(lambda x: x.reshape((periods * every,) + x.shape[2:]), srec)
    return carry, srec, crec


@precision.pinned  # the whole closed loop is traced inside (mjx_radar.precision)
def advance(task, params, carry: LoopCarry, periods: int, planner: str = "mppi"):
    """Advances a trial by ``periods`` control periods (the period index is in the carry).

    Args:
        task: the scenario's task (static).
        params: :class:`~mjx_radar.task.params.TaskParams` (runtime; method included).
        carry: the loop state (:func:`init_carry`, or a previous call's).
        periods: number of control periods (static).
        planner: the planner's registered name (static).

    Returns:
        ``(carry, steps, controls)`` as :func:`rollout`.
    """
    env, plan = make_env(task, params, planner)
    return rollout(env, plan, carry, periods)


def simulate(task, params, trial, steps: int | None = None, planner: str = "mppi"):
    """Runs one closed-loop trial from its start.

    Args:
        task: the scenario's task (static).
        params: runtime parameters (method, numbers, seed).
        trial: trial index (traced int; vmap over it for many trials).
        steps: number of filter steps K (static); default ``task.timing.steps``.
        planner: the planner's registered name (static; default the paper's MPPI).

    Returns:
        :class:`TrialResult` with ``steps`` of leading size K and ``controls`` of
        leading size K / control_every.
    """
    k_total = task.timing.steps if steps is None else steps
    every = task.timing.control_every
    if k_total % every:
        raise ValueError(f"steps: {k_total} must be a multiple of {every}")
    carry, ok = init_carry(task, params, trial, planner)
    _, srec, crec = advance(task, params, carry, k_total // every, planner)
    return TrialResult(srec, crec, ok)
