"""Typed, immutable scenario configuration (SPEC defaults; tables also in schema_detection,
schema_metrics, schema_filter, schema_planner, schema_tracker, schema_world,
schema_terrain): frozen, hashable dataclasses (static under ``jax.jit``), SI units; each
field's allowed range is its metadata (:mod:`mjx_radar.io.checks`)."""

from __future__ import annotations

import importlib
import math
from dataclasses import dataclass, field

from mjx_radar.io.checks import choice, col, flag, host, name_rule, rows, rule, runtime, table
from mjx_radar.scenario.names import accept_toml_names
from mjx_radar.scenario.schema_detection import DetectionConfig
from mjx_radar.scenario.schema_filter import FilterConfig
from mjx_radar.scenario.schema_metrics import MetricsConfig
from mjx_radar.scenario.schema_planner import MPPIConfig, PlannerConfig
from mjx_radar.scenario.schema_sensing import MeasurementConfig, RadarEquation
from mjx_radar.scenario.schema_terrain import Terrain
from mjx_radar.scenario.schema_tracker import TrackerConfig
from mjx_radar.scenario.schema_world import MovingObstacle, RadarOverride, TargetMotion, positive

SCENE = 1e5  # |x|, |y| bound of every position [m] (float32 keeps ~1 cm there)
TARGET_COLUMNS = (  # plausibility bounds of an initial target state (docs/scenarios.md)
    ("x", col(-SCENE, SCENE, "m")),
    ("y", col(-SCENE, SCENE, "m")),
    ("z", col(0.0, 1e4, "m", lo_open=True)),  # above the ground plane of the radars
    ("vx", col(-1e3, 1e3, "m/s")),
    ("vy", col(-1e3, 1e3, "m/s")),
    ("vz", col(-1e3, 1e3, "m/s")),
)
RADAR_COLUMNS = (
    ("x", col(-SCENE, SCENE, "m")),
    ("y", col(-SCENE, SCENE, "m")),
    ("theta", col(-10.0, 10.0, "rad")),
)


@dataclass(frozen=True)
class RadarLimits:
    """Unicycle control and state limits (SPEC §3), symmetric about zero."""

    accel: float = field(default=35.0, metadata=positive("|a| bound", "m/s^2", hi=1e4))
    alpha: float = field(default=math.pi, metadata=positive("|alpha| bound", "rad/s^2", hi=1e4))
    speed: float = field(default=50.0, metadata=positive("|v| bound", "m/s", hi=1e3))
    omega: float = field(default=2.0 * math.pi, metadata=positive("|omega| bound", "rad/s", hi=1e3))


@dataclass(frozen=True)
class Timing:
    """Filter and control clocks (SPEC §4, §9)."""

    dt_filter: float = field(default=0.025, metadata=positive("CKF / truth step", "s", hi=1.0))
    dt_control: float = field(
        default=0.1,
        metadata=rule(
            float,
            0.0,
            10.0,
            lo_open=True,
            doc="MPPI step; an integer multiple of dt_filter",
            unit="s",
        ),
    )
    steps: int = field(
        default=600,
        metadata=rule(
            int, 1, 10_000_000, doc="filter steps per trial; a multiple of dt_control/dt_filter"
        ),
    )

    @property
    def control_every(self) -> int:
        """Number of filter steps per control step."""
        return int(round(self.dt_control / self.dt_filter))


