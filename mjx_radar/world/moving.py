"""Moving obstacles: vehicles driving polylines at constant speed (pure JAX, docs/maps.md).

A ``[[moving_obstacles]]`` table (:class:`~mjx_radar.scenario.schema.MovingObstacle`) gives a
footprint (box of half extents ``(l, w)`` or disc of radius r), a height h, a path of
waypoints ``w_0 .. w_{P-1}``, a speed c, an arc-length offset s0 and ``end``. With the
segments ``w_i -> w_{i+1}`` (``end = "loop"`` adds ``w_{P-1} -> w_0``), their lengths
``L_i``, start arc lengths ``S_i = Σ_{j<i} L_j`` and the total ``L = Σ L_i``::

    s(t) = s0 + c t,   s' = s mod L (loop)  or  min(s, L) (stop)
    i(t) = max{i : S_i <= s'},   p(t) = w_i + (s' - S_i) u_i,   u_i = (w_{i+1} - w_i) / L_i

a closed form of t (no integration), evaluated in JAX from the runtime
:class:`MovingParams` (``TaskParams.moving``). A box's long axis is the direction
``u_i`` of the segment it is on. The obstacle stands on z = 0 and reaches z = h.

Used by the planner's ``moving_obstacle`` cost (:func:`keep_out_cost`, at the horizon's
times ``t_plan + (k + 1) dt_control``), by line of sight in the filter (the truth at the
step's time) and in the planner with ``mpc.los`` (:func:`blocked`), and by the truth
plant's mocap bodies (:mod:`mjx_radar.physics.moving_bodies`).
"""

from __future__ import annotations

from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from mjx_radar.scenario.geometry import moving_footprint_sdf, segments
from mjx_radar.scenario.geometry import moving_geometry as geometry
from mjx_radar.world import occlusion

_PAD = 1e30  # start arc length of a padding segment (never reached)


class MovingParams(NamedTuple):
    """Runtime arrays of K moving obstacles (S = the most segments of one path).

    Attributes:
        start: ``[K, S, 2]`` segment start points w_i [m].
        unit: ``[K, S, 2]`` segment unit directions u_i.
        seg_s: ``[K, S]`` start arc length S_i [m] (padding: 1e30).
        total: ``[K]`` path length L [m] (closed loop: with the closing segment).
        speed: ``[K]`` c [m/s]; offset: ``[K]`` s0 [m]; loop: ``[K]`` bool.
    """

    start: Any
    unit: Any
    seg_s: Any
    total: Any
    speed: Any
    offset: Any
    loop: Any


def moving_params(moving, dtype) -> MovingParams | None:
    """The :class:`MovingParams` of a scenario's ``moving_obstacles`` (None if empty)."""
    if not moving:
        return None
    segs = [segments(m.path, m.end == "loop") for m in moving]
    s = max(len(g[0]) for g in segs)
    start, unit = np.zeros((len(moving), s, 2)), np.zeros((len(moving), s, 2))
    unit[..., 0], seg_s = 1.0, np.full((len(moving), s), _PAD)
    for k, (a, u, ss, _) in enumerate(segs):
        start[k, : len(a)], unit[k, : len(a)], seg_s[k, : len(a)] = a, u, ss
    arr = lambda x: jnp.asarray(np.asarray(x, float), dtype)  # noqa: E731
    return MovingParams(
        arr(start),
        arr(unit),
        arr(seg_s),
        arr([g[3] for g in segs]),
        arr([m.speed for m in moving]),
        arr([m.offset for m in moving]),
        jnp.asarray([m.end == "loop" for m in moving]),
    )


def pose(mp: MovingParams, t):
    """Positions and headings of the K obstacles at times ``t``.

    Args:
        mp: :class:`MovingParams`.
        t: ``[...]`` times [s] since the trial's start.

    Returns:
        ``(xy [..., K, 2], unit [..., K, 2])``: footprint centre and the direction of
        the segment it is on (a box's long axis).
    """
    t = jnp.asarray(t, mp.speed.dtype)[..., None]  # [..., 1]
    s = mp.offset + mp.speed * t  # [..., K]
    s = jnp.where(mp.loop, jnp.mod(s, mp.total), jnp.clip(s, 0.0, mp.total))
    i = jnp.sum(mp.seg_s <= s[..., None], axis=-1) - 1  # [..., K]
    i = jnp.clip(i, 0, mp.seg_s.shape[-1] - 1)
    k = jnp.arange(mp.total.shape[0])
    u = mp.unit[k, i]
    return mp.start[k, i] + (s - mp.seg_s[k, i])[..., None] * u, u


def footprint_sdf(moving, xy, unit, p):
    """Exact 2-D signed distance ``[..., K]`` of points ``p [..., 2]`` to each footprint
    at centres ``xy [..., K, 2]`` with long axes ``unit [..., K, 2]`` (negative inside)."""
    return moving_footprint_sdf(moving, xy, unit, p, jnp)


