"""Per-target cubature Kalman filter bank: M independent 6-D CKFs (issue 15).

The paper's filter is one joint CKF over the stacked state ``x[6M]``. With the
constant-velocity model the targets move independently (``A``, ``W`` block-diagonal)
and every measurement sees one target only (``z_nm = 2‖p_m − r_n‖ + v_nm``,
independent noise), so for a block-diagonal prior the exact Bayesian posterior
factorises over targets. The bank keeps one 6-D CKF per target::

    x̂_m⁻, P_m⁻ = CKF-predict(x̂_m, P_m; A₆, Q₆)                m = 1..M
    x̂_m⁺, P_m⁺ = CKF-update(x̂_m⁻, P_m⁻; z_m, h_m, R_m)          z_m = (z_1m, …, z_Nm)

with ``h_m(x₆) = (h_pair(r_1, x₆), …, h_pair(r_N, x₆))`` stacked to ``[N·p]``. For
the range model ``h_pair(r, x₆) = [2‖x₆[:3] − r‖]`` (p = 1) and ``R_m = diag(C (ẑ_m/2)⁴)``
(DDR) or ``σ_R² I_N`` (CCR).

Relation to the joint CKF. For a linear h both are the Kalman filter and agree to
round-off. For the range model they differ only in the cubature rule: the joint
rule puts its 12M points at ``x̂ ± √(6M)·S_i`` (each point moves one target), the
bank at ``x̂_m ± √6·S_i``; both are exact for polynomials of degree ≤ 3, so the
difference is of the order of the 4th-order terms of h (relative ``O((σ/d)²)``
for position spread σ at range d) and the joint filter also picks up tiny
spurious cross-target covariances that the bank drops.

Cost: the joint update factors a ``6M×6M`` covariance and an ``NM×NM`` innovation
covariance, O((6M)³ + (NM)³); the bank factors M matrices of size 6 and N, O(M(6³ + N³)).

Conversions :func:`joint_to_bank` / :func:`bank_to_joint` let the rest of the loop
(metrics, NEES, planner) keep the joint ``mean[6M], cov[6M, 6M]`` interface.
All functions are pure JAX, ``vmap``-ed over targets, with static shapes.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from mjx_radar.estimation.filters import ckf, ckf_sqrt
from mjx_radar.estimation.sensor.sensing import ddr_noise_cov

__all__ = [
    "joint_to_bank",
    "bank_to_joint",
    "predict_bank",
    "update_bank",
    "range_pair",
    "ddr_R",
    "ccr_R",
    "predict_joint",
    "update_ranges",
]


def joint_to_bank(mean, cov):
    """Per-target blocks of a joint estimate (off-diagonal blocks are dropped).

    Args:
        mean: ``[6M]`` stacked mean.
        cov: ``[6M, 6M]`` joint covariance.

    Returns:
        ``(means[M, 6], covs[M, 6, 6])`` with ``covs[m] = cov[6m:6m+6, 6m:6m+6]``.
    """
    mean = jnp.asarray(mean)
    m = mean.shape[0] // 6
    if mean.ndim != 1 or 6 * m != mean.shape[0] or cov.shape != (6 * m, 6 * m):
        raise ValueError(f"mean must be [6M] and cov [6M, 6M], got {mean.shape}, {cov.shape}")
    blocks = jnp.asarray(cov, mean.dtype).reshape(m, 6, m, 6)
    idx = jnp.arange(m)
    return mean.reshape(m, 6), blocks[idx, :, idx, :]


def bank_to_joint(means, covs):
    """Joint estimate of a bank: stacked means and a block-diagonal covariance.

    Args:
        means: ``[M, 6]``.
        covs: ``[M, 6, 6]``.

    Returns:
        ``(mean[6M], cov[6M, 6M])``, cov zero off the diagonal 6×6 blocks.
    """
    means = jnp.asarray(means)
    covs = jnp.asarray(covs, means.dtype)
    m = means.shape[0]
    eye = jnp.eye(m, dtype=means.dtype)
    cov = eye[:, None, :, None] * covs[:, :, None, :]  # [M, 6, M, 6]
    return means.reshape(-1), cov.reshape(6 * m, 6 * m)


def predict_bank(means, covs, A6, Q6, form: str = "covariance"):
    """CKF time update of every target with the same linear model.

    Args:
        means: ``[M, 6]`` posterior means.
        covs: ``[M, 6, 6]`` posterior covariances.
        A6: ``[6, 6]`` per-target transition.
        Q6: ``[6, 6]`` per-target process noise.
        form: "covariance", or "sqrt" (:mod:`ckf_sqrt`): ``covs`` are then lower
            Cholesky factors ``S_m`` (returned likewise) and ``Q6`` a factor
            ``[6, q]`` of the process noise.

    Returns:
        ``(means[M, 6], covs[M, 6, 6])`` predicted moments (= ``A P Aᵀ + Q`` up to
        round-off, computed by :func:`ckf.predict` exactly as in the joint filter).
    """
    filt = ckf_sqrt if form == "sqrt" else ckf

    def one(x, p):
        return filt.predict(x, p, lambda v: A6 @ v, Q6)

    return jax.vmap(one)(means, covs)


def update_bank(
    means, covs, z, radar_pos, h_pair, R_fn, mask=None, residual=None, form: str = "covariance"
):
    """CKF measurement update of every target from its own N radars' measurements.

    Args:
        means: ``[M, 6]`` predicted means.
        covs: ``[M, 6, 6]`` predicted covariances.
        z: ``[N, M, p]`` measurements; ``z[n, m]`` of target m by radar n.
        radar_pos: ``[N, 3]`` radar positions (anything ``h_pair`` takes, leading axis N).
        h_pair: ``h_pair(radar_pos[n], x6[6]) -> [p]`` noiseless measurement of one
            target by one radar (e.g. :func:`range_pair`).
        R_fn: per-target noise covariance ``[N·p, N·p]`` or callable
            ``R_fn(z_hat[N·p]) -> [N·p, N·p]`` (e.g. :func:`ddr_R`, :func:`ccr_R`);
            rows ordered ``n·p + i``.
        mask: optional ``[N, M]`` bool, True where the pair (n, m) is measured; a False
            pair is dropped exactly (:func:`ckf.update` ``mask``).
        residual: optional ``(a[N·p], b[N·p]) -> a − b`` with angles wrapped
            (:func:`ckf.update` ``residual``).
        form: "covariance", or "sqrt": ``covs`` are lower Cholesky factors (in and out).

    Returns:
        ``(means[M, 6], covs[M, 6, 6])`` posterior moments.
    """
    filt = ckf_sqrt if form == "sqrt" else ckf
    z = jnp.asarray(z)
    if z.ndim != 3 or z.shape[1] != means.shape[0]:
        raise ValueError(f"z must be [N, M, p] with M = {means.shape[0]}, got {z.shape}")
    n, m, p = z.shape
    zm = jnp.swapaxes(z, 0, 1).reshape(m, n * p)  # [M, N*p], row n*p + i

    def h_target(x6):
        return jax.vmap(lambda r: h_pair(r, x6))(radar_pos).reshape(n * p)

    def one(x, P, zz, keep):
        return filt.update(x, P, zz, h_target, R_fn, mask=keep, residual=residual)

    if mask is None:
        return jax.vmap(lambda x, P, zz: one(x, P, zz, None))(means, covs, zm)
    keep = jnp.repeat(jnp.asarray(mask, bool).T, p, axis=1)  # [M, N*p]
    return jax.vmap(one)(means, covs, zm, keep)


def range_pair(radar_pos, x6):
    """Round-trip range of one target by one radar: ``[2‖x6[:3] − radar_pos‖]`` (p = 1)."""
    return 2.0 * jnp.linalg.norm(x6[:3] - radar_pos)[None]


def ddr_R(C):
    """DDR noise ``R(ẑ) = diag(C (ẑ/2)⁴)`` as a callable of the predicted ranges."""
    return lambda z_hat: ddr_noise_cov(z_hat, C)


def ccr_R(n_radars: int, sigma_r2, dtype=None):
    """CCR noise ``σ_R² I_N`` of one target's N range measurements."""
    return sigma_r2 * jnp.eye(int(n_radars), dtype=dtype or jnp.result_type(float))


