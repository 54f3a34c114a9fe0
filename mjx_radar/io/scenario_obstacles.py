"""Validation of a scenario's obstacles: ``[[obstacles]]`` tables and the ``[forest]``.

Split from :mod:`mjx_radar.io.scenario` (which imports this module lazily and
whose checking helpers it uses). Errors are :class:`ScenarioError` with a
one-line message naming the field and the allowed values.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from mjx_radar.config import Obstacle, Scenario
from mjx_radar.io.checks import INF, NONNEG, POS, ScenarioError, check
from mjx_radar.world import obstacles as geometry

_FOREST = {  # field -> (rule, default); a list default is a [low, high] pair
    "count": ((int, 1, 5000, True), None),
    "region": ((float, -INF, INF, True), None),
    "seed": ((int, 0, 2**31 - 1, True), 0),
    "radius": (POS, [1.0, 2.5]),
    "height": (POS, [8.0, 20.0]),
    "spacing": (NONNEG, 8.0),
    "clearance": (NONNEG, 10.0),
}


def obstacle(i: int, raw: Any, base: Path) -> Obstacle:
    """Validates one ``[[obstacles]]`` table."""
    field = f"obstacles[{i}]"
    if not isinstance(raw, dict):
        raise ScenarioError(f"{field}: must be a table")
    kind = check(f"{field}.kind", raw.get("kind"), (str, ("box", "cylinder", "mesh")))
    allowed = {"kind", "pos", "size", "yaw", "path", "scale"}
    for key in raw:
        if key not in allowed:
            raise ScenarioError(f"{field}.{key}: unknown field; allowed: {', '.join(allowed)}")
    pos = raw.get("pos", [0.0, 0.0, 0.0])
    if not isinstance(pos, list) or len(pos) != 3:
        raise ScenarioError(f"{field}.pos = {pos!r}: must be 3 numbers")
    pos = tuple(check(f"{field}.pos", v, (float, -INF, INF, True)) for v in pos)
    n_size = {"box": 3, "cylinder": 2, "mesh": 0}[kind]
    size = raw.get("size", [])
    if not isinstance(size, list) or len(size) != n_size:
        raise ScenarioError(f"{field}.size = {size!r}: a {kind} needs {n_size} numbers > 0")
    size = tuple(check(f"{field}.size", v, POS) for v in size)
    path = ""
    if kind == "mesh":
        path = str((base / str(raw.get("path", ""))).resolve())
        if not raw.get("path") or not Path(path).is_file():
            raise ScenarioError(
                f"{field}.path = {raw.get('path')!r}: must be an existing mesh file"
            )
        _check_mesh(field, raw["path"], path)
    yaw = check(f"{field}.yaw", raw.get("yaw", 0.0), (float, -INF, INF, True))
    scale = check(f"{field}.scale", raw.get("scale", 1.0), POS)
    return Obstacle(kind=kind, pos=pos, size=size, yaw=yaw, path=path, scale=scale)


def _one_line(err: Exception) -> str:
    text = str(err).strip()
    return text.splitlines()[0] if text else type(err).__name__


def _check_mesh(field: str, given: str, path: str) -> None:
    try:
        verts, _ = geometry._mesh_local(path, 1.0)
    except Exception as err:  # trimesh raises many types for bad files
        raise ScenarioError(
            f"{field}.path = {given!r}: cannot read mesh ({_one_line(err)})"
        ) from None
    if len(verts) < 4 or float(np.ptp(verts, axis=0).min()) <= 0.0:
        raise ScenarioError(f"{field}.path = {given!r}: mesh must enclose a volume")


def _numbers(field: str, raw: Any, n: int, rule: tuple) -> list:
    if not isinstance(raw, list) or len(raw) != n:
        raise ScenarioError(f"{field} = {raw!r}: must be a list of {n} numbers")
    return [check(field, v, rule) for v in raw]


def forest(raw: Any, radar_init) -> tuple[Obstacle, ...]:
    """Validates the ``[forest]`` table and generates its trees (cylinders)."""
    if not isinstance(raw, dict):
        raise ScenarioError("forest: must be a table")
    for key in raw:
        if key not in _FOREST:
            raise ScenarioError(f"forest.{key}: unknown field; allowed: {', '.join(_FOREST)}")
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
        raise ScenarioError(f"forest.region = {v['region']!r}: need xmin < xmax and ymin < ymax")
    for key in ("radius", "height"):
        if v[key][0] > v[key][1]:
            raise ScenarioError(f"forest.{key} = {v[key]!r}: need low <= high")
    trees = geometry.generate_forest(
        v["count"], v["region"], v["seed"], v["radius"], v["height"], v["spacing"],
        [r[:2] for r in radar_init], v["clearance"],
    )  # fmt: skip
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
    from mjx_radar.physics.plant import contact_envelope

    need = geometry.HULL_RADIUS + contact_envelope(s.limits, s.timing.dt_filter)
    gap = geometry.union_sdf(s.obstacles, [r[:2] for r in s.radar_init])
    for i, g in enumerate(gap):
        if g < need:
            raise ScenarioError(
                f"radars[{i}] = {list(s.radar_init[i])}: starts {g:.2f} m from an obstacle "
                f"footprint; need >= {need:.2f} m (radar hull + contact envelope)"
            )
