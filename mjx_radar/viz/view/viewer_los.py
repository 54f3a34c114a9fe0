"""Which lines of sight are blocked, and the vehicles, for the viewer and the live view.

The run directory keeps the radars' and drones' trajectories and the scenario, not the
per-pair visibility; the viewer recomputes it on the host for the frames it draws with
the simulator's own tests on the scene's world components
(:mod:`mjx_radar.world.components`; :mod:`mjx_radar.world.occlusion`: the obstacles and
terrain, :mod:`mjx_radar.world.terrain_los`; :mod:`mjx_radar.world.moving`: the vehicles at
the frame's time ``(k + 1) dt``, as the filter sees them at step k), eagerly in JAX (no
compile; about a millisecond per frame).

- :func:`visibility`: ``[F, N, M]`` bool, True where the radar sees the drone.
- :func:`vehicle_lines`: the moving obstacles at a time as wireframe prisms (footprint at
  z = 0 and at their height h, vertical edges), the geometry the line of sight uses.
"""

from __future__ import annotations

import functools

import numpy as np

from mjx_radar.viz.view.viewer_world import polylines, segments


def visibility(ground, obstacles, moving, radar, target, times) -> np.ndarray:
    """``[F, N, M]`` line of sight of each radar-drone pair at F frames.

    Args:
        ground, obstacles, moving: the scene's :class:`~mjx_radar.world.components.Ground`,
            :class:`~mjx_radar.world.components.StaticObstacles` and
            :class:`~mjx_radar.world.components.MovingObstacles` (each empty when absent).
        radar: ``[F, N, 3]`` radar positions [m].
        target: ``[F, M, 3]`` drone positions [m] (NaN rows: absent, reported visible).
        times: ``[F]`` the frames' times [s] (the vehicles' poses).
    """
    radar = np.asarray(radar, np.float32)
    target = np.nan_to_num(np.asarray(target, np.float32))
    shape = (radar.shape[0], radar.shape[1], target.shape[1])
    if not (ground.present or obstacles.present or moving.present):
        return np.ones(shape, bool)
    clear = _program(ground.config, obstacles.shapes, moving.vehicles)
    return np.asarray(clear(radar, target, np.asarray(times, np.float32)))


@functools.cache
def _program(terrain, shapes, moving):
    """The jitted ``(radar [F, N, 3], target [F, M, 3], times [F]) -> [F, N, M]`` of a
    world (the ``[terrain]`` table or None, the obstacles, the vehicles), cached: compiled
    once per shape (the live view's states share one)."""
    import jax
    import jax.numpy as jnp

    from mjx_radar.world import occlusion
    from mjx_radar.world.components import Ground, StaticObstacles

    occ = Ground(terrain).occluding(StaticObstacles(shapes).occluders)
    mp = None
    if moving:
        from mjx_radar.world.moving import blocked, moving_params

        mp = moving_params(moving, jnp.float32)

    @jax.jit  # one compiled call for all frames (op by op: seconds)
    def clear(r, g, t):
        vis = jnp.ones((*r.shape[:2], g.shape[1]), bool)
        if occ is not None:
            vis &= occlusion.line_of_sight(occ, r, g)
        if mp is not None:
            step = lambda t, r, g: ~blocked(moving, mp, t, r[:, None], g[None])  # noqa: E731
            vis &= jax.vmap(step)(t, r, g)
        return vis

    return clear


def los_segments(radar, target, visible) -> tuple[np.ndarray, np.ndarray]:
    """``(visible, blocked)`` NaN-separated segments radar -> drone of one frame
    (``radar [N, 3]``, ``target [M, 3]`` with NaN rows for absent drones, ``visible [N, M]``)."""
    n, m = len(radar), len(target)
    a, b = np.repeat(radar, m, 0), np.tile(target, (n, 1))
    vis = np.asarray(visible, bool).reshape(-1)
    gap = np.full((1, 3), np.nan, np.float32)  # never empty: plotly lists no empty trace
    return segments(a[vis], b[vis]) if vis.any() else gap, (
        segments(a[~vis], b[~vis]) if (~vis).any() else gap
    )


@functools.cache
def _pose(moving):
    """The moving obstacles' jitted closed-form pose ``t -> (xy [K, 2], unit [K, 2])``."""
    import jax

    from mjx_radar.world.moving import moving_params, pose

    mp = moving_params(moving, np.float32)
    return jax.jit(lambda t: pose(mp, t))


def vehicle_lines(moving, t: float) -> np.ndarray:
    """``[P, 3]`` wireframe prisms of the moving obstacles at time ``t`` [s] (empty if none)."""
    if not moving:
        return np.zeros((0, 3), np.float32)
    from mjx_radar.world.moving import geometry

    xy, unit = (np.asarray(a, float) for a in _pose(tuple(moving))(np.float32(t)))
    half, cyl, height = geometry(moving)
    pieces = []
    for c, u, (hl, hw), is_cyl, h in zip(xy, unit, half, cyl, height, strict=True):
        if is_cyl:
            a = np.linspace(0.0, 2 * np.pi, 25)
            poly = c + hl * np.stack([np.cos(a), np.sin(a)], -1)
        else:
            v = np.array([-u[1], u[0]])
            corners = [hl * u + hw * v, -hl * u + hw * v, -hl * u - hw * v, hl * u - hw * v]
            poly = c + np.array([*corners, corners[0]])
        lo = np.column_stack([poly, np.zeros(len(poly))])
        hi = np.column_stack([poly, np.full(len(poly), float(h))])
        edges = slice(None, None, 6) if is_cyl else slice(None, -1)
        pieces += [polylines(np.stack([lo, hi])), segments(lo[edges], hi[edges])]
    return np.concatenate(pieces).astype(np.float32)
