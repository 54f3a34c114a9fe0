"""Validation of a scenario's map tables: ``[buildings]`` (GeoJSON) and ``[occupancy]``.

Both tables are expanded once, when the scenario is read, into obstacles
(``Scenario.obstacles``, after the ``[[obstacles]]`` and ``[forest]`` ones), like
the forest: buildings into convex extruded mesh obstacles
(:mod:`mjx_radar.scenario.buildings`), occupied cells into merged boxes
(:mod:`mjx_radar.scenario.occupancy`). The map files are resolved relative to the
scenario file's folder ``base`` with the mesh path policy (absolute or leaving
``base`` only with ``allow_external_paths = true``). Errors are one-line
:class:`ScenarioError` naming the field (docs/maps.md).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from mjx_radar.io.checks import Rule, ScenarioError, check, check_table, show
from mjx_radar.scenario.schema import SCENE, Obstacle

#: field -> (rule, default, doc); default None = required
BUILDINGS = {
    "path": (None, None, "GeoJSON FeatureCollection of Polygon/MultiPolygon footprints"),
    "crs": (
        Rule(str, choices=("local", "lonlat")),
        None,
        "'local' (metres, x east, y north) or 'lonlat' (WGS84 degrees)",
    ),
    "origin": (None, [], "[lon, lat] of the local frame's origin [deg] (crs = 'lonlat' only)"),
    "height_key": (Rule(str), "height", "feature property holding the height [m]"),
}
OCCUPANCY = {
    "path": (None, None, "ROS map_server YAML file (image, resolution, origin, thresholds)"),
    "height": (Rule(float, 0.0, 1e3, lo_open=True), 5.0, "obstacle height of occupied cells [m]"),
    "unknown": (
        Rule(str, choices=("occupied", "free")),
        "occupied",
        "what a cell between the thresholds becomes",
    ),
}
SUFFIXES = {"buildings": (".geojson", ".json"), "occupancy": (".yaml", ".yml")}


def map_path(field: str, given: Any, base: Path, allow_external: bool, suffixes) -> Path:
    """The resolved path of an existing map file inside ``base`` (mesh path policy)."""
    name = f"{field} = {show(given)}"
    if not isinstance(given, str) or not given or "\x00" in given:
        raise ScenarioError(f"{name}: must be an existing map file ({', '.join(suffixes)})")
    try:
        path = (base / given).resolve()
        inside = path.is_relative_to(base.resolve())
        is_file = path.is_file()
    except (OSError, RuntimeError) as err:
        raise ScenarioError(f"{name}: cannot resolve path ({err})") from None
    if (Path(given).is_absolute() or not inside) and not allow_external:
        raise ScenarioError(
            f"{name}: absolute or outside the scenario file's folder; set "
            "allow_external_paths = true at the top level to allow it"
        )
    if not is_file:
        raise ScenarioError(f"{name}: must be an existing map file")
    if path.suffix.lower() not in suffixes:
        raise ScenarioError(f"{name}: unsupported map type; must be {' or '.join(suffixes)}")
    return path


def _fields(table: str, raw: Any, spec: dict) -> dict:
    check_table(table, raw, spec)
    out = {}
    for key, (rule, default, _) in spec.items():
        if key not in raw and default is None:
            raise ScenarioError(f"{table}.{key}: missing required field")
        value = raw.get(key, default)
        out[key] = check(f"{table}.{key}", value, rule) if rule is not None else value
    return out


def buildings(raw: Any, base: Path, allow_external: bool = False) -> tuple[Obstacle, ...]:
    """Validates ``[buildings]`` and returns its buildings' convex mesh parts."""
    from mjx_radar.scenario import buildings as geo

    v = _fields("buildings", raw, BUILDINGS)
    path = map_path("buildings.path", v["path"], base, allow_external, SUFFIXES["buildings"])
    origin = v["origin"]
    if v["crs"] == "lonlat":
        if not isinstance(origin, list) or len(origin) != 2:
            raise ScenarioError(
                f"buildings.origin = {show(origin)}: crs = 'lonlat' needs "
                "[lon, lat] of the local origin [deg]"
            )
        origin = (
            check("buildings.origin[0]", origin[0], Rule(float, -180.0, 180.0)),
            check("buildings.origin[1]", origin[1], Rule(float, -85.0, 85.0)),
        )
    elif origin != []:
        raise ScenarioError(f"buildings.origin = {show(origin)}: only with crs = 'lonlat'")
    try:
        found = geo.read_geojson(path, v["crs"], origin, v["height_key"])
        obstacles = geo.building_obstacles(found)
    except geo.MapError as err:
        raise ScenarioError(f"buildings.path = {show(v['path'])}: {err}") from None
    except OSError as err:
        raise ScenarioError(f"buildings: cannot write the building meshes ({err})") from None
    _check_extent("buildings", obstacles)
    return obstacles


def occupancy(raw: Any, base: Path, allow_external: bool = False) -> tuple[Obstacle, ...]:
    """Validates ``[occupancy]`` and returns its occupied cells as merged boxes."""
    from mjx_radar.scenario import buildings as geo
    from mjx_radar.scenario import occupancy as grid_map

    v = _fields("occupancy", raw, OCCUPANCY)
    path = map_path("occupancy.path", v["path"], base, allow_external, SUFFIXES["occupancy"])
    try:
        grid = grid_map.read_map(path, v["unknown"])
        obstacles = grid_map.box_obstacles(grid, v["height"])
    except geo.MapError as err:
        raise ScenarioError(f"occupancy.path = {show(v['path'])}: {err}") from None
    if not obstacles:
        raise ScenarioError(f"occupancy.path = {show(v['path'])}: the map has no occupied cell")
    _check_extent("occupancy", obstacles)
    return obstacles


def _check_extent(table: str, obstacles) -> None:
    for o in obstacles:
        if o.size and max(o.size) > 1e4:
            big = max(o.size)
            raise ScenarioError(f"{table}: an obstacle of half size {big:g} m; at most 1e4 m")
        if max(abs(o.pos[0]), abs(o.pos[1])) > SCENE:
            raise ScenarioError(
                f"{table}: an obstacle at {list(o.pos[:2])} lies beyond "
                f"{SCENE:g} m of the origin (check origin / crs)"
            )


def map_files(raw: dict, base: Path) -> list[Path]:
    """Every file a scenario's map tables read (for bundling): GeoJSON, YAML, image."""
    import yaml

    files = []
    if isinstance(raw.get("buildings"), dict):
        files.append((base / raw["buildings"]["path"]).resolve())
    if isinstance(raw.get("occupancy"), dict):
        meta_path = (base / raw["occupancy"]["path"]).resolve()
        files.append(meta_path)
        files.append((meta_path.parent / yaml.safe_load(meta_path.read_text())["image"]).resolve())
    return files
