"""Targets that appear and leave (``[[target_motion]]`` ``appear`` / ``leave``) in the loop.

A target is present for ``appear <= t < leave``
(:func:`mjx_radar.physics.target_motion.present`). In the closed loop an absent target

* yields no measurement: its radar-target pairs are masked out of the CKF update
  exactly (as blocked lines of sight) and add no information to the PCRLB;
* costs nothing in the planner: its weight in the information and R2T terms is 0
  (``TaskParams.target_weight``, the presence at the planning instant);
* has no error in the metrics: RMSE, NEES and PCRLB are over the present targets
  only (:func:`error_metrics`; 0 when none is), and ``targets_present`` counts them.

When a target appears its track starts afresh (:func:`start_tracks`): its block of the
estimate becomes ``x + e``, ``e ~ N(0, p0 I)`` (the consistent draw of the initial
estimate, SPEC §4), its covariance ``p0 I`` with no cross-covariance, and its PFIM
``I / p0``.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from mjx_radar.estimation import linalg
from mjx_radar.physics import target_motion


def _target_mask(flags, m: int) -> jax.Array:
    """``[6M]`` bool: every state component of the flagged targets ``flags [M]``."""
    return jnp.repeat(flags, 6, total_repeat_length=6 * m)


def start_tracks(mean, cov_p, new, truth, key, p0):
    """Re-initialises the tracks of the targets ``new [M]`` (bool) that just appeared.

    Args:
        mean: [6M] estimate; cov_p: [6M, 6M] its covariance P.
        new: [M] bool, the appearing targets.
        truth: [M, 6] true states now.
        key: PRNG key of the draw ``e``.
        p0: initial variance [m²].

    Returns:
        ``(mean, P)`` with the new targets' blocks reset and their cross-covariances 0.
    """
    m = truth.shape[0]
    sel = _target_mask(new, m)
    err = jnp.sqrt(p0) * jax.random.normal(key, mean.shape, mean.dtype)
    mean = jnp.where(sel, truth.reshape(-1) + err, mean)
    cross = sel[:, None] | sel[None, :]
    cov_p = jnp.where(cross, 0.0, cov_p) + jnp.diag(jnp.where(sel, p0, 0.0).astype(cov_p.dtype))
    return mean, cov_p


def start_pfim(pfim, new, p0):
    """``pfim [M, 6, 6]`` with the appearing targets' information reset to ``I / p0``."""
    return jnp.where(new[:, None, None], jnp.eye(6, dtype=pfim.dtype) / p0, pfim)


def error_metrics(truth, mean, cov_p, present):
    """RMSE (position, state) and NEES over the present targets only.

    Args:
        truth: [M, 6]; mean: [6M]; cov_p: [6M, 6M].
        present: [M] bool.

    Returns:
        ``(rmse_pos, rmse_state, nees)``: ``sqrt(Σ_present |e_pos|² / n)``, the same for
        the state, and ``e_Sᵀ P_SS⁻¹ e_S`` of the present targets' marginal (``6n`` dof);
        all 0 when no target is present.
    """
    m = truth.shape[0]
    sel = _target_mask(present, m)
    err = jnp.where(sel, mean - truth.reshape(-1), 0.0)
    e = err.reshape(m, 6)
    n = jnp.maximum(jnp.sum(present), 1).astype(mean.dtype)
    rmse_pos = jnp.sqrt(jnp.sum(e[:, :3] ** 2) / n)
    rmse_state = jnp.sqrt(jnp.sum(e**2) / n)
    # the marginal of the present targets: absent rows / columns replaced by identity
    cross = sel[:, None] & sel[None, :]
    cov_s = jnp.where(cross, cov_p, 0.0) + jnp.diag(jnp.where(sel, 0.0, 1.0).astype(cov_p.dtype))
    nees = err @ linalg.psd_solve(cov_s, err)
    return rmse_pos, rmse_state, nees


def metrics(bound_trace, truth, mean, cov_p, present=None):
    """``(crlb_pos, rmse_pos, rmse_state, nees)`` of one step.

    ``bound_trace [M]``: ``tr[J_m⁻¹]_pos``. ``present`` None: every target (the paper's
    means over M targets and the full NEES); else over the present targets only.
    """
    if present is not None:
        return (crlb_pos(bound_trace, present), *error_metrics(truth, mean, cov_p, present))
    err = mean - truth.reshape(-1)
    e = err.reshape(truth.shape[0], 6)
    rmse_pos = jnp.sqrt(jnp.mean(jnp.sum(e[:, :3] ** 2, -1)))
    rmse_state = jnp.sqrt(jnp.mean(jnp.sum(e**2, -1)))
    nees = err @ linalg.psd_solve(cov_p, err)
    return jnp.sqrt(jnp.mean(bound_trace)), rmse_pos, rmse_state, nees


def crlb_pos(bound_trace, present):
    """``sqrt(mean over present targets of tr[J⁻¹]_pos)`` (0 when none is present)."""
    n = jnp.maximum(jnp.sum(present), 1).astype(bound_trace.dtype)
    return jnp.sqrt(jnp.sum(jnp.where(present, bound_trace, 0.0)) / n)


def health_truth(truth, mean, present):
    """The truth the lost-track detector sees: an absent target's estimate (zero error)."""
    return jnp.where(present[:, None], truth, mean.reshape(truth.shape))


def begin_step(motion, k, dt, vis, state, truth, filt, stream, p0, n: int):
    """Presence at filter step ``k`` (time ``k dt``), after the plant step.

    Args:
        motion: the :class:`~mjx_radar.physics.target_motion.MotionParams`, or None
            (every target always present: returns ``vis`` and ``state`` unchanged).
        vis: [N, M] line of sight, or None.
        state: ``(mean, cov, pfim)``, ``cov`` in the filter's form ``filt`` (P or S).
        truth: [M, 6]; stream: the trial's estimate stream; p0: initial variance.
        n: number of radars N.

    Returns:
        ``(present [M], mask [N, M] of measured pairs or None, state)`` with the tracks
        of appearing targets started (:func:`start_tracks`, :func:`start_pfim`; only
        computed when some target appears).
    """
    m = truth.shape[0]
    if motion is None:
        return jnp.ones(m, bool), vis, state
    here = target_motion.present(motion, k * dt)
    pairs = here[None, :] if vis is None else vis & here[None, :]
    pairs = jnp.broadcast_to(pairs, (n, m))
    mean, cov, pfim = state
    new = target_motion.appears_between(motion, (k - 1) * dt, k * dt)
    key = jax.random.fold_in(stream, k)

    def start(mc):
        mean_p, cov_p = start_tracks(mc[0], filt.cov(mc[1]), new, truth, key, p0)
        return mean_p, filt.carry(cov_p)

    mean, cov = jax.lax.cond(jnp.any(new), start, lambda mc: mc, (mean, cov))
    return here, pairs, (mean, cov, start_pfim(pfim, new, p0))


def plan_params(params, t):
    """``params`` with the planner's target weights (the presence at the planning instant)
    and, with moving obstacles, the planning instant ``t`` (their predicted positions)."""
    if params.moving is not None:
        params = params._replace(plan_time=jnp.asarray(t, params.p0.dtype))
    if params.motion is None:
        return params
    here = target_motion.present(params.motion, t)
    return params._replace(target_weight=here.astype(params.p0.dtype))
