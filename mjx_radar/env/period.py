"""One filter step of the closed loop (paper Algorithm 1, SPEC §8), under a held control.

Per 25 ms filter step k: tracker predict, the MJX plant step (drones fly, radars
actuate ``u``), every radar measures every drone (DDR noise), line of sight, presence,
detections and clutter (:mod:`~mjx_radar.env.scan`), tracker update (PDA with
clutter), the lost-track detector, the PCRLB along the truth and the step's metrics.
The drones' motion does not depend on the control and the prediction does not depend
on the truth, so stepping drones and radars in one MJX step after planning is the same
as the paper's order (truth, predict, plan, actuate).

Obstacles (docs/obstacles.md): a radar-target pair whose straight segment is blocked
yields no measurement -- the update skips it exactly (``mask``) and it adds no
information to the PCRLB; contacts are counted per step. Targets that appear / leave are
masked out of measurements, planner cost and metrics (:mod:`~mjx_radar.env.presence`).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from mjx_radar.env import filter_ops, managed, presence, scan, track_health
from mjx_radar.env.records import StepRecord
from mjx_radar.env.streams import streams_of
from mjx_radar.estimation import linalg
from mjx_radar.estimation.filters import ckf_sqrt
from mjx_radar.estimation.information import fisher
from mjx_radar.estimation.sensor import measurement
from mjx_radar.physics import plant as physics
from mjx_radar.physics import target_motion
from mjx_radar.world import moving


def make_filter_step(task, params, key, tracker: filter_ops.FilterOps):
    """``filter_step(loop, k, u) -> (loop, (StepRecord, seen [N, M]))`` of one trial.

    Args:
        task: the scenario's task (static); params: its runtime parameters.
        key: the trial's key (:func:`~mjx_radar.env.streams.trial_key`).
        tracker: the scenario's :class:`~mjx_radar.env.filter_ops.FilterOps`.

    ``loop`` is an :class:`~mjx_radar.env.state.LoopState`, ``k`` the filter step
    (traced int, 1-based), ``u`` ``[N, 2]`` the radars' held control.
    """
    n, m = task.fleet.n_radars, task.n_targets
    model, noise = task.measurement, params.noise
    plant = task.truth
    w6 = params.sigma_w2 * task.w6_filter_unit
    streams = streams_of(key)
    filt = ckf_sqrt.form_ops(task.filter.form)  # "sqrt": the carried cov is S of P = S Sᵀ
    motion = params.motion  # None without [[target_motion]] (the paper's CV drones)
    dt = task.timing.dt_filter

    def filter_step(loop, k, u):
        data, mean0, cov0, pfim, health, modes0 = loop
        mean, cov, modes_p = tracker.predict(mean0, cov0, modes0)
        accel_key = jax.random.fold_in(streams.drones, k)
        data = target_motion.step_plant(
            plant, data, u, motion, accel_key, k, params.sigma_w2, params.moving
        )
        radars = physics.radar_state(plant, data)
        truth = physics.target_state(plant, data)
        z = model.sample(
            jax.random.fold_in(streams.measurement, k), radars[:, :3], truth[:, :3], noise
        )
        # [N, M] line of sight (truth geometry, vehicles at t_k; None: all clear)
        vis = moving.truth_visibility(task.world, params, radars[:, :3], truth[:, :3], k * dt)
        # [M] present targets (absent: not measured); tracks start as targets appear
        here, vis, (mean, cov, pfim) = presence.begin_step(
            motion, k, dt, vis, (mean, cov, pfim), truth, filt, streams.estimate, params.p0, n
        )
        modes_p = tracker.begin(modes_p, mean, cov, k)  # the IMM's modes of appearing targets
        obs = scan.observe(task.detection, params, key, k, radars[:, :3], truth[:, :3], z, vis)
        post = tracker.update(mean, cov, modes_p, z, radars[:, :3], obs, vis)
        prior = ((mean0, cov0, modes0), (mean, cov, modes_p))
        mean, cov, modes, blown = finite_update(*prior, post, tracker.keep or filter_ops.keep)
        (track_pos, track_exist), (mean, cov) = tracks_of(
            tracker, modes, (mean, cov), truth, here, params.p0
        )
        cov_p = filt.cov(cov)  # P for the detector, metrics and records (S Sᵀ for "sqrt")
        truth_h = presence.health_truth(truth, mean, here)  # absent targets: no error
        health, flags_h = track_health.step_health(health, truth_h, mean, cov_p, dt)
        diverged = flags_h.diverged | blown
        pfim, bound = pcrlb_step(model, radars, truth, noise, obs.seen, pfim, (task.a6_filter, w6))
        everyone = None if motion is None else here
        crlb, rmse_pos, rmse_state, nees = presence.metrics(bound, truth, mean, cov_p, everyone)
        seen = jnp.ones((n, m), bool) if obs.seen is None else obs.seen
        rec = StepRecord(
            truth,
            mean,
            jnp.diagonal(cov_p),
            radars,
            rmse_pos,
            rmse_state,
            nees,
            crlb,
            physics.obstacle_contacts(plant, data),
            obs.n_vis,
            obs.n_det,
            obs.n_fa,
            flags_h.lost | diverged,
            diverged,
            jnp.sum(here).astype(jnp.int32),
            here,
            track_pos,
            track_exist,
            jnp.ones((n, m), bool) if vis is None else jnp.broadcast_to(vis, (n, m)),
            seen,
        )
        return type(loop)(data, mean, cov, pfim, health, modes), (rec, seen)

    return filter_step


def finite_update(before, predicted, post, keep=filter_ops.keep):
    """``(mean, cov, modes, blown)``: the update where it is finite.

    A diverged misspecified filter (CCR noise model) can overflow float32 in the update;
    keep the prediction then (or, if that overflowed too, the last estimate), so no NaN
    ever propagates (SPEC §4). ``blown`` flags the step (the detector flags the trial).

    Args:
        before: ``(mean, cov, modes)`` of the last step.
        predicted: ``(mean, cov, modes)`` of the prediction.
        post: ``(mean, cov, modes, ...)`` of the tracker's update.
        keep: the modes' fallback (:attr:`~mjx_radar.env.filter_ops.FilterOps.keep`).
    """
    (mean0, cov0, modes0), (mean, cov, modes_p) = before, predicted
    finite = lambda a, b: jnp.all(jnp.isfinite(a)) & jnp.all(jnp.isfinite(b))  # noqa: E731
    ok_pred, ok = finite(mean, cov), finite(*post[:2])
    blown = ~(ok_pred & ok)
    modes = keep(ok_pred, ok, post[2], modes_p, modes0)
    mean, cov = jnp.where(ok_pred, mean, mean0), jnp.where(ok_pred, cov, cov0)
    mean, cov = jnp.where(ok, post[0], mean), jnp.where(ok, post[1], cov)
    return mean, cov, modes, blown


def tracks_of(tracker, modes, estimate, truth, here, p0):
    """``((track_pos [K, 3], track_exist [K]), (mean, cov))`` of the step's estimate.

    The joint estimate is indexed like the truth (K = M, existing where present); a track
    table's metrics use its confirmed tracks assigned to the drones
    (:func:`~mjx_radar.env.managed.truth_view`).
    """
    mean, cov = estimate
    if tracker.tracks is None:  # the joint estimate, indexed like the truth
        return (mean.reshape(truth.shape[0], 6)[:, :3], here), (mean, cov)
    view = tracker.tracks(modes)
    return (view.mean[:, :3], view.exist), managed.truth_view(truth, here, view, p0)


def pcrlb_step(model, radars, truth, noise, seen, pfim, process):
    """``(pfim, bound [M])``: the PFIM along the true trajectory with the true (DDR) model,
    one step (``process``: ``(A, W)`` of the filter step), and the PCRLB's position trace."""
    j3 = measurement.information_dense(
        model, radars[:, :3], truth[:, :3], noise, jnp.asarray(False), mask=seen
    )
    jd = fisher.data_information(j3)
    a6, w6 = process
    pfim = jax.vmap(fisher.pfim_step, (0, None, None, 0))(pfim, a6, w6, jd)
    bound = jnp.trace(linalg.psd_inv(pfim)[:, :3, :3], axis1=-2, axis2=-1)  # [M]
    return pfim, bound
