"""The closed loop of paper Algorithm 1 (SPEC §8) for one trial, vmappable over trials.

Per 25 ms filter step k = 1..K::

    CKF predict                         (x_k|k-1, P_k|k-1)
    every dt_control: MPPI from the predicted estimate -> radar control u
    MJX plant step: drones fly (white acceleration w_k), radars actuate u
    measure all N*M round-trip ranges with the true DDR noise
    CKF update (DDR or CCR noise model, per method)

The drones' motion does not depend on the control and the prediction does not
depend on the truth, so stepping drones and radars in one MJX step after
planning is the same as the paper's order (truth, predict, plan, actuate).

Random numbers (common random numbers, SPEC §9): a trial's key is
``fold_in(PRNGKey(seed), trial)`` split into fixed streams for the placement,
the initial estimate error, the drones' noise, the measurement noise and MPPI,
so every method sees the same truth, placement and noise draws.

Obstacles (docs/obstacles.md): a radar-target pair whose straight segment is
blocked yields no measurement -- the CKF update skips it exactly (``mask``) and
it adds no information to the PCRLB; contacts are counted per step. Missed detections
and clutter: :mod:`~mjx_radar.env.scan`; targets that appear / leave are masked out
of measurements, planner cost and metrics: :mod:`~mjx_radar.env.presence`."""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp

from mjx_radar import precision
from mjx_radar.control import mppi
from mjx_radar.env import filter_ops, placement, presence, scan, track_health
from mjx_radar.env.records import (
    ControlRecord,
    StepRecord,
    TrialResult,
    kept_samples,
)
from mjx_radar.env.streams import trial_streams
from mjx_radar.estimation import ckf_sqrt, fisher, linalg, measurement
from mjx_radar.physics import plant as physics
from mjx_radar.physics import target_motion
from mjx_radar.task.planner import make_planner
from mjx_radar.task.task import RadarTask
from mjx_radar.world import moving


class LoopCarry(NamedTuple):
    """State of a trial between control periods (a pytree; vmappable)."""

    data: object  # mjx.Data of the truth plant (radars + drones)
    mean: jax.Array  # [6M] posterior mean
    cov: jax.Array  # [6M, 6M] posterior covariance P, or its factor S (filter.form = "sqrt")
    pfim: jax.Array  # [M, 6, 6] PFIM along the true trajectory (for the PCRLB)
    u_plan: jax.Array  # [H, 2N] warm start of MPPI
    health: track_health.HealthState  # lost-track detector state
    modes: object = ()  # the IMM's imm.ImmState (filter.motion = "imm"; mean/cov combined)


@precision.pinned  # full float32 dots, also on GPUs (mjx_radar.precision)
def init_carry(task: RadarTask, params, trial) -> tuple[LoopCarry, jax.Array]:
    """Initial loop state of a trial and whether its radars could be placed."""
    sc = task.scenario
    init = placement.initial_conditions(sc, params, trial_streams(params.seed, trial))
    m, n = sc.n_targets, sc.n_radars
    return LoopCarry(
        data=physics.init_data(task.truth, init.radar_state, init.target_state),
        mean=init.mean,
        cov=ckf_sqrt.form_ops(sc.filter.form).carry(init.cov),  # P, or S for "sqrt"
        pfim=jnp.broadcast_to(jnp.eye(6) / params.p0, (m, 6, 6)),
        u_plan=jnp.zeros((sc.mpc.horizon, 2 * n)),
        health=track_health.init_health(m),
        modes=filter_ops.init_modes(sc, init.mean, init.cov),
    ), init.ok


def _idle_plan(task: RadarTask, u_plan):
    """The control record of a period without planning (radars stay put)."""
    sc = task.scenario
    n, h = sc.n_radars, sc.mpc.horizon
    zeros = jnp.zeros((n, 2))
    s = kept_samples(sc)
    rec = ControlRecord(
        zeros, jnp.zeros((h, n, 2)), jnp.zeros((s, h, n, 2)), jnp.zeros(s), jnp.zeros(s)
    )
    return zeros, u_plan, rec


class Stages(NamedTuple):
    """One control period of a trial in two stages (closures over task, params, trial).

    * ``plan(carry, j) -> (u, u_plan, controls)``: MPPI at control step ``j`` (traced
      int); ``u`` [N, 2] is applied over the period, ``u_plan`` [H, 2N] the next warm
      start, ``controls`` its :class:`ControlRecord`.
    * ``period(carry, j, u, u_plan) -> (carry, steps)``: the period's ``control_every``
      filter steps (truth, measurement, CKF, metrics) under ``u``; ``steps`` a
      :class:`StepRecord` of leading size ``control_every``.
    """

    plan: object
    period: object


