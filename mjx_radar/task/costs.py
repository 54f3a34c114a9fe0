"""Cost terms of the radar-placement objective (SPEC §6), one small pure function each.

A term maps the rolled-out horizon to a per-step cost ``[H]`` (undiscounted); the
objective (:mod:`mjx_radar.task.objective`) is ``Σ_terms Σ_t γ^t term_t`` and reports
every term's discounted value. With t = 0..H-1 indexing the radar state after control
t+1 and E_p the mean over the CKF cubature points of the target states at that time:

* ``information``: ``−E_p[Σ_m log det J_m(t)]`` with J the SFIM, or the PFIM recursion
  started from the filter's information (method flag ``pfim``; only that branch runs);
  the measurement model gives the per-pair information (DDR or CCR noise: flag ``ccr``);
* ``radar_radar``: ``α1 · #{radar pairs closer than R2R}``;
* ``radar_target``: ``α2 · E_p[#{radar-target pairs closer than R2T}]``;
* ``obstacle`` (scenes with obstacles): ``α_obs Σ_n relu(margin − φ(p_n(t)))``, φ the
  footprints' signed distance -- metres of intrusion into the keep-out band;
* ``control_effort`` (``mpc.alpha_effort > 0``): ``α_u Σ_n (a/a_max)² + (α/α_max)²``.

Adding a term: write ``def my_term(h: Horizon, task, params) -> [H]`` here and list it
in :func:`cost_terms` (docs/extending.md).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp

from mjx_radar.estimation import fisher, measurement
from mjx_radar.world import obstacles, occlusion


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
    radar_pos = h.radar[..., :3]  # [H, N, 3]
    tgt = h.target_points[..., :3]  # [H, P, M, 3]
    hh, p, m = tgt.shape[:3]
    # Targets as coordinate arrays over the P·M points ([H, P·M] each): the per-sample
    # work below is then contiguous elementwise arithmetic (vectorised by XLA's CPU
    # backend; the [..., 3] layout was ~10x slower), reduced over points by a dot.
    xyz = tuple(tgt[..., c].reshape(hh, p * m) for c in range(3))
    mask = None  # [H, N, P·M] line of sight to the predicted target means
    if task.occluders is not None:
        vis = occlusion.line_of_sight(task.occluders, radar_pos, tgt.mean(1))  # [H, N, M]
        mask = jnp.broadcast_to(vis[:, :, None], (hh, vis.shape[1], p, m)).reshape(hh, -1, p * m)
    j3 = measurement.information_components(
        task.measurement, radar_pos, xyz, params.noise, params.method.ccr, mask
    )  # 6 x [H, P·M]

    def sfim(j3):
        # E_p Σ_m log det J as a product with a weight vector: XLA's CPU backend does
        # not vectorise a reduction fused onto this elementwise body (~8x slower).
        ld = fisher.logdet_components(j3)  # [H, P·M]
        return ld @ jnp.full((p * m,), 1.0 / p, ld.dtype)

    def pfim(j3):
        wp = jnp.full((p,), 1.0 / p, j3[0].dtype)
        jd = tuple(jnp.einsum("hpm,p->hm", c.reshape(hh, p, m), wp) for c in j3)  # 6 x [H, M]
        ld = fisher.pfim_logdets(h.info0, task.a6, task.w6_unit, params.sigma_w2, jd)
        return ld.sum(-1)

    return -jax.lax.cond(params.method.pfim, pfim, sfim, j3)


def radar_radar(h: Horizon, task, params) -> jax.Array:
    pos = h.radar[..., :3]
    n = pos.shape[1]
    iu, ju = jnp.triu_indices(n, k=1)
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
    return params.alpha_r2t * (close @ jnp.full((p * m,), 1.0 / p, pos.dtype))


def obstacle(h: Horizon, task, params) -> jax.Array:
    mpc = task.scenario.mpc
    depth = jax.nn.relu(mpc.obs_margin - obstacles.sdf(task.obstacle_grid, h.radar[..., :2]))
    return mpc.alpha_obs * jnp.sum(depth, axis=-1)


def control_effort(h: Horizon, task, params) -> jax.Array:
    lim = task.scenario.limits
    scaled = h.controls / jnp.asarray([lim.accel, lim.alpha], h.controls.dtype)
    return task.scenario.mpc.alpha_effort * jnp.sum(scaled**2, axis=(-1, -2))


def cost_terms(scenario) -> tuple[CostTerm, ...]:
    """The terms of a scenario's objective, in reporting order."""
    terms = [
        CostTerm("information", information),
        CostTerm("radar_radar", radar_radar),
        CostTerm("radar_target", radar_target),
    ]
    if scenario.obstacles and scenario.mpc.alpha_obs > 0:
        terms.append(CostTerm("obstacle", obstacle))
    if scenario.mpc.alpha_effort > 0:
        terms.append(CostTerm("control_effort", control_effort))
    return tuple(terms)