def predict_joint(mean, cov, A6, Q6, form: str = "covariance"):
    """Joint-interface time update through the bank (drop-in for ``ckf.predict``).

    Args:
        mean: ``[6M]``; cov: ``[6M, 6M]`` (only its diagonal blocks are used).
        A6, Q6: ``[6, 6]`` per-target transition and process noise.
        form: "covariance", or "sqrt" (cov a block-diagonal factor, Q6 a factor).

    Returns:
        ``(mean[6M], cov[6M, 6M])`` with a block-diagonal covariance (or factor).
    """
    return bank_to_joint(*predict_bank(*joint_to_bank(mean, cov), A6, Q6, form))


def update_ranges(mean, cov, z, radar_pos, R_fn, mask=None):
    """Joint-interface range update through the bank (drop-in for ``ckf.update``).

    Args:
        mean: ``[6M]`` predicted mean.
        cov: ``[6M, 6M]`` predicted covariance (only its diagonal blocks are used).
        z: ``[N·M]`` round-trip ranges, row-major ``n·M + m`` (as ``sensing.sample_ranges``).
        radar_pos: ``[N, 3]``.
        R_fn: per-target ``[N, N]`` noise or callable (:func:`ddr_R`, :func:`ccr_R`).
        mask: optional ``[N, M]`` (or flat ``[N·M]``) bool line of sight.

    Returns:
        ``(mean[6M], cov[6M, 6M])`` with a block-diagonal covariance.
    """
    means, covs = joint_to_bank(mean, cov)
    n, m = radar_pos.shape[0], means.shape[0]
    zb = jnp.asarray(z, means.dtype).reshape(n, m, 1)
    keep = None if mask is None else jnp.asarray(mask, bool).reshape(n, m)
    means, covs = update_bank(means, covs, zb, radar_pos, range_pair, R_fn, mask=keep)
    return bank_to_joint(means, covs)
