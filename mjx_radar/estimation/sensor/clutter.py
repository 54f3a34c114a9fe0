"""Poisson clutter (false alarms) of every radar's scan, in a fixed-size buffer (issue 23).

Each radar sees ``N_c ~ Poisson(λ_c)`` false alarms per scan, ``λ_c = clutter_density ·
(r_max − r_min)``, at one-way ranges uniform on ``[r_min, r_max]`` (round-trip
measurement ``2r``) and, for the range-azimuth model, azimuths uniform on (−π, π].
Counts above the cap ``max_false_alarms`` are truncated (the scenario reader refuses
densities with ``P(N_c > cap) > 1e-6``). The filter's clutter density per unit
measurement volume is ``λ_c / V``, ``V = 2 (r_max − r_min)`` [m] (× 2π rad with azimuth).

A radar's scan is the buffer ``[M + cap]`` of its detected target returns followed by
its false alarms, with a validity mask (the filter does not know which is which):
static shapes, jittable, ``vmap``-able over trials.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

__all__ = ["sample_clutter", "measurement_volume", "density", "scan_buffer"]


def sample_clutter(key, params, n_radars: int, cap: int, dim: int):
    """False alarms of N radars at one scan.

    Args:
        key: the scan's key of the clutter stream.
        params: :class:`mjx_radar.estimation.sensor.detection.DetectionParams`.
        n_radars: N (static); cap: buffer size (static); dim: measurement size (static).

    Returns:
        ``(z[N, cap, dim], valid[N, cap], count[N])`` with ``count = min(N_c, cap)``.
    """
    kc, kr, ka = jax.random.split(key, 3)
    dt = jnp.asarray(params.clutter_min).dtype
    lam = jnp.asarray(params.clutter_rate, jnp.float32)
    count = jnp.minimum(jax.random.poisson(kc, lam, (n_radars,)), cap).astype(jnp.int32)
    valid = jnp.arange(cap)[None, :] < count[:, None]
    r = jax.random.uniform(kr, (n_radars, cap), dt, params.clutter_min, params.clutter_max)
    comps = [2.0 * r]
    if dim == 2:
        comps.append(jax.random.uniform(ka, (n_radars, cap), dt, -jnp.pi, jnp.pi))
    return jnp.stack(comps, axis=-1), valid, count


def measurement_volume(params, dim: int):
    """``V = 2 (r_max − r_min)`` [m] (× 2π with azimuth): the clutter's measurement volume."""
    v = 2.0 * (params.clutter_max - params.clutter_min)
    return v * (2.0 * jnp.pi) if dim == 2 else v


def density(params, dim: int):
    """Clutter density per unit measurement volume ``λ = λ_c / V``."""
    return params.clutter_rate / measurement_volume(params, dim)


def scan_buffer(z, hit, z_clutter, valid_clutter):
    """Every radar's scan: target returns then false alarms.

    Args:
        z: ``[N, M, dim]`` target returns; hit: ``[N, M]`` bool detected (and visible).
        z_clutter: ``[N, cap, dim]``; valid_clutter: ``[N, cap]``.

    Returns:
        ``(zs[N, M + cap, dim], valid[N, M + cap])``.
    """
    return (
        jnp.concatenate([z, z_clutter.astype(z.dtype)], axis=1),
        jnp.concatenate([hit, valid_clutter], axis=1),
    )
