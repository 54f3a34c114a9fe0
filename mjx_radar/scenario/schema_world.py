"""Configuration beyond the paper's world: per-target motion and per-radar overrides.

:class:`TargetMotion` is one ``[[target_motion]]`` table, :class:`RadarOverride` one
``[[radar_override]]`` table. Split from :mod:`mjx_radar.scenario.schema` (which re-exports
both); each field's allowed range is its metadata (:mod:`mjx_radar.io.checks`), read by
:mod:`mjx_radar.scenario.motion` / :mod:`mjx_radar.scenario.fleet` and listed in
docs/scenarios.md.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from mjx_radar.io.checks import INF, choice, col, flag, rows, rule, runtime

SCENE = 1e5  # |x|, |y| bound of every position [m] (as mjx_radar.scenario.schema.SCENE)


def positive(doc: str, unit: str = "", hi: float = INF) -> dict:
    """Metadata of a float in (0, hi]."""
    return rule(float, 0.0, hi, lo_open=True, doc=doc, unit=unit)


WAYPOINT_COLUMNS = (
    ("x", col(-SCENE, SCENE, "m")),
    ("y", col(-SCENE, SCENE, "m")),
    ("z", col(0.0, 1e4, "m", lo_open=True)),
)


@dataclass(frozen=True)
class TargetMotion:
    """How one target flies in the truth plant (``[[target_motion]]``, docs/scenarios.md).

    ``model``: "cv" (the paper's constant velocity with white acceleration, the
    default of every target without a table), "waypoints" (bounded-acceleration
    pursuit of ``waypoints`` at ``speed``), "turn" (coordinated turn at ``rate``) or
    "track" (the CSV ``path`` of ``t, x, y, z``). Non-CV models are a nominal path
    (:mod:`mjx_radar.physics.target_motion`); ``sigma_w2`` adds a CV perturbation on top.
    ``appear`` / ``leave``: the target is present for ``appear <= t < leave`` (absent:
    no measurements, no planner cost, no error in the metrics).
    """

    target: int = field(metadata=rule(int, 0, 999, doc="index of the target row (0-based)"))
    model: str = field(
        default="cv", metadata=choice("cv", "waypoints", "turn", "track", doc="motion model")
    )
    waypoints: tuple[tuple[float, ...], ...] = field(
        default=(), metadata=rows(WAYPOINT_COLUMNS, doc="waypoints: at least 2 rows [x, y, z]")
    )
    speed: float = field(
        default=20.0, metadata=positive("waypoints: commanded speed", "m/s", hi=1e3)
    )
    accel_max: float = field(
        default=10.0, metadata=positive("waypoints: acceleration bound", "m/s^2", hi=1e4)
    )
    capture: float = field(
        default=0.0,
        metadata=rule(
            float,
            0.0,
            1e5,
            doc="waypoints: a waypoint counts as passed within "
            "this distance (0: 2 speed^2 / accel_max)",
            unit="m",
        ),
    )
    loop: bool = field(default=False, metadata=flag("waypoints: fly the list again after the last"))
    rate: float = field(
        default=0.0,
        metadata=rule(
            float, -10.0, 10.0, doc="turn: turn rate (> 0 counter-clockwise)", unit="rad/s"
        ),
    )
    path: str = ""  # track: CSV of t, x, y, z (absolute once loaded; scenario.motion)
    track: tuple[tuple[float, ...], ...] = ()  # track: the CSV rows, read when loaded
    sigma_w2: float = field(
        default=-1.0,
        metadata=rule(
            float,
            -1.0,
            1e4,
            doc="truth white-acceleration variance of this "
            "target (-1: the scenario's sigma_w2 for cv, 0 for the others)",
            unit="m^2/s^4",
        ),
    )
    appear: float = field(
        default=0.0, metadata=rule(float, 0.0, 1e7, doc="time the target appears", unit="s")
    )
    leave: float = field(
        default=INF,
        metadata=rule(
            float, 0.0, 1e7, lo_open=True, doc="time the target leaves (omitted: never)", unit="s"
        ),
    )


@dataclass(frozen=True)
class RadarOverride:
    """One radar's departures from the fleet's tables (``[[radar_override]]``).

    ``radar_eq`` / ``limits``: ``((field, value), ...)`` replacing those fields of the
    scenario's ``[radar_equation]`` / ``[limits]`` for this radar (the rest are the
    fleet's). ``mobile = false``: a fixed site (the planner never moves it).
    """

    radar: int = field(metadata=rule(int, 0, 999, doc="index of the radar (0-based)"))
    mobile: bool = field(default=True, metadata=flag("false: a fixed site that never moves"))
    radar_eq: tuple[tuple[str, float], ...] = ()  # [radar_override.radar_equation]
    limits: tuple[tuple[str, float], ...] = ()  # [radar_override.limits] (accel, alpha)


PATH_COLUMNS = (("x", col(-SCENE, SCENE, "m")), ("y", col(-SCENE, SCENE, "m")))


@dataclass(frozen=True)
class MovingObstacle:
    """A vehicle driving a polyline on the ground (``[[moving_obstacles]]``, docs/maps.md).

    Its footprint centre at time t is the point at arc length
    ``s(t) = offset + speed · t`` along ``path`` (wrapped modulo the closed loop's length
    with ``end = "loop"``, where the last waypoint joins the first; held at the last
    waypoint with ``end = "stop"``); a box is turned along the segment it is on
    (:mod:`mjx_radar.world.moving`). Solid in the truth plant (an MJCF mocap body), a
    keep-out for the planner at its predicted positions, an occluder of lines of sight.
    """

    kind: str = field(metadata=choice("box", "cylinder", doc="footprint"))
    size: tuple[float, ...] = ()  # box: half length, half width; cylinder: radius [m]
    height: float = field(default=3.0, metadata=positive("height above the ground", "m", 1e3))
    path: tuple[tuple[float, ...], ...] = field(
        default=(), metadata=runtime(rows(PATH_COLUMNS, doc="path: at least 2 waypoints [x, y]"))
    )
    speed: float = field(
        default=10.0, metadata=runtime(positive("speed along the path", "m/s", 100.0))
    )
    offset: float = field(
        default=0.0,
        metadata=runtime(rule(float, 0.0, 1e6, doc="arc length along the path at t = 0", unit="m")),
    )
    end: str = field(
        default="loop",
        metadata=choice(
            "loop",
            "stop",
            doc="after the last waypoint: back to the first (closed loop) or stop there",
        ),
    )
