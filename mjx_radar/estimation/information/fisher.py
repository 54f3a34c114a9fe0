"""Fisher information of range measurements: SFIM and PFIM (SPEC §5).

Standard FIM (positions only, 3×3 per target) of ``z ~ N(2d, v(d))`` with
``d = p_T − p_R``, ``r = ‖d‖``, unit vector ``u = d/r``: for a Gaussian,
``J = ∇μ ∇μᵀ / v + ∇v ∇vᵀ / (2v²)``. With ``∇μ = 2u``:

* DDR (``v = C r⁴``, ``∇v = 4 C r³ u``):
  ``J = d dᵀ (4/(C r⁶) + 8/r⁴) = u uᵀ (4/(C r⁴) + 8/r²)``;
* CCR (``v = σ_R²``): ``J = 4 d dᵀ / (r² σ_R²) = 4 u uᵀ / σ_R²``.

Contributions are summed over radars. (Computed via unit vectors to keep
float32 powers of r in range.)

Posterior FIM (Tichavský et al. 1998) of a linear-Gaussian transition
``x' = A x + w``, ``w ~ N(0, W)``, per target 6×6::

    J_{k+1} = (W + A J_k⁻¹ Aᵀ)⁻¹ + J_D,   J_D = [[Σ_n J_nm, 0], [0, 0]]

(SPEC fixes the paper's ``AᵀJ⁻¹A`` typo). All inverses go through
:mod:`mjx_radar.estimation.linalg`. Every function accepts extra leading batch dims.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from mjx_radar.batching import batched_like
from mjx_radar.estimation import linalg, linalg_small

__all__ = ["INFO_FLOOR", "sfim", "sfim_ccr", "pfim_step", "data_information", "logdet"]

INFO_FLOOR = 1e-6
"""Absolute information floor [1/m²] added before ``log det``: negligible against
SFIM entries O(1e-2..1e2) 1/m², but keeps log det finite and smooth for the
rank-deficient FIM of a target seen by fewer than three radars."""


def _geometry(radar_pos, target_pos):
    """Unit vectors ``u[..., N, M, 3]`` and ranges ``r[..., N, M]`` (shape-checked)."""
    radar_pos = jnp.asarray(radar_pos)
    target_pos = jnp.asarray(target_pos)
    for name, x in (("radar_pos", radar_pos), ("target_pos", target_pos)):
        if x.ndim < 2 or x.shape[-1] != 3:
            raise ValueError(f"{name} must have shape [..., K, 3], got {tuple(x.shape)}")
    dtype = jnp.result_type(radar_pos, target_pos, float)
    d = target_pos[..., None, :, :].astype(dtype) - radar_pos[..., :, None, :].astype(dtype)
    r = jnp.sqrt(jnp.sum(d**2, axis=-1))
    if not isinstance(r, jax.core.Tracer) and not bool(np.all(np.asarray(r) > 0)):
        raise ValueError("radar-target range must be > 0 m (a radar coincides with a target)")
    return d / r[..., None], r


def _outer_sum(w, u):
    """``Σ_n w[..., n, m] u uᵀ`` -> ``[..., M, 3, 3]``.

    Written as broadcast-multiply-and-sum rather than an einsum: XLA fuses it into
    one elementwise loop, whereas a dot_general over 3×3 blocks becomes millions
    of tiny matrix products inside the MPPI objective.
    """
    outer = w[..., None, None] * u[..., :, None] * u[..., None, :]
    return jnp.sum(outer, axis=-4)


def sfim(radar_pos, target_pos, C, mask=None):
    """DDR standard Fisher information of each target's position.

    Args:
        radar_pos: ``[..., N, 3]`` radar positions [m].
        target_pos: ``[..., M, 3]`` target positions [m].
        C: range-noise constant (variance ``C d⁴``), scalar.
        mask: optional ``[..., N, M]`` bool/0-1, False for pairs without a
            measurement (blocked line of sight): they contribute no information.

    Returns:
        ``[..., M, 3, 3]``: ``J_m = Σ_n d dᵀ (4/(C‖d‖⁶) + 8/‖d‖⁴)`` [1/m²].
    """
    u, r = _geometry(radar_pos, target_pos)
    r2 = r**2
    w = 4.0 / (C * r2 * r2) + 8.0 / r2
    if mask is not None:
        w = w * jnp.asarray(mask, w.dtype)
    return _outer_sum(w, u)


def sfim_ccr(radar_pos, target_pos, sigma_r2):
    """CCR standard Fisher information of each target's position.

    Args:
        radar_pos: ``[..., N, 3]`` radar positions [m].
        target_pos: ``[..., M, 3]`` target positions [m].
        sigma_r2: constant range variance σ_R² [m²], scalar.

    Returns:
        ``[..., M, 3, 3]``: ``J_m = Σ_n 4 d dᵀ / (‖d‖² σ_R²)`` [1/m²].
    """
    u, r = _geometry(radar_pos, target_pos)
    w = jnp.broadcast_to(4.0 / jnp.asarray(sigma_r2, r.dtype), r.shape)
    return _outer_sum(w, u)


def data_information(J3):
    """Embed a position FIM into the 6-D CV state: ``[[J3, 0], [0, 0]]``.

    Args:
        J3: ``[..., 3, 3]`` position information.

    Returns:
        ``[..., 6, 6]``.
    """
    J3 = jnp.asarray(J3)
    if J3.shape[-2:] != (3, 3):
        raise ValueError(f"J3 must have shape [..., 3, 3], got {tuple(J3.shape)}")
    pad = [(0, 0)] * (J3.ndim - 2) + [(0, 3), (0, 3)]
    return jnp.pad(J3, pad)


def pfim_step(J, A, W, J_data):
    """One step of the Tichavský posterior-FIM recursion.

    Args:
        J: ``[..., n, n]`` current information ``J_k`` (PD).
        A: ``[..., n, n]`` transition matrix.
        W: ``[..., n, n]`` process-noise covariance (may be singular).
        J_data: ``[..., n, n]`` data information at step k+1 (PSD).

    Returns:
        ``[..., n, n]``: ``(W + A J⁻¹ Aᵀ)⁻¹ + J_data``, symmetrised.
    """
    J = jnp.asarray(J)
    A = jnp.asarray(A, J.dtype)
    prior_cov = W + A @ linalg.psd_inv(J) @ jnp.swapaxes(A, -1, -2)
    return linalg.symmetrize(linalg.psd_inv(prior_cov) + J_data)


def _const_congruence(A, X):
    """``A X Aᵀ`` for a constant ``A[n, n]`` (numpy) and symmetric entries ``X[i][j]``.

    Zeros of ``A`` are skipped at trace time (the CV transition is half zeros).
    """
    n = A.shape[0]
    ax = [
        [sum(A[i, k] * X[k][j] for k in range(n) if A[i, k] != 0.0) for j in range(n)]
        for i in range(n)
    ]
    out = [[None] * n for _ in range(n)]
    for i in range(n):
        for j in range(i + 1):
            out[i][j] = out[j][i] = sum(ax[i][k] * A[j, k] for k in range(n) if A[j, k] != 0.0)
    return out


def pfim_logdets(J0, A, W_unit, sigma_w2, jd, floor: float = INFO_FLOOR, unroll: int = 1):
    """``log det(J_t + floor·I)`` along the PFIM recursion, on one array per matrix entry.

    The planner's hot path: the same recursion as :func:`pfim_step` (``J_{t+1} =
    (W + A J_t⁻¹ Aᵀ)⁻¹ + [[J_D,t+1, 0], [0, 0]]``), with every 6×6 matrix held as 21
    arrays over the batch so that the work is elementwise (vectorised over the batch
    on the CPU, few kernels on the GPU) instead of millions of tiny matrix products.
    The Cholesky factor of ``J_t`` serves both its log det and the next step's inverse.

    Args:
        J0: ``[..., 6, 6]`` information at the start.
        A: ``[6, 6]`` transition (a concrete, non-traced constant).
        W_unit: ``[6, 6]`` process noise per unit ``sigma_w2`` (concrete constant).
        sigma_w2: process-noise scale (scalar, may be traced).
        jd: position data information ``(xx, xy, xz, yy, yz, zz)``, each ``[T, ...]``
            (step t's information, added at step t).
        floor: absolute information floor added before the log det.
        unroll: steps per loop iteration (``lax.scan``'s ``unroll``).

    Returns:
        ``[T, ...]`` log-determinants of ``J_1 .. J_T``.
    """
    a, w = np.asarray(A, float), np.asarray(W_unit, float)
    n = a.shape[0]
    pos = {(0, 0): 0, (1, 0): 1, (2, 0): 2, (1, 1): 3, (2, 1): 4, (2, 2): 5}
    J0 = jnp.asarray(J0)
    chol0 = linalg_small.psd_cholesky_entries(linalg_small.entries(J0))

    def step(chol, jdt):
        prior = _const_congruence(a, linalg_small.inv_from_cholesky_entries(chol))
        prior = [
            [prior[i][j] + sigma_w2 * w[i, j] if w[i, j] != 0.0 else prior[i][j] for j in range(n)]
            for i in range(n)
        ]
        new = linalg_small.inv_from_cholesky_entries(linalg_small.psd_cholesky_entries(prior))
        new = [
            [
                new[i][j] + jdt[pos[(max(i, j), min(i, j))]] if max(i, j) < 3 else new[i][j]
                for j in range(n)
            ]
            for i in range(n)
        ]
        floored = [[new[i][j] + floor if i == j else new[i][j] for j in range(n)] for i in range(n)]
        chol_new = linalg_small.psd_cholesky_entries(new)
        return chol_new, linalg_small.logdet_from_cholesky_entries(
            linalg_small.psd_cholesky_entries(floored)
        )

    chol0 = batched_like(chol0, (jd, chol0))  # J0 shared by the samples: one batching
    _, out = jax.lax.scan(step, chol0, tuple(jd), unroll=unroll)
    return out


def logdet(J, floor: float = INFO_FLOOR):
    """``log det(J + floor·I)`` of information matrices ``[..., n, n]`` -> ``[...]``."""
    return linalg.logdet_psd(J, floor=floor)


def ddr_weight(C):
    """Per-pair SFIM weight of the DDR model as a function of range: ``4/(C r⁴) + 8/r²``."""

    def weight(r2):
        inv = 1.0 / r2
        return inv * ((4.0 / C) * inv + 8.0)

    return weight


def ccr_weight(sigma_r2):
    """Per-pair SFIM weight of the CCR model: ``4/σ_R²`` (independent of range)."""
    return lambda r2: jnp.full_like(r2, 4.0 / sigma_r2)


def sfim_packed(radar_pos, target_pos, weight, mask=None):
    """SFIM as its 6 unique entries, fused for large batches (the MPPI objective).

    Same values as :func:`sfim` / :func:`sfim_ccr` (``weight`` from
    :func:`ddr_weight` / :func:`ccr_weight`), but accumulated radar by radar in
    elementwise arithmetic, which XLA fuses into one loop without 3×3 temporaries.

    Args:
        radar_pos: ``[..., N, 3]`` radar positions (broadcast against targets' batch dims).
        target_pos: ``[..., M, 3]`` target positions.
        weight: ``w(r²)`` per-pair weight of ``u uᵀ``.
        mask: optional ``[..., N, M]`` bool/0-1 (broadcast like the positions); pairs
            with False (blocked line of sight) contribute nothing.

    Returns:
        ``[..., M, 6]`` entries ``(xx, xy, xz, yy, yz, zz)``.
    """
    acc = None
    for n in range(radar_pos.shape[-2]):
        d = target_pos - radar_pos[..., n : n + 1, :]  # [..., M, 3]
        r2 = d[..., 0] * d[..., 0] + d[..., 1] * d[..., 1] + d[..., 2] * d[..., 2]
        g = weight(r2) / r2  # w u uᵀ = (w / r²) d dᵀ
        if mask is not None:
            g = g * jnp.asarray(mask[..., n, :], g.dtype)
        x, y, z = d[..., 0], d[..., 1], d[..., 2]
        term = [g * x * x, g * x * y, g * x * z, g * y * y, g * y * z, g * z * z]
        acc = term if acc is None else [a + t for a, t in zip(acc, term, strict=True)]
    return jnp.stack(acc, axis=-1)


def unpack_sym3(p):
    """``[..., 6]`` entries ``(xx, xy, xz, yy, yz, zz)`` -> ``[..., 3, 3]`` symmetric matrix."""
    xx, xy, xz, yy, yz, zz = (p[..., i] for i in range(6))
    return jnp.stack(
        [jnp.stack([xx, xy, xz], -1), jnp.stack([xy, yy, yz], -1), jnp.stack([xz, yz, zz], -1)],
        axis=-2,
    )


def logdet_components(entries, floor: float = INFO_FLOOR):
    """``log det(J + floor·I)`` of 3×3 information given as its 6 entries -> ``[...]``.

    Args:
        entries: ``(xx, xy, xz, yy, yz, zz)``, each ``[...]`` (as returned by
            :func:`mjx_radar.estimation.sensor.measurement.information_components`).
        floor: absolute information floor [1/m²].
    """
    return linalg_small.logdet_sym3(*entries, floor=floor)


def logdet_packed(p, floor: float = INFO_FLOOR):
    """``log det(J + floor·I)`` of packed 3×3 information ``[..., 6]`` -> ``[...]``."""
    return linalg_small.logdet_sym3(*(p[..., i] for i in range(6)), floor=floor)
