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
import math
from pathlib import Path
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

MAX_NODES = 4096  # grid nodes per side at most
PNG_MODES = {"I;16": 65535.0, "I;16B": 65535.0, "I;16L": 65535.0, "I": 65535.0, "L": 255.0}


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


class TerrainFileError(ValueError):
    """A terrain file that cannot be used; ``str(err)`` is one line."""


def read_heights(path: str | Path) -> np.ndarray:
    """Raw grid values of a ``.npy`` or grayscale ``.png`` file, float64 ``[ny, nx]``.

    PNG values are divided by the largest code (65535 or 255) and flipped so that
    row 0 is the south edge (the image's bottom row). Raises :class:`TerrainFileError`
    (one line) on a wrong dtype, shape, non-finite values or a colour image.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".npy":
        try:
            arr = np.load(path, allow_pickle=False)
        except (OSError, ValueError, EOFError) as err:
            raise TerrainFileError(f"not a readable .npy array ({_line(err)})") from None
        if not (np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer)):
            raise TerrainFileError(f"dtype {arr.dtype} is not allowed; need float or integer")
        grid = arr.astype(np.float64)
    elif suffix == ".png":
        from PIL import Image, UnidentifiedImageError

        try:
            with Image.open(path) as img:
                mode = img.mode
                if mode not in PNG_MODES:
                    raise TerrainFileError(
                        f"PNG mode {mode} is not grayscale; need a 16-bit (or 8-bit) grayscale PNG"
                    )
                grid = np.asarray(img, dtype=np.float64) / PNG_MODES[mode]
        except (OSError, UnidentifiedImageError) as err:
            raise TerrainFileError(f"not a readable PNG image ({_line(err)})") from None
        grid = grid[::-1]  # image rows run north to south
    else:
        raise TerrainFileError(f"suffix {suffix or '(none)'} is not allowed; need .npy or .png")
    if grid.ndim != 2 or min(grid.shape) < 2 or max(grid.shape) > MAX_NODES:
        raise TerrainFileError(
            f"shape {grid.shape} is not allowed; need a 2-D grid of 2 to {MAX_NODES} nodes per side"
        )
    if not np.all(np.isfinite(grid)):
        bad = np.argwhere(~np.isfinite(grid))[0]
        raise TerrainFileError(f"non-finite height at row {bad[0]}, column {bad[1]}")
    return grid


def _line(err: Exception) -> str:
    text = str(err).strip()
    return text.splitlines()[0] if text else type(err).__name__


@functools.cache
def node_heights(terrain) -> np.ndarray:
    """``[ny, nx]`` heights [m] of a :class:`~mjx_radar.config.Terrain` (host, cached)."""
    return terrain.height_scale * read_heights(terrain.path)


def grid_geometry(terrain, shape) -> tuple[np.ndarray, np.ndarray]:
    """``(origin [2], spacing [2])`` of a grid of ``shape = (ny, nx)``."""
    ext = np.array([terrain.extent_x, terrain.extent_y])
    return -0.5 * ext, ext / (np.array([shape[1], shape[0]]) - 1.0)


@functools.cache
def terrain_grid(terrain) -> TerrainGrid:
    """The :class:`TerrainGrid` of a scenario's terrain (float32 constants, cached)."""
    h = node_heights(terrain)
    origin, spacing = grid_geometry(terrain, h.shape)
    with jax.ensure_compile_time_eval():  # cached: never capture a tracer
        f32 = functools.partial(jnp.asarray, dtype=jnp.float32)
        return TerrainGrid(f32(h), f32(origin), f32(spacing))


def max_grade(terrain) -> float:
    """``tan(max_slope_deg)``: the steepest grade a radar drives on."""
    return math.tan(math.radians(terrain.max_slope_deg))


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


def height_np(terrain, xy) -> np.ndarray:
    """Host float64 bilinear height of a config terrain at ``xy [..., 2]`` (no JAX)."""
    h = node_heights(terrain)
    origin, spacing = grid_geometry(terrain, h.shape)
    ny, nx = h.shape
    s = np.clip((np.asarray(xy, float) - origin) / spacing, 0.0, [nx - 1, ny - 1])
    ij = np.clip(np.floor(s), 0, [nx - 2, ny - 2]).astype(int)
    f = s - ij
    j, i, u, v = ij[..., 0], ij[..., 1], f[..., 0], f[..., 1]
    return (h[i, j] * (1 - u) + h[i, j + 1] * u) * (1 - v) + (
        h[i + 1, j] * (1 - u) + h[i + 1, j + 1] * u
    ) * v
