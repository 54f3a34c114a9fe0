"""Occupancy grid maps in ROS ``map_server`` format → box obstacles (host only).

A map is a YAML file (``image``, ``resolution``, ``origin``, ``negate``,
``occupied_thresh``, ``free_thresh``, optional ``mode``) and a grayscale or RGB(A)
image (PGM, PNG, ...), read exactly as ROS ``map_server`` reads it (ROS wiki
``map_server`` §YAML format; ``navigation/map_server/src/image_loader.cpp``;
Nav2 ``nav2_map_server/src/map_io.cpp``):

* a pixel's value ``x`` is the mean of its colour channels (alpha excluded);
  with ``negate = 0`` its occupancy probability is ``p = (255 − x) / 255``
  (black = occupied), with ``negate = 1`` ``p = x / 255``;
* ``p > occupied_thresh`` → occupied; ``p < free_thresh`` → free; otherwise
  unknown (``mode: trinary``, the default). In ``mode: scale`` map_server gives such
  a cell a scaled value in (0, 100) (or unknown when its alpha < 255); either way it
  is neither occupied nor free, and here it is unknown too. ``mode: raw`` is refused;
* image row 0 is the TOP of the map: cell ``(i, j)`` (column i, row j counted
  from the BOTTOM image row) covers ``[i, i + 1) × [j, j + 1)`` cells of side
  ``resolution`` [m/pixel] in the map frame, whose origin is the lower-left corner
  of the bottom-left pixel at the pose ``origin = [x, y, yaw]`` (yaw
  counter-clockwise, rad) in the world.

Unknown cells are occupied by default (``unknown = "occupied"``; ``"free"`` drops
them). Occupied cells become boxes standing on z = 0 of a given height: maximal
runs of occupied cells along each row, then runs with equal columns in
consecutive rows merged into one rectangle (:func:`merge_runs`). The union of the
boxes is exactly the set of occupied cells.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import NamedTuple

import numpy as np

from mjx_radar.scenario.buildings import MapError
from mjx_radar.scenario.schema import Obstacle

MAX_PIXELS = 4096 * 4096
MAX_BOXES = 5000
_KEYS = ("image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh", "mode")


class OccupancyGrid(NamedTuple):
    """An occupancy grid in the map frame (row 0 = bottom).

    Attributes:
        occupied: ``[rows, cols]`` bool; ``occupied[j, i]`` is cell (i, j).
        resolution: cell side [m].
        origin: (x, y, yaw) of the grid's lower-left corner in the world [m, m, rad].
    """

    occupied: np.ndarray
    resolution: float
    origin: tuple[float, float, float]


def _yaml_float(v):
    """A YAML 1.1 string that is a float to yaml-cpp (ROS): ``5e-1`` (no dot) -> 0.5."""
    if isinstance(v, str):
        try:
            return float(v.strip())
        except ValueError:
            return v
    return v


def _number(meta: dict, key: str, lo: float, hi: float) -> float:
    v = _yaml_float(meta.get(key))
    if isinstance(v, bool) or not isinstance(v, int | float) or not (lo <= v <= hi):
        raise MapError(f"{key} = {v!r}: must be a number in [{lo:g}, {hi:g}]")
    return float(v)


def read_map(yaml_path: str | Path, unknown: str = "occupied") -> OccupancyGrid:
    """Reads a ``map_server`` YAML + image pair.

    Args:
        yaml_path: the YAML file; its ``image`` is resolved relative to its folder.
        unknown: ``"occupied"`` or ``"free"``: what an unknown cell becomes.

    Raises:
        MapError: one line naming the key or the image problem.
    """
    import yaml
    from PIL import Image

    yaml_path = Path(yaml_path)
    try:
        meta = yaml.safe_load(yaml_path.read_text())
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as err:
        raise MapError(f"not a readable YAML file ({str(err).splitlines()[0]})") from None
    except RecursionError:
        raise MapError("not a readable YAML file (nested too deeply)") from None
    if not isinstance(meta, dict):
        raise MapError("must be a YAML mapping with image, resolution, origin, ...")
    for key in ("image", "resolution", "origin", "occupied_thresh", "free_thresh"):
        if key not in meta:
            raise MapError(f"{key}: missing required key")
    res = _number(meta, "resolution", 1e-3, 1e3)
    occ_th = _number(meta, "occupied_thresh", 0.0, 1.0)
    free_th = _number(meta, "free_thresh", 0.0, 1.0)
    if free_th > occ_th:
        raise MapError(f"free_thresh = {free_th} > occupied_thresh = {occ_th}")
    negate = meta.get("negate", 0)
    if negate not in (0, 1) or isinstance(negate, float):
        raise MapError(f"negate = {negate!r}: must be 0 or 1")
    mode = meta.get("mode", "trinary")
    if mode not in ("trinary", "scale"):
        raise MapError(f"mode = {mode!r}: must be trinary or scale (raw is not supported)")
    origin = meta["origin"]
    origin = [_yaml_float(v) for v in origin] if isinstance(origin, list) else origin
    if (
        not isinstance(origin, list)
        or len(origin) != 3
        or not all(isinstance(v, int | float) and math.isfinite(v) for v in origin)
    ):
        raise MapError(f"origin = {origin!r}: must be [x, y, yaw] (3 finite numbers)")
    image = meta["image"]
    if not isinstance(image, str) or not image:
        raise MapError(f"image = {image!r}: must be a file name")
    img_path = yaml_path.parent / image
    if Path(image).is_absolute() or ".." in Path(image).parts:
        raise MapError(f"image = {image!r}: must be a path inside the YAML file's folder")
    try:
        with Image.open(img_path) as img:
            if img.width * img.height > MAX_PIXELS:
                raise MapError(f"image {image}: {img.width}x{img.height} pixels; at most 4096²")
            if img.mode not in ("L", "LA", "RGB", "RGBA", "P", "1"):
                raise MapError(f"image {image}: mode {img.mode}; need 8-bit gray or RGB(A)")
            img = img.convert("RGBA" if img.mode in ("LA", "RGBA", "P") else "RGB")
            px = np.asarray(img, np.float64)
    except MapError:
        raise
    except Exception as err:  # PIL raises many types for bad images
        raise MapError(f"image {image}: cannot read ({str(err).splitlines()[0]})") from None
    x = px[..., :3].mean(-1)
    p = x / 255.0 if negate else (255.0 - x) / 255.0
    occupied = p > occ_th
    free = p < free_th
    unknown_cells = ~occupied & ~free
    if unknown not in ("occupied", "free"):
        raise MapError(f"unknown = {unknown!r}: must be 'occupied' or 'free'")
    if unknown == "occupied":
        occupied = occupied | unknown_cells
    return OccupancyGrid(occupied[::-1].copy(), res, tuple(float(v) for v in origin))


def merge_runs(occupied: np.ndarray) -> list[tuple[int, int, int, int]]:
    """Rectangles ``(i0, i1, j0, j1)`` (half-open cell ranges) tiling the occupied cells.

    Row by row, maximal runs ``[i0, i1)`` of occupied cells; a run equal to an open
    rectangle's columns in the previous row extends it (``j1 += 1``).
    """
    done: list[tuple[int, int, int, int]] = []
    open_: dict[tuple[int, int], int] = {}  # (i0, i1) -> j0 of the rectangle growing upwards
    for j, row in enumerate(np.asarray(occupied, bool)):
        edges = np.flatnonzero(np.diff(np.concatenate([[0], row.astype(np.int8), [0]])))
        runs = set(zip(edges[::2].tolist(), edges[1::2].tolist(), strict=True))
        for run in list(open_):
            if run not in runs:
                done.append((*run, open_.pop(run), j))
        for run in runs:
            open_.setdefault(run, j)
    done += [(*run, j0, len(occupied)) for run, j0 in open_.items()]
    return sorted(done, key=lambda r: (r[2], r[0]))


def to_world(grid: OccupancyGrid, uv: np.ndarray) -> np.ndarray:
    """World xy ``[..., 2]`` of map-frame points ``uv[..., 2]`` given in cells."""
    x0, y0, yaw = grid.origin
    c, s = math.cos(yaw), math.sin(yaw)
    u, v = uv[..., 0] * grid.resolution, uv[..., 1] * grid.resolution
    return np.stack([x0 + c * u - s * v, y0 + s * u + c * v], -1)


def cell_centres(grid: OccupancyGrid) -> np.ndarray:
    """``[rows, cols, 2]`` world xy of every cell centre."""
    rows, cols = grid.occupied.shape
    jj, ii = np.meshgrid(np.arange(rows), np.arange(cols), indexing="ij")
    return to_world(grid, np.stack([ii + 0.5, jj + 0.5], -1))


def box_obstacles(grid: OccupancyGrid, height: float) -> tuple[Obstacle, ...]:
    """The merged rectangles of occupied cells as boxes of ``height`` [m] on z = 0."""
    rects = merge_runs(grid.occupied)
    if len(rects) > MAX_BOXES:
        raise MapError(f"{len(rects)} boxes after merging occupied cells; at most {MAX_BOXES}")
    out = []
    for i0, i1, j0, j1 in rects:
        cx, cy = to_world(grid, np.array([0.5 * (i0 + i1), 0.5 * (j0 + j1)]))
        half = (0.5 * (i1 - i0) * grid.resolution, 0.5 * (j1 - j0) * grid.resolution)
        out.append(
            Obstacle(
                kind="box",
                pos=(float(cx), float(cy), 0.5 * height),
                size=(*half, 0.5 * height),
                yaw=math.atan2(math.sin(grid.origin[2]), math.cos(grid.origin[2])),
            )
        )
    return tuple(out)
