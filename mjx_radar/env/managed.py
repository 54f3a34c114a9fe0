"""The ``"managed"`` tracker: a track table for an unknown, changing number of drones (issue 35).

Selected by ``[tracker] management = "managed"`` (docs/track_management.md). Its own
state (``modes``) is a :class:`~mjx_radar.estimation.tracks.track_table.TrackTable` of
``max_tracks`` slots; it never reads the joint estimate ``[6M]`` the loop carries (which
is indexed like the truth), nor the presence of the drones, nor the order of the
returns (each radar's buffer is sorted by range). Per scan:

1. predict every live slot (CV, the filter's process noise; with ``height_std > 0`` the
   altitude pseudo-measurement of :mod:`~mjx_radar.estimation.tracks.altitude`, with
   ``height_scans > 0`` only on tracks younger than that many scans);
2. associate the scans to the live slots (the per-track PDA associator by default,
   ``association = "gnn"`` the joint GNN assignment,
   :mod:`~mjx_radar.estimation.tracks.track_update`; any associator of that signature drops in
   through ``managed_tracker(..., associator=...)``);
3. the life cycle: hits, M-of-N confirmation, deletion (:func:`track_table.maintain`;
   with ``vanish_misses > 0`` sooner for a track no radar sees);
4. births from the returns no live track explains (:mod:`~mjx_radar.estimation.tracks.track_birth`;
   with ``birth_shared = s > 0`` at most s of a birth's returns may be claimed ones;
   with ``birth_scans > 1`` through the candidates of
   :mod:`~mjx_radar.estimation.tracks.multiscan_birth`, and ``modes`` is ``(table, candidates)``).

``FilterOps.tracks`` shows the table (:class:`~mjx_radar.estimation.tracks.track_table.TrackView`):
the planner plans for it, the records hold it. For the loop's metrics (RMSE, NEES, the
lost-track detector) :func:`truth_view` assigns confirmed tracks to the present drones.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from mjx_radar.env.filter_ops import FilterOps
from mjx_radar.estimation.sensor import clutter
from mjx_radar.estimation.tracks import (
    altitude,
    multiscan_birth,
    track_birth,
    track_table,
    track_update,
)

__all__ = ["managed_tracker", "life_rules", "truth_view", "CUTOFF_M", "DENSITY_FLOOR"]

#: assignment cut-off of :func:`truth_view` [m] (= the lost-track detector's error floor)
CUTOFF_M = 50.0
#: clutter density per unit measurement volume the PDA assumes without clutter
DENSITY_FLOOR = 1e-6


def managed_tracker(task, params, associator=None) -> FilterOps:
    """The managed tracker of ``task.tracker`` (module docstring).

    Args:
        task, params: the scenario's task and runtime parameters.
        associator: ``factory(task, params) -> associate`` (the signature of
            :mod:`~mjx_radar.estimation.tracks.track_update`); default per-track PDA.
    """
    model, cfg = task.measurement, task.tracker
    n, k = task.fleet.n_radars, cfg.max_tracks
    hit_r, birth_r = cfg.radars_needed(n, model.dim)
    rules = life_rules(cfg)
    births = track_birth.BirthSettings(
        cfg.max_births, birth_r, cfg.birth_height, cfg.birth_height_std, cfg.birth_speed_std
    )._replace(shared=cfg.birth_shared)
    multi = cfg.birth_scans > 1  # multi-scan births: modes = (table, candidates)
    ms = _multiscan_settings(cfg, model.dim)
    a6 = task.a6_filter
    q6 = params.sigma_w2 * task.w6_filter_unit
    dp, ccr = params.detection, params.method.ccr
    p_empty = params.p0
    associate = _associator(task, params) if associator is None else associator(task, params)

    def init(mean, cov):  # no track: the tracker is not told where the drones start
        table = track_table.empty(k, n, mean.dtype, p_empty)
        return (
            (table, multiscan_birth.empty(ms.capacity, n, mean.dtype, p_empty)) if multi else table
        )

    def predict(mean, cov, modes):
        table = modes[0] if multi else modes
        on = track_table.live(table)
        a = a6.astype(table.mean.dtype)
        m = table.mean @ a.T
        p = jnp.einsum("ij,kjl,ml->kim", a, table.cov, a) + q6.astype(table.cov.dtype)
        m = jnp.where(on[:, None], m, table.mean)
        p = jnp.where(on[:, None, None], p, table.cov)
        if cfg.height_std > 0:  # the altitude pseudo-measurement (off by default)
            young = on & (table.age < cfg.height_scans) if cfg.height_scans else on
            m, p = altitude.height_update(m, p, young, cfg.birth_height, cfg.height_std**2)
        table = table._replace(mean=m, cov=p)
        return mean, cov, ((table, modes[1]) if multi else table)

    def update(mean, cov, modes, z, radar_pos, scan, los=None):
        table, cands = modes if multi else (modes, None)
        if scan.zs is None:  # no clutter: the detected returns are the scan
            valid = jnp.ones(z.shape[:2], bool) if scan.seen is None else scan.seen
            zs = z
        else:
            zs, valid = scan.zs, scan.valid
        zs, valid = track_update.sorted_scans(zs, valid)
        table, hit, explained = track_update.update(table, zs, valid, radar_pos, associate, hit_r)
        table = track_table.maintain(table, hit, rules, p_empty)
        r_var = track_birth.scan_variances(model, zs, params.noise, ccr)
        avoid = (table.mean[:, :3], table.cov[:, :3, :3], track_table.live(table))
        free = valid & ~explained
        args = (model, zs, free, r_var, radar_pos, dp.gate, births, avoid, valid)
        if multi:
            fits = track_birth.fit_seeds(*args)
            new, cands = multiscan_birth.step(cands, fits, a6, ms, avoid, p_empty)
            return mean, cov, (track_table.insert(table, *new), cands)
        new = track_birth.births(*args)
        return mean, cov, track_table.insert(table, *new)

    def tracks(modes):
        return track_table.view(modes[0] if multi else modes, cfg.tentative_weight)

    return FilterOps(predict, update, lambda modes, mean, cov, k: modes, init, tracks)


def life_rules(cfg) -> track_table.LifeRules:
    """The table's confirmation and deletion rules of ``[tracker]`` (``cfg``)."""
    return track_table.LifeRules(
        cfg.confirm_m, cfg.confirm_n, cfg.delete_misses, cfg.delete_cov, cfg.vanish_misses
    )