def plan_times(dt, params, h: int):
    """``[H]`` times of the horizon's radar states: ``t_plan + (k + 1) dt`` (``dt`` the
    control period [s])."""
    t0 = 0.0 if params.plan_time is None else params.plan_time
    return t0 + dt * jnp.arange(1, h + 1, dtype=params.moving.speed.dtype)


def keep_out_cost(h, vehicles, mpc, params) -> jax.Array:
    """``[H]`` cost ``α_obs Σ_n relu(margin − min_k φ_k(p_n(t_k), t_k))`` (moving footprints).

    Args:
        h: the :class:`~mjx_radar.task.costs.Horizon`; vehicles: the
            :class:`~mjx_radar.world.components.MovingObstacles`; mpc: the ``[mpc]`` table
            (``alpha_obs``, ``obs_margin``); params: the runtime parameters (``moving``).
    """
    times = plan_times(vehicles.dt_control, params, h.radar.shape[0])
    xy, unit = pose(params.moving, times)  # [H, K, 2]
    phi = footprint_sdf(
        vehicles.vehicles, xy[:, None], unit[:, None], h.radar[..., :2]
    )  # [H, N, K]
    depth = jax.nn.relu(mpc.obs_margin - phi.min(-1))
    return mpc.alpha_obs * jnp.sum(depth, axis=-1)


def occluders_at(moving, xy, unit) -> occlusion.Occluders:
    """The obstacles at one pose (``xy, unit [K, 2]``) as :class:`occlusion.Occluders`:
    boxes as 6 planes, cylinders as ``(c_x, c_y, r, 0, h)`` rows."""
    half, cyl, height = geometry(moving)
    box, cy = np.flatnonzero(~cyl), np.flatnonzero(cyl)
    c, s = unit[box, 0], unit[box, 1]
    zero, one = jnp.zeros_like(c), jnp.ones_like(c)
    ax = jnp.stack([c, s, zero], -1)
    ay = jnp.stack([-s, c, zero], -1)
    az = jnp.stack([zero, zero, one], -1)
    ctr = jnp.concatenate([xy[box], jnp.asarray(height[box, None] / 2, xy.dtype)], -1)
    ext = (
        jnp.asarray(half[box, 0], xy.dtype),
        jnp.asarray(half[box, 1], xy.dtype),
        jnp.asarray(height[box] / 2, xy.dtype),
    )
    rows = [
        jnp.concatenate([g * a, (g * jnp.sum(a * ctr, -1) + e)[:, None]], -1)
        for a, e in zip((ax, ay, az), ext, strict=True)
        for g in (1.0, -1.0)
    ]
    cyls = jnp.stack(
        [
            xy[cy, 0],
            xy[cy, 1],
            jnp.asarray(half[cy, 0], xy.dtype),
            jnp.zeros(len(cy), xy.dtype),
            jnp.asarray(height[cy], xy.dtype),
        ],
        -1,
    )
    return occlusion.Occluders(jnp.stack(rows, 1).reshape(len(box), 6, 4), cyls)


def blocked(moving, mp: MovingParams, t, a, b):
    """``[...]`` bool: segments ``a -> b`` ``[..., 3]`` blocked by a moving obstacle at the
    scalar time ``t`` (the closed-form pose, then :func:`occlusion.segment_blocked`)."""
    xy, unit = pose(mp, t)
    return occlusion.segment_blocked(occluders_at(moving, xy, unit), a, b)


def truth_visibility(world, params, radar_pos, target_pos, t):
    """``[N, M]`` line of sight of the truth at time ``t`` (static occluders and terrain,
    moving obstacles), or None when the scene has no occluder (every pair visible).
    ``world`` is the :class:`~mjx_radar.world.components.World`."""
    vis = None
    if world.occluders is not None:
        vis = occlusion.line_of_sight(world.occluders, radar_pos, target_pos)
    if params.moving is None:
        return vis
    a, b = radar_pos[:, None, :], target_pos[None, :, :]
    clear = ~blocked(world.moving.vehicles, params.moving, t, a, b)
    return clear if vis is None else vis & clear


def plan_visibility(world, params, radar_pos, target_mean):
    """``[H, N, M]`` planner line of sight (``mpc.los``) at the horizon's times, or None
    (planner blind to occlusion): ``world`` the :class:`~mjx_radar.world.components.World`,
    ``radar_pos [H, N, 3]``, ``target_mean [H, M, 3]``."""
    vis = None
    if world.plan_occluders is not None:
        vis = occlusion.line_of_sight(world.plan_occluders, radar_pos, target_mean)
    if params.moving is None or not world.plan_los:
        return vis
    moving = world.moving.vehicles
    times = plan_times(world.moving.dt_control, params, radar_pos.shape[0])
    step = lambda t, r, m: ~blocked(moving, params.moving, t, r[:, None], m[None])  # noqa: E731
    clear = jax.vmap(step)(times, radar_pos, target_mean)
    return clear if vis is None else vis & clear
