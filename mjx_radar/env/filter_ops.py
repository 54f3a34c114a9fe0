"""The closed loop's tracking filter: CKF predict / update behind one interface.

:func:`make` returns the :class:`FilterOps` of a scenario: the paper's joint CKF, the
per-target bank (``filter.structure = "per-target"``, :mod:`~mjx_radar.estimation.filter_bank`)
in the covariance or square-root form, or the IMM bank (``filter.motion = "imm"``,
:mod:`~mjx_radar.estimation.imm`: CV + coordinated turns, docs/filters.md). Every
variant keeps the joint interface ``mean [6M], cov [6M, 6M]`` (the combined estimate for
the IMM), which is what the metrics, the lost-track detector and the planner see; the
IMM's mode-conditioned state rides along as ``modes`` (an
:class:`~mjx_radar.estimation.imm.ImmState`; ``()`` for the CV filters, so their
programs and numbers are the same as before the IMM).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import jax
import jax.numpy as jnp

from mjx_radar.estimation import (
    ckf_sqrt,
    filter_bank,
    ground_prior,
    imm,
    measurement_filter,
)
from mjx_radar.physics import target_motion
from mjx_radar.task.task import RadarTask, process_noise


class FilterOps(NamedTuple):
    """The filter of a scenario (closures over the task and runtime parameters)."""

    predict: Callable  # (mean, cov, modes) -> (mean, cov, modes) predicted one step
    update: Callable  # (mean, cov, modes, z [N, M, p], radar_pos [N, 3], vis [N, M] | None)
    begin: Callable  # (modes, mean, cov, k) -> modes restarted for targets appearing at k


def init_modes(scenario, mean, cov):
    """The IMM's initial modes (every mode at the initial estimate), or ``()`` without it."""
    if scenario.filter.motion != "imm":
        return ()
    return imm.init(*filter_bank.joint_to_bank(mean, cov))


def keep(ok_pred, ok, post, pred, prev):
    """The modes that match the loop's fallback: posterior if finite, else prediction
    (if finite), else the previous step's (a no-op on ``()``)."""
    pick = lambda a, b, c: jnp.where(ok, a, jnp.where(ok_pred, b, c))  # noqa: E731
    return jax.tree_util.tree_map(pick, post, pred, prev)


def make(task: RadarTask, params) -> FilterOps:
    """The :class:`FilterOps` of ``task.scenario`` with the noise model of ``params.method``."""
    sc = task.scenario
    model = task.measurement
    r_filter = measurement_filter.noise_cov_fn(model, params.noise, params.method.ccr)
    residual = measurement_filter.flat_residual(model) if model.dim > 1 else None
    per_target, form = sc.filter.structure == "per-target", sc.filter.form
    filt = ckf_sqrt.form_ops(form)  # process noise: Q, or a factor of it
    a_f = task.a_filter
    q_f = filt.noise(process_noise(task, params))
    q6 = filt.noise(params.sigma_w2 * task.w6_filter_unit)

    def h_pair(r, x6):
        return model.predict(r[None], x6[None, :3]).reshape(model.dim)

    if sc.filter.motion == "imm":
        return _imm_ops(task, params, q6, h_pair, r_filter, residual)

    def predict(mean, cov, modes):
        if per_target:  # M independent 6-D CKFs (block-diagonal covariance)
            return (*filter_bank.predict_joint(mean, cov, task.a6_filter, q6, form), modes)
        return (*filt.predict(mean, cov, lambda x: a_f @ x, q_f), modes)

    def update(mean, cov, modes, z, radar_pos, vis):
        if per_target:
            means, covs = filter_bank.joint_to_bank(mean, cov)
            post = filter_bank.update_bank(
                means, covs, z, radar_pos, h_pair, r_filter, mask=vis, residual=residual, form=form
            )
            mean, cov = filter_bank.bank_to_joint(*post)
        else:
            keep_ = None if vis is None else jnp.repeat(vis.reshape(-1), model.dim)
            h = measurement_filter.measurement_function(model, radar_pos)
            kw = {} if residual is None else {"residual": residual}
            mean, cov = filt.update(mean, cov, z.reshape(-1), h, r_filter, mask=keep_, **kw)
        if sc.filter.ground_prior:
            mean, cov = ground_prior.apply_ground_prior(mean, cov)
        return mean, cov, modes

    return FilterOps(predict, update, lambda modes, mean, cov, k: modes)


def _imm_ops(task: RadarTask, params, q6, h_pair, r_filter, residual) -> FilterOps:
    """The IMM bank (covariance form, per target; scenario.plausibility enforces both)."""
    sc = task.scenario
    dt = sc.timing.dt_filter
    dtype = q6.dtype
    F = jnp.asarray(imm.mode_transitions(sc.filter.imm_turn_rate, dt), dtype)
    Pi = jnp.asarray(imm.markov_matrix(sc.filter.imm_switch_prob, dt), dtype)
    motion = params.motion

    def joint(modes):
        return filter_bank.bank_to_joint(*imm.combine_bank(modes))

    def predict(mean, cov, modes):
        modes = imm.predict_bank(modes, F, q6, Pi)
        return (*joint(modes), modes)

    def update(mean, cov, modes, z, radar_pos, vis):
        modes = imm.update_bank(modes, z, radar_pos, h_pair, r_filter, mask=vis, residual=residual)
        if sc.filter.ground_prior:  # each mode reflected to z >= 0
            refl = jax.vmap(jax.vmap(ground_prior.apply_ground_prior))
            means, covs = refl(modes.means, modes.covs)
            modes = modes._replace(means=means, covs=covs)
        return (*joint(modes), modes)

    def begin(modes, mean, cov, k):
        if motion is None:  # every target present from the start
            return modes
        new = target_motion.appears_between(motion, (k - 1) * dt, k * dt)  # [M]
        fresh = imm.init(*filter_bank.joint_to_bank(mean, cov))
        sel = lambda a, b: jnp.where(new.reshape((-1,) + (1,) * (a.ndim - 1)), a, b)  # noqa: E731
        return jax.tree_util.tree_map(sel, fresh, modes)

    return FilterOps(predict, update, begin)
