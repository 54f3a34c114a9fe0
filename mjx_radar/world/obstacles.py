"""Static obstacles on the ground: footprints, a 2-D signed-distance grid, forests.

Radars drive on the plane z = 0, so for the planner's collision cost only the
obstacles' footprints matter (their xy projections; every obstacle is treated as
standing on the ground). Footprints:

* box: the rectangle of half extents ``(sx, sy)`` rotated by ``yaw``;
* cylinder (vertical): the disc of radius ``r``;
* mesh: the convex hull of the projected vertices (MJX collides with the convex
  hull of a mesh too, so footprint and physics agree; split non-convex buildings
  into convex parts).

The signed distance ``φ(p)`` of the union (negative inside) is sampled ONCE per
scenario on a regular grid on the host (exact per-obstacle formulas, min over
obstacles) and read back in JAX by bilinear interpolation (:func:`sdf`). Outside
the grid ``φ(p) ≈ φ(q) + ‖p − q‖`` with q the clamped point (an upper bound of the
true, 1-Lipschitz φ; the grid covers every obstacle plus a pad, so nothing is missed).
"""

from __future__ import annotations

import functools
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from mjx_radar.scenario.geometry import (  # noqa: F401  (re-exported: world.obstacles.*)
    HULL_RADIUS,
    contact_envelope,
    footprint_polygon,
    footprint_sdf,
    generate_forest,
    mesh_local,
    mesh_vertices,
    rotation_z,
    union_sdf,
)
from mjx_radar.scenario.schema import Obstacle

MAX_CELLS = 512  # grid points per side at most (the grid is a constant of the objective)
MIN_RESOLUTION = 0.5  # finest grid spacing [m]


class SdfGrid(NamedTuple):
    """A sampled 2-D signed-distance field.

    Attributes:
        values: ``[ny, nx]`` φ at ``origin + (i_x, i_y) * resolution`` [m].
        origin: ``[2]`` xy of ``values[0, 0]`` [m].
        resolution: ``[]`` grid spacing [m].
    """

    values: jnp.ndarray
    origin: jnp.ndarray
    resolution: jnp.ndarray


def _bounds(obs: Obstacle) -> np.ndarray:
    if obs.kind == "cylinder":
        r = obs.size[0]
        return np.array([obs.pos[0] - r, obs.pos[1] - r, obs.pos[0] + r, obs.pos[1] + r])
    poly = footprint_polygon(obs)
    return np.concatenate([poly.min(0), poly.max(0)])


@functools.cache
def sdf_grid(obstacles: tuple[Obstacle, ...], half_width: float, pad: float = 64.0) -> SdfGrid:
    """Samples the union footprint SDF on a grid (host, cached per obstacle set).

    The grid covers ``[-w, w]²`` (the placement box) and every footprint, each
    grown by ``pad``; spacing ``max(MIN_RESOLUTION, extent / (MAX_CELLS - 1))``.

    Args:
        obstacles: the scenario's obstacles (at least one).
        half_width: placement half width w [m].
        pad: margin around the covered region [m].

    Returns:
        :class:`SdfGrid` (float32 device arrays).
    """
    if not obstacles:
        raise ValueError("obstacles: need at least one obstacle for an SDF grid")
    b = np.stack([_bounds(o) for o in obstacles])
    lo = np.minimum(b[:, :2].min(0), -half_width) - pad
    hi = np.maximum(b[:, 2:].max(0), half_width) + pad
    res = max(MIN_RESOLUTION, float((hi - lo).max()) / (MAX_CELLS - 1))
    nx, ny = (np.ceil((hi - lo) / res).astype(int) + 1).tolist()
    gx, gy = np.meshgrid(lo[0] + res * np.arange(nx), lo[1] + res * np.arange(ny))
    values = union_sdf(obstacles, np.stack([gx, gy], -1))
    with jax.ensure_compile_time_eval():  # cached: never capture a tracer
        return SdfGrid(
            jnp.asarray(values, jnp.float32), jnp.asarray(lo, jnp.float32), jnp.float32(res)
        )


def sdf(grid: SdfGrid, xy: jnp.ndarray) -> jnp.ndarray:
    """Bilinear lookup of a sampled SDF (pure JAX).

    Args:
        grid: :class:`SdfGrid`.
        xy: ``[..., 2]`` query points [m].

    Returns:
        ``[...]`` signed distance [m] (negative inside a footprint).
    """
    ny, nx = grid.values.shape
    hi = grid.origin + grid.resolution * jnp.array([nx - 1, ny - 1], grid.origin.dtype)
    q = jnp.clip(xy, grid.origin, hi)
    u = (q - grid.origin) / grid.resolution
    i0 = jnp.clip(jnp.floor(u), 0, jnp.array([nx - 2, ny - 2])).astype(jnp.int32)
    f = u - i0
    ix, iy, fx, fy = i0[..., 0], i0[..., 1], f[..., 0], f[..., 1]
    v = grid.values
    top = v[iy, ix] * (1 - fx) + v[iy, ix + 1] * fx
    bot = v[iy + 1, ix] * (1 - fx) + v[iy + 1, ix + 1] * fx
    return top * (1 - fy) + bot * fy + jnp.linalg.norm(xy - q, axis=-1)
