"""MJX physics: the scene on the device, one jittable step, and batched rollouts.

State conventions (arrays, float32 unless x64 is on):

* radar state ``[N, 6]`` = ``[x, y, z, theta, v, omega]``: x, y, theta live in
  ``qpos``, v and omega in the integrator actuators' activations ``act``; z = 0, or on
  terrain the ground height plus the antenna height (kinematic, see below).
* target (drone) state ``[M, 6]`` = ``[x, y, z, vx, vy, vz]``: position in
  ``qpos``, velocity in ``act``.

One :func:`step` writes the controls (radar ``[a, alpha]``, drone white
acceleration ``w``) and the servo set-points (mean velocity over the step,
``v + a dt / 2``) into ``ctrl`` and calls MJX's step. With the deadbeat servo
gains of :mod:`mjx_radar.physics.scene` this is exactly the Euler map of SPEC §2/§3
(``qvel`` after a step holds the mean velocity over that step, not the state's
velocity). Obstacles add contacts that stop a radar (truth plant only; planner rollouts
stay contact-free); a radar held back has ``v`` reset to the speed it made good.

Terrain is followed kinematically, not through contacts (z = the grid's lookup, steep
ground stops a radar: :mod:`mjx_radar.physics.terrain_follow`, docs/terrain.md).
"""

from __future__ import annotations

import dataclasses
import functools

import jax
import jax.numpy as jnp
import mujoco
import numpy as np

from mjx_radar.physics import contacts, fused_step, mjx_module, staged_step
from mjx_radar.physics.contacts import obstacle_contacts  # noqa: F401 (plant API)
from mjx_radar.physics.model_checks import constant_mass_matrix, zero_bias
from mjx_radar.physics.scene import SceneIndex, build_scene
from mjx_radar.physics.terrain_follow import slope_stop
from mjx_radar.scenario.schema import RadarLimits
from mjx_radar.world.components import Ground
from mjx_radar.world.obstacles import contact_envelope

mjx = mjx_module.load()


@dataclasses.dataclass(frozen=True, eq=False)
class Plant:
    """A compiled scene on the device. Hashable by identity (usable as a jit static).

    Attributes:
        mj_model: host MuJoCo model (rendering, inspection).
        model: the MJX model on the device.
        index: addresses of radar / drone quantities.
        dt: physics step [s].
        limits: radar control limits (controls are clipped before the step).
        fast: use the contact-free step (no collision, constraint, sensor, passive or
            bias-force stages, and the constant mass-matrix factor); set when the scene
            has no contacts, its mass matrix does not depend on the configuration and
            its bias forces (Coriolis, centrifugal; gravity is off) vanish.
        fused: that step as one fused expression built from the compiled model
            (:mod:`~mjx_radar.physics.fused_step`, checked against ``mj_step`` when
            built), or None (MJX's stages, :func:`staged_step.contact_free_step`).
        ground: the :class:`~mjx_radar.world.components.Ground` the radars stand on
            (empty: flat ground z = 0; on terrain z is its height plus the antenna
            height and steep ground stops a radar).
    """

    mj_model: mujoco.MjModel
    model: mjx.Model
    index: SceneIndex
    dt: float
    limits: RadarLimits
    fast: bool = False
    ground: Ground = Ground()
    moving: tuple = ()  # moving obstacles' shapes (mocap bodies, physics.moving_bodies)
    fused: object = None  # physics.fused_step.FusedModel of a fast scene, or None

    @property
    def n_radars(self) -> int:
        return self.index.radar_qpos.shape[0]

    @property
    def n_drones(self) -> int:
        return self.index.drone_qpos.shape[0]