def _associator(task, params):
    """The built-in associator of ``[tracker] association`` (step 2 of the module docstring)."""
    model, cfg, dp = task.measurement, task.tracker, params.detection
    density = clutter.density(dp, model.dim) if task.detection.clutter else DENSITY_FLOOR
    args = (model, params.noise, params.method.ccr, task.detection.model, dp, density, dp.gate)
    args = (*args, dp.gate_probability, task.filter.ground_prior)
    if cfg.association == "gnn":  # the exclusive joint assignment
        return track_update.gnn_associator(*args)
    if cfg.association == "jpda":  # the joint marginals (loopy BP)
        return track_update.jpda_associator(*args, cfg.lbp_iterations)
    return track_update.pda_associator(*args)


def _multiscan_settings(cfg, dim: int) -> multiscan_birth.MultiScanSettings:
    """The multi-scan births of ``[tracker]`` (used when ``birth_scans > 1``): Kc =
    ``max_tracks`` candidates, at most ``max(8, 2 max_births)`` new ones per scan."""
    return multiscan_birth.MultiScanSettings(
        scans=cfg.birth_scans,
        capacity=cfg.max_tracks,
        new_per_scan=max(8, 2 * cfg.max_births),
        max_births=cfg.max_births,
        speed_std=cfg.birth_speed_std,
        dim=dim,
    )


def truth_view(truth, present, view: track_table.TrackView, p0, cutoff: float = CUTOFF_M):
    """The confirmed tracks assigned to the present drones, as a joint estimate (metrics only).

    Greedy assignment (the globally nearest confirmed track–drone pair first, each used
    once) within ``cutoff``. A present drone without a track gets the estimate
    ``truth + (cutoff, 0, 0, 0, 0, 0)`` (error = the cut-off, as in GOSPA) with
    covariance ``cutoff² I``; an absent drone its truth with ``p0 I``.

    Args:
        truth: ``[M, 6]``; present: ``[M]`` bool; view: the table's view; p0: [m²].

    Returns:
        ``(mean [6M], P [6M, 6M])`` block-diagonal.
    """
    m = truth.shape[0]
    d = jnp.linalg.norm(truth[:, None, :3] - view.mean[None, :, :3], axis=-1)  # [M, K]
    d = jnp.where(present[:, None] & view.exist[None, :], d, jnp.inf)
    match = jnp.full(m, -1, jnp.int32)
    for _ in range(m):  # static: at most M assignments
        flat = jnp.argmin(d)
        i, j = jnp.unravel_index(flat, d.shape)
        ok = d[i, j] < cutoff
        match = match.at[i].set(jnp.where(ok, j, match[i]))
        d = jnp.where(
            ok & ((jnp.arange(m)[:, None] == i) | (jnp.arange(d.shape[1]) == j)), jnp.inf, d
        )
    got = match >= 0
    j = jnp.maximum(match, 0)
    miss = truth + jnp.zeros(6, truth.dtype).at[0].set(cutoff)
    eye = jnp.eye(6, dtype=truth.dtype)
    mean = jnp.where(got[:, None], view.mean[j], jnp.where(present[:, None], miss, truth))
    blocks = jnp.where(
        got[:, None, None],
        view.cov[j],
        jnp.where(present[:, None, None], cutoff**2 * eye, p0 * eye),
    )
    return mean.reshape(-1), jax.scipy.linalg.block_diag(*[blocks[i] for i in range(m)])
