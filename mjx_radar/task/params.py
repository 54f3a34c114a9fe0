"""A scenario split into its compiled *shape* and its runtime *parameters*.

One compiled program serves every scenario of the same shape (N radars, M targets,
horizon, MPPI samples and iterations, clocks, obstacles, rollout backend,
measurement model): the numbers users vary between runs -- the method, the radar
equation, the keep-out distances and weights, the discount, the initial states, the
process noise, ``p0`` and the seed -- enter the program as a :class:`TaskParams`
pytree of arrays, so changing them hits the compilation cache.

:func:`shape_key` blanks those numbers in the (hashable, static) scenario with
``None``: any code that still reads one of them from the static scenario fails at
trace time instead of silently using a stale value.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from mjx_radar.estimation.sensor import detection, measurement
from mjx_radar.io.checks import is_host, is_runtime
from mjx_radar.scenario.schema import DetectionConfig, Scenario
from mjx_radar.task.method import Method, MethodFlags
from mjx_radar.world.components import Ground
from mjx_radar.world.moving import MovingParams, moving_params

if TYPE_CHECKING:  # annotations only (imported lazily where used)
    from mjx_radar.physics.target_motion import MotionParams


class TaskParams(NamedTuple):
    """Runtime numbers of a scenario and method (all arrays; unbatched over trials).

    Shapes: ``target_init [M, 6]``, ``radar_init [N, 3]`` (zeros without fixed starts),
    the rest scalars; ``motion`` (per-target motion and presence,
    :class:`~mjx_radar.physics.target_motion.MotionParams`) and ``target_weight``
    (the planner's ``[M]`` presence weights, set per control step by the closed loop)
    are None unless the scenario has ``[[target_motion]]`` tables.
    """

    method: MethodFlags
    noise: measurement.NoiseParams
    seed: jax.Array  # [] uint32 base seed of the trial streams
    sigma_w2: jax.Array  # [] target white-acceleration variance [m²/s⁴]
    p0: jax.Array  # [] initial covariance p0·I [m²]
    placement_half_width: jax.Array  # [] [m]
    target_init: jax.Array  # [M, 6]
    radar_init: jax.Array  # [N, 3] x, y, theta
    gamma: jax.Array  # [] discount
    r2t: jax.Array  # [] radar-target keep-out [m]
    r2r: jax.Array  # [] radar-radar keep-out [m]
    alpha_r2r: jax.Array  # [] weight of radar-radar violations
    alpha_r2t: jax.Array  # [] weight of radar-target violations
    detection: detection.DetectionParams | None = None  # issue 23
    motion: MotionParams | None = None  # with [[target_motion]], else None
    target_weight: jax.Array | None = None  # [M] planner weight (presence), None: all 1
    moving: MovingParams | None = None  # with [[moving_obstacles]], else None
    plan_time: jax.Array | None = None  # [] planning instant [s] (moving obstacles)


def task_params(scenario: Scenario, method: Method, seed: int | None = None) -> TaskParams:
    """The runtime parameters of ``scenario`` for ``method`` (JAX default float dtype)."""
    mpc = scenario.mpc
    dtype = jnp.result_type(float)  # float32, or float64 under x64
    arr = lambda x: jnp.asarray(x, dtype)  # noqa: E731
    n = scenario.n_radars
    radar_init = np.zeros((n, 3)) if not scenario.radar_init else np.asarray(scenario.radar_init)
    target_init, motion = np.asarray(scenario.target_init, float), None
    if scenario.target_motion:  # per-target motion (a track starts at its CSV's start)
        from mjx_radar.physics import target_motion

        x0, tables, timing = scenario.target_init, scenario.target_motion, scenario.timing
        target_init = np.array(target_motion.initial_states(x0, tables, timing.dt_filter), float)
        motion = target_motion.motion_params(x0, tables, timing, scenario.sigma_w2, dtype)
    target_init = Ground(scenario.terrain).targets_above(target_init)  # z above the ground
    return TaskParams(
        method=method.flags(),
        noise=measurement.noise_params(scenario, dtype=dtype),
        seed=jnp.asarray(scenario.seed if seed is None else seed, jnp.uint32),
        sigma_w2=arr(scenario.sigma_w2),
        p0=arr(scenario.p0),
        placement_half_width=arr(scenario.placement_half_width),
        target_init=arr(target_init),
        radar_init=arr(radar_init),
        gamma=arr(mpc.gamma),
        r2t=arr(mpc.r2t),
        r2r=arr(mpc.r2r),
        alpha_r2r=arr(mpc.alpha_r2r),
        alpha_r2t=arr(mpc.alpha_r2t),
        detection=detection_of(scenario, dtype),
        motion=motion,
        moving=moving_params(scenario.moving_obstacles, dtype),
    )


def detection_of(scenario: Scenario, dtype=None):
    """The scenario's :class:`~mjx_radar.estimation.sensor.detection.DetectionParams`: its
    ``[detection]`` table with the radar equation of every radar (each its own in a
    mixed fleet whose ``[[radar_override]]`` tables give one)."""
    eq = scenario.radar_eq
    if any(ov.radar_eq for ov in scenario.radar_override):
        from mjx_radar.scenario.fleet import radar_equation

        eq = tuple(radar_equation(scenario, i) for i in range(scenario.n_radars))
    dim = 1 if scenario.measurement.model == "range" else 2
    return detection.detection_params(scenario.detection, eq, scenario.n_targets, dim, dtype)


def _blank(value):
    """A runtime value blanked: numbers to None, a name to "", rows keep their count, a
    table keeps its type with every field None."""
    if dataclasses.is_dataclass(value):
        return type(value)(**{f.name: None for f in dataclasses.fields(value)})
    if isinstance(value, tuple):
        return tuple(_blank(v) for v in value)
    return "" if isinstance(value, str) else None


def blank_runtime(obj):
    """``obj`` (a config dataclass) with every field marked runtime blanked (nested tables
    and tuples of tables too): what the field metadata says enters programs as arguments.
    Host settings (:func:`~mjx_radar.io.checks.host`, read after the run) are blanked too."""
    changes = {}
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        if is_runtime(f) or is_host(f):
            changes[f.name] = _blank(value)
        elif dataclasses.is_dataclass(value):
            changes[f.name] = blank_runtime(value)
        elif isinstance(value, tuple) and value and dataclasses.is_dataclass(value[0]):
            changes[f.name] = tuple(blank_runtime(v) for v in value)
    return dataclasses.replace(obj, **changes) if changes else obj


def shape_key(scenario: Scenario) -> Scenario:
    """``scenario`` with every runtime number replaced by ``None`` (the compiled shape).

    The runtime fields are those marked :func:`~mjx_radar.io.checks.runtime` in the
    schema's metadata (:func:`blank_runtime`); two rules of the shape follow: obstacle
    scenes keep ``placement_half_width`` (it sizes the obstacle cost's distance grid),
    and the detection switches stay (clutter on/off, and any perfect detection is one
    program). Two scenarios with equal keys run on the same compiled program.
    """
    shape = blank_runtime(scenario)
    det = dataclasses.replace(shape.detection, clutter_density=float(scenario.detection.clutter))
    if not (det.detects or det.clutter):  # perfect detection (also fixed_pd = 1): one program
        det = blank_runtime(dataclasses.replace(DetectionConfig(), gate_probability=None))
    width = scenario.placement_half_width if scenario.obstacles else None
    return dataclasses.replace(shape, detection=det, placement_half_width=width)
