"""TEMPORARY minimal range model (replaced by the measurement-model branch)."""

from __future__ import annotations

import dataclasses
from typing import NamedTuple

import jax
import jax.numpy as jnp

from mjx_radar.estimation import fisher, sensing


class NoiseParams(NamedTuple):
    c: jax.Array
    sigma_r2: jax.Array
    c_az: jax.Array
    sigma_az2: jax.Array


@dataclasses.dataclass(frozen=True)
class RangeModel:
    name: str = "range"
    dim: int = 1

    def predict(self, radar_pos, target_pos):
        d = target_pos[None, :, :] - radar_pos[:, None, :]
        return 2.0 * jnp.sqrt(jnp.sum(d**2, -1))[..., None]

    def variance(self, z_hat, params, ccr):
        return jnp.where(ccr, params.sigma_r2, params.c * (z_hat / 2.0) ** 4)

    def sample(self, key, radar_pos, target_pos, params):
        d = sensing.ranges(radar_pos, target_pos).reshape(-1)
        eps = jax.random.normal(key, d.shape, dtype=d.dtype)
        z = 2.0 * d + jnp.sqrt(jnp.asarray(params.c, d.dtype)) * d**2 * eps
        return z.reshape(radar_pos.shape[0], target_pos.shape[0], 1)

    def residual(self, a, b):
        return a - b

    def pair_information(self, d, params, ccr):
        r2 = d[..., 0] * d[..., 0] + d[..., 1] * d[..., 1] + d[..., 2] * d[..., 2]
        inv = 1.0 / r2
        w = jnp.where(ccr, 4.0 / params.sigma_r2, inv * ((4.0 / params.c) * inv + 8.0))
        g = w / r2
        x, y, z = d[..., 0], d[..., 1], d[..., 2]
        return jnp.stack([g * x * x, g * x * y, g * x * z, g * y * y, g * y * z, g * z * z], -1)


def make_model(name: str = "range"):
    return RangeModel()


def information(model, radar_pos, target_pos, params, ccr, mask=None):
    acc = None
    for n in range(radar_pos.shape[-2]):
        d = target_pos - radar_pos[..., n : n + 1, :]
        g = model.pair_information(d, params, ccr)
        if mask is not None:
            g = g * jnp.asarray(mask[..., n, :], g.dtype)[..., None]
        acc = g if acc is None else acc + g
    return acc


def information_dense(model, radar_pos, target_pos, params, ccr, mask=None):
    return fisher.unpack_sym3(information(model, radar_pos, target_pos, params, ccr, mask))


def measurement_function(model, radar_pos):
    def h(x):
        pos = jnp.reshape(x, (-1, 6))[:, :3]
        return model.predict(radar_pos, pos).reshape(-1)

    return h


def noise_cov_fn(model, params, ccr):
    def r(z_hat):
        return jnp.diag(model.variance(z_hat.reshape(-1, model.dim), params, ccr).reshape(-1))

    return r


def noise_params(scenario):
    c = sensing.noise_constant(scenario.radar_eq, scenario.n_targets)
    f = lambda x: jnp.asarray(x, jnp.float32)  # noqa: E731
    return NoiseParams(f(c), f(sensing.ccr_variance(c, scenario.mpc.r2t)), f(0.0), f(0.0))
