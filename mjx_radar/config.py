"""Typed, immutable configuration of a scenario (SPEC defaults).

Every dataclass here is frozen and hashable so a whole :class:`Scenario` can be
passed as a static argument to ``jax.jit``. Units are SI (m, s, rad, W, Hz).
Loading and validation of scenario files lives in :mod:`mjx_radar.io.scenario`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

METHODS = ("stationary", "ccr-sfim", "ccr-pfim", "ddr-sfim", "ddr-pfim")


@dataclass(frozen=True)
class RadarEquation:
    """Radar-equation parameters (SPEC §1, paper Table "Radar Equation")."""

    fc: float = 1e8  # carrier frequency [Hz]
    loss: float = 1.0  # general loss factor L [-]
    gain_tx: float = 200.0  # transmit gain [-]
    gain_rx: float = 200.0  # receive gain [-]
    r_ref: float = 500.0  # range at which SNR equals snr_db [m]
    rcs: float = 1.0  # radar cross section [m^2]
    power_tx: float = 1000.0  # transmit power [W]
    snr_db: float = -20.0  # SNR at r_ref [dB]


@dataclass(frozen=True)
class RadarLimits:
    """Unicycle control and state limits (SPEC §3), symmetric about zero."""

    accel: float = 35.0  # |a| [m/s^2]
    alpha: float = math.pi  # |alpha| [rad/s^2]
    speed: float = 50.0  # |v| [m/s]
    omega: float = 2.0 * math.pi  # |omega| [rad/s]


@dataclass(frozen=True)
class Timing:
    """Filter and control clocks (SPEC §4, §9)."""

    dt_filter: float = 0.025  # CKF / truth step [s]
    dt_control: float = 0.1  # MPPI step [s]; an integer multiple of dt_filter
    steps: int = 600  # filter steps per trial

    @property
    def control_every(self) -> int:
        """Number of filter steps per control step."""
        return int(round(self.dt_control / self.dt_filter))


@dataclass(frozen=True)
class MPCConfig:
    """MPC objective weights and horizon (SPEC §6)."""

    horizon: int = 15  # K, steps of dt_control
    gamma: float = 0.95  # discount
    r2t: float = 125.0  # radar-target keep-out [m]
    r2r: float = 10.0  # radar-radar keep-out [m]
    alpha_r2r: float = 500.0  # weight of radar-radar violations
    alpha_r2t: float = 1000.0  # weight of radar-target violations
    alpha_obs: float = 1000.0  # weight of obstacle intrusion [1/m] (only with obstacles)
    obs_margin: float = 6.0  # keep-out from obstacle footprints, radar centre [m]
    los: bool = False  # planner drops occluded radar-target pairs (truth always does)
    rollout: str = "mjx"  # "mjx" (MuJoCo-MJX physics) | "analytic" (closed-form unicycle)


@dataclass(frozen=True)
class MPPIConfig:
    """MPPI with adaptive importance sampling (SPEC §7). Task-agnostic."""

    samples: int = 200
    iterations: int = 5
    std_accel: float = 25.0  # initial proposal std of a [m/s^2]
    std_alpha_deg: float = 45.0  # initial proposal std of alpha [deg/s^2]
    weighting: str = "ce"  # "ce" | "softmax"
    elite_threshold: float = 0.9  # ce: elites are costs <= (1 - thr) quantile
    temperature: float = 0.1  # softmax temperature
    shrinkage: str = "ledoit-wolf"  # "ledoit-wolf" | "oas" | "none"


@dataclass(frozen=True)
class FilterConfig:
    """Structure of the tracking filter (issue 15)."""

    structure: str = "joint"  # "joint" (paper's joint CKF) | "per-target" (filter bank)


@dataclass(frozen=True)
class Obstacle:
    """A static obstacle. ``kind`` is "box", "cylinder" or "mesh".

    box: ``size`` = half extents (x, y, z); cylinder: ``size`` = (radius, half
    height); mesh: ``path`` to an OBJ/STL file, ``scale`` uniform.
    """

    kind: str
    pos: tuple[float, float, float] = (0.0, 0.0, 0.0)
    size: tuple[float, ...] = ()
    yaw: float = 0.0
    path: str = ""
    scale: float = 1.0


@dataclass(frozen=True)
class Scenario:
    """Everything that defines an experiment. Hashable (static under jit)."""

    name: str
    n_radars: int
    target_init: tuple[tuple[float, ...], ...]  # [M][6] rows x y z vx vy vz
    seed: int = 0
    sigma_w2: float = 10.0  # target white-acceleration variance [m^2/s^4]
    p0: float = 50.0  # initial CKF covariance P0 = p0 * I
    placement_half_width: float = 400.0  # radars placed in [-w, w]^2
    radar_eq: RadarEquation = field(default_factory=RadarEquation)
    limits: RadarLimits = field(default_factory=RadarLimits)
    timing: Timing = field(default_factory=Timing)
    mpc: MPCConfig = field(default_factory=MPCConfig)
    mppi: MPPIConfig = field(default_factory=MPPIConfig)
    filter: FilterConfig = field(default_factory=FilterConfig)
    obstacles: tuple[Obstacle, ...] = ()
    radar_init: tuple[tuple[float, ...], ...] = ()  # optional fixed [N][3] rows x y theta

    @property
    def n_targets(self) -> int:
        return len(self.target_init)
