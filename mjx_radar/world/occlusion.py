"""Line of sight: is the straight radar-target segment blocked by an obstacle? (pure JAX)

Obstacles are turned once (host side) into two padded array sets:

* convex polyhedra ``{x : n_i · x <= d_i}`` -- boxes (6 planes, oriented by yaw)
  and meshes (planes of the 3-D convex hull of the world vertices, as MJX
  collides with the hull too). A segment ``p(t) = a + t (b - a)``, ``t ∈ [0, 1]``,
  meets one by Cyrus-Beck clipping: with ``num_i = d_i - n_i·a``,
  ``den_i = n_i·(b - a)``, ``t_lo = max(0, max_{den<0} num/den)``,
  ``t_hi = min(1, min_{den>0} num/den)``; blocked iff ``t_lo < t_hi`` and no
  plane with ``den = 0`` has ``num < 0``. Padding planes are ``0·x <= 1``.
* vertical cylinders (centre c, radius r, heights [z0, z1]): the t-interval
  where ``‖p_xy(t) - c‖ <= r`` (roots of a quadratic) intersected with the
  interval where ``z0 <= p_z(t) <= z1`` and with [0, 1]; blocked iff non-empty.

Touching (an interval of zero length) does not block. A radar on the ground next
to a wall sees over it only if the segment clears the wall.

Terrain (``Occluders.terrain``, a height grid): the segment is blocked where it
passes below the ground (:mod:`mjx_radar.world.terrain_los`, exact per cell).
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from mjx_radar.scenario.schema import Obstacle
from mjx_radar.world import terrain_los
from mjx_radar.world.obstacles import mesh_vertices, rotation_z

_TINY = 1e-9


class Occluders(NamedTuple):
    """Obstacles as arrays for segment tests.

    Attributes:
        planes: ``[K1, F, 4]`` half-spaces ``(n_x, n_y, n_z, d)`` of each convex polyhedron.
        cylinders: ``[K2, 5]`` rows ``(c_x, c_y, r, z0, z1)``.
        terrain: a :class:`~mjx_radar.world.terrain.TerrainGrid`, or None (flat ground).
    """

    planes: jnp.ndarray
    cylinders: jnp.ndarray
    terrain: object = None


def _box_planes(obs: Obstacle) -> np.ndarray:
    axes = rotation_z(obs.yaw).T  # rows = world directions of the local axes
    c = np.asarray(obs.pos, float)
    rows = []
    for i in range(3):
        for sgn in (1.0, -1.0):
            n = sgn * axes[i]
            rows.append([*n, n @ c + obs.size[i]])
    return np.asarray(rows)


def _mesh_planes(obs: Obstacle) -> np.ndarray:
    import trimesh

    hull = trimesh.convex.convex_hull(mesh_vertices(obs))
    n = np.asarray(hull.face_normals)
    d = np.einsum("fi,fi->f", n, np.asarray(hull.triangles)[:, 0])
    return np.unique(np.round(np.concatenate([n, d[:, None]], -1), 9), axis=0)


@functools.cache
def occluders(obstacles: tuple[Obstacle, ...]) -> Occluders:
    """Builds the :class:`Occluders` of a scenario's obstacles (host, cached)."""
    polys = [
        _box_planes(o) if o.kind == "box" else _mesh_planes(o)
        for o in obstacles
        if o.kind in ("box", "mesh")
    ]
    f = max([len(p) for p in polys], default=1)
    planes = np.zeros((len(polys), f, 4))
    planes[..., 3] = 1.0  # padding: 0 . x <= 1
    for k, p in enumerate(polys):
        planes[k, : len(p)] = p
    cyl = [
        (o.pos[0], o.pos[1], o.size[0], o.pos[2] - o.size[1], o.pos[2] + o.size[1])
        for o in obstacles
        if o.kind == "cylinder"
    ]
    cylinders = np.asarray(cyl, float).reshape(-1, 5)
    with jax.ensure_compile_time_eval():  # cached: never capture a tracer
        return Occluders(jnp.asarray(planes, jnp.float32), jnp.asarray(cylinders, jnp.float32))


def _poly_blocked(planes, a, e):
    """``[..., K1]`` Cyrus-Beck test of segments ``a + t e`` against each polyhedron."""
    n, d = planes[..., :3], planes[..., 3]  # [K1, F, 3], [K1, F]
    num = d - jnp.einsum("kfi,...i->...kf", n, a)
    den = jnp.einsum("kfi,...i->...kf", n, e)
    par = jnp.abs(den) < _TINY
    t = num / jnp.where(par, 1.0, den)
    t_lo = jnp.max(jnp.where(~par & (den < 0), t, 0.0), axis=-1).clip(0.0)
    t_hi = jnp.min(jnp.where(~par & (den > 0), t, 1.0), axis=-1).clip(max=1.0)
    outside = jnp.any(par & (num < 0), axis=-1)
    return (t_lo < t_hi) & ~outside


