"""The radar-placement MPC objective (SPEC §6): the discounted sum of the cost terms.

For one candidate control sequence ``u[H, N, 2]`` of all radars::

    S(u) = Σ_terms Σ_{t=0}^{H-1} γ^t term_t(u)

with the terms of :mod:`mjx_radar.task.costs` (information, radar-radar and
radar-target keep-out, obstacle intrusion). The objective knows nothing of sampling;
:class:`Plan` reports every term's discounted value so users can see what drives a
decision. The rollouts ignore obstacles (contact-free planner plant).
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp

from mjx_radar import precision
from mjx_radar.estimation import linalg
from mjx_radar.estimation.filters import ckf
from mjx_radar.task.costs import Horizon


class PlanContext(NamedTuple):
    """What the objective needs at one control step (traced arrays).

    Attributes:
        radar_state: [N, 6] current radar states.
        target_points: [H, P, M, 6] cubature points of the target states at each
            horizon step (P = 2 * 6M points).
        info0: [M, 6, 6] current information (inverse marginal covariance) per target.
    """

    radar_state: jax.Array
    target_points: jax.Array
    info0: jax.Array


class Plan(NamedTuple):
    """Per-sample auxiliary output of the objective (for plots, video and diagnosis).

    Attributes:
        radar_xy: [H, N, 2] planned radar positions.
        terms: ``{term name: []}`` discounted value of every cost term (their sum is
            the cost; ``-terms["information"]`` is the discounted expected log det).
    """

    radar_xy: jax.Array
    terms: dict


@precision.pinned
def plan_context(task, radar_state, mean, cov) -> PlanContext:
    """Builds the :class:`PlanContext` from the CKF estimate at the planning time.

    Args:
        task: the :class:`~mjx_radar.task.task.RadarTask`.
        radar_state: [N, 6] radar states.
        mean: [6M] stacked target mean at the same instant as ``radar_state`` (M the
            tracks planned for: the drones, or a track table's slots).
        cov: [6M, 6M] its covariance.
    """
    m, h = mean.shape[0] // 6, task.mpc.horizon
    blocks = jnp.stack([cov[6 * i : 6 * i + 6, 6 * i : 6 * i + 6] for i in range(m)])
    if task.filter.structure == "per-target":
        # Independent targets: 12 cubature points per target, point i of every target
        # in configuration i (each target's expectation is over its own points).
        a6 = task.a6.astype(mean.dtype)
        pts = jax.vmap(lambda x, p: ckf.horizon_points(x, p, lambda v: a6 @ v, h), (0, 0), 2)(
            mean.reshape(m, 6), blocks
        )  # [H, 12, M, 6]
    else:
        a = task.a_control.astype(mean.dtype)
        pts = ckf.horizon_points(mean, cov, lambda x: a @ x, h)
        pts = pts.reshape(pts.shape[0], pts.shape[1], m, 6)
    return PlanContext(radar_state=radar_state, target_points=pts, info0=linalg.psd_inv(blocks))


def make_objective(task):
    """Returns ``cost(u[H, N*2], ctx, params) -> (cost[], Plan)`` for one sequence.

    Its dots are traced at :data:`mjx_radar.precision.ESTIMATION`, the rollout's at
    :data:`~mjx_radar.precision.PLANNER`. One jitted function per task (kept on it):
    traced once per program it is used in, and compiled once when called eagerly.
    """
    cost = task.__dict__.get("_objective")
    if cost is None:
        cost = _objective(task)
        object.__setattr__(task, "_objective", cost)  # a frozen dataclass: not a field
    return cost


def _objective(task):
    h, n = task.mpc.horizon, task.fleet.n_radars

    @precision.pinned  # cubature expectations in full float32 (mjx_radar.precision)
    def cost(u_flat, ctx: PlanContext, params):
        u = u_flat.reshape(h, n, 2)
        with precision.scope("planner"):
            traj = task.rollout(ctx.radar_state, u)  # [H, N, 6]
        hz = Horizon(u, traj, ctx.target_points, ctx.info0)
        disc = params.gamma ** jnp.arange(h, dtype=traj.dtype)
        terms = {t.name: jnp.sum(disc * t.fn(hz, task, params)) for t in task.terms}
        total = sum(terms.values())
        return total, Plan(radar_xy=traj[..., :2], terms=terms)

    # Traced once per program, inlined where it is called: MPPI calls it three times (the
    # aux shape, the vmapped samples, the plan of the mean); the later calls reuse the
    # cached jaxpr (vmap batches it, no Python). The same operations reach XLA, so the
    # same numbers (docs/notes/scaling-history.md, "Tracing the objective once").
    return jax.jit(cost, inline=True)
