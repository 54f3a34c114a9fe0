"""The tracker contract (:class:`FilterOps`) and the built-in filter forms.

The filter forms (docs/tracking.md, "Roles"): ``"ckf"`` the paper's joint CKF,
``"bank"`` the per-target bank (``filter.structure = "per-target"``,
:mod:`~mjx_radar.estimation.filters.filter_bank`) in the covariance or square-root form,
``"imm"`` the IMM bank (``filter.motion = "imm"``, :mod:`~mjx_radar.estimation.filters.imm`:
CV + coordinated turns, docs/filters.md), and ``"pda"`` the per-target bank with PDA
association of cluttered scans (``[detection] clutter``). :mod:`mjx_radar.env.trackers`
composes the scenario's tracker from its roles; :func:`mjx_radar.register_tracker` adds
a whole one. Every tracker keeps the joint interface ``mean [6M], cov [6M, 6M]`` (the
combined estimate for the IMM), which is what the metrics, the lost-track detector and
the planner see; a tracker's own state rides along as ``modes`` (the IMM's
:class:`~mjx_radar.estimation.filters.imm.ImmState`; ``()`` for the others, so their programs
and numbers are the same as before). The associators ``"jpda"`` and ``"gnn"`` (joint
association of cluttered scans, ``[tracker]``) drive the bank in
:mod:`mjx_radar.env.association_ops`, ``"mht"`` (K association histories across scans)
in :mod:`mjx_radar.env.mht_ops`.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import jax
import jax.numpy as jnp

from mjx_radar.estimation.filters import (
    ckf_sqrt,
    filter_bank,
    ground_prior,
    imm,
    measurement_filter,
)
from mjx_radar.physics import target_motion
from mjx_radar.task.task import RadarTask, process_noise


class FilterOps(NamedTuple):
    """The tracker contract: pure functions (closures over the task and runtime parameters).

    * ``predict(mean, cov, modes) -> (mean, cov, modes)``: one filter step ahead.
    * ``update(mean, cov, modes, z, radar_pos, scan, los) -> (mean, cov, modes)``: the
      scan's measurements; ``z`` ``[N, M, dim]`` per pair, ``scan`` a
      :class:`~mjx_radar.env.scan.Scan` (``seen`` [N, M] pairs detected or None;
      with clutter the unlabelled returns ``zs``, ``valid``), ``los`` [N, M] or None.
    * ``begin(modes, mean, cov, k) -> modes``: restarted for targets appearing at step k.
    * ``init(mean, cov) -> modes``: the tracker's own state at t = 0 (``()`` if none).
    * ``tracks``: None (the joint estimate is indexed like the truth), or for a tracker
      that does not know the drones (``"managed"``, :mod:`~mjx_radar.env.managed`)
      ``tracks(modes) -> (mean [K, 6], cov [K, 6, 6], weight [K], exist [K])``: its K
      track slots, the planner's weight of each and whether it is a confirmed track.
      The planner, the reward and the records then use these instead of the joint one.
    * ``plan_view``: None (the planner plans from the joint estimate), or
      ``plan_view(mean, cov, modes) -> (mean, cov)``: the joint estimate the planner sees
      instead (the MHT's mixture of its hypotheses, ``[tracker] plan_on``); the metrics
      and the reward keep the tracker's own.
    * ``keep``: None (a non-finite update falls back leaf by leaf, :func:`keep`), or
      ``keep(ok_pred, ok, post, pred, prev) -> modes`` the tracker's own fallback (the
      MHT's scan counter follows the loop's step whatever the update gave).

    ``cov`` is P, or its factor S with ``filter.form = "sqrt"``.
    """

    predict: Callable
    update: Callable
    begin: Callable
    init: Callable = lambda mean, cov: ()  # noqa: E731
    tracks: Callable | None = None
    plan_view: Callable | None = None
    keep: Callable | None = None


def keep(ok_pred, ok, post, pred, prev):
    """The modes that match the loop's fallback: posterior if finite, else prediction
    (if finite), else the previous step's (a no-op on ``()``)."""
    pick = lambda a, b, c: jnp.where(ok, a, jnp.where(ok_pred, b, c))  # noqa: E731
    return jax.tree_util.tree_map(pick, post, pred, prev)


