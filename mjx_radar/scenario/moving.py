"""Validation of ``[[moving_obstacles]]`` tables: vehicles on polyline paths (docs/maps.md).

::

    [[moving_obstacles]]
    kind = "box"                   # box | cylinder
    size = [2.5, 1.0]              # box: half length, half width; cylinder: [radius] [m]
    height = 2.5                   # [m]
    path = [[-200, -200], [200, -200], [200, 200], [-200, 200]]
    speed = 8.0                    # [m/s]
    offset = 0.0                   # arc length at t = 0 [m]
    end = "loop"                   # loop (closed polyline) | stop (at the last waypoint)

Every failure is one :class:`ScenarioError` line naming the field and the allowed values.
Refused with ``[terrain]`` (the vehicles stand on z = 0).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

from mjx_radar.io.checks import Rows, ScenarioError, check, check_table, show
from mjx_radar.scenario.schema import MovingObstacle

MAX_MOVING = 100
MAX_WAYPOINTS = 1000
_FIELDS = {f.name: f for f in dataclasses.fields(MovingObstacle)}
_ALLOWED = ("kind", "size", "height", "path", "speed", "offset", "end")


def moving_obstacles(raw: Any) -> tuple[MovingObstacle, ...]:
    """Validates the ``moving_obstacles`` array of tables."""
    if not isinstance(raw, list) or len(raw) > MAX_MOVING:
        raise ScenarioError(f"moving_obstacles: must be an array of tables (at most {MAX_MOVING})")
    return tuple(moving_obstacle(i, t) for i, t in enumerate(raw))


def moving_obstacle(i: int, raw: Any) -> MovingObstacle:
    """Validates one ``[[moving_obstacles]]`` table."""
    field = f"moving_obstacles[{i}]"
    check_table(field, raw, _ALLOWED)
    for key in ("kind", "size", "path"):
        if key not in raw:
            raise ScenarioError(f"{field}.{key}: missing required field")
    kwargs: dict[str, Any] = {}
    for key in ("kind", "height", "speed", "offset", "end"):
        if key in raw:
            kwargs[key] = check(f"{field}.{key}", raw[key], _FIELDS[key].metadata["rule"])
    need = 2 if kwargs["kind"] == "box" else 1
    size = raw["size"]
    what = "[half length, half width]" if need == 2 else "[radius]"
    if not isinstance(size, list) or len(size) != need:
        raise ScenarioError(
            f"{field}.size = {show(size)}: must be {what} for kind = {kwargs['kind']!r}"
        )
    for j, v in enumerate(size):
        ok = isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)
        if not ok or not 0.0 < v <= 1e3:
            raise ScenarioError(f"{field}.size[{j}] = {show(v)}: must be a number in (0, 1000] m")
    kwargs["size"] = tuple(float(v) for v in size)
    kwargs["path"] = path = _path(f"{field}.path", raw["path"])
    loop = kwargs.get("end", _FIELDS["end"].default) == "loop"
    if loop and math.dist(path[-1], path[0]) < 1e-3:
        raise ScenarioError(
            f"{field}.path[{len(path) - 1}] = {show(list(path[-1]))}: repeats path[0]; "
            'end = "loop" closes the path itself (drop the last waypoint)'
        )
    return MovingObstacle(**kwargs)


def _path(field: str, raw: Any) -> tuple[tuple[float, ...], ...]:
    spec: Rows = _FIELDS["path"].metadata["rule"]
    if not isinstance(raw, list) or not 2 <= len(raw) <= MAX_WAYPOINTS:
        raise ScenarioError(f"{field}: must be a list of 2 to {MAX_WAYPOINTS} [x, y] rows")
    out: list[tuple[float, ...]] = []
    for j, row in enumerate(raw):
        if not isinstance(row, list) or len(row) != 2:
            raise ScenarioError(f"{field}[{j}] = {show(row)}: must be 2 numbers [x, y]")
        p = tuple(
            check(f"{field}[{j}] ({c})", v, r) for (c, r), v in zip(spec.columns, row, strict=True)
        )
        if out and math.dist(p, out[-1]) < 1e-3:
            raise ScenarioError(
                f"{field}[{j}] = {show(row)}: repeats the waypoint before it "
                "(segments must be at least 1 mm long)"
            )
        out.append(p)
    return tuple(out)


def to_dict(m: MovingObstacle) -> dict:
    """The TOML table of one moving obstacle (what :func:`moving_obstacle` reads back equal)."""
    if not isinstance(m, MovingObstacle):
        return m  # not a MovingObstacle: moving_obstacle() names the field and refuses it
    return {
        "kind": m.kind,
        "size": list(m.size),
        "height": m.height,
        "path": [list(p) for p in m.path],
        "speed": m.speed,
        "offset": m.offset,
        "end": m.end,
    }


def check_scene(scenario) -> None:
    """Cross checks: no ``[terrain]`` (vehicles stand on z = 0), fixed radar starts clear
    of every vehicle at t = 0 (hull radius + contact envelope)."""
    if scenario.terrain is not None:
        raise ScenarioError(
            "moving_obstacles: not supported with [terrain] (the vehicles "
            "stand on z = 0; docs/maps.md)"
        )
    if not scenario.radar_init:
        raise ScenarioError(
            "moving_obstacles: need fixed radar starts (`radars` rows); random "
            "placement does not avoid obstacles"
        )
    import numpy as np

    from mjx_radar.scenario.geometry import (
        HULL_RADIUS,
        contact_envelope,
        moving_footprint_sdf,
        moving_start,
    )

    xy, unit = moving_start(scenario.moving_obstacles)
    radars = np.asarray(scenario.radar_init, np.float32)[:, :2]
    phi = moving_footprint_sdf(scenario.moving_obstacles, xy, unit, radars)  # [N, K]
    need = HULL_RADIUS + contact_envelope(scenario.limits, scenario.timing.dt_filter)
    n, k = np.unravel_index(np.argmin(phi), phi.shape)
    if phi[n, k] < need:
        raise ScenarioError(
            f"radars[{n}]: {phi[n, k]:.2f} m from moving_obstacles[{k}] at t = 0;"
            f" must be at least {need:.2f} m (hull + contact envelope)"
        )