@dataclass(frozen=True)
class MPCConfig:
    """MPC objective weights and horizon (SPEC §6)."""

    horizon: int = field(default=15, metadata=rule(int, 1, 1000, doc="K, steps of dt_control"))
    gamma: float = field(
        default=0.95, metadata=runtime(rule(float, 0.0, 1.0, lo_open=True, doc="discount"))
    )
    r2t: float = field(
        default=125.0,
        metadata=runtime(rule(float, 0.0, 1e4, doc="radar-target keep-out", unit="m")),
    )
    r2r: float = field(
        default=10.0, metadata=runtime(rule(float, 0.0, 1e4, doc="radar-radar keep-out", unit="m"))
    )
    alpha_r2r: float = field(
        default=500.0,
        metadata=runtime(rule(float, 0.0, 1e9, doc="weight of radar-radar violations")),
    )
    alpha_r2t: float = field(
        default=1000.0,
        metadata=runtime(rule(float, 0.0, 1e9, doc="weight of radar-target violations")),
    )
    alpha_effort: float = field(
        default=0.0,
        metadata=rule(
            float,
            0.0,
            1e9,
            doc="weight of the control effort (a/a_max)^2 + "
            "(alpha/alpha_max)^2 summed over radars (0: term off)",
        ),
    )
    alpha_assoc: float = field(
        default=0.0,
        metadata=rule(
            float,
            0.0,
            1e9,
            doc="weight of drone pairs whose ranges coincide at a radar, "
            "exp(-(r_i - r_j)^2 / (2 assoc_scale^2)) summed over radars and pairs (0: term off)",
        ),
    )
    assoc_scale: float = field(
        default=5.0,
        metadata=rule(
            float,
            0.0,
            1e3,
            lo_open=True,
            doc="range separation below which two drones' returns at a radar are confusable",
            unit="m",
        ),
    )
    alpha_obs: float = field(
        default=1000.0,
        metadata=rule(
            float, 0.0, 1e9, doc="weight of obstacle intrusion (only with obstacles)", unit="1/m"
        ),
    )
    obs_margin: float = field(
        default=6.0,
        metadata=rule(
            float, 0.0, 1e3, doc="keep-out from obstacle footprints, radar centre", unit="m"
        ),
    )
    los: bool = field(
        default=False,
        metadata=flag("planner drops occluded radar-target pairs (truth always does)"),
    )
    rollout: str = field(
        default="mjx",
        metadata=choice(
            "mjx", "analytic", doc="planner rollouts: MuJoCo-MJX physics or closed-form unicycle"
        ),
    )
    aligned: bool = field(
        default=True,
        metadata=flag(
            "plan from the estimate at the radars' instant (false: the paper code's "
            "one-filter-step lead of the targets)"
        ),
    )
    substeps: int = field(
        default=1,
        metadata=rule(
            int,
            1,
            100,
            doc="Euler sub-steps per control step in the planner's rollouts "
            "(the plant integrates at dt_filter: substeps = dt_control/dt_filter matches it)",
        ),
    )


@dataclass(frozen=True)
class Obstacle:
    """A static obstacle. ``kind`` is "box", "cylinder" or "mesh".

    box: ``size`` = half extents (x, y, z); cylinder: ``size`` = (radius, half
    height); mesh: ``path`` to an OBJ/STL file, ``scale`` uniform.
    """

    kind: str = field(metadata=choice("box", "cylinder", "mesh", doc="obstacle type"))
    pos: tuple[float, float, float] = (0.0, 0.0, 0.0)
    size: tuple[float, ...] = ()
    yaw: float = field(
        default=0.0, metadata=rule(float, -10.0, 10.0, doc="rotation about z", unit="rad")
    )
    path: str = ""
    scale: float = field(default=1.0, metadata=positive("uniform mesh scale", hi=1e3))


