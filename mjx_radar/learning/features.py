"""What a learned policy sees, does and is paid: observation features, actions, reward.

These three functions are shared by training (:mod:`mjx_radar.learning.brax_env`,
:mod:`mjx_radar.learning.gym_env`) and evaluation (the planner ``policy:DIR``,
:mod:`mjx_radar.learning.policy`), so a policy is run on exactly what it was trained on.

**Observation** (:func:`features`, ``[feature_size(N, M)]``, float32): only what the
radars know (:class:`~mjx_radar.planners.base.Observation`), never the truth, each
feature O(1) for any scene (L = ``placement_half_width``, v̄ = ``limits.speed``):

* per radar ``[x/L, y/L, z/L, cos θ, sin θ, v/v̄, ω/ω̄]`` (7N);
* per target the estimate ``[p/L, v/v̄]`` (6M);
* per radar-target pair the estimated geometry ``[d/L, cos β, sin β]`` with d the
  horizontal range and β the bearing from the radar's heading (3NM);
* per target the covariance block P_m: ``log10 σ_i`` of its 6 standard deviations and
  its 15 correlation coefficients ``ρ_ij = P_ij / (σ_i σ_j)`` (21M);
* per target its presence weight (M) and per pair last scan's detection (NM).

**Action** (:func:`action_to_control`): ``a ∈ [-1, 1]^{2N}`` (a tanh-squashed Gaussian
policy's range) mapped affinely onto each radar's box ``[lower, upper]`` of
``(acceleration, angular acceleration)``: ``u = mid + a · half``.

**Reward** (:func:`penalty` added to the environment's reward): the information the
radars hold, ``-Σ_m log det P_m,pos`` (``RadarEnv.step``), minus the scenario's
non-information cost terms (keep-out of other radars, of the drones, of obstacles and
steep ground, control effort: :func:`mjx_radar.task.costs.cost_terms`) evaluated at the
radars' state after the period, with the drones at their estimated positions.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from mjx_radar.env.inputs import check_action
from mjx_radar.task.costs import Horizon


def feature_size(n: int, m: int) -> int:
    """Length of :func:`features` for N radars and M targets."""
    return 7 * n + 6 * m + 3 * n * m + 21 * m + m + n * m


def features(env, obs) -> jax.Array:
    """``[feature_size]`` float32 features of ``obs`` (module docstring)."""
    m, limits = env.task.n_targets, env.task.fleet.limits
    big_l = jnp.asarray(env.params.placement_half_width, jnp.float32)
    vbar, wbar = jnp.float32(limits.speed), jnp.float32(limits.omega)
    rs = obs.radar_state.astype(jnp.float32)  # [N, 6] x y z θ v ω
    th = rs[:, 3]
    radar = jnp.concatenate(
        [
            rs[:, :3] / big_l,
            jnp.cos(th)[:, None],
            jnp.sin(th)[:, None],
            rs[:, 4:5] / vbar,
            rs[:, 5:6] / wbar,
        ],
        axis=1,
    )
    mean = obs.mean.astype(jnp.float32).reshape(m, 6)
    est = jnp.concatenate([mean[:, :3] / big_l, mean[:, 3:] / vbar], axis=1)
    dxy = mean[None, :, :2] - rs[:, None, :2]  # [N, M, 2]
    d = jnp.sqrt(jnp.sum(dxy**2, -1) + 1e-6)
    bearing = jnp.arctan2(dxy[..., 1], dxy[..., 0]) - th[:, None]
    pairs = jnp.stack([d / big_l, jnp.cos(bearing), jnp.sin(bearing)], -1)  # [N, M, 3]
    cov_f = covariance_features(obs.cov, m)
    return jnp.concatenate(
        [
            radar.reshape(-1),
            est.reshape(-1),
            pairs.reshape(-1),
            cov_f.reshape(-1),
            obs.target_weight.astype(jnp.float32).reshape(-1),
            obs.detections.astype(jnp.float32).reshape(-1),
        ]
    )


def covariance_features(cov, m: int) -> jax.Array:
    """``[M, 21]``: ``log10 σ_i`` of each target's 6 standard deviations and its 15
    correlations ``ρ_ij`` (clipped to [-1, 1]) of the ``[6M, 6M]`` covariance ``cov``."""
    cov = cov.astype(jnp.float32)
    blocks = jnp.stack([cov[6 * i : 6 * i + 6, 6 * i : 6 * i + 6] for i in range(m)])
    var = jnp.maximum(jnp.diagonal(blocks, axis1=1, axis2=2), 1e-12)  # [M, 6]
    sig = jnp.sqrt(var)
    corr = blocks / (sig[:, :, None] * sig[:, None, :])
    iu = np.triu_indices(6, k=1)  # static indices
    return jnp.concatenate([jnp.log10(sig), jnp.clip(corr[:, iu[0], iu[1]], -1, 1)], axis=1)


def action_to_control(env, action) -> jax.Array:
    """``[N, 2]`` controls of a policy action ``[2N]`` in ``[-1, 1]`` (clipped first)."""
    lower, upper = env.action_bounds
    a = jnp.clip(check_action(action, lower.shape[0], "action"), -1.0, 1.0)  # never reshaped
    mid, half = 0.5 * (upper + lower), 0.5 * (upper - lower)
    return mid + a * half.astype(mid.dtype)


def control_to_action(env, control) -> jax.Array:
    """The inverse of :func:`action_to_control`: ``[2N]`` in ``[-1, 1]`` of ``[N, 2]``."""
    lower, upper = env.action_bounds
    u = jnp.clip(jnp.reshape(control, lower.shape), lower, upper)
    return ((2.0 * u - (upper + lower)) / (upper - lower)).reshape(-1)


def penalty(env, obs_before, obs_after, control) -> jax.Array:
    """``[]`` the non-information cost terms at the radars' state after a period.

    Args:
        env: the :class:`~mjx_radar.env.environment.RadarEnv`.
        obs_before: the observation the action was chosen from (its time sets the
            presence weights and the moving obstacles' poses one period later, as the
            planner's first horizon step).
        obs_after: the observation after the period (radar states, target estimates).
        control: ``[N, 2]`` the applied control.
    """
    task = env.task
    terms = [t for t in task.terms if t.name != "information"]  # the planner's own terms
    if not terms:
        return jnp.zeros((), jnp.float32)
    params = env.planning_params(obs_before)
    m = task.n_targets
    h = Horizon(
        controls=jnp.reshape(control, (1, task.fleet.n_radars, 2)),
        radar=obs_after.radar_state[None],
        target_points=obs_after.mean.reshape(1, 1, m, 6),
        info0=jnp.zeros((m, 6, 6), obs_after.mean.dtype),
    )
    return sum(t.fn(h, task, params)[0] for t in terms).astype(jnp.float32)


def keepout_depth(env, obs) -> jax.Array:
    """``[]`` the graded radar-drone keep-out (training's reward shaping, ``keepout_grade``).

    ``α_r2t Σ_{n,m} w_m (1 - d_nm / R2T)_+``, with ``d_nm`` the 3-D distance from radar
    n to the estimate of target m and ``w_m`` its presence weight: 0 at the keep-out's
    edge, growing with the depth inside it (``α_r2t`` per pair at zero distance). Unlike
    the MPC's step term (``α_r2t`` for any pair inside), it tells a policy how deep it is.
    """
    m, p = env.n_targets, env.params
    pos = obs.mean.astype(jnp.float32).reshape(m, 6)[:, :3]
    gap = obs.radar_state[:, None, :3].astype(jnp.float32) - pos[None]  # [N, M, 3]
    d = jnp.sqrt(jnp.sum(gap**2, -1))
    depth = jnp.maximum(0.0, 1.0 - d / p.r2t.astype(jnp.float32))
    weight = obs.target_weight.astype(jnp.float32)
    return p.alpha_r2t.astype(jnp.float32) * jnp.sum(depth * weight[None, :])
