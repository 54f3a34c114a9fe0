"""Host-side obstacle geometry (numpy, trimesh, scipy): footprints, exact signed distances,
generated forests, and the static shape of moving obstacles.

The scenario readers validate with these (radar starts clear of every footprint, mesh
files readable); :mod:`mjx_radar.world.obstacles` samples the same footprints into the
planner's signed-distance grid and :mod:`mjx_radar.world.moving` evaluates the moving
footprints in JAX. Footprints (radars drive on the plane z = 0):

* box: the rectangle of half extents ``(sx, sy)`` rotated by ``yaw``;
* cylinder (vertical): the disc of radius ``r``;
* mesh: the convex hull of the projected vertices (MJX collides with the convex
  hull of a mesh too, so footprint and physics agree).
"""

from __future__ import annotations

import functools
from collections.abc import Sequence

import numpy as np

from mjx_radar.scenario.schema import Obstacle

HULL_RADIUS = 2.5  # physical collision sphere of a radar (models/radar.xml "hull") [m]


def contact_envelope(limits, dt: float) -> float:
    """Growth of a radar's collision sphere [m]: one step's largest displacement + 5 cm."""
    return (limits.speed + 0.5 * limits.accel * dt) * dt + 0.05


def rotation_z(yaw: float) -> np.ndarray:
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


@functools.cache
def mesh_local(path: str, scale: float) -> tuple[np.ndarray, np.ndarray]:
    import trimesh  # host-side only

    mesh = trimesh.load(path, force="mesh")
    return np.asarray(mesh.vertices, np.float64) * scale, np.asarray(mesh.faces, np.int64)


def mesh_vertices(obs: Obstacle) -> np.ndarray:
    """``[V, 3]`` world vertices of a mesh obstacle (scaled, rotated by yaw, translated)."""
    local, _ = mesh_local(obs.path, float(obs.scale))
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


# moving obstacles (docs/maps.md): static shape and the pose at t = 0


def segments(path, loop: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """``(start [S, 2], unit [S, 2], seg_s [S], total)`` of one path (host, float64)."""
    w = np.asarray(path, np.float64)
    if loop:
        w = np.concatenate([w, w[:1]])
    d = np.diff(w, axis=0)
    length = np.linalg.norm(d, axis=-1)
    seg_s = np.concatenate([[0.0], np.cumsum(length)[:-1]])
    return w[:-1], d / length[:, None], seg_s, float(length.sum())


def moving_geometry(moving) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(half [K, 2], cylinder [K] bool, height [K])`` of the footprints (host, static):
    a box's half length and half width, a cylinder's radius twice."""
    cyl = np.array([m.kind == "cylinder" for m in moving])
    half = np.array(
        [(m.size[0], m.size[0]) if c else m.size[:2] for m, c in zip(moving, cyl, strict=True)]
    )
    return half.astype(float), cyl, np.array([m.height for m in moving], float)


def moving_footprint_sdf(moving, xy, unit, p, xp=np):
    """Exact 2-D signed distance ``[..., K]`` of points ``p [..., 2]`` to each footprint
    at centres ``xy [..., K, 2]`` with long axes ``unit [..., K, 2]`` (negative inside);
    ``xp``: the array module (numpy on the host, jax.numpy in the loop)."""
    half, cyl, _ = moving_geometry(moving)
    d = p[..., None, :] - xy  # [..., K, 2]
    c, s = unit[..., 0], unit[..., 1]
    q = xp.abs(xp.stack([c * d[..., 0] + s * d[..., 1], -s * d[..., 0] + c * d[..., 1]], -1))
    q = q - xp.asarray(half, q.dtype)
    box = xp.linalg.norm(xp.maximum(q, 0.0), axis=-1) + xp.minimum(q.max(-1), 0.0)
    disc = xp.linalg.norm(d, axis=-1) - xp.asarray(half[:, 0], d.dtype)
    return xp.where(xp.asarray(cyl), disc, box)


def moving_start(moving, dtype=np.float32) -> tuple[np.ndarray, np.ndarray]:
    """``(xy [K, 2], unit [K, 2])`` of the moving obstacles at t = 0 (host; the closed
    form of :func:`mjx_radar.world.moving.pose`: arc length s0, wrapped or clamped)."""
    xy, unit = [], []
    for m in moving:
        a, u, seg_s, total = (np.asarray(x, dtype) for x in segments(m.path, m.end == "loop"))
        s = dtype(m.offset)
        s = np.mod(s, total) if m.end == "loop" else np.clip(s, dtype(0.0), total)
        i = min(max(int(np.sum(seg_s <= s)) - 1, 0), len(seg_s) - 1)
        xy.append(a[i] + (s - seg_s[i]) * u[i])
        unit.append(u[i])
    return np.stack(xy), np.stack(unit)
