"""Terrain: a height field on a regular grid, its file reader and a pure-JAX lookup.

The grid ``H[i, j]`` (``[ny, nx]``, metres) holds the ground height at
``x_j = x0 + j dx``, ``y_i = y0 + i dy`` with ``x0 = -extent_x / 2``,
``dx = extent_x / (nx - 1)`` (likewise y): the grid is centred on the origin.
Between nodes the height is the **bilinear** interpolant; with cell-local
coordinates ``(u, v) ∈ [0, 1]²`` of the cell ``(i, j)``::

    h = H00 (1-u)(1-v) + H01 u (1-v) + H10 (1-u) v + H11 u v      (H_ab = H[i+a, j+b])
    ∂h/∂x = ((1-v)(H01 - H00) + v (H11 - H10)) / dx
    ∂h/∂y = ((1-u)(H10 - H00) + u (H11 - H01)) / dy

Outside the grid the point is clamped to it (the edge heights continue; the
gradient across the edge is 0). The slope is ``|∇h|`` (a grade, rise over run;
``atan`` of it in degrees is the angle). MuJoCo's ``hfield`` (the rendered and
MJCF ground, :mod:`mjx_radar.physics.scene`) splits each cell into two triangles
instead; the two surfaces agree at the nodes and along cell edges and differ by at
most ``|H00 + H11 - H01 - H10| / 4`` at a cell's centre.
"""

from __future__ import annotations

import functools
from typing import NamedTuple

import jax
import jax.numpy as jnp

from mjx_radar.io.terrain_file import (  # noqa: F401 (host side, re-exported)
    TerrainFileError,
    grid_geometry,
    height_np,
    max_grade,
    node_heights,
    read_heights,
)


class TerrainGrid(NamedTuple):
    """A height grid for JAX lookups.

    Attributes:
        heights: ``[ny, nx]`` node heights [m].
        origin: ``[2]`` xy of ``heights[0, 0]`` [m].
        spacing: ``[2]`` node spacing ``(dx, dy)`` [m].
    """

    heights: jnp.ndarray
    origin: jnp.ndarray
    spacing: jnp.ndarray


@functools.cache
def terrain_grid(terrain) -> TerrainGrid:
    """The :class:`TerrainGrid` of a scenario's terrain (float32 constants, cached)."""
    h = node_heights(terrain)
    origin, spacing = grid_geometry(terrain, h.shape)
    with jax.ensure_compile_time_eval():  # cached: never capture a tracer
        f32 = functools.partial(jnp.asarray, dtype=jnp.float32)
        return TerrainGrid(f32(h), f32(origin), f32(spacing))


def _cell(grid: TerrainGrid, xy):
    """Cell indices ``(i, j)`` and local coordinates ``(u, v)``, plus inside-ness per axis."""
    ny, nx = grid.heights.shape
    s = (jnp.asarray(xy) - grid.origin.astype(jnp.result_type(xy))) / grid.spacing
    hi = jnp.array([nx - 1, ny - 1], s.dtype)
    inside = (s >= 0) & (s <= hi)
    s = jnp.clip(s, 0.0, hi)
    ij = jnp.clip(jnp.floor(s), 0, hi - 1).astype(jnp.int32)
    f = s - ij
    return ij[..., 1], ij[..., 0], f[..., 0], f[..., 1], inside


def _corners(grid, i, j, dtype):
    h = grid.heights.astype(dtype)
    return h[i, j], h[i, j + 1], h[i + 1, j], h[i + 1, j + 1]


def height(grid: TerrainGrid, xy) -> jax.Array:
    """Bilinear ground height ``[...]`` [m] at points ``xy [..., 2]``."""
    xy = jnp.asarray(xy)
    i, j, u, v, _ = _cell(grid, xy)
    h00, h01, h10, h11 = _corners(grid, i, j, xy.dtype)
    return (h00 * (1 - u) + h01 * u) * (1 - v) + (h10 * (1 - u) + h11 * u) * v


def gradient(grid: TerrainGrid, xy) -> jax.Array:
    """``[..., 2]`` gradient ``(∂h/∂x, ∂h/∂y)`` of the bilinear height (0 across the edge)."""
    xy = jnp.asarray(xy)
    i, j, u, v, inside = _cell(grid, xy)
    h00, h01, h10, h11 = _corners(grid, i, j, xy.dtype)
    sp = grid.spacing.astype(xy.dtype)
    gx = ((1 - v) * (h01 - h00) + v * (h11 - h10)) / sp[0]
    gy = ((1 - u) * (h10 - h00) + u * (h11 - h01)) / sp[1]
    return jnp.stack([gx, gy], -1) * inside


def slope(grid: TerrainGrid, xy) -> jax.Array:
    """``[...]`` grade ``|∇h|`` (rise over run) at ``xy [..., 2]``."""
    g = gradient(grid, xy)
    return jnp.sqrt(jnp.sum(g * g, -1))


def on_ground(grid: TerrainGrid, radar, antenna: float) -> jax.Array:
    """Radar states ``[..., 6]`` with z set to the ground height plus the antenna height."""
    z = height(grid, radar[..., :2]) + jnp.asarray(antenna, radar.dtype)
    return radar.at[..., 2].set(z.astype(radar.dtype))