def make_plant(
    n_radars: int,
    n_drones: int,
    dt: float,
    limits: RadarLimits | None = None,
    obstacles=(),
    terrain=None,
    moving=(),
) -> Plant:
    """Builds the scene and puts it on the device (see :func:`scene.build_scene`).

    ``terrain`` (a :class:`~mjx_radar.scenario.schema.Terrain`): the scene's ground becomes its
    hfield and the radars follow the grid kinematically (module docstring). ``moving``:
    moving obstacles as mocap bodies (:mod:`~mjx_radar.physics.moving_bodies`).
    """
    limits = RadarLimits() if limits is None else limits
    # The most a radar moves in one step: the collision sphere grows by this much so
    # that the physical hull never enters an obstacle on the step of impact.
    margin = contact_envelope(limits, dt) if (obstacles or moving) else 0.0
    mj_model, index = build_scene(
        n_radars, n_drones, dt, obstacles, margin, terrain, moving=tuple(moving)
    )
    # Plants are cached and may first be built while a jit trace is running: keep the
    # device model concrete so it never captures a tracer. On this process's own device:
    # MJX's default, jax.devices()[0], belongs to process 0 under jax.distributed.
    with jax.ensure_compile_time_eval():
        model = mjx.put_model(mj_model, device=jax.local_devices()[0])
    contact_free = bool(mj_model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_CONTACT)
    fast = contact_free and constant_mass_matrix(mj_model) and zero_bias(mj_model)
    fused = fused_step.build(mj_model, index) if fast and FUSED_STEP else None
    return Plant(
        mj_model,
        model,
        index,
        float(dt),
        limits,
        fast,
        Ground(terrain),
        moving=tuple(moving),
        fused=fused,
    )


FUSED_STEP: bool = True
"""Build the fused step for fast scenes (:mod:`~mjx_radar.physics.fused_step`); False
keeps MJX's stages (benchmarks and tests compare the two)."""

MESH_CONTACTS: bool = True
"""Scenes with contacts step through :func:`staged_step.step`; False: ``mjx.step``."""


@functools.cache
def planner_plant(dt_control: float, limits: RadarLimits) -> Plant:
    """One-radar plant at the control step ``dt_control`` (MPPI rollouts) with the
    radars' ``limits``, cached per pair.

    Built WITHOUT the obstacles: rollouts stay contact-free (about 100x cheaper);
    the objective keeps radars away from obstacles with its own cost term. Without
    contacts the radars do not interact, so :func:`radar_rollout` vmaps this one-radar
    model over the N radars: 1.6x (N = 3) to 2.3x (N = 8) faster on 2 CPU cores than
    one model holding all N (``mjx`` stages loop over bodies; a vmap batches them).
    """
    return make_plant(1, 0, dt_control, limits)


@functools.cache
def truth_plant(
    n_radars: int,
    n_targets: int,
    dt_filter: float,
    limits: RadarLimits,
    obstacles: tuple = (),
    terrain=None,
    moving: tuple = (),
) -> Plant:
    """Radars and drones at the filter step ``dt_filter`` (the closed-loop truth), with the
    static obstacles, the terrain and the moving obstacles (the arguments of
    :func:`make_plant`), cached per argument list."""
    if n_targets < 1:
        raise ValueError(f"n_targets: {n_targets} is not allowed; need at least 1")
    return make_plant(n_radars, n_targets, dt_filter, limits, obstacles, terrain, moving)


def check_finite(name: str, x) -> None:
    if not isinstance(x, jax.core.Tracer) and not np.all(np.isfinite(np.asarray(x))):
        raise ValueError(f"{name}: contains non-finite values; need finite numbers")


def check_shape(name: str, x, shape: tuple[int, ...]) -> None:
    if tuple(jnp.shape(x)) != shape:
        raise ValueError(f"{name}: shape {tuple(jnp.shape(x))} is not the expected {shape}")


def init_data(plant: Plant, radar_state: jax.Array, target_state: jax.Array | None = None):
    """MJX data holding the given radar ([N, 6]) and target ([M, 6]) states."""
    idx = plant.index
    check_shape("radar_state", radar_state, (plant.n_radars, 6))
    check_finite("radar_state", radar_state)
    data = mjx.make_data(plant.model)
    qpos = data.qpos.at[idx.radar_qpos].set(radar_state[:, jnp.array([0, 1, 3])])
    act = data.act.at[idx.radar_act].set(radar_state[:, 4:6])
    if plant.n_drones:
        if target_state is None:
            raise ValueError("target_state: required, the plant has drones")
        check_shape("target_state", target_state, (plant.n_drones, 6))
        check_finite("target_state", target_state)
        qpos = qpos.at[idx.drone_qpos].set(target_state[:, :3])
        act = act.at[idx.drone_act].set(target_state[:, 3:])
    data = data.replace(qpos=qpos.astype(data.qpos.dtype), act=act.astype(data.act.dtype))
    if plant.fast and plant.fused is None:  # the constant mass-matrix factor, once
        data = mjx.kinematics(plant.model, data)
        data = mjx.com_pos(plant.model, data)
        data = mjx.factor_m(plant.model, mjx.crb(plant.model, data))
    return data


