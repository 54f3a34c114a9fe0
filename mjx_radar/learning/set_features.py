"""What a fleet-size-agnostic policy sees: the observation as sets of radars, targets and
radar-target pairs (:class:`SetObs`), with masks for padding.

The flat features (:func:`mjx_radar.learning.features.features`) fix the numbers of
radars N and targets M; these keep each entity's features on its own row, so a network
that shares its encoders across rows and pools over them
(:mod:`mjx_radar.learning.set_net`) applies to any N and M, and to batches of several
fleet sizes padded to one shape (:func:`pad`, the masks mark the real rows). With
L = ``placement_half_width``, v̄, ω̄ the speed and turn-rate limits and R2T the
radar-drone keep-out radius:

* ``radar [N, 7]``: ``x/L, y/L, z/L, cos θ, sin θ, v/v̄, ω/ω̄``;
* ``target [M, 28]``: the estimate ``p/L, v/v̄`` (6), its covariance block as
  ``log10 σ_i`` and correlations (21, :func:`~mjx_radar.learning.features.covariance_features`),
  its presence weight (1);
* ``pair [N, M, 6]``: horizontal range ``d/L``, ``cos β, sin β`` (β the bearing from the
  radar's heading), height difference ``dz/L``, ``d₃/R2T - 1`` (0 on the keep-out's
  edge, negative inside) and last scan's detection (0 or 1);
* ``radar_mask [N]``, ``target_mask [M]``: 1 for real rows, 0 for padding.

``version="v2"`` (``DistillConfig(features="v2")``; off by default) adds what the keep-out
and the ground need, each computable from the observation and the map alone:

* radar ``+3``: the ground's gradient ``∂h/∂x, ∂h/∂y`` under the radar (rise over run)
  and its grade over the vehicles' limit ``|∇h| / tan(max_slope)`` (zeros without
  terrain);
* pair ``+4``: the closing rate ``ḋ₃ / v̄ = (q - p)·(q̇ - ṗ) / (d₃ v̄)`` (negative:
  closing), the keep-out margin ahead ``d₃(τ) / R2T - 1`` with both moving at constant
  velocity for the MPC's horizon ``τ = H·T``, a flag marking the radar's nearest present
  drone (``d₃`` smallest; the keep-out is a minimum over drones, which mean and max
  pooling of the other features do not single out), and the line of sight from the
  radar to the estimate (1 clear, 0 blocked by the ground or obstacles, as the
  detection model's :func:`~mjx_radar.world.occlusion.line_of_sight`).
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp

from mjx_radar.learning.features import covariance_features

RADAR_SIZE, TARGET_SIZE, PAIR_SIZE = 7, 28, 6
#: feature versions: (radar, target, pair) sizes
SIZES = {"v1": (7, 28, 6), "v2": (10, 28, 10)}


class SetObs(NamedTuple):
    """One observation as sets (module docstring); leading batch axes allowed."""

    radar: jax.Array  # [N, 7]
    target: jax.Array  # [M, 28]
    pair: jax.Array  # [N, M, 6]
    radar_mask: jax.Array  # [N] 1: a real radar
    target_mask: jax.Array  # [M] 1: a real target


def set_features(env, obs, version: str = "v1") -> SetObs:
    """The :class:`SetObs` of an :class:`~mjx_radar.planners.base.Observation`.

    Args:
        env: the :class:`~mjx_radar.env.environment.RadarEnv` (scales, keep-out radius).
        obs: what the radars know (``radar_state [N, 6]``, ``mean [6M]``, ``cov [6M, 6M]``,
            ``target_weight [M]``, ``detections [N, M]``).
        version: ``"v1"`` or ``"v2"`` (module docstring; sizes :data:`SIZES`).

    Returns:
        float32 sets, every feature O(1); NaN and inf replaced and clipped to ±1000.
    """
    limits = env.task.fleet.limits
    m = obs.mean.shape[0] // 6
    big_l = jnp.asarray(env.params.placement_half_width, jnp.float32)
    r2t = jnp.asarray(env.params.r2t, jnp.float32)
    vbar, wbar = jnp.float32(limits.speed), jnp.float32(limits.omega)
    rs = obs.radar_state.astype(jnp.float32)  # [N, 6] x y z θ v ω
    th = rs[:, 3]
    radar = jnp.concatenate(
        [rs[:, :3] / big_l, jnp.cos(th)[:, None], jnp.sin(th)[:, None]]
        + [rs[:, 4:5] / vbar, rs[:, 5:6] / wbar],
        axis=1,
    )
    mean = obs.mean.astype(jnp.float32).reshape(m, 6)
    weight = obs.target_weight.astype(jnp.float32).reshape(m, 1)
    target = jnp.concatenate(
        [mean[:, :3] / big_l, mean[:, 3:] / vbar, covariance_features(obs.cov, m), weight], 1
    )
    gap = mean[None, :, :3] - rs[:, None, :3]  # [N, M, 3]
    d = jnp.sqrt(jnp.sum(gap[..., :2] ** 2, -1) + 1e-6)
    d3 = jnp.sqrt(jnp.sum(gap**2, -1) + 1e-6)
    bearing = jnp.arctan2(gap[..., 1], gap[..., 0]) - th[:, None]
    pair = jnp.stack(
        [d / big_l, jnp.cos(bearing), jnp.sin(bearing), gap[..., 2] / big_l, d3 / r2t - 1.0]
        + [obs.detections.astype(jnp.float32)],
        -1,
    )
    if version == "v2":
        radar = jnp.concatenate([radar, _ground(env, rs)], 1)
        pair = jnp.concatenate([pair, _keepout(env, rs, mean, weight[:, 0], gap, d3)], -1)
    n = rs.shape[0]
    out = SetObs(radar, target, pair, jnp.ones(n, jnp.float32), jnp.ones(m, jnp.float32))
    return jax.tree.map(lambda x: jnp.clip(jnp.nan_to_num(x, nan=0.0), -1e3, 1e3), out)


def _ground(env, rs) -> jax.Array:
    """``[N, 3]`` the ground's gradient under each radar and its grade over the limit."""
    ground = env.task.world.ground
    if not ground.present:
        return jnp.zeros((rs.shape[0], 3), jnp.float32)
    from mjx_radar.world import terrain

    t = ground.config
    g = terrain.gradient(ground.grid, rs[:, :2]).astype(jnp.float32)
    limit = jnp.tan(jnp.deg2rad(jnp.float32(min(t.max_slope_deg, 89.0))))
    grade = jnp.sqrt(jnp.sum(g * g, -1, keepdims=True))
    return jnp.concatenate([g, grade / limit], 1)