def _cyl_blocked(cyl, a, e):
    """``[..., K2]`` segment test against vertical cylinders."""
    c, r, z0, z1 = cyl[:, :2], cyl[:, 2], cyl[:, 3], cyl[:, 4]
    w = a[..., None, :2] - c  # [..., K2, 2]
    exy = e[..., None, :2]
    qa = jnp.sum(exy * exy, -1)
    qb = 2.0 * jnp.sum(w * exy, -1)
    qc = jnp.sum(w * w, -1) - r**2
    disc = qb * qb - 4.0 * qa * qc
    flat = qa < _TINY  # vertical segment: inside for all t or none
    sq = jnp.sqrt(jnp.maximum(disc, 0.0))
    safe = jnp.where(flat, 1.0, 2.0 * qa)
    lo_xy = jnp.where(flat, jnp.where(qc <= 0, 0.0, 1.0), (-qb - sq) / safe)
    hi_xy = jnp.where(flat, jnp.where(qc <= 0, 1.0, 0.0), (-qb + sq) / safe)
    hi_xy = jnp.where(~flat & (disc < 0), -1.0, hi_xy)
    az, ez = a[..., None, 2], e[..., None, 2]
    hor = jnp.abs(ez) < _TINY
    ez_safe = jnp.where(hor, 1.0, ez)
    ta, tb = (z0 - az) / ez_safe, (z1 - az) / ez_safe
    inside_z = (az >= z0) & (az <= z1)
    lo_z = jnp.where(hor, jnp.where(inside_z, 0.0, 1.0), jnp.minimum(ta, tb))
    hi_z = jnp.where(hor, jnp.where(inside_z, 1.0, 0.0), jnp.maximum(ta, tb))
    lo = jnp.maximum(jnp.maximum(lo_xy, lo_z), 0.0)
    hi = jnp.minimum(jnp.minimum(hi_xy, hi_z), 1.0)
    return lo < hi


def segment_blocked(occ: Occluders, a, b):
    """Whether segments ``a -> b`` are blocked by any obstacle.

    Args:
        occ: :class:`Occluders`.
        a: ``[..., 3]`` start points [m].
        b: ``[..., 3]`` end points [m] (broadcast with ``a``).

    Returns:
        ``[...]`` bool, True where some obstacle meets the open segment.
    """
    a, b = jnp.broadcast_arrays(jnp.asarray(a), jnp.asarray(b))
    e = b - a
    out = jnp.zeros(a.shape[:-1], bool)
    if occ.planes.shape[0]:
        out |= jnp.any(_poly_blocked(occ.planes.astype(a.dtype), a, e), axis=-1)
    if occ.cylinders.shape[0]:
        out |= jnp.any(_cyl_blocked(occ.cylinders.astype(a.dtype), a, e), axis=-1)
    if occ.terrain is not None:
        out |= terrain_los.segment_blocked(occ.terrain, a, b)
    return out


def with_terrain(occ: Occluders | None, grid) -> Occluders:
    """``occ`` (or no obstacles) with the terrain grid ``grid`` as an occluder too."""
    if occ is None:
        with jax.ensure_compile_time_eval():
            occ = Occluders(jnp.zeros((0, 1, 4), jnp.float32), jnp.zeros((0, 5), jnp.float32))
    return occ._replace(terrain=grid)


def line_of_sight(occ: Occluders, radar_pos, target_pos):
    """Visibility of every radar-target pair.

    Args:
        occ: :class:`Occluders`.
        radar_pos: ``[..., N, 3]`` radar positions [m].
        target_pos: ``[..., M, 3]`` target positions [m].

    Returns:
        ``[..., N, M]`` bool, True where the segment is clear (measurement available).
    """
    a = jnp.asarray(radar_pos)[..., :, None, :]
    b = jnp.asarray(target_pos)[..., None, :, :]
    return ~segment_blocked(occ, a, b)


def visibility(obstacles: Sequence[Obstacle], radar_pos, target_pos):
    """:func:`line_of_sight` for an obstacle tuple (all True without obstacles)."""
    shape = jnp.broadcast_shapes(jnp.shape(radar_pos)[:-2], jnp.shape(target_pos)[:-2]) + (
        jnp.shape(radar_pos)[-2],
        jnp.shape(target_pos)[-2],
    )
    if not obstacles:
        return jnp.ones(shape, bool)
    return line_of_sight(occluders(tuple(obstacles)), radar_pos, target_pos)
