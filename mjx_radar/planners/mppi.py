"""The paper's planner behind the planner contract: MPPI over the information objective.

Wraps :func:`mjx_radar.task.planner.make_planner` (the MPC step the benchmarks time):
the carry is the warm start ``u_plan [H, 2N]`` (the previous mean sequence shifted by
one control step) and the last :class:`~mjx_radar.env.records.ControlRecord` (planned
positions, kept samples, weights, costs). What is compiled follows the task's program
kind: nothing for ``"none"`` (the radars keep still), one information kind, or both
behind ``lax.cond`` on the method's runtime flags (``"all"``); ``"sfim+none"`` /
``"pfim+none"`` plan or hold by the flag ``plans``; ``"sfim+pfim+none"`` switches
between holding and each information's whole planner (a study's shared programs).
"""

from __future__ import annotations

import dataclasses
from typing import NamedTuple

import jax
import jax.numpy as jnp

from mjx_radar.control import mppi
from mjx_radar.env.records import ControlRecord
from mjx_radar.planners.base import Planner
from mjx_radar.planners.records import idle_record, plan_record
from mjx_radar.task.method import SWITCH, plans_optional
from mjx_radar.task.planner import make_planner


class MPPICarry(NamedTuple):
    u_plan: jax.Array  # [H, 2N] warm start of the next call
    record: ControlRecord  # the last call's record


class MPPIPlanner(Planner):
    """MPPI with adaptive importance sampling (SPEC §7) on ``env.task``'s objective."""

    name = "mppi"

    def __init__(self, env):
        super().__init__(env)
        self.task = env.task
        kind = env.task.kind
        self._optimize = make_planner(env.task) if kind not in ("none", SWITCH) else None
        # a study's one program per shape: each information's whole planner in a branch
        self._per_info = (
            {i: make_planner(dataclasses.replace(env.task, kind=i)) for i in ("sfim", "pfim")}
            if kind == SWITCH
            else None
        )

    def init(self) -> MPPICarry:
        n = self.env.n_radars
        u_plan = jnp.zeros((self.task.mpc.horizon, 2 * n))
        return MPPICarry(u_plan, idle_record(jnp.zeros((n, 2)), *self.record_shape))

    def _idle(self, carry: MPPICarry):
        zeros = jnp.zeros((self.env.n_radars, 2))
        return zeros, MPPICarry(carry.u_plan, idle_record(zeros, *self.record_shape))

    def _mppi(self, carry: MPPICarry, obs, key, optimize=None):
        params = self.env.planning_params(obs)  # presence weights, vehicles' time
        res, mean_plan = (optimize or self._optimize)(
            obs.radar_state, obs.mean, obs.cov, carry.u_plan, key, params
        )
        keep = slice(0, self.record_shape[1])
        rec = plan_record(
            res.mean[0].reshape(self.env.n_radars, 2),
            mean_plan.radar_xy,
            res.aux.radar_xy[keep],
            res.weights[keep],
            res.costs[keep],
        )
        return rec.control, MPPICarry(mppi.shift(res.mean), rec)

    def plan(self, carry: MPPICarry, obs, key):
        kind = self.task.kind
        if kind == "none":  # stationary program: no planner compiled
            return self._idle(carry)
        if kind == SWITCH:  # hold, or plan with the method's information
            flags = self.env.params.method
            branch = flags.plans.astype(jnp.int32) * (1 + flags.pfim.astype(jnp.int32))
            sfim, pfim = self._per_info["sfim"], self._per_info["pfim"]
            return jax.lax.switch(
                branch,
                [
                    lambda: self._idle(carry),
                    lambda: self._mppi(carry, obs, key, sfim),
                    lambda: self._mppi(carry, obs, key, pfim),
                ],
            )
        if not plans_optional(kind):  # one information kind: always plans
            return self._mppi(carry, obs, key)
        return jax.lax.cond(
            self.env.params.method.plans,
            lambda: self._mppi(carry, obs, key),
            lambda: self._idle(carry),
        )

    def record(self, carry: MPPICarry, action) -> ControlRecord:
        return carry.record


class HoldPlanner(Planner):
    """Radars keep still: zero acceleration (the ``stationary`` method's planner)."""

    name = "hold"

    def plan(self, carry, obs, key):
        return jnp.zeros((self.env.n_radars, 2)), carry
