"""The ``[planner]`` table of a scenario: the settings of the planner zoo (docs/planners.md).

Part of :mod:`mjx_radar.scenario.schema` (re-exported there as ``config.PlannerConfig``),
with the ``[mppi]`` table (:class:`MPPIConfig`, the paper's planner).
Which planner runs is the method's (``"ddr-sfim+cem"``, ``--planner``, ``simulate(...,
planner=)``); this table holds each built-in planner's own settings. The compute budget
is common to all: ``mppi.samples x mppi.iterations`` rollouts per control call for the
sampling planners (MPPI, predictive sampling, CEM, CMA-ES), ``gradient_steps`` gradient
steps (about three rollouts each) for ``grad``. Every field is static (part of the
compiled shape): a planner's settings are baked into its program. The defaults are the
values the planners had as class attributes, so runs keep their numbers.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from mjx_radar.io.checks import choice, rule
from mjx_radar.scenario.schema_world import positive


@dataclass(frozen=True)
class PlannerConfig:
    """Settings of the built-in planners other than MPPI (``[mppi]`` holds MPPI's).

    ``elite_fraction``, ``std_floor``: CEM keeps the ``round(elite_fraction x samples)``
    best sequences and refits a diagonal Gaussian to them, its standard deviation never
    below ``std_floor`` times the initial one. ``gradient_steps``, ``learning_rate``,
    ``optimizer``: gradient MPC (``grad``), projected optax steps in normalised box
    coordinates. ``polish_steps``, ``polish_learning_rate``: the gradient polish of
    ``hybrid`` after half the sampling iterations. ``es_std_init``: CMA-ES / Sep-CMA-ES
    (evosax) initial step size in units of the proposal standard deviation.
    """

    elite_fraction: float = field(
        default=0.1,
        metadata=rule(float, 0.0, 1.0, lo_open=True, doc="cem: fraction of samples kept as elites"),
    )
    std_floor: float = field(
        default=0.05,
        metadata=rule(float, 0.0, 1.0, doc="cem: floor of the refitted std, x the initial std"),
    )
    gradient_steps: int = field(
        default=20, metadata=rule(int, 1, 10_000, doc="grad: gradient steps per control call")
    )
    learning_rate: float = field(
        default=0.05,
        metadata=rule(
            float, 0.0, 10.0, lo_open=True, doc="grad: step size (box normalised to [-1, 1])"
        ),
    )
    optimizer: str = field(
        default="adam", metadata=choice("adam", "sgd", doc="grad and hybrid: optax optimiser")
    )
    polish_steps: int = field(
        default=10, metadata=rule(int, 1, 10_000, doc="hybrid: gradient steps after sampling")
    )
    polish_learning_rate: float = field(
        default=0.02,
        metadata=rule(float, 0.0, 10.0, lo_open=True, doc="hybrid: step size of the polish"),
    )
    es_std_init: float = field(
        default=1.0,
        metadata=rule(
            float, 0.0, 100.0, lo_open=True, doc="cmaes, sep-cmaes: initial step, x proposal std"
        ),
    )


@dataclass(frozen=True)
class MPPIConfig:
    """MPPI with adaptive importance sampling (SPEC §7). Task-agnostic."""

    samples: int = field(
        default=200, metadata=rule(int, 2, 1_000_000, doc="rollouts per iteration")
    )
    iterations: int = field(
        default=5, metadata=rule(int, 1, 1000, doc="adaptive importance-sampling iterations")
    )
    std_accel: float = field(
        default=25.0, metadata=positive("initial proposal std of a", "m/s^2", hi=1e4)
    )
    std_alpha_deg: float = field(
        default=45.0, metadata=positive("initial proposal std of alpha", "deg/s^2", hi=1e5)
    )
    weighting: str = field(default="ce", metadata=choice("ce", "softmax", doc="sample weighting"))
    elite_threshold: float = field(
        default=0.9, metadata=positive("ce: elites are costs <= (1 - thr) quantile", hi=1.0)
    )
    temperature: float = field(default=0.1, metadata=positive("softmax temperature", hi=1e6))
    shrinkage: str = field(
        default="ledoit-wolf",
        metadata=choice("ledoit-wolf", "oas", "none", doc="covariance shrinkage"),
    )
