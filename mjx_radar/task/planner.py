"""One MPC control step for the radars: the radar objective optimised by MPPI.

Joins the task (:mod:`mjx_radar.task.objective`) and the task-agnostic optimiser
(:mod:`mjx_radar.control.mppi`): builds the planning context from the CKF estimate,
turns the scenario's proposal std (``a`` in m/s², ``alpha`` in deg/s²) and control
limits into per-dimension arrays over the N radars' flattened controls ``[H, 2N]``,
and runs :func:`mppi.optimize`. Used by the closed loop and by the benchmarks, so
both time and run the same step.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import jax
import jax.numpy as jnp

from mjx_radar import precision
from mjx_radar.control import mppi
from mjx_radar.physics import kinematics
from mjx_radar.scenario.schema import MPPIConfig, RadarLimits
from mjx_radar.task import objective


@dataclasses.dataclass(frozen=True)
class Fleet:
    """The radars as the planner and the environment see them.

    Attributes:
        n_radars: N.
        limits: the fleet's :class:`~mjx_radar.scenario.schema.RadarLimits`.
        bounds: a mixed fleet's per-radar ``(|a| [N], |alpha| [N])`` bounds, 0 for its
            fixed sites (``[[radar_override]]``, :func:`mjx_radar.scenario.fleet.control_bounds`),
            or None (every radar has ``limits``).
        fixed_starts: whether the scenario fixes where the radars start (``radars =
            [...]``; the numbers are the runtime ``params.radar_init``), else they are
            placed at random (:mod:`mjx_radar.env.placement`).
    """

    n_radars: int
    limits: RadarLimits
    bounds: tuple[tuple[float, ...], tuple[float, ...]] | None = None
    fixed_starts: bool = False


def control_box(fleet: Fleet) -> tuple[jax.Array, jax.Array]:
    """Lower and upper bounds ``[2N]`` of the radars' flattened controls ``[a0, α0, a1, ...]``.

    ``|a| <= limits.accel``, ``|α| <= limits.alpha``; a mixed fleet's per-radar limits,
    and 0 for its fixed sites (``[[radar_override]]``).
    """
    lower, upper = kinematics.control_bounds(fleet.limits)
    lower, upper = jnp.tile(lower, fleet.n_radars), jnp.tile(upper, fleet.n_radars)
    if fleet.bounds is not None:  # a mixed fleet: per-radar bounds, fixed sites bound to 0
        upper = jnp.asarray(fleet.bounds, lower.dtype).T.reshape(-1)
        lower = -upper
    return lower, upper


def proposal_std(mppi: MPPIConfig, upper: jax.Array) -> jax.Array:
    """``[2N]`` sampling std ``[std_accel, std_alpha, ...]`` (rad/s²) of the ``[mppi]``
    table, 0 where ``upper`` ``[2N]`` is 0 (the fixed sites of a mixed fleet never move)."""
    std = jnp.array([mppi.std_accel, jnp.deg2rad(mppi.std_alpha_deg)])
    return jnp.where(upper > 0, jnp.tile(std, upper.shape[0] // 2), 0.0)


def make_planner(task) -> Callable:
    """Returns ``plan(radar_state[N,6], mean[6M], cov[6M,6M], u_plan[H,2N], key, params)``.

    ``plan`` gives ``(result, mean_plan)``: the :class:`mppi.MPPIResult` over the
    flattened controls ``[H, 2N]`` (apply ``result.mean[0]``, warm-start the next
    step with ``mppi.shift(result.mean)``) and the :class:`objective.Plan` of the
    optimised mean sequence. ``mean``/``cov`` are the estimate at the time of
    ``radar_state``. Jittable; ``task`` is static, ``params`` a runtime pytree.
    Dots are traced at :data:`mjx_radar.precision.ESTIMATION`, the MPPI sampling at
    :data:`~mjx_radar.precision.PLANNER`.
    """
    cost_fn = objective.make_objective(task)
    lower, upper = control_box(task.fleet)
    init_std = proposal_std(task.mppi, upper)

    @precision.pinned
    def plan(radar_state: jax.Array, mean: jax.Array, cov: jax.Array, u_plan, key, params):
        ctx = objective.plan_context(task, radar_state, mean, cov)
        with precision.scope("planner"):  # MPPI sampling and refit; the cost re-pins
            res = mppi.optimize(
                lambda u: cost_fn(u, ctx, params), u_plan, key, task.mppi, init_std, lower, upper
            )
        return res, cost_fn(res.mean, ctx, params)[1]

    return plan
