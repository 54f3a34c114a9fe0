"""Terrain files on the host (NumPy only, no JAX): reading, node heights, a float64 lookup.

The grid conventions and the bilinear interpolant are those of
:mod:`mjx_radar.world.terrain` (which re-exports these names); this module stays free of
JAX so that ``mjx-radar validate`` of a terrain scenario stays light.
"""

from __future__ import annotations

import functools
import math
from pathlib import Path

import numpy as np

MAX_NODES = 4096  # grid nodes per side at most
PNG_MODES = {"I;16": 65535.0, "I;16B": 65535.0, "I;16L": 65535.0, "I": 65535.0, "L": 255.0}


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
        if not isinstance(arr, np.ndarray):  # np.load of an np.savez archive: an NpzFile
            arr.close()
            raise TerrainFileError("an .npz archive, not a .npy array; save one array with np.save")
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
    check_float32(grid)
    return grid


def check_float32(grid: np.ndarray, scale: float = 1.0) -> None:
    """Refuses heights (times ``scale``) beyond float32's range (the programs' dtype)."""
    big = np.abs(grid) * abs(scale) > np.finfo(np.float32).max
    if np.any(big):
        bad = np.argwhere(big)[0]
        raise TerrainFileError(
            f"height {grid[bad[0], bad[1]] * scale:.3g} at row {bad[0]}, column {bad[1]} "
            "overflows float32 (the simulation's dtype)"
        )


def _line(err: Exception) -> str:
    text = str(err).strip()
    return text.splitlines()[0] if text else type(err).__name__


@functools.cache
def node_heights(terrain) -> np.ndarray:
    """``[ny, nx]`` heights [m] of a :class:`~mjx_radar.scenario.schema.Terrain` (host, cached)."""
    return terrain.height_scale * read_heights(terrain.path)


def grid_geometry(terrain, shape) -> tuple[np.ndarray, np.ndarray]:
    """``(origin [2], spacing [2])`` of a grid of ``shape = (ny, nx)``."""
    ext = np.array([terrain.extent_x, terrain.extent_y])
    return -0.5 * ext, ext / (np.array([shape[1], shape[0]]) - 1.0)


def max_grade(terrain) -> float:
    """``tan(max_slope_deg)``: the steepest grade a radar drives on."""
    return math.tan(math.radians(terrain.max_slope_deg))


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
