"""An altitude pseudo-measurement for the managed table's tracks (docs/track_management.md).

Range-only radars on the ground observe a drone's height poorly: the range to a point
at horizontal distance ρ and height h changes by ``∂r/∂h = h / r`` (≈ 0.1 at 500 m),
so a small inconsistency among the ranges a track takes (one radar's return of the
neighbouring drone) moves it tens of metres up or down while it stays on the drone in
the plane. With ``[tracker] height_std = σ_a > 0`` every live track takes, after the
CV prediction of each scan, the scalar pseudo-measurement ``z_a = h₀`` (``birth_height``)
of its height ``e_zᵀ x`` with variance ``σ_a²`` (the linear Kalman update)::

    s = P_zz + σ_a²,   k = P e_z / s,   x ← x + k (h₀ − x_z),   P ← P − k kᵀ s.

Repeated every scan (Δt), it is a measurement of spectral density ``σ_a² Δt``: with
the CV process noise of white acceleration ``q`` on the height and nothing else
observing it, the steady-state height variance is ``√2 q^{1/4} (σ_a² Δt)^{3/4}``
(the continuous-time Kalman–Bucy filter of a double integrator), so σ_a sets how
strongly an unobserved height is held near ``h₀`` (σ_a = 150 m at 25 ms, q = 10:
≈ 16 m std), while the ranges pull it where they observe it. Default off.
"""

from __future__ import annotations

import jax.numpy as jnp

from mjx_radar.estimation import linalg

__all__ = ["height_update"]


def height_update(mean, cov, on, h0: float, var: float):
    """Every live slot's update with the pseudo-measurement ``z = h₀`` of its height.

    Args:
        mean: ``[K, 6]``; cov: ``[K, 6, 6]`` (position first, height at index 2).
        on: ``[K]`` bool live slots (the others are returned unchanged).
        h0: the height ``h₀`` [m]; var: ``σ_a²`` [m²] (> 0).

    Returns:
        ``(mean [K, 6], cov [K, 6, 6])``.
    """
    s = cov[:, 2, 2] + var  # [K]
    gain = cov[:, :, 2] / s[:, None]  # [K, 6]
    new_mean = mean + gain * (h0 - mean[:, 2])[:, None]
    new_cov = cov - gain[:, :, None] * gain[:, None, :] * s[:, None, None]
    new_cov = linalg.symmetrize(new_cov)
    return (
        jnp.where(on[:, None], new_mean, mean),
        jnp.where(on[:, None, None], new_cov, cov),
    )