def _cv_ops(task: RadarTask, params, per_target: bool) -> FilterOps:
    """The CV trackers: joint CKF or per-target bank, covariance or square-root form."""
    model = task.measurement
    r_filter = measurement_filter.noise_cov_fn(model, params.noise, params.method.ccr)
    residual = measurement_filter.flat_residual(model) if model.dim > 1 else None
    form = task.filter.form
    filt = ckf_sqrt.form_ops(form)  # process noise: Q, or a factor of it
    a_f = task.a_filter
    q_f = filt.noise(process_noise(task, params))
    q6 = filt.noise(params.sigma_w2 * task.w6_filter_unit)

    def h_pair(r, x6):
        return model.predict(r[None], x6[None, :3]).reshape(model.dim)

    def predict(mean, cov, modes):
        if per_target:  # M independent 6-D CKFs (block-diagonal covariance)
            return (*filter_bank.predict_joint(mean, cov, task.a6_filter, q6, form), modes)
        return (*filt.predict(mean, cov, lambda x: a_f @ x, q_f), modes)

    def update(mean, cov, modes, z, radar_pos, scan, los=None):
        vis = scan.seen
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
        if task.filter.ground_prior:
            mean, cov = ground_prior.apply_ground_prior(mean, cov)
        return mean, cov, modes

    return FilterOps(predict, update, lambda modes, mean, cov, k: modes)


def joint_ckf(task: RadarTask, params) -> FilterOps:
    """``"ckf"``: the paper's joint CKF over the stacked state ``[6M]``."""
    return _cv_ops(task, params, per_target=False)


def ckf_bank(task: RadarTask, params) -> FilterOps:
    """``"bank"``: M independent 6-D CKFs (block-diagonal covariance)."""
    return _cv_ops(task, params, per_target=True)


def pda_bank(task: RadarTask, params) -> FilterOps:
    """``"pda"``: the per-target bank (covariance form) with sequential PDA of cluttered
    scans (:func:`~mjx_radar.env.scan.pda_update`)."""
    return clutter_bank(task, params)


def clutter_bank(task: RadarTask, params, assoc=None) -> FilterOps:
    """The per-target bank (covariance form) updating from cluttered scans: per-target PDA,
    or with ``assoc`` a joint association rule (:mod:`mjx_radar.env.association_ops`)."""
    model = task.measurement
    bank = _cv_ops(task, params, per_target=True)

    def update(mean, cov, modes, z, radar_pos, scan_, los=None):
        if scan_.zs is None:  # no clutter buffer: the bank's update of the detected pairs
            return bank.update(mean, cov, modes, z, radar_pos, scan_, los)
        from mjx_radar.env.scan import pda_update

        ccr = params.method.ccr
        post = pda_update(task, params, model, ccr, mean, cov, scan_, radar_pos, los, assoc)
        return (*post, modes)

    return bank._replace(update=update)


def imm_bank(task: RadarTask, params) -> FilterOps:
    """``"imm"``: the IMM bank (covariance form, per target; io.plausibility enforces both)."""
    model = task.measurement
    r_filter = measurement_filter.noise_cov_fn(model, params.noise, params.method.ccr)
    residual = measurement_filter.flat_residual(model) if model.dim > 1 else None
    q6 = ckf_sqrt.form_ops(task.filter.form).noise(params.sigma_w2 * task.w6_filter_unit)

    def h_pair(r, x6):
        return model.predict(r[None], x6[None, :3]).reshape(model.dim)

    dt = task.timing.dt_filter
    dtype = q6.dtype
    F = jnp.asarray(imm.mode_transitions(task.filter.imm_turn_rate, dt), dtype)
    Pi = jnp.asarray(imm.markov_matrix(task.filter.imm_switch_prob, dt), dtype)
    motion = params.motion

    def joint(modes):
        return filter_bank.bank_to_joint(*imm.combine_bank(modes))

    def predict(mean, cov, modes):
        modes = imm.predict_bank(modes, F, q6, Pi)
        return (*joint(modes), modes)

    def update(mean, cov, modes, z, radar_pos, scan, los=None):
        modes = imm.update_bank(
            modes, z, radar_pos, h_pair, r_filter, mask=scan.seen, residual=residual
        )
        if task.filter.ground_prior:  # each mode reflected to z >= 0
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

    def init(mean, cov):  # every mode at the initial estimate
        return imm.init(*filter_bank.joint_to_bank(mean, cov))

    return FilterOps(predict, update, begin, init)
