"""One scan's detections and false alarms, and the PDA update of the bank (issue 23).

The closed loop (:mod:`mjx_radar.loop.closed_loop`) asks :func:`observe` what the
radars report at filter step k: with a Pd model each visible pair is detected with its
Pd (:mod:`mjx_radar.estimation.sensor.detection`), with clutter every radar's scan is the
fixed buffer of its detected returns and its false alarms
(:mod:`mjx_radar.estimation.sensor.clutter`), which :func:`pda_update` associates per target
(:mod:`mjx_radar.estimation.data_association.pda`). Draws come from the trial's detection streams
(:func:`mjx_radar.env.streams.detection_streams`), folded with k.

A missed pair is skipped like a blocked one (the CKF ``mask``) and the PCRLB counts the
pairs detected (it ignores the clutter: a bound conditioned on the detections). The
joint filter has no association: the scenario reader refuses it with clutter.
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp

from mjx_radar.env.streams import detection_streams_of
from mjx_radar.estimation.data_association import jpda, pda
from mjx_radar.estimation.filters import filter_bank, ground_prior
from mjx_radar.estimation.sensor import clutter, detection


class Scan(NamedTuple):
    """What the radars report at one scan."""

    seen: jax.Array | None  # [N, M] bool visible and detected (None: every pair)
    n_vis: jax.Array  # [] int32 pairs with line of sight
    n_det: jax.Array  # [] int32 pairs detected
    n_fa: jax.Array  # [] int32 false alarms of all radars
    zs: jax.Array | None  # [N, M + cap, dim] scans (clutter only)
    valid: jax.Array | None  # [N, M + cap]


def observe(det_cfg, params, key, k, radar_pos, target_pos, z, vis) -> Scan:
    """Detections (and false alarms) of scan ``k`` from the truth geometry.

    Args:
        det_cfg: the scenario's :class:`~mjx_radar.scenario.schema.DetectionConfig` (static).
        params: :class:`~mjx_radar.task.params.TaskParams`.
        key: the trial's key (:func:`~mjx_radar.env.streams.trial_key`): its
            detection streams.
        k: filter step (traced int).
        radar_pos: ``[N, 3]``; target_pos: ``[M, 3]`` true positions.
        z: ``[N, M, dim]`` the pairs' measurements; vis: ``[N, M]`` line of sight or None.
    """
    n, m, dim = z.shape
    n_vis = jnp.int32(n * m) if vis is None else jnp.sum(vis).astype(jnp.int32)
    streams = detection_streams_of(key)
    seen, n_det, n_fa, zs, valid = vis, n_vis, jnp.int32(0), None, None
    if det_cfg.detects:  # a missed pair is skipped like a blocked one
        key = jax.random.fold_in(streams.detection, k)
        hit = detection.draw_pairs(det_cfg.model, params.detection, key, radar_pos, target_pos)
        seen = hit if vis is None else vis & hit
        n_det = jnp.sum(seen).astype(jnp.int32)
    if det_cfg.clutter:  # unlabelled scans: detected returns, then false alarms
        key = jax.random.fold_in(streams.clutter, k)
        zc, vc, counts = clutter.sample_clutter(
            key, params.detection, n, det_cfg.max_false_alarms, dim
        )
        zs, valid = clutter.scan_buffer(z, jnp.ones((n, m), bool) if seen is None else seen, zc, vc)
        n_fa = jnp.sum(counts).astype(jnp.int32)
    return Scan(seen, n_vis, n_det, n_fa, zs, valid)


def pda_update(task, params, model, ccr, mean, cov, scan: Scan, radar_pos, los, assoc=None):
    """Sequential PDA per target of a scan with clutter (per-target bank, covariance form),
    or with ``assoc`` a joint association rule
    (:func:`mjx_radar.estimation.data_association.jpda.rule`) of
    all targets per radar (:func:`mjx_radar.estimation.data_association.jpda.update_bank`).

    The filter's Pd of a pair is the model's at the predicted range (0 where ``los`` says
    the pair is blocked); the clutter density per unit measurement volume is
    :func:`clutter.density`. ``filter.ground_prior`` applies after the update.

    Returns:
        ``(mean[6M], cov[6M, 6M])`` with a block-diagonal covariance.
    """
    det_cfg = task.detection
    means, covs = filter_bank.joint_to_bank(mean, cov)
    d2 = jnp.sum((means[None, :, :3] - radar_pos[:, None, :]) ** 2, -1)  # [N, M]
    pd = detection.pair_probability(det_cfg.model, params.detection, d2)
    pd = pd if los is None else jnp.where(los, pd, 0.0)
    dp = params.detection
    args = (means, covs, scan.zs, scan.valid, radar_pos, model, params.noise, ccr, pd)
    tail = (clutter.density(dp, model.dim), dp.gate, dp.gate_probability)
    if assoc is None:
        post = pda.update_bank(*args, *tail)
    else:
        post = jpda.update_bank(*args, *tail, assoc)
    mean, cov = filter_bank.bank_to_joint(*post)
    if task.filter.ground_prior:
        mean, cov = ground_prior.apply_ground_prior(mean, cov)
    return mean, cov