def _keepout(env, rs, mean, weight, gap, d3) -> jax.Array:
    """``[N, M, 4]``: closing rate, margin ahead, nearest-drone flag, line of sight."""
    task = env.task
    r2t, vbar = jnp.asarray(env.params.r2t, jnp.float32), jnp.float32(task.fleet.limits.speed)
    th, v = rs[:, 3], rs[:, 4]
    vr = jnp.stack([v * jnp.cos(th), v * jnp.sin(th), jnp.zeros_like(v)], -1)  # [N, 3]
    dv = mean[None, :, 3:] - vr[:, None]  # [N, M, 3]
    rate = jnp.sum(gap * dv, -1) / (d3 * vbar)
    tau = jnp.float32(task.mpc.horizon * task.timing.dt_control)
    ahead = jnp.sqrt(jnp.sum((gap + tau * dv) ** 2, -1) + 1e-6) / r2t - 1.0
    present = (weight > 0)[None, :]
    far = jnp.where(present, d3, jnp.inf)
    nearest = (far <= jnp.min(far, 1, keepdims=True)) & present
    occ = task.world.occluders
    if occ is None:
        los = jnp.ones_like(d3)
    else:
        from mjx_radar.world.occlusion import line_of_sight

        los = line_of_sight(occ, rs[:, :3], mean[:, :3]).astype(jnp.float32)
    return jnp.stack([rate, ahead, nearest.astype(jnp.float32), los], -1)


def pad(x: SetObs, n: int, m: int) -> SetObs:
    """``x`` (one observation) padded with zero rows to ``n`` radars and ``m`` targets."""
    dn, dm = n - x.radar.shape[0], m - x.target.shape[0]
    if dn < 0 or dm < 0:
        raise ValueError(f"pad: {x.radar.shape[0]} radars, {x.target.shape[0]} targets > {n}, {m}")
    return SetObs(
        jnp.pad(x.radar, ((0, dn), (0, 0))),
        jnp.pad(x.target, ((0, dm), (0, 0))),
        jnp.pad(x.pair, ((0, dn), (0, dm), (0, 0))),
        jnp.pad(x.radar_mask, (0, dn)),
        jnp.pad(x.target_mask, (0, dm)),
    )


def flat_size(n: int, m: int, version: str = "v1") -> int:
    """Length of :func:`flatten` for N radars and M targets."""
    rs, ts, ps = SIZES[version]
    return n * rs + m * ts + n * m * ps + n + m


def flatten(x: SetObs) -> jax.Array:
    """``[flat_size(N, M)]``: one observation's sets as one vector (brax's observation)."""
    return jnp.concatenate([jnp.reshape(v, (-1,)) for v in x])


def unflatten(flat: jax.Array, n: int, m: int, version: str = "v1") -> SetObs:
    """The inverse of :func:`flatten` (leading batch axes kept)."""
    lead = flat.shape[:-1]
    rs, ts, ps = SIZES[version]
    sizes = [n * rs, m * ts, n * m * ps, n, m]
    shapes = [(n, rs), (m, ts), (n, m, ps), (n,), (m,)]
    parts, start = [], 0
    for size, shape in zip(sizes, shapes, strict=True):
        parts.append(flat[..., start : start + size].reshape(lead + shape))
        start += size
    return SetObs(*parts)