@accept_toml_names  # Scenario(targets=..., radars=..., radar_equation=...) as in the file
@dataclass(frozen=True)
class Scenario:
    """Everything that defines an experiment. Hashable (static under jit)."""

    name: str = field(metadata=runtime(name_rule("scenario name (file names of results)")))
    n_radars: int = field(metadata=rule(int, 1, 1000, doc="number of radars N"))
    target_init: tuple[tuple[float, ...], ...] = field(  # [M][6] rows x y z vx vy vz
        metadata=runtime(
            rows(TARGET_COLUMNS, doc="initial target states, one row per target", toml="targets")
        )
    )
    seed: int = field(
        default=0, metadata=runtime(rule(int, 0, 2**31 - 1, doc="base seed of the trials"))
    )
    sigma_w2: float = field(
        default=10.0,
        metadata=runtime(
            rule(float, 0.0, 1e4, doc="target white-acceleration variance", unit="m^2/s^4")
        ),
    )
    p0: float = field(
        default=50.0,
        metadata=runtime(
            rule(float, 1e-6, 1e6, doc="initial CKF covariance P0 = p0 * I", unit="m^2")
        ),
    )
    placement_half_width: float = field(
        default=400.0, metadata=runtime(positive("radars placed in [-w, w]^2", "m", 1e5))
    )
    radar_eq: RadarEquation = field(
        default_factory=RadarEquation,
        metadata=runtime(table("radar equation (SPEC 1)", toml="radar_equation")),
    )
    limits: RadarLimits = field(
        default_factory=RadarLimits, metadata=table("radar control and state limits")
    )
    timing: Timing = field(default_factory=Timing, metadata=table("filter and control clocks"))
    mpc: MPCConfig = field(default_factory=MPCConfig, metadata=table("MPC objective and horizon"))
    mppi: MPPIConfig = field(default_factory=MPPIConfig, metadata=table("MPPI sampler"))
    filter: FilterConfig = field(
        default_factory=FilterConfig, metadata=table("state estimator (docs/statistics.md)")
    )
    measurement: MeasurementConfig = field(
        default_factory=MeasurementConfig, metadata=table("measurement model (docs/measurement.md)")
    )
    obstacles: tuple[Obstacle, ...] = ()  # [[obstacles]] and [forest]: scenario.obstacles
    target_motion: tuple[TargetMotion, ...] = ()  # [[target_motion]]: scenario.motion
    radar_override: tuple[RadarOverride, ...] = ()  # [[radar_override]]: scenario.fleet
    terrain: Terrain | None = None  # [terrain]: scenario.terrain (None: flat ground z = 0)
    moving_obstacles: tuple[MovingObstacle, ...] = ()  # [[moving_obstacles]]: scenario.moving
    radar_init: tuple[tuple[float, ...], ...] = field(  # optional fixed [N][3] rows x y theta
        default=(),
        metadata=runtime(
            rows(RADAR_COLUMNS, count="n_radars", doc="optional fixed radar starts", toml="radars")
        ),
    )
    detection: DetectionConfig = field(
        default_factory=DetectionConfig,
        metadata=table("detection probability, clutter, association (docs/detection.md)"),
    )
    planner: PlannerConfig = field(
        default_factory=PlannerConfig,
        metadata=table("settings of the planner zoo: cem, grad, hybrid, cmaes (docs/planners.md)"),
    )
    metrics: MetricsConfig = field(
        default_factory=MetricsConfig,
        metadata=host(table("GOSPA / OSPA settings (docs/tracking_metrics.md)")),
    )
    tracker: TrackerConfig = field(
        default_factory=TrackerConfig,
        metadata=table("multi-target association: pda, jpda, gnn, mht (docs/tracking.md)"),
    )

    @property
    def n_targets(self) -> int:
        return len(self.target_init)

    def replace(self, **changes) -> Scenario:
        """A validated copy; tables as dicts (``mpc={"r2t": 150.0}``): scenario.edit."""
        return _edit().replace(self, **changes)

    def to_toml(self, path=None) -> str:
        """The scenario as TOML (written to ``path`` if given); loads back equal."""
        return _edit().to_toml(self, path)


def _edit():
    """:mod:`mjx_radar.scenario.edit`, found by name when a method needs it.

    The schema sits below the reader and ``edit`` (which validates through the reader and
    builds a :class:`Scenario`), so it never imports them: the two methods above reach
    ``edit`` late, by name, as the registry reaches its built-in plug-ins.
    """
    return importlib.import_module("mjx_radar.scenario.edit")
