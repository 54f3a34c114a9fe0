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
from typing import Any, NamedTuple

import jax.numpy as jnp
import numpy as np

from mjx_radar.estimation import detection, measurement
from mjx_radar.scenario.schema import DetectionConfig, RadarEquation, Scenario
from mjx_radar.task.method import Method, MethodFlags
from mjx_radar.world.moving import moving_params


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
    seed: Any  # uint32 base seed of the trial streams
    sigma_w2: Any  # target white-acceleration variance [m²/s⁴]
    p0: Any  # initial covariance p0·I
    placement_half_width: Any  # [m]
    target_init: Any  # [M, 6]
    radar_init: Any  # [N, 3] x, y, theta
    gamma: Any  # discount
    r2t: Any  # radar-target keep-out [m]
    r2r: Any  # radar-radar keep-out [m]
    alpha_r2r: Any
    alpha_r2t: Any
    detection: Any = None  # detection.DetectionParams (issue 23)
    motion: Any = None  # physics.target_motion.MotionParams with [[target_motion]], else None
    target_weight: Any = None  # [M] planner weight of each target (presence), None: all 1
    moving: Any = None  # world.moving.MovingParams with [[moving_obstacles]], else None
    plan_time: Any = None  # [] planning instant [s] (set per control step with moving obstacles)


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

        target_init = np.array(target_motion.initial_states(scenario), float)
        motion = target_motion.motion_params(scenario, dtype)
    if scenario.terrain is not None and scenario.terrain.targets_agl:  # z above the ground
        from mjx_radar.io.terrain_file import height_np

        target_init[:, 2] += height_np(scenario.terrain, target_init[:, :2])
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
        detection=detection.detection_params(scenario, dtype),
        motion=motion,
        moving=moving_params(scenario.moving_obstacles, dtype),
    )


def shape_key(scenario: Scenario) -> Scenario:
    """``scenario`` with every runtime number replaced by ``None`` (the compiled shape).

    Two scenarios with equal keys run on the same compiled program. Obstacle scenes
    keep ``placement_half_width`` (it sizes the obstacle cost's distance grid).
    """
    blank_rows = lambda rows: tuple((None,) * len(r) for r in rows)  # noqa: E731
    mpc = dataclasses.replace(
        scenario.mpc, gamma=None, r2t=None, r2r=None, alpha_r2r=None, alpha_r2t=None
    )
    blank_eq = RadarEquation(**{f.name: None for f in dataclasses.fields(RadarEquation)})
    meas = dataclasses.replace(scenario.measurement, beamwidth_deg=None, monopulse_slope=None)
    det = dataclasses.replace(  # numbers are DetectionParams; switches (fixed_pd < 1) stay
        scenario.detection,
        pfa=None,
        gain_db=None,  # gate_probability: the IRF table
        clutter_range_min=None,
        clutter_range_max=None,
        clutter_density=float(scenario.detection.clutter),
    )
    moving = tuple(
        dataclasses.replace(  # paths, speeds, offsets: MovingParams (end: the
            m, path=blank_rows(m.path), speed=None, offset=None
        )  # number of segments stays)
        for m in scenario.moving_obstacles
    )
    if not (det.detects or det.clutter):  # perfect detection (also fixed_pd = 1): one program
        det = dataclasses.replace(
            DetectionConfig(),
            pfa=None,
            gain_db=None,
            gate_probability=None,
            clutter_range_min=None,
            clutter_range_max=None,
        )
    return dataclasses.replace(
        scenario,
        name="",
        seed=None,
        sigma_w2=None,
        p0=None,
        placement_half_width=(scenario.placement_half_width if scenario.obstacles else None),
        radar_eq=blank_eq,
        target_init=blank_rows(scenario.target_init),
        radar_init=blank_rows(scenario.radar_init),
        mpc=mpc,
        measurement=meas,
        detection=det,
        moving_obstacles=moving,
    )
