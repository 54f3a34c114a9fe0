"""The PCRLB along saved true trajectories, in float64 on the host (SPEC §5, issue 13).

The closed loop computes the PFIM recursion in the device's float32, which is
off by up to a few percent once the information grows large (6×6 inverses of
matrices with entries spanning ~10 orders of magnitude). This module recomputes
it in numpy float64 from the saved arrays, per target m (6×6)::

    J_0 = I / p0,
    J_{k+1} = (W + A J_k⁻¹ Aᵀ)⁻¹ + J_D(x_{k+1}),   J_D = [[Σ_n J_nm, 0], [0, 0]],
    J_nm = vis_nm · u uᵀ (4 / (C r⁴) + 8 / r²),    u = (p_Tm − p_Rn) / r,

with the CV model ``A = [[I, Δt I], [0, I]]``, ``W = σ_W² G Gᵀ``,
``G = [½Δt² I; Δt I]`` (:mod:`mjx_radar.estimation.information.fisher`,
:mod:`mjx_radar.physics.motion`). The bound on target m's position error is
``tr[J_m⁻¹]_pos`` (the upper-left 3×3 of the inverse); its mean over targets is
the bound on the per-step squared position RMSE, ``E[rmse_pos²] >= mean_m
tr[J_m⁻¹]_pos``.

The clean comparison of a filter with the bound (:func:`rmse_vs_bound`) is
therefore between ``sqrt(mean over trials of rmse_pos²)`` and ``sqrt(mean over
trials of the bound trace)`` per step, not between means of square roots.
"""

from __future__ import annotations

import numpy as np

__all__ = ["cv_matrices", "sfim_np", "pcrlb_float64", "rmse_vs_bound"]


def cv_matrices(dt: float, sigma_w2: float) -> tuple[np.ndarray, np.ndarray]:
    """``(A[6, 6], W[6, 6])`` of the per-target CV model in float64."""
    i3 = np.eye(3)
    a = np.block([[i3, dt * i3], [np.zeros((3, 3)), i3]])
    g = np.vstack([0.5 * dt**2 * i3, dt * i3])
    return a, sigma_w2 * g @ g.T


def sfim_np(radar_pos, target_pos, C, vis=None) -> np.ndarray:
    """DDR position FIM in float64: ``[..., N, 3]``, ``[..., M, 3]`` -> ``[..., M, 3, 3]``.

    Args:
        radar_pos: ``[..., N, 3]`` radar positions [m].
        target_pos: ``[..., M, 3]`` target positions [m].
        C: range-noise constant (variance ``C d⁴``): scalar, or ``[N, 1]`` per radar.
        vis: optional ``[..., N, M]`` line-of-sight mask (False: no information).
    """
    d = target_pos[..., None, :, :] - radar_pos[..., :, None, :]  # [..., N, M, 3]
    r2 = np.sum(d * d, axis=-1)
    w = (4.0 / (C * r2 * r2) + 8.0 / r2) / r2  # w u uᵀ = (w / r²) d dᵀ
    if vis is not None:
        w = w * np.asarray(vis, np.float64)
    return np.einsum("...nm,...nmi,...nmj->...mij", w, d, d)


def _sym(x):
    return 0.5 * (x + np.swapaxes(x, -1, -2))


def pcrlb_float64(radar_pos, target, C, dt, sigma_w2, p0, vis=None) -> dict:
    """Posterior CRLB along the true trajectories, float64, vectorised over trials and targets.

    Args:
        radar_pos: ``[T, K, N, 3]`` radar positions at each filter step [m].
        target: ``[T, K, M, 6]`` true target states at each filter step.
        C: DDR range-noise constant.
        dt: filter step [s].
        sigma_w2: acceleration variance σ_W² [m²/s⁴].
        p0: initial covariance scale (``J_0 = I / p0``) [m², m²/s²].
        vis: optional ``[T, K, N, M]`` line-of-sight mask.

    Returns:
        dict with ``bound_pos_trace[T, K]`` = ``mean_m tr[J_m⁻¹]_pos`` [m²] and
        ``crlb_pos[T, K]`` = its square root [m] (the closed loop's ``crlb_pos``).
    """
    radar_pos = np.asarray(radar_pos, np.float64)
    target = np.asarray(target, np.float64)
    if radar_pos.ndim != 4 or radar_pos.shape[-1] != 3:
        raise ValueError(f"radar_pos must have shape [T, K, N, 3], got {radar_pos.shape}")
    if target.ndim != 4 or target.shape[-1] != 6 or target.shape[:2] != radar_pos.shape[:2]:
        raise ValueError(
            f"target must have shape [T, K, M, 6] matching radar_pos {radar_pos.shape[:2]}, "
            f"got {target.shape}"
        )
    t, k, _, _ = radar_pos.shape
    m = target.shape[2]
    a, w = cv_matrices(float(dt), float(sigma_w2))
    J = np.broadcast_to(np.eye(6) / float(p0), (t, m, 6, 6)).copy()
    trace = np.empty((t, k))
    for i in range(k):
        prior = _sym(w + a @ np.linalg.inv(J) @ a.T)
        J = np.linalg.inv(prior)
        vi = None if vis is None else np.asarray(vis)[:, i]
        J[..., :3, :3] += sfim_np(radar_pos[:, i], target[:, i, :, :3], C, vi)
        J = _sym(J)
        cov = np.linalg.inv(J)
        trace[:, i] = np.mean(np.trace(cov[..., :3, :3], axis1=-2, axis2=-1), axis=-1)
    return {"bound_pos_trace": trace, "crlb_pos": np.sqrt(trace)}


def rmse_vs_bound(rmse_pos, bound_pos_trace) -> tuple[np.ndarray, np.ndarray]:
    """Per-step RMSE over trials and the matching square root of the mean bound.

    Args:
        rmse_pos: ``[T, K]`` per-trial, per-step position RMSE [m].
        bound_pos_trace: ``[T, K]`` ``mean_m tr[J_m⁻¹]_pos`` [m²] (or ``crlb_pos²``).

    Returns:
        ``(sqrt(mean_T rmse_pos²)[K], sqrt(mean_T bound_pos_trace)[K])`` [m]: the first is
        never below the second for an unbiased estimator (in expectation).
    """
    r = np.asarray(rmse_pos, np.float64)
    b = np.asarray(bound_pos_trace, np.float64)
    return np.sqrt(np.mean(r * r, axis=0)), np.sqrt(np.mean(b, axis=0))
