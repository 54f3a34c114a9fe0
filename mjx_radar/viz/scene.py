"""What the figures draw of a run's scenario: typed slices, read once.

The offline viewer, the live view, the video and the snapshot draw a run from a
:class:`Scene`, built once where the scenario is read (:func:`scene_of`: the run
directory's loader, :mod:`mjx_radar.viz.run_dir`, and the callers of the live view), never
from the :class:`~mjx_radar.scenario.schema.Scenario` itself. Its world part is the
simulator's own typed components (:mod:`mjx_radar.world.components`), each empty when
absent, so each viewer layer takes the one component it draws::

    ground     Ground            the terrain surface, draping, the radars' z (video)
    obstacles  StaticObstacles   wireframes, footprints, lines of sight
    moving     MovingObstacles   the vehicles at a time, lines of sight

with the clocks (``timing``), the fleet as drawn (fixed sites, starts, placement square,
R2T ring), the drones' starts and ``[[target_motion]]`` tables (routes, presence) and
whether the run draws detections (the counts panel).
"""

from __future__ import annotations

import dataclasses

from mjx_radar.scenario.schema import Scenario, TargetMotion, Timing
from mjx_radar.world.components import Ground, MovingObstacles, StaticObstacles


@dataclasses.dataclass(frozen=True, eq=False)
class Scene:
    """The typed description of a run's scene (N radars, M drones).

    Attributes:
        name: the scenario's name (titles).
        timing: the clocks (:class:`~mjx_radar.scenario.schema.Timing`).
        ground, obstacles, moving: the world's components (each empty when absent; the
            obstacles without the planner's cost grid).
        fixed: ``[N]`` whether each radar is a fixed site (``[[radar_override]]
            mobile = false``).
        radar_init: ``[N][3]`` the radars' fixed starts ``[x, y, theta]``, or ``()``.
        half_width: the placement square's half width [m].
        r2t: the radar-to-target ring radius [m] (``mpc.r2t``).
        target_init: ``[M][6]`` the drones' initial states.
        target_motion: the ``[[target_motion]]`` tables (waypoint routes, appear / leave).
        detection_on: whether the run draws detections or false alarms (``[detection]``).
    """

    name: str
    timing: Timing
    ground: Ground
    obstacles: StaticObstacles
    moving: MovingObstacles
    fixed: tuple[bool, ...]
    radar_init: tuple[tuple[float, ...], ...]
    half_width: float
    r2t: float
    target_init: tuple[tuple[float, ...], ...]
    target_motion: tuple[TargetMotion, ...] = ()
    detection_on: bool = False

    @property
    def n_radars(self) -> int:
        return len(self.fixed)

    @property
    def n_targets(self) -> int:
        return len(self.target_init)

    @property
    def occluded(self) -> bool:
        """Whether anything can block a line of sight (obstacles, terrain, vehicles)."""
        return self.obstacles.present or self.ground.present or self.moving.present


def scene_of(scenario: Scenario) -> Scene:
    """The :class:`Scene` of a validated scenario (host only: no JAX array is built)."""
    fixed = [False] * scenario.n_radars
    for ov in scenario.radar_override:
        fixed[ov.radar] = not ov.mobile
    d = scenario.detection
    return Scene(
        name=scenario.name,
        timing=scenario.timing,
        ground=Ground(scenario.terrain),
        obstacles=StaticObstacles(tuple(scenario.obstacles)),
        moving=MovingObstacles(tuple(scenario.moving_obstacles), scenario.timing.dt_control),
        fixed=tuple(fixed),
        radar_init=tuple(scenario.radar_init),
        half_width=float(scenario.placement_half_width),
        r2t=float(scenario.mpc.r2t),
        target_init=tuple(scenario.target_init),
        target_motion=tuple(scenario.target_motion),
        detection_on=bool(d is not None and (d.detects or d.clutter)),
    )
