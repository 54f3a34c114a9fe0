"""The radar task, built once per scenario shape (hydrax's Task, brax's System).

A :class:`RadarTask` holds everything static that the closed loop and the planner
need: the typed parts of the scenario shape (:func:`mjx_radar.task.params.shape_key`)
the lower floors read (clocks, MPC, MPPI, filter, tracker, detection, the fleet), the
world's components built once (:class:`~mjx_radar.world.components.World`: ground,
static and moving obstacles, lines of sight), the truth and planner plants, the
planner's rollout backend, the measurement model, the cost terms and the CV matrices of
the filter and planning clocks. Everything numeric that users vary is in
:class:`mjx_radar.task.params.TaskParams`. The floors from ``env/`` down read these
parts, never ``task.scenario``: that is kept for the floors above and for plug-ins
(registered cost terms, trackers and planners).
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp

from mjx_radar.estimation.sensor import measurement
from mjx_radar.physics import kinematics, motion
from mjx_radar.physics import plant as physics
from mjx_radar.physics.rollout import radar_rollout
from mjx_radar.scenario.schema import (
    DetectionConfig,
    FilterConfig,
    MPCConfig,
    MPPIConfig,
    PlannerConfig,
    Scenario,
    Timing,
    TrackerConfig,
)
from mjx_radar.task import cost_plugins, costs
from mjx_radar.task.planner import Fleet
from mjx_radar.world.components import Ground, World, make_world


@dataclasses.dataclass(frozen=True, eq=False)
class RadarTask:
    """Static parts of a scenario (hashable by identity: a ``jit`` static).

    Attributes:
        scenario: the scenario shape (runtime numbers blanked), for plug-ins and the
            floors above the environment.
        n_targets: M; fleet: the radars (:class:`~mjx_radar.task.planner.Fleet`).
        timing, mpc, mppi, filter, tracker, detection, planner: the scenario's tables.
        world: the :class:`~mjx_radar.world.components.World` (ground, obstacles,
            vehicles, lines of sight).
        measurement: the measurement model (range, range + azimuth, ...).
        terms: the objective's cost terms.
        rollout: ``(radar_state[N,6], u[H,N,2]) -> [H,N,6]`` planner rollout.
        truth: the truth plant (radars, drones, obstacles).
        a_filter, q_filter_unit: CV transition and process noise per unit σ_W² at
            the filter step, ``[6M, 6M]``.
        a_control: CV transition at the control step ``[6M, 6M]``.
        a6, w6_unit: one target's control-step transition / unit process noise [6, 6].
        a6_filter, w6_filter_unit: the same at the filter step (the PCRLB).
        kind: what is compiled of the planner (:data:`~mjx_radar.task.method.PROGRAM_KINDS`):
            ``"all"`` (every method, runtime flags), ``"sfim"`` / ``"pfim"`` (that
            information only) or ``"none"`` (no planner: stationary radars).
    """

    scenario: Scenario
    n_targets: int
    fleet: Fleet
    timing: Timing
    mpc: MPCConfig
    mppi: MPPIConfig
    filter: FilterConfig
    tracker: TrackerConfig
    detection: DetectionConfig
    planner: PlannerConfig
    world: World
    measurement: Any
    terms: tuple[costs.CostTerm, ...]
    rollout: Callable
    truth: physics.Plant
    a_filter: jax.Array
    q_filter_unit: jax.Array
    a_control: jax.Array
    a6: jax.Array
    w6_unit: jax.Array
    a6_filter: jax.Array
    w6_filter_unit: jax.Array
    kind: str = "all"


def _rollout_backend(scenario: Scenario, ground: Ground) -> Callable:
    """``(state[N,6], u[H,N,2]) -> [H,N,6]``, each control held for ``mpc.substeps`` steps."""
    k, limits = scenario.mpc.substeps, scenario.limits
    dt = scenario.timing.dt_control / k
    if scenario.mpc.rollout == "mjx":
        # one radar, vmapped over the N radars by radar_rollout (see planner_plant)
        dt_control = scenario.timing.dt_control
        plant = (
            physics.planner_plant(dt_control, limits)
            if k == 1
            else physics.make_plant(1, 0, dt, limits)
        )

        def integrate(state, u):
            return radar_rollout(plant, state, u)
    else:

        def integrate(state, u):
            return kinematics.unicycle_rollout(state, u, dt, limits)

    if ground.present:  # z on the ground: the analytic lookup (no contacts)
        flat = integrate

        def integrate(state, u):
            return ground.on_ground(flat(state, u))

    if k == 1:
        return integrate
    return lambda state, u: integrate(state, jnp.repeat(u, k, axis=0))[k - 1 :: k]


def _truth_plant(shape: Scenario):
    """The truth plant of a scenario shape (:func:`~mjx_radar.physics.plant.truth_plant`)."""
    world = (shape.obstacles, shape.terrain, shape.moving_obstacles)
    return physics.truth_plant(
        shape.n_radars, shape.n_targets, shape.timing.dt_filter, shape.limits, *world
    )


def make_task(shape: Scenario, kind: str = "all") -> RadarTask:
    """Builds the task of a scenario shape (cached: one task per shape, program kind,
    registered cost terms (:func:`mjx_radar.task.cost_plugins.registry_key`) and process)."""
    return _task_of_kind(shape, cost_plugins.registry_key(), kind)


@functools.cache
def _task_of_kind(shape: Scenario, registry: tuple, kind: str) -> RadarTask:
    from mjx_radar.task.method import PROGRAM_KINDS

    if kind not in PROGRAM_KINDS:
        raise ValueError(f"program kind {kind!r} not in {PROGRAM_KINDS}")
    base = _make_task(shape, registry)
    return base if kind == "all" else dataclasses.replace(base, kind=kind)


@functools.cache
def _make_task(shape: Scenario, registry: tuple) -> RadarTask:
    t, m = shape.timing, shape.n_targets
    world = make_world(
        shape.terrain,
        shape.obstacles,
        shape.moving_obstacles,
        t.dt_control,
        shape.mpc,
        shape.placement_half_width,
    )
    bounds = None
    if shape.radar_override:  # a mixed fleet: per-radar bounds, fixed sites bound to 0
        from mjx_radar.scenario.fleet import control_bounds

        bounds = tuple(tuple(b) for b in control_bounds(shape))
    return RadarTask(
        scenario=shape,
        n_targets=m,
        fleet=Fleet(shape.n_radars, shape.limits, bounds),
        timing=t,
        mpc=shape.mpc,
        mppi=shape.mppi,
        filter=shape.filter,
        tracker=shape.tracker,
        detection=shape.detection,
        planner=shape.planner,
        world=world,
        measurement=measurement.make_model(shape.measurement.model),
        terms=costs.builtin_terms(world, shape.mpc) + costs.registered_terms(shape),
        rollout=_rollout_backend(shape, world.ground),
        truth=_truth_plant(shape),
        a_filter=motion.cv_transition(t.dt_filter, m),
        q_filter_unit=motion.cv_process_noise(t.dt_filter, 1.0, m),
        a_control=motion.cv_transition(t.dt_control, m),
        a6=motion.cv_transition(t.dt_control, 1),
        w6_unit=motion.cv_process_noise(t.dt_control, 1.0, 1),
        a6_filter=motion.cv_transition(t.dt_filter, 1),
        w6_filter_unit=motion.cv_process_noise(t.dt_filter, 1.0, 1),
    )


def build(scenario: Scenario, method="ddr-sfim", seed: int | None = None):
    """``(task, params)`` of a scenario and method: the static task and the runtime numbers.

    Args:
        scenario: a validated scenario.
        method: a :class:`~mjx_radar.task.method.Method` or its name.
        seed: base seed (default the scenario's).
    """
    from mjx_radar.task.method import parse_method
    from mjx_radar.task.params import shape_key, task_params

    return make_task(shape_key(scenario)), task_params(scenario, parse_method(method), seed)


def process_noise(task: RadarTask, params) -> jax.Array:
    """Filter-step process noise ``σ_W² Q₁`` ``[6M, 6M]``."""
    return jnp.asarray(params.sigma_w2, task.q_filter_unit.dtype) * task.q_filter_unit
