"""The radar-placement MPC objective (SPEC §6). Knows nothing of sampling.

For one candidate control sequence ``u[H, N, 2]`` of all radars::

    S = -sum_t g^t E_p[ sum_m log det J_m(t) ]
        + a1 sum_t g^t #{radar pairs closer than R2R}
        + a2 sum_t g^t E_p[ #{radar-target pairs closer than R2T} ]

with t = 0..H-1 indexing the radar state after control t+1, and the
expectation E_p over the CKF cubature points of the target state propagated
through the CV transition to the same time (:func:`ckf.horizon_points`).
``J_m`` is the SFIM (DDR or CCR variant, SPEC §5) or the PFIM recursion started
from the current filter information of target m (the inverse of its marginal
covariance block) with the horizon's SFIM expectation as data term.

With obstacles (docs/obstacles.md) two optional parts:

* obstacle cost ``+ a_obs sum_t g^t sum_n relu(margin - phi(p_n(t)))``, phi the
  footprints' signed distance (:func:`obstacles.sdf`), i.e. metres of intrusion
  into the keep-out band of width ``mpc.obs_margin`` around every footprint,
  weighted by ``mpc.alpha_obs`` (on whenever the scenario has obstacles);
* ``mpc.los``: a pair whose segment from the radar to the target's predicted
  mean (the centroid of the cubature points at that step) is blocked contributes
  no information (one visibility test per pair and step, shared by the points).

The rollouts themselves ignore obstacles (contact-free planner plant).
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp

from mjx_radar.config import METHODS, Scenario
from mjx_radar.estimation import fisher, linalg
from mjx_radar.estimation.sensing import ccr_variance, noise_constant
from mjx_radar.physics import kinematics, motion
from mjx_radar.physics import plant as physics
from mjx_radar.world import obstacles, occlusion


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
    """Per-sample auxiliary output of the objective (for plots and video)."""

    radar_xy: jax.Array  # [H, N, 2] planned radar positions
    info: jax.Array  # [] discounted expected log det term (without sign)


def parse_method(method: str) -> tuple[str, str]:
    """``"ddr-pfim"`` -> ``("ddr", "pfim")``. ``"stationary"`` -> ``("ddr", "none")``."""
    if method not in METHODS:
        raise ValueError(f"method: {method!r} is not one of {', '.join(METHODS)}")
    if method == "stationary":
        return "ddr", "none"
    model, info = method.split("-")
    return model, info


def plan_context(scenario: Scenario, radar_state, mean, cov) -> PlanContext:
    """Builds the :class:`PlanContext` from the predicted CKF estimate.

    Args:
        scenario: the scenario (horizon, control step, number of targets).
        radar_state: [N, 6] radar states.
        mean: [6M] predicted stacked target mean.
        cov: [6M, 6M] predicted covariance.
    """
    from mjx_radar.estimation import ckf

    m = scenario.n_targets
    a = motion.cv_transition(scenario.timing.dt_control, m, dtype=mean.dtype)
    pts = ckf.horizon_points(mean, cov, lambda x: a @ x, scenario.mpc.horizon)
    blocks = jnp.stack([cov[6 * i : 6 * i + 6, 6 * i : 6 * i + 6] for i in range(m)])
    return PlanContext(
        radar_state=radar_state,
        target_points=pts.reshape(pts.shape[0], pts.shape[1], m, 6),
        info0=linalg.psd_inv(blocks),
    )


def _pair_count_below(dist: jax.Array, threshold: float) -> jax.Array:
    return jnp.sum((dist < threshold).astype(dist.dtype))


def _obstacle_cost(scenario: Scenario):
    """``xy[H, N, 2] -> [H]``: ``a_obs sum_n relu(margin - phi(xy_n))``, or None."""
    mpc = scenario.mpc
    if not scenario.obstacles or mpc.alpha_obs <= 0:
        return None
    grid = obstacles.sdf_grid(
        scenario.obstacles, scenario.placement_half_width, max(64.0, 4.0 * mpc.obs_margin)
    )

    def cost(xy):
        depth = jax.nn.relu(mpc.obs_margin - obstacles.sdf(grid, xy))
        return mpc.alpha_obs * jnp.sum(depth, axis=-1)

    return cost


def make_objective(scenario: Scenario, method: str):
    """Returns ``cost(u[H, N*2], ctx) -> (cost, Plan)`` for one control sequence."""
    model, info_kind = parse_method(method)
    if info_kind == "none":
        raise ValueError("method: 'stationary' has no planning objective")
    mpc, n, m = scenario.mpc, scenario.n_radars, scenario.n_targets
    c = noise_constant(scenario.radar_eq, m)
    sigma_r2 = ccr_variance(c, mpc.r2t)
    h = mpc.horizon
    disc = mpc.gamma ** jnp.arange(h)
    a6 = motion.cv_transition(scenario.timing.dt_control, 1)
    w6 = motion.cv_process_noise(scenario.timing.dt_control, scenario.sigma_w2, 1)
    triu = jnp.triu_indices(n, k=1)

    weight = fisher.ddr_weight(c) if model == "ddr" else fisher.ccr_weight(sigma_r2)
    obstacle_cost = _obstacle_cost(scenario)
    occ = occlusion.occluders(scenario.obstacles) if scenario.obstacles and mpc.los else None

    if mpc.rollout == "mjx":
        plant = physics.planner_plant(scenario)

        def rollout(state, u):
            return physics.radar_rollout(plant, state, u)
    else:

        def rollout(state, u):
            return kinematics.unicycle_rollout(
                state, u, scenario.timing.dt_control, scenario.limits
            )

    def cost(u_flat, ctx: PlanContext):
        traj = rollout(ctx.radar_state, u_flat.reshape(h, n, 2))  # [H, N, 6]
        radar_pos = traj[..., :3]
        tgt_pos = ctx.target_points[..., :3]  # [H, P, M, 3]
        # SFIM at every horizon step and cubature point, packed: [H, P, M, 6]
        vis = None  # [H, 1, N, M] line of sight to the predicted target means
        if occ is not None:
            vis = occlusion.line_of_sight(occ, radar_pos, tgt_pos.mean(1))[:, None]
        j3 = fisher.sfim_packed(radar_pos[:, None], tgt_pos, weight, mask=vis)
        if info_kind == "sfim":
            ld = fisher.logdet_packed(j3).sum(-1).mean(-1)  # [H]
        else:
            jd = fisher.data_information(fisher.unpack_sym3(j3.mean(1)))  # [H, M, 6, 6]

            def rec(jm, jdt):  # jm [M,6,6]
                jm = jax.vmap(fisher.pfim_step, (0, None, None, 0))(jm, a6, w6, jdt)
                return jm, jm

            _, jseq = jax.lax.scan(rec, ctx.info0, jd)
            ld = fisher.logdet(jseq).sum(-1)  # [H]
        info = jnp.sum(disc * ld)
        # Radar-radar pairs closer than R2R: [H]
        drr = jnp.linalg.norm(radar_pos[:, :, None] - radar_pos[:, None], axis=-1)
        n_rr = jax.vmap(lambda d: _pair_count_below(d[triu], mpc.r2r))(drr)
        # Radar-target pairs closer than R2T, expected over cubature points: [H]
        drt = jnp.linalg.norm(radar_pos[:, None, :, None] - tgt_pos[:, :, None], axis=-1)
        n_rt = jnp.mean(jnp.sum(drt < mpc.r2t, axis=(-1, -2)), axis=-1).astype(info.dtype)
        total = -info + mpc.alpha_r2r * jnp.sum(disc * n_rr) + mpc.alpha_r2t * jnp.sum(disc * n_rt)
        if obstacle_cost is not None:
            total = total + jnp.sum(disc * obstacle_cost(radar_pos[..., :2]))
        return total, Plan(radar_xy=radar_pos[..., :2], info=info)

    return cost
