"""The ``[terrain]`` table: height-field file path policy, file checks, targets vs ground.

``path`` is resolved relative to the scenario file's folder, like mesh paths
(absolute paths and paths leaving it need ``allow_external_paths = true``); the
numeric fields follow their rules in :class:`mjx_radar.scenario.schema.Terrain`. The file
itself is read once here, so a bad file (wrong dtype, NaN heights, a colour image,
...) fails at load time with one line naming ``terrain.path``
(:func:`mjx_radar.world.terrain.read_heights`). After the scenario is built,
:func:`check_targets` refuses a target that starts below the ground (absolute z),
and fixed radar starts on slopes beyond the vehicle limit.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

from mjx_radar.io.checks import ScenarioError, check, key_name, show
from mjx_radar.scenario.schema import Scenario, Terrain

SUFFIXES = (".npy", ".png")


def terrain(raw: Any, base: Path, allow_external: bool) -> Terrain:
    """Reads and checks the ``[terrain]`` table (``base``: the scenario file's folder)."""
    if not isinstance(raw, dict):
        raise ScenarioError(f"terrain: must be a table, got {type(raw).__name__}")
    rules = {f.name: f.metadata["rule"] for f in dataclasses.fields(Terrain) if f.metadata}
    for key in raw:
        if key not in rules and key != "path":
            allowed = ", ".join(["path", *rules])
            raise ScenarioError(f"terrain.{key_name(key)}: unknown field; allowed: {allowed}")
    kwargs = {k: check(f"terrain.{k}", raw[k], r) for k, r in rules.items() if k in raw}
    if "path" not in raw:
        raise ScenarioError("terrain.path: missing required field (a .npy or .png height field)")
    kwargs["path"] = _path(raw["path"], base, allow_external)
    out = Terrain(**kwargs)
    from mjx_radar.io.terrain_file import (
        TerrainFileError,
        check_float32,
        node_heights,
        read_heights,
    )

    try:
        check_float32(read_heights(out.path), out.height_scale)
    except TerrainFileError as err:
        raise ScenarioError(f"terrain.path = {show(raw['path'])}: {err}") from None
    node_heights.cache_clear()  # a file rewritten in place is read again
    return out


def _path(given: Any, base: Path, allow_external: bool) -> str:
    name = f"terrain.path = {show(given)}"
    if not isinstance(given, str) or not given or "\x00" in given:
        raise ScenarioError(f"{name}: must be an existing .npy or .png file")
    try:
        path = (base / given).resolve()
        inside = path.is_relative_to(base.resolve())
        is_file = path.is_file()
    except (OSError, RuntimeError) as err:
        raise ScenarioError(f"{name}: cannot resolve path ({type(err).__name__})") from None
    if (Path(given).is_absolute() or not inside) and not allow_external:
        raise ScenarioError(
            f"{name}: absolute or outside the scenario file's folder; set "
            "allow_external_paths = true at the top level to allow it"
        )
    if not is_file:
        raise ScenarioError(f"{name}: must be an existing .npy or .png file")
    if path.suffix.lower() not in SUFFIXES:
        raise ScenarioError(f"{name}: unsupported file type; must be .npy or .png")
    return str(path)


def check_targets(s: Scenario) -> None:
    """Refuses targets starting below the terrain and fixed radar starts on steep ground."""
    import numpy as np

    from mjx_radar.io.terrain_file import height_np, max_grade, node_heights

    t = s.terrain
    if t is None:
        return
    if not t.targets_agl:
        for j, row in enumerate(s.target_init):
            ground = float(height_np(t, np.asarray(row[:2])))
            if row[2] <= ground:
                raise ScenarioError(
                    f"targets[{j}][2] (z) = {row[2]}: starts below the terrain (ground "
                    f"{ground:.2f} m at x = {row[0]}, y = {row[1]}); raise it or set "
                    "terrain.targets_agl = true"
                )
    h = node_heights(t)
    for i, row in enumerate(s.radar_init):
        if abs(row[0]) > t.extent_x / 2 or abs(row[1]) > t.extent_y / 2:
            raise ScenarioError(
                f"radars[{i}] = {show(list(row))}: outside the terrain grid (|x| <= "
                f"{t.extent_x / 2:g} m, |y| <= {t.extent_y / 2:g} m: terrain.extent_x / extent_y)"
            )
        g = _grade(t, h, np.asarray(row[:2], float))
        if g > max_grade(t):
            raise ScenarioError(
                f"radars[{i}] = {show(list(row))}: starts on a slope of "
                f"{np.degrees(np.arctan(g)):.1f} deg, steeper than terrain.max_slope_deg = "
                f"{t.max_slope_deg}"
            )


def _grade(t: Terrain, h, xy) -> float:
    """Host grade |∇h| by central differences of the bilinear height (0.01 of a cell)."""
    import numpy as np

    from mjx_radar.io.terrain_file import grid_geometry, height_np

    eps = 0.01 * grid_geometry(t, h.shape)[1]
    gx = (height_np(t, xy + [eps[0], 0]) - height_np(t, xy - [eps[0], 0])) / (2 * eps[0])
    gy = (height_np(t, xy + [0, eps[1]]) - height_np(t, xy - [0, eps[1]])) / (2 * eps[1])
    return float(np.hypot(gx, gy))
