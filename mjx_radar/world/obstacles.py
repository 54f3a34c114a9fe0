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
from collections.abc import Sequence
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from mjx_radar.config import Obstacle

HULL_RADIUS = 2.5  # physical collision sphere of a radar (models/radar.xml "hull") [m]
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


def contact_envelope(limits, dt: float) -> float:
    """Growth of a radar's collision sphere [m]: one step's largest displacement + 5 cm."""
    return (limits.speed + 0.5 * limits.accel * dt) * dt + 0.05


def rotation_z(yaw: float) -> np.ndarray:
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


@functools.cache
def _mesh_local(path: str, scale: float) -> tuple[np.ndarray, np.ndarray]:
    import trimesh  # host-side only

    mesh = trimesh.load(path, force="mesh")
    return np.asarray(mesh.vertices, np.float64) * scale, np.asarray(mesh.faces, np.int64)


def mesh_vertices(obs: Obstacle) -> np.ndarray:
    """``[V, 3]`` world vertices of a mesh obstacle (scaled, rotated by yaw, translated)."""
    local, _ = _mesh_local(obs.path, float(obs.scale))
    return local @ rotation_z(obs.yaw).T + np.asarray(obs.pos)


def _hull_2d(points: np.ndarray) -> np.ndarray:
    """Counter-clockwise convex hull ``[K, 2]`` of 2-D points."""
    from scipy.spatial import ConvexHull

    return points[ConvexHull(points).vertices]


def footprint_polygon(obs: Obstacle) -> np.ndarray:
    """Counter-clockwise footprint polygon ``[K, 2]`` of a box or mesh obstacle."""
    if obs.kind == "box":
        sx, sy = obs.size[0], obs.size[1]
        corners = np.array([[sx, sy, 0], [-sx, sy, 0], [-sx, -sy, 0], [sx, -sy, 0]], float)
        return (corners @ rotation_z(obs.yaw).T)[:, :2] + np.asarray(obs.pos[:2])
    if obs.kind == "mesh":
        return _hull_2d(mesh_vertices(obs)[:, :2])
    raise ValueError(f"obstacle.kind: {obs.kind!r} has no polygon footprint")


def _polygon_sdf(poly: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """Exact signed distance of points ``[P, 2]`` to a convex CCW polygon ``[K, 2]``."""
    a, b = poly, np.roll(poly, -1, axis=0)
    e = b - a  # [K, 2]
    w = xy[:, None, :] - a[None]  # [P, K, 2]
    t = np.clip(np.sum(w * e, -1) / np.maximum(np.sum(e * e, -1), 1e-300), 0.0, 1.0)
    dist = np.linalg.norm(w - t[..., None] * e, axis=-1).min(-1)
    cross = e[None, :, 0] * w[..., 1] - e[None, :, 1] * w[..., 0]
    return np.where(np.all(cross >= 0, axis=-1), -dist, dist)


def footprint_sdf(obs: Obstacle, xy: np.ndarray) -> np.ndarray:
    """Exact 2-D signed distance ``[...]`` of points ``xy[..., 2]`` to one footprint (host)."""
    xy = np.asarray(xy, np.float64)
    flat = xy.reshape(-1, 2)
    if obs.kind == "cylinder":
        out = np.linalg.norm(flat - np.asarray(obs.pos[:2]), axis=-1) - obs.size[0]
    elif obs.kind == "box":
        c, s = np.cos(obs.yaw), np.sin(obs.yaw)
        d = flat - np.asarray(obs.pos[:2])
        q = np.abs(np.stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]], -1))
        q = q - np.asarray(obs.size[:2])
        out = np.linalg.norm(np.maximum(q, 0.0), axis=-1) + np.minimum(q.max(-1), 0.0)
    else:
        out = _polygon_sdf(footprint_polygon(obs), flat)
    return out.reshape(xy.shape[:-1])


def union_sdf(obstacles: Sequence[Obstacle], xy: np.ndarray) -> np.ndarray:
    """Signed distance to the union of footprints (min over obstacles; +inf if none)."""
    out = np.full(np.shape(xy)[:-1], np.inf)
    for obs in obstacles:
        out = np.minimum(out, footprint_sdf(obs, xy))
    return out


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


def generate_forest(
    count: int,
    region: Sequence[float],
    seed: int,
    radius: Sequence[float],
    height: Sequence[float],
    spacing: float,
    keep_clear: Sequence[Sequence[float]] = (),
    clearance: float = 0.0,
    tries: int = 200,
) -> tuple[Obstacle, ...]:
    """Places ``count`` vertical cylinder trees by rejection sampling (host, deterministic).

    Args:
        count: number of trees.
        region: ``(xmin, ymin, xmax, ymax)`` of the tree centres [m].
        seed: numpy seed.
        radius: ``(rmin, rmax)`` trunk radius range [m] (uniform).
        height: ``(hmin, hmax)`` height range [m] (uniform); trees stand on z = 0.
        spacing: minimum gap between two trunks' surfaces [m].
        keep_clear: xy points (e.g. fixed radar starts) no trunk may come near.
        clearance: minimum distance from a ``keep_clear`` point to a trunk surface [m].
        tries: candidate draws per tree.

    Returns:
        The trees as cylinder obstacles; fewer than ``count`` if they did not fit.
    """
    rng = np.random.default_rng(seed)
    x0, y0, x1, y1 = region
    clear = np.asarray(keep_clear, float).reshape(-1, 2)
    trees: list[tuple[float, float, float, float]] = []
    for _ in range(count):
        for _ in range(tries):
            x, y = rng.uniform(x0, x1), rng.uniform(y0, y1)
            r, h = rng.uniform(*radius), rng.uniform(*height)
            ok = all(np.hypot(x - tx, y - ty) >= r + tr + spacing for tx, ty, tr, _ in trees)
            ok &= bool(np.all(np.hypot(clear[:, 0] - x, clear[:, 1] - y) >= r + clearance))
            if ok:
                trees.append((round(x, 2), round(y, 2), round(r, 2), round(h, 2)))
                break
        else:
            break
    return tuple(
        Obstacle(kind="cylinder", pos=(x, y, 0.5 * h), size=(r, 0.5 * h)) for x, y, r, h in trees
    )