def radar_state(plant: Plant, data) -> jax.Array:
    """[N, 6] radar states ``[x, y, z, theta, v, omega]`` read from MJX data (z = 0, or
    on terrain the ground height at (x, y) plus the antenna height)."""
    out = planar_state(data.qpos[plant.index.radar_qpos], data.act[plant.index.radar_act])
    return plant.ground.on_ground(out)


def planar_state(q: jax.Array, va: jax.Array) -> jax.Array:
    """``[N, 6]`` ``[x, y, 0, theta, v, omega]`` from joint positions ``q [N, 3]`` (x, y,
    yaw) and activations ``va [N, 2]`` (v, omega)."""
    return jnp.concatenate([q[:, :2], jnp.zeros_like(q[:, :1]), q[:, 2:3], va], axis=-1)


def target_state(plant: Plant, data) -> jax.Array:
    """[M, 6] drone states ``[x, y, z, vx, vy, vz]`` read from MJX data."""
    return jnp.concatenate(
        [data.qpos[plant.index.drone_qpos], data.act[plant.index.drone_act]], axis=-1
    )


def clip_controls(plant: Plant, radar_u: jax.Array) -> jax.Array:
    """``[N, 2]`` radar controls ``[a, alpha]`` clipped to the plant's limits."""
    lim = plant.limits
    return jnp.clip(radar_u, jnp.array([-lim.accel, -lim.alpha]), jnp.array([lim.accel, lim.alpha]))


def radar_ctrl(plant: Plant, va: jax.Array, u: jax.Array) -> jax.Array:
    """``[N, 5]`` actuator controls (speed, turn, drive, lateral, steer) from the
    activations ``va [N, 2]`` (v, omega) and clipped controls ``u [N, 2]``: the servo
    set-points are the mean velocities over the step, ``v + u dt / 2``."""
    mean_v = va + 0.5 * plant.dt * u
    return jnp.concatenate([u, mean_v[:, :1], jnp.zeros_like(u[:, :1]), mean_v[:, 1:]], -1)


def step(
    plant: Plant,
    data,
    radar_u: jax.Array,
    drone_accel: jax.Array | None = None,
    drone_mean_v: jax.Array | None = None,
):
    """One physics step.

    Args:
        plant: the scene.
        data: MJX data.
        radar_u: [N, 2] radar controls ``[a, alpha]``, clipped to the limits.
        drone_accel: [M, 3] drone accelerations held over the step (white noise).
        drone_mean_v: [M, 3] the drones' mean velocity over the step (the position
            servo's set-point); default ``v + drone_accel dt / 2``, the CV map
            (:mod:`mjx_radar.physics.target_motion` sets it for nominal paths).

    Returns:
        The next MJX data.
    """
    idx, dt = plant.index, plant.dt
    u = clip_controls(plant, radar_u)
    if plant.ground.present:  # the ground's slope stop (none on flat ground)
        data, u = slope_stop(plant, data, u)
    rc = radar_ctrl(plant, data.act[idx.radar_act], u)  # [N, 5]; rc[:, 2]: mean speed
    ctrl = data.ctrl.at[idx.radar_ctrl].set(rc.astype(data.ctrl.dtype))
    if plant.n_drones:
        w = jnp.zeros((plant.n_drones, 3)) if drone_accel is None else drone_accel
        mean_w = data.act[idx.drone_act] + 0.5 * dt * w if drone_mean_v is None else drone_mean_v
        drone_ctrl = jnp.concatenate([w, mean_w], axis=-1)
        ctrl = ctrl.at[idx.drone_ctrl].set(drone_ctrl.astype(data.ctrl.dtype))
    data = data.replace(ctrl=ctrl)
    if plant.fused is not None:
        qpos, qvel, act = fused_step.data_step(
            jnp, plant.fused, data.qpos, data.qvel, data.act, ctrl
        )
        return data.replace(qpos=qpos, qvel=qvel, act=act, time=data.time + dt)
    if plant.fast:
        return staged_step.contact_free_step(plant.model, data)
    data = (staged_step.step if MESH_CONTACTS else mjx.step)(plant.model, data)
    if idx.obstacle_geoms.size:
        data = contacts.contact_speed(plant, data, rc[:, 2])
    return data