@precision.pinned  # the whole closed loop is traced inside (mjx_radar.precision)
def advance(
    task: RadarTask, params, trial, carry: LoopCarry, start, periods: int
) -> tuple[LoopCarry, StepRecord, ControlRecord]:
    """Advances a trial by ``periods`` control periods starting at control step ``start``.

    Args:
        task: the scenario's task (static).
        params: :class:`~mjx_radar.task.params.TaskParams` (runtime; method included).
        trial: trial index (traced).
        carry: the loop state after ``start`` control periods.
        start: index of the first control period (traced int).
        periods: number of control periods (static).

    Returns:
        ``(carry, steps, controls)``: steps with leading size periods * control_every,
        controls with leading size ``periods``.
    """
    every = task.scenario.timing.control_every
    st = stages(task, params, trial)

    def control_period(lc: LoopCarry, j):
        u, u_plan, crec = st.plan(lc, j)
        lc, srec = st.period(lc, j, u, u_plan)
        return lc, (srec, crec)

    js = start + jnp.arange(periods)
    carry, (srec, crec) = jax.lax.scan(control_period, carry, js)
    srec = jax.tree_util.tree_map(lambda x: x.reshape((periods * every,) + x.shape[2:]), srec)
    return carry, srec, crec


def stages(task: RadarTask, params, trial) -> Stages:
    """The two :class:`Stages` of a control period (traced inside a pinned program)."""
    sc = task.scenario
    every = sc.timing.control_every
    n = sc.n_radars
    model, noise, flags = task.measurement, params.noise, params.method
    plant = task.truth
    w6 = params.sigma_w2 * task.w6_filter_unit
    planner = make_planner(task) if task.kind != "none" else None
    streams = trial_streams(params.seed, trial)
    filt = ckf_sqrt.form_ops(sc.filter.form)  # "sqrt": the carried cov is S of P = S Sᵀ
    fops = filter_ops.make(task, params)  # CKF (joint or bank) or IMM predict / update
    motion = params.motion  # None without [[target_motion]] (the paper's CV drones)
    dt = sc.timing.dt_filter

    def filter_step(carry, k, u):
        data, mean0, cov0, pfim, health, modes0 = carry
        mean, cov, modes_p = fops.predict(mean0, cov0, modes0)
        accel_key = jax.random.fold_in(streams.drones, k)
        data = target_motion.step_plant(
            plant, data, u, motion, accel_key, k, params.sigma_w2, params.moving
        )
        radars = physics.radar_state(plant, data)
        truth = physics.target_state(plant, data)
        key = jax.random.fold_in(streams.measurement, k)
        z = model.sample(key, radars[:, :3], truth[:, :3], noise)  # [N, M, dim]
        # [N, M] line of sight (truth geometry, vehicles at t_k; None: all clear)
        vis = moving.truth_visibility(task, params, radars[:, :3], truth[:, :3], k * dt)
        # [M] present targets (absent: not measured); tracks start as targets appear
        here, vis, (mean, cov, pfim) = presence.begin_step(
            motion, k, dt, vis, (mean, cov, pfim), truth, filt, streams.estimate, params.p0, n
        )
        modes_p = fops.begin(modes_p, mean, cov, k)  # the IMM's modes of appearing targets
        obs = scan.observe(sc.detection, params, trial, k, radars[:, :3], truth[:, :3], z, vis)
        post = (
            (
                *scan.pda_update(sc, params, model, flags.ccr, mean, cov, obs, radars[:, :3], vis),
                modes_p,
            )
            if sc.detection.clutter
            else fops.update(mean, cov, modes_p, z, radars[:, :3], obs.seen)
        )
        # A diverged misspecified filter (CCR noise model) can overflow float32 in the
        # update; keep the prediction then (or, if that overflowed too, the last
        # estimate), so no NaN ever propagates (SPEC §4). The detector flags the trial.
        finite = lambda a, b: jnp.all(jnp.isfinite(a)) & jnp.all(jnp.isfinite(b))  # noqa: E731
        ok_pred, ok = finite(mean, cov), finite(*post[:2])
        blown = ~(ok_pred & ok)
        modes = filter_ops.keep(ok_pred, ok, post[2], modes_p, modes0)
        mean, cov = jnp.where(ok_pred, mean, mean0), jnp.where(ok_pred, cov, cov0)
        mean, cov = jnp.where(ok, post[0], mean), jnp.where(ok, post[1], cov)
        cov_p = filt.cov(cov)  # P for the detector, metrics and records (S Sᵀ for "sqrt")
        truth_h = presence.health_truth(truth, mean, here)  # absent targets: no error
        health, flags_h = track_health.step_health(health, truth_h, mean, cov_p, dt)
        diverged = flags_h.diverged | blown
        # PFIM along the true trajectory with the true (DDR) model: the PCRLB.
        j3 = measurement.information_dense(
            model, radars[:, :3], truth[:, :3], noise, jnp.asarray(False), mask=obs.seen
        )
        jd = fisher.data_information(j3)
        pfim = jax.vmap(fisher.pfim_step, (0, None, None, 0))(pfim, task.a6_filter, w6, jd)
        bound = jnp.trace(linalg.psd_inv(pfim)[:, :3, :3], axis1=-2, axis2=-1)  # [M]
        everyone = None if motion is None else here
        crlb, rmse_pos, rmse_state, nees = presence.metrics(bound, truth, mean, cov_p, everyone)
        contacts = physics.obstacle_contacts(plant, data)
        rec = StepRecord(
            truth,
            mean,
            jnp.diagonal(cov_p),
            radars,
            rmse_pos,
            rmse_state,
            nees,
            crlb,
            contacts,
            obs.n_vis,
            obs.n_det,
            obs.n_fa,
            flags_h.lost | diverged,
            diverged,
            jnp.sum(here).astype(jnp.int32),
        )
        return (data, mean, cov, pfim, health, modes), rec

    def plan(loop, j, u_plan):
        data, mean, cov = loop[:3]
        # MPPI plans from the estimate at the radars' instant (mpc.aligned), or -- as
        # the paper's code -- from the estimate predicted one filter step ahead.
        pm, pc = (mean, cov) if sc.mpc.aligned else fops.predict(mean, cov, loop[5])[:2]
        pc = filt.cov(pc)  # the planner takes P
        key = jax.random.fold_in(streams.planner, j)
        p_plan = presence.plan_params(params, j * every * dt)  # presence, vehicles' time
        res, mean_plan = planner(physics.radar_state(plant, data), pm, pc, u_plan, key, p_plan)
        keep = slice(0, kept_samples(sc))
        rec = ControlRecord(
            res.mean[0].reshape(n, 2),
            mean_plan.radar_xy,
            res.aux.radar_xy[keep],
            res.weights[keep],
            res.costs[keep],
        )
        return rec.control, mppi.shift(res.mean), rec

    def plan_stage(lc: LoopCarry, j):
        loop = (lc.data, lc.mean, lc.cov, lc.pfim, lc.health, lc.modes)
        if task.kind == "none":  # stationary program: no planner compiled
            return _idle_plan(task, lc.u_plan)
        if task.kind != "all":  # one information kind: always plans
            return plan(loop, j, lc.u_plan)
        return jax.lax.cond(
            flags.plans, lambda: plan(loop, j, lc.u_plan), lambda: _idle_plan(task, lc.u_plan)
        )

    def period_stage(lc: LoopCarry, j, u, u_plan):
        loop = (lc.data, lc.mean, lc.cov, lc.pfim, lc.health, lc.modes)
        ks = j * every + 1 + jnp.arange(every)
        loop, srec = jax.lax.scan(lambda c_, k: filter_step(c_, k, u), loop, ks)
        data, mean, cov, pfim, health, modes = loop
        return LoopCarry(data, mean, cov, pfim, u_plan, health, modes), srec

    return Stages(plan_stage, period_stage)


def simulate(task: RadarTask, params, trial, steps: int | None = None):
    """Runs one closed-loop trial from its start.

    Args:
        task: the scenario's task (static).
        params: runtime parameters (method, numbers, seed).
        trial: trial index (traced int; vmap over it for many trials).
        steps: number of filter steps K (static); default ``scenario.timing.steps``.

    Returns:
        :class:`TrialResult` with ``steps`` of leading size K and ``controls`` of
        leading size K / control_every.
    """
    sc = task.scenario
    k_total = sc.timing.steps if steps is None else steps
    every = sc.timing.control_every
    if k_total % every:
        raise ValueError(f"steps: {k_total} must be a multiple of {every}")
    carry, ok = init_carry(task, params, trial)
    _, srec, crec = advance(task, params, trial, carry, 0, k_total // every)
    return TrialResult(srec, crec, ok)
