"""Cost terms of the radar-placement objective (SPEC §6), one small pure function each.

A term maps the rolled-out horizon to a per-step cost ``[H]`` (undiscounted); the
objective (:mod:`mjx_radar.task.objective`) is ``Σ_terms Σ_t γ^t term_t`` and reports
every term's discounted value. With t = 0..H-1 indexing the radar state after control
t+1 and E_p the mean over the CKF cubature points of the target states at that time:

* ``information``: ``−E_p[Σ_m log det J_m(t)]`` with J the SFIM (each pair weighted by its
  detection probability, and with clutter the PDA reduction, under ``[detection]``:
  the expected FIM, docs/detection.md), or the PFIM recursion
  started from the filter's information (method flag ``pfim``; only that branch runs;
  a task of program kind ``"sfim"`` / ``"pfim"`` compiles only its branch);
  the measurement model gives the per-pair information (DDR or CCR noise: flag ``ccr``);
* ``radar_radar``: ``α1 · #{radar pairs closer than R2R}``;
* ``radar_target``: ``α2 · E_p[#{radar-target pairs closer than R2T}]``;
* ``obstacle`` (scenes with obstacles): ``α_obs Σ_n relu(margin − φ(p_n(t)))``, φ the
  footprints' signed distance -- metres of intrusion into the keep-out band;
* ``moving_obstacle`` (scenes with ``[[moving_obstacles]]``, ``alpha_obs > 0``): the same
  intrusion into the band around each moving footprint at its predicted position at the
  step's time ``t_plan + (t + 1) dt_control`` (:func:`mjx_radar.world.moving.keep_out_cost`);
* ``terrain_slope`` (scenes with terrain, ``terrain.alpha_slope > 0``):
  ``α_slope Σ_n relu(|∇h(p_n(t))| − tan(max_slope_deg))`` (keep-out of steep ground);
* ``control_effort`` (``mpc.alpha_effort > 0``): ``α_u Σ_n (a/a_max)² + (α/α_max)²``;
* ``association`` (``mpc.alpha_assoc > 0``): ``α_a E_p[Σ_n Σ_{i<j} exp(−(r_ni − r_nj)² /
  (2 s²))]``, r_ni the range from radar n to target i and s = ``mpc.assoc_scale``: the
  expected number of target pairs whose returns a radar cannot tell apart (a range-only
  radar swaps such returns between two tracks; docs/tracking.md).

Adding a term: write ``def my_term(h: Horizon, task, params) -> [H]`` here and list it
in :func:`builtin_terms` and :data:`mjx_radar.registry.COST_TERMS` (docs/extending.md), or
register it from a script (``mjx_radar.register_cost_term``,
:mod:`mjx_radar.task.cost_plugins`): registered terms follow the built-in ones, and their
code is part of every program cache key.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from mjx_radar.estimation.data_association import pda
from mjx_radar.estimation.information import fisher
from mjx_radar.estimation.sensor import detection, measurement
from mjx_radar.task import cost_plugins
from mjx_radar.task.method import information_of
from mjx_radar.world import moving
from mjx_radar.world.components import make_world


class Horizon(NamedTuple):
    """What cost terms see of one candidate plan.

    Attributes:
        controls: [H, N, 2] the candidate controls.
        radar: [H, N, 6] rolled-out radar states.
        target_points: [H, P, M, 6] cubature points of the targets (P = 12M).
        info0: [M, 6, 6] current filter information per target (PFIM start).
    """

    controls: jax.Array
    radar: jax.Array
    target_points: jax.Array
    info0: jax.Array


class CostTerm(NamedTuple):
    name: str
    fn: Callable[[Horizon, Any, Any], jax.Array]  # (horizon, task, params) -> [H]


def information(h: Horizon, task, params) -> jax.Array:
    info = information_of(task.kind)  # one kind: only its branch
    if info is not None:
        return -(_pfim if info == "pfim" else _sfim)(h, task, params)
    return -jax.lax.cond(
        params.method.pfim, lambda: _pfim(h, task, params), lambda: _sfim(h, task, params)
    )


def _components(h: Horizon, task, params, target_major: bool):
    """``6 x [H, P·M]`` position FIM entries at the cubature points, with the points
    point-major (index ``p·M + m``) or target-major (``m·P + p``)."""
    radar_pos = h.radar[..., :3]  # [H, N, 3]
    tgt = h.target_points[..., :3]  # [H, P, M, 3]
    hh, p, m = tgt.shape[:3]
    # Targets as coordinate arrays over the P·M points ([H, P·M] each): the per-sample
    # work below is then contiguous elementwise arithmetic (vectorised by XLA's CPU
    # backend; the [..., 3] layout was ~10x slower), reduced over points by a dot.
    pts = jnp.swapaxes(tgt, 1, 2) if target_major else tgt  # per trial, not per sample
    xyz = tuple(pts[..., c].reshape(hh, p * m) for c in range(3))
    mask = None  # [H, N, P·M] line of sight to the predicted target means (mpc.los)
    vis = moving.plan_visibility(task.world, params, radar_pos, tgt.mean(1))  # [H, N, M] or None
    if vis is not None:
        vis = vis[:, :, :, None] if target_major else vis[:, :, None]
        mask = jnp.broadcast_to(vis, (hh, vis.shape[1], *pts.shape[1:3])).reshape(hh, -1, p * m)
    det = task.detection
    if (det.detects or det.clutter) and det.planner:  # expected FIM (docs/detection.md)
        pd = detection.planner_weights(
            det.model,
            params.detection,
            radar_pos,
            xyz,
            pda.planner_factor(det, task.measurement, params),
        )
        mask = pd if mask is None else pd * mask
    return measurement.information_components(
        task.measurement, radar_pos, xyz, params.noise, params.method.ccr, mask
    )


def _sfim(h: Horizon, task, params) -> jax.Array:
    """``[H]`` ``E_p Σ_m log det J`` (points point-major)."""
    p, m = h.target_points.shape[1:3]
    ld = fisher.logdet_components(_components(h, task, params, False))  # [H, P·M]
    # a product with a weight vector: XLA's CPU backend does not vectorise a reduction
    # fused onto this elementwise body (~8x slower)
    return ld @ _point_weights(params, p, m, ld.dtype)


def _pfim(h: Horizon, task, params) -> jax.Array:
    """``[H]`` ``Σ_m log det J_m`` along the PFIM recursion, the data information averaged
    over each target's points. Target-major points make that average a product over the
    minor axis: point-major (``einsum("hpm,p->hm")``), XLA emitted it as one strided,
    transposing kernel that took 95% of a study chunk's MPPI call on an H100 (39 of
    42 ms per iteration at 250 trials x 200 samples: 209 ms per call, now 19 ms;
    docs/notes/scaling-history.md). CPU time unchanged."""
    hh, p, m = h.target_points.shape[:3]
    j3 = _components(h, task, params, target_major=True)
    wp = jnp.full((p,), 1.0 / p, j3[0].dtype)
    jd = tuple(c.reshape(hh, m, p) @ wp for c in j3)  # 6 x [H, M]; a dot (see _sfim)
    ld = fisher.pfim_logdets(h.info0, task.a6, task.w6_unit, params.sigma_w2, jd)
    if params.target_weight is not None:  # absent targets cost nothing
        return ld @ params.target_weight.astype(ld.dtype)
    return ld.sum(-1)


def radar_radar(h: Horizon, task, params) -> jax.Array:
    pos = h.radar[..., :3]
    n = pos.shape[1]
    iu, ju = np.triu_indices(n, k=1)  # static: no index arithmetic in the program
    d = jnp.linalg.norm(pos[:, iu] - pos[:, ju], axis=-1)  # [H, pairs]
    return params.alpha_r2r * jnp.sum(d < params.r2r, axis=-1).astype(pos.dtype)


def radar_target(h: Horizon, task, params) -> jax.Array:
    pos = h.radar[..., :3]  # [H, N, 3]
    tgt = h.target_points[..., :3]  # [H, P, M, 3]
    hh, p, m = tgt.shape[:3]
    xyz = [tgt[..., c].reshape(hh, p * m) for c in range(3)]  # coordinate arrays, as above
    r2t2 = params.r2t * params.r2t
    close = sum(
        (sum((xyz[c] - pos[:, n, c : c + 1]) ** 2 for c in range(3)) < r2t2).astype(pos.dtype)
        for n in range(pos.shape[1])
    )  # [H, P·M]: radars within R2T of each point
    return params.alpha_r2t * (close @ _point_weights(params, p, m, pos.dtype))


def _point_weights(params, p: int, m: int, dtype) -> jax.Array:
    """``[P·M]`` weights of the cubature points (point-major): ``1/P``, times the target's
    presence weight ``params.target_weight [M]`` when set (absent targets: 0)."""
    w = jnp.full((p * m,), 1.0 / p, dtype)
    if params.target_weight is None:
        return w
    return w * jnp.tile(params.target_weight.astype(dtype), p)


def obstacle(h: Horizon, task, params) -> jax.Array:
    mpc = task.mpc
    depth = jax.nn.relu(mpc.obs_margin - task.world.obstacles.signed_distance(h.radar[..., :2]))
    return mpc.alpha_obs * jnp.sum(depth, axis=-1)


def moving_obstacle(h: Horizon, task, params) -> jax.Array:
    return moving.keep_out_cost(h, task.world.moving, task.mpc, params)


def terrain_slope(h: Horizon, task, params) -> jax.Array:
    """``α_slope Σ_n relu(|∇h(p_n(t))| − tan(max_slope))``: grade beyond the vehicle limit."""
    return task.world.ground.slope_cost(h.radar[..., :2])  # [H]


def control_effort(h: Horizon, task, params) -> jax.Array:
    lim = task.fleet.limits
    scaled = h.controls / jnp.asarray([lim.accel, lim.alpha], h.controls.dtype)
    return task.mpc.alpha_effort * jnp.sum(scaled**2, axis=(-1, -2))


def association(h: Horizon, task, params) -> jax.Array:
    """``[H]`` ``α_a E_p[Σ_n Σ_{i<j} w_i w_j exp(−(r_ni − r_nj)² / (2 s²))]``: the target
    pairs whose ranges coincide at a radar within ``s`` (``w``: presence weights, 1 when
    unset). A pair's returns at that radar are then exchangeable, and a range-only
    tracker may swap them between the two tracks."""
    pos = h.radar[:, None, :, None, :3]  # [H, 1, N, 1, 3]
    tgt = h.target_points[:, :, None, :, :3]  # [H, P, 1, M, 3]
    rng = jnp.sqrt(jnp.sum((tgt - pos) ** 2, axis=-1))  # [H, P, N, M]
    m = rng.shape[-1]
    iu, ju = np.triu_indices(m, k=1)  # static pairs
    gap = rng[..., iu] - rng[..., ju]  # [H, P, N, pairs]
    s = task.mpc.assoc_scale
    near = jnp.exp(-0.5 * (gap / s) ** 2)
    if params.target_weight is not None:
        w = params.target_weight.astype(near.dtype)
        near = near * (w[iu] * w[ju])
    return task.mpc.alpha_assoc * jnp.mean(jnp.sum(near, axis=(-1, -2)), axis=-1)


def builtin_terms(world, mpc) -> tuple[CostTerm, ...]:
    """The built-in terms of an objective, in reporting order: the information and the
    keep-outs, then each world component's term where it is present and weighted
    (``world`` a :class:`~mjx_radar.world.components.World`, ``mpc`` the ``[mpc]`` table)."""
    terms = [
        CostTerm("information", information),
        CostTerm("radar_radar", radar_radar),
        CostTerm("radar_target", radar_target),
    ]
    if world.obstacles.present and mpc.alpha_obs > 0:
        terms.append(CostTerm("obstacle", obstacle))
    if world.moving.present and mpc.alpha_obs > 0:
        terms.append(CostTerm("moving_obstacle", moving_obstacle))
    if world.ground.slope_cost_on:
        terms.append(CostTerm("terrain_slope", terrain_slope))
    if mpc.alpha_effort > 0:
        terms.append(CostTerm("control_effort", control_effort))
    if mpc.alpha_assoc > 0:
        terms.append(CostTerm("association", association))
    return tuple(terms)


def registered_terms(shape) -> tuple[CostTerm, ...]:
    """The terms registered from scripts whose ``enabled(scenario)`` accepts ``shape``."""
    return tuple(CostTerm(t.name, t) for t in cost_plugins.registered() if t.applies(shape))


def cost_terms(scenario) -> tuple[CostTerm, ...]:
    """The terms of a scenario's objective, in reporting order (registered terms last):
    the task's ``terms`` (:func:`builtin_terms` of its world, :func:`registered_terms`)."""
    s = scenario
    parts = (s.terrain, s.obstacles, s.moving_obstacles, s.timing.dt_control, s.mpc)
    return builtin_terms(make_world(*parts, s.placement_half_width), s.mpc) + registered_terms(s)
