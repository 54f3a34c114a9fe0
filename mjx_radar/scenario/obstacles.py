"""Validation of a scenario's obstacles: ``[[obstacles]]`` tables and the ``[forest]``.

Split from :mod:`mjx_radar.scenario.reader` (which imports this module lazily, only
when a scenario declares obstacles: the geometry pulls in NumPy and JAX). Errors
are :class:`ScenarioError` with a one-line message naming the field and the
allowed values.

Mesh paths are resolved relative to the scenario file's folder ``base``; an
absolute path or one that leaves ``base`` (``../``, or a link pointing out) is
refused unless the scenario sets ``allow_external_paths = true``.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

from mjx_radar.io.checks import Rule, ScenarioError, check, check_table, key_name, show
from mjx_radar.scenario.schema import SCENE, Obstacle, Scenario

_COORD = Rule(float, -SCENE, SCENE)
_SIZE = Rule(float, 0.0, 1e4, lo_open=True)
_MESH_SUFFIXES = (".obj", ".stl")
_FOREST = {  # field -> (rule, default); a list default is a [low, high] pair
    "count": (Rule(int, 1, 5000), None),
    "region": (_COORD, None),
    "seed": (Rule(int, 0, 2**31 - 1), 0),
    "radius": (Rule(float, 0.0, 1e3, lo_open=True), [1.0, 2.5]),
    "height": (_SIZE, [8.0, 20.0]),
    "spacing": (Rule(float, 0.0, 1e4), 8.0),
    "clearance": (Rule(float, 0.0, 1e4), 10.0),
}


def _rule(name: str) -> Rule:
    return next(f for f in dataclasses.fields(Obstacle) if f.name == name).metadata["rule"]


def obstacle(i: int, raw: Any, base: Path, allow_external: bool = False) -> Obstacle:
    """Validates one ``[[obstacles]]`` table (mesh paths relative to ``base``)."""
    field = f"obstacles[{i}]"
    if not isinstance(raw, dict):
        raise ScenarioError(f"{field}: must be a table")
    kind = check(f"{field}.kind", raw.get("kind"), _rule("kind"))
    allowed = ("kind", "pos", "size", "yaw", "path", "scale")
    for key in raw:
        if key not in allowed:
            raise ScenarioError(
                f"{field}.{key_name(key)}: unknown field; allowed: {', '.join(allowed)}"
            )
    pos = raw.get("pos", [0.0, 0.0, 0.0])
    if not isinstance(pos, list) or len(pos) != 3:
        raise ScenarioError(f"{field}.pos = {show(pos)}: must be 3 numbers")
    pos = tuple(check(f"{field}.pos[{j}]", v, _COORD) for j, v in enumerate(pos))
    n_size = {"box": 3, "cylinder": 2, "mesh": 0}[kind]
    size = raw.get("size", [])
    if not isinstance(size, list) or len(size) != n_size:
        raise ScenarioError(f"{field}.size = {show(size)}: a {kind} needs {n_size} numbers > 0")
    size = tuple(check(f"{field}.size[{j}]", v, _SIZE) for j, v in enumerate(size))
    path = ""
    if kind == "mesh":
        path = _mesh_path(field, raw.get("path"), base, allow_external)
    elif "path" in raw:
        raise ScenarioError(f"{field}.path: only a mesh obstacle has a path")
    yaw = check(f"{field}.yaw", raw.get("yaw", 0.0), _rule("yaw"))
    scale = check(f"{field}.scale", raw.get("scale", 1.0), _rule("scale"))
    return Obstacle(kind=kind, pos=pos, size=size, yaw=yaw, path=path, scale=scale)


def _mesh_path(field: str, given: Any, base: Path, allow_external: bool) -> str:
    """The absolute path of an existing, readable mesh file inside ``base``."""
    name = f"{field}.path = {show(given)}"
    if not isinstance(given, str) or not given or "\x00" in given:
        raise ScenarioError(f"{name}: must be an existing mesh file ({', '.join(_MESH_SUFFIXES)})")
    path = Path(resolve_file(f"{field}.path", given, base, allow_external, "mesh file"))
    if path.suffix.lower() not in _MESH_SUFFIXES:
        raise ScenarioError(f"{name}: unsupported mesh type; must be {' or '.join(_MESH_SUFFIXES)}")
    _check_mesh(field, given, str(path))
    return str(path)


def resolve_file(field: str, given: Any, base: Path, allow_external: bool, what: str) -> str:
    """The absolute path of an existing file ``given`` relative to ``base`` (the path policy).

    Shared by mesh obstacles and track CSVs (:mod:`mjx_radar.scenario.motion`).
    """
    name = f"{field} = {show(given)}"
    if not isinstance(given, str) or not given or "\x00" in given:
        raise ScenarioError(f"{name}: must be the path of an existing {what}")
    try:
        path = (base / given).resolve()
        inside = path.is_relative_to(base.resolve())
        is_file = path.is_file()
    except (OSError, RuntimeError) as err:
        raise ScenarioError(f"{name}: cannot resolve path ({_one_line(err)})") from None
    if (Path(given).is_absolute() or not inside) and not allow_external:
        raise ScenarioError(
            f"{name}: absolute or outside the scenario file's folder; set "
            "allow_external_paths = true at the top level to allow it"
        )
    if not is_file:
        raise ScenarioError(f"{name}: must be an existing {what}")
    return str(path)


def _one_line(err: Exception) -> str:
    text = str(err).strip()
    return text.splitlines()[0] if text else type(err).__name__


def _format_problem(path: str) -> str | None:
    """Why the file is not a well-formed OBJ/STL (cheap checks before trimesh), or None."""
    data = Path(path).read_bytes()
    if path.lower().endswith(".stl"):
        if data[:5].lower() == b"solid" and data.isascii():
            return None  # ASCII STL
        if len(data) >= 84:
            n = int.from_bytes(data[80:84], "little")
            if len(data) == 84 + 50 * n and n > 0:
                return None  # binary STL: header, count, 50 bytes per triangle
        return "neither an ASCII STL (text starting with 'solid') nor a binary STL (size mismatch)"
    try:
        data.decode("utf-8")
    except UnicodeDecodeError as err:
        return f"an OBJ file must be text; not UTF-8 at byte offset {err.start}"
    return None


def _check_mesh(field: str, given: str, path: str) -> None:
    import numpy as np

    from mjx_radar.scenario import geometry

    name = f"{field}.path = {show(given)}"
    try:
        problem = _format_problem(path)
    except OSError as err:
        raise ScenarioError(f"{name}: cannot read mesh file ({err.strerror})") from None
    if problem:
        raise ScenarioError(f"{name}: unreadable mesh file {path}: {problem}")
    try:
        verts, _ = geometry.mesh_local(path, 1.0)
    except Exception as err:  # trimesh raises many types for bad files
        raise ScenarioError(f"{name}: cannot read mesh file {path} ({_one_line(err)})") from None
    if len(verts) < 4 or not np.all(np.isfinite(verts)) or float(np.ptp(verts, 0).min()) <= 0:
        raise ScenarioError(f"{name}: mesh must enclose a volume (>= 4 finite vertices)")
    if float(np.abs(verts).max()) > SCENE:
        raise ScenarioError(f"{name}: mesh vertices must lie within {SCENE:g} m of its origin")


def _numbers(field: str, raw: Any, n: int, rule: Rule) -> list:
    if not isinstance(raw, list) or len(raw) != n:
        raise ScenarioError(f"{field} = {show(raw)}: must be a list of {n} numbers")
    return [check(f"{field}[{j}]", v, rule) for j, v in enumerate(raw)]


def forest(raw: Any, radar_init) -> tuple[Obstacle, ...]:
    """Validates the ``[forest]`` table and generates its trees (cylinders)."""
    from mjx_radar.scenario import geometry

    check_table("forest", raw, _FOREST)
    v: dict[str, Any] = {}
    for key, (rule, default) in _FOREST.items():
        if key not in raw and default is None:
            raise ScenarioError(f"forest.{key}: missing required field")
        value = raw.get(key, default)
        n = {"region": 4, "radius": 2, "height": 2}.get(key)
        v[key] = (
            _numbers(f"forest.{key}", value, n, rule) if n else check(f"forest.{key}", value, rule)
        )
    x0, y0, x1, y1 = v["region"]
    if not (x0 < x1 and y0 < y1):
        raise ScenarioError(f"forest.region = {v['region']}: need xmin < xmax and ymin < ymax")
    for key in ("radius", "height"):
        if v[key][0] > v[key][1]:
            raise ScenarioError(f"forest.{key} = {v[key]!r}: need low <= high")
    trees = geometry.generate_forest(
        v["count"],
        v["region"],
        v["seed"],
        v["radius"],
        v["height"],
        v["spacing"],
        [r[:2] for r in radar_init],
        v["clearance"],
    )
    if len(trees) < v["count"]:
        raise ScenarioError(
            f"forest.count = {v['count']}: only {len(trees)} trees fit in forest.region with "
            f"forest.spacing = {v['spacing']} and forest.clearance = {v['clearance']}"
        )
    return trees


def check_radar_clearance(s: Scenario) -> None:
    """With obstacles, the fixed radar starts must exist and clear every footprint."""
    if not s.obstacles:
        return
    if not s.radar_init:
        raise ScenarioError(
            "radars: required when obstacles are declared (random placement does not avoid "
            "obstacles); give n_radars rows [x, y, theta] clear of them"
        )
    from mjx_radar.scenario import geometry
    from mjx_radar.scenario.geometry import contact_envelope

    need = geometry.HULL_RADIUS + contact_envelope(s.limits, s.timing.dt_filter)
    gap = geometry.union_sdf(s.obstacles, [r[:2] for r in s.radar_init])
    for i, g in enumerate(gap):
        if g < need:
            raise ScenarioError(
                f"radars[{i}] = {list(s.radar_init[i])}: starts {g:.2f} m from an obstacle "
                f"footprint; need >= {need:.2f} m (radar hull + contact envelope)"
            )
