"""Constant-velocity target motion model (SPEC §2).

Per target the state is ``[x, y, z, vx, vy, vz]`` and

    x_{k+1} = A x_k + w,   A = [[I, Δt·I], [0, I]],
    w ~ N(0, W),           W = G Σ_w Gᵀ,  G = [½Δt²·I; Δt·I],  Σ_w = σ_W²·I.

For M targets the stacked state is the concatenation of the per-target states
(length 6M) and A, W are block-diagonal with M identical 6×6 blocks. The truth
simulator and the filter must use the same Δt and σ_W² (SPEC §2).
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

__all__ = ["cv_transition", "cv_process_noise"]


def _check(dt, n_targets):
    if not float(dt) > 0.0:
        raise ValueError(f"dt must be > 0 (seconds), got {dt!r}")
    if int(n_targets) != n_targets or int(n_targets) < 1:
        raise ValueError(f"n_targets must be an integer >= 1, got {n_targets!r}")


def cv_transition(dt: float, n_targets: int = 1, dtype=None):
    """Block-diagonal constant-velocity transition matrix.

    Args:
        dt: step Δt [s] (> 0, a concrete Python number).
        n_targets: number of targets M (>= 1).
        dtype: output dtype; default float (float32, or float64 under x64).

    Returns:
        ``A[6M, 6M]`` with blocks ``[[I₃, Δt·I₃], [0, I₃]]``.
    """
    _check(dt, n_targets)
    i3 = np.eye(3)
    a = np.block([[i3, dt * i3], [np.zeros((3, 3)), i3]])
    return jnp.asarray(np.kron(np.eye(int(n_targets)), a), dtype=dtype or jnp.result_type(float))


def cv_process_noise(dt: float, sigma_w2: float, n_targets: int = 1, dtype=None):
    """Block-diagonal process-noise covariance of the white-acceleration CV model.

    Args:
        dt: step Δt [s] (> 0).
        sigma_w2: acceleration variance σ_W² [m²/s⁴] (>= 0).
        n_targets: number of targets M (>= 1).
        dtype: output dtype; default float (float32, or float64 under x64).

    Returns:
        ``W[6M, 6M]`` with blocks ``σ_W² [[Δt⁴/4·I, Δt³/2·I], [Δt³/2·I, Δt²·I]]``
        (= ``G Σ_w Gᵀ``; rank 3 per block).
    """
    _check(dt, n_targets)
    if not float(sigma_w2) >= 0.0:
        raise ValueError(f"sigma_w2 must be >= 0 (m^2/s^4), got {sigma_w2!r}")
    g = np.vstack([0.5 * dt**2 * np.eye(3), dt * np.eye(3)])
    w = sigma_w2 * g @ g.T
    return jnp.asarray(np.kron(np.eye(int(n_targets)), w), dtype=dtype or jnp.result_type(float))
