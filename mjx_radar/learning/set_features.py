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
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp

from mjx_radar.learning.features import covariance_features

RADAR_SIZE, TARGET_SIZE, PAIR_SIZE = 7, 28, 6


class SetObs(NamedTuple):
    """One observation as sets (module docstring); leading batch axes allowed."""

    radar: jax.Array  # [N, 7]
    target: jax.Array  # [M, 28]
    pair: jax.Array  # [N, M, 6]
    radar_mask: jax.Array  # [N] 1: a real radar
    target_mask: jax.Array  # [M] 1: a real target


def set_features(env, obs) -> SetObs:
    """The :class:`SetObs` of an :class:`~mjx_radar.planners.base.Observation`.

    Args:
        env: the :class:`~mjx_radar.env.environment.RadarEnv` (scales, keep-out radius).
        obs: what the radars know (``radar_state [N, 6]``, ``mean [6M]``, ``cov [6M, 6M]``,
            ``target_weight [M]``, ``detections [N, M]``).

    Returns:
        float32 sets, every feature O(1); NaN and inf replaced and clipped to ±1000.
    """
    sc = env.scenario
    m = obs.mean.shape[0] // 6
    big_l = jnp.asarray(env.params.placement_half_width, jnp.float32)
    r2t = jnp.asarray(env.params.r2t, jnp.float32)
    vbar, wbar = jnp.float32(sc.limits.speed), jnp.float32(sc.limits.omega)
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
    n = rs.shape[0]
    out = SetObs(radar, target, pair, jnp.ones(n, jnp.float32), jnp.ones(m, jnp.float32))
    return jax.tree.map(lambda x: jnp.clip(jnp.nan_to_num(x, nan=0.0), -1e3, 1e3), out)


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


def flat_size(n: int, m: int) -> int:
    """Length of :func:`flatten` for N radars and M targets."""
    return n * RADAR_SIZE + m * TARGET_SIZE + n * m * PAIR_SIZE + n + m


def flatten(x: SetObs) -> jax.Array:
    """``[flat_size(N, M)]``: one observation's sets as one vector (brax's observation)."""
    return jnp.concatenate([jnp.reshape(v, (-1,)) for v in x])


def unflatten(flat: jax.Array, n: int, m: int) -> SetObs:
    """The inverse of :func:`flatten` (leading batch axes kept)."""
    lead = flat.shape[:-1]
    sizes = [n * RADAR_SIZE, m * TARGET_SIZE, n * m * PAIR_SIZE, n, m]
    shapes = [(n, RADAR_SIZE), (m, TARGET_SIZE), (n, m, PAIR_SIZE), (n,), (m,)]
    parts, start = [], 0
    for size, shape in zip(sizes, shapes, strict=True):
        parts.append(flat[..., start : start + size].reshape(lead + shape))
        start += size
    return SetObs(*parts)
