"""Scene builder: N radar vehicles, M drones, a ground plane and obstacles as one MJCF model.

The radar and drone bodies come from ``models/radar.xml`` and ``models/drone.xml``
and are attached with :class:`mujoco.MjSpec` under the prefixes ``radar{i}/`` and
``drone{j}/``. The builder

* sets the timestep and the Euler integrator (one physics step = one Euler step
  of SPEC §2/§3),
* sets every velocity-servo gain to ``kv = M_ii / dt`` from the compiled mass
  matrix, so each servo reaches its commanded velocity in exactly one step,
* disables gravity, springs and dampers (radars are planar, drones fly on their
  own thrust; without joint damping Euler's implicit-damping refactor is off
  too) and disables contacts entirely when there are no obstacles
  (contacts cost ~100x a contact-free MJX step, see MJX-NOTES).

Collision bits: radar hulls ``contype=2, conaffinity=1``, obstacles
``contype=1, conaffinity=2``: radars collide with obstacles, not with each
other, the ground or drones.

Contacts with obstacles (see docs/obstacles.md). The deadbeat servos command up
to ``m·v/dt`` of force, so contacts are made nearly hard and frictionless:
``condim = 1``, ``solimp = CONTACT_SOLIMP`` (impedance 0.99-0.999, i.e. ~0.1 % of
the servo's push leaks through), default ``solref`` (time constant clamped to
2·dt), a few Newton iterations, and MJX's broad phase keeps only the nearest
``2N`` hull-obstacle pairs per geom-type group (``max_geom_pairs``). MJX's
sphere-convex collider reports no distance for separated pairs, so a contact
margin cannot look ahead; instead the collision sphere is grown by
``hull_margin`` (the most a radar moves in one step, :func:`physics.make_plant`):
on the step of impact the grown sphere penetrates by at most that much, so the
physical hull (radius 2.5 m) never enters an obstacle.
"""

from __future__ import annotations

import dataclasses
import functools
import importlib.resources
from collections.abc import Sequence
from pathlib import Path

import mujoco
import numpy as np

from mjx_radar.physics import moving_bodies as mb
from mjx_radar.physics.scene_world import (  # noqa: F401 (re-exported)
    CONTACT_SOLIMP,
    add_ground,
    add_obstacle,
    add_terrain,
)
from mjx_radar.scenario.schema import Obstacle
from mjx_radar.world.components import Ground

RADAR_ACTUATORS = ("speed", "turn", "drive", "lateral", "steer")
SOLVER_ITERATIONS = 4  # Newton iterations (one or two contacts per radar converge fast)
DRONE_ACTUATORS = ("vx", "vy", "vz", "sx", "sy", "sz")


@dataclasses.dataclass(frozen=True)
class SceneIndex:
    """Addresses of the radar and drone quantities inside ``MjData`` (numpy int arrays).

    Attributes:
        radar_qpos: [N, 3] qpos addresses of (x, y, yaw).
        radar_act: [N, 2] activation addresses of (v, omega).
        radar_ctrl: [N, 5] ctrl addresses of (speed, turn, drive, lateral, steer).
        drone_qpos: [M, 3] qpos addresses of (x, y, z).
        drone_act: [M, 3] activation addresses of (vx, vy, vz).
        drone_ctrl: [M, 6] ctrl addresses of (vx, vy, vz, sx, sy, sz).
        obstacle_geoms: [K] geom ids of the obstacles.
        radar_hull: [N] geom ids of the radars' collision spheres.
    """

    radar_qpos: np.ndarray
    radar_act: np.ndarray
    radar_ctrl: np.ndarray
    drone_qpos: np.ndarray
    drone_act: np.ndarray
    drone_ctrl: np.ndarray
    obstacle_geoms: np.ndarray
    radar_hull: np.ndarray


@functools.cache
def _model_xml(name: str) -> str:
    """MJCF text of ``models/<name>`` (installed package data, or the source checkout)."""
    try:
        return importlib.resources.files("mjx_radar.models").joinpath(name).read_text()
    except ModuleNotFoundError:  # running from a checkout without installing
        return (Path(__file__).resolve().parents[2] / "models" / name).read_text()


def build_scene(
    n_radars: int,
    n_drones: int,
    dt: float,
    obstacles: Sequence[Obstacle] = (),
    hull_margin: float = 0.0,
    terrain=None,
    radar_z_joint: bool = False,
    moving=(),
) -> tuple[mujoco.MjModel, SceneIndex]:
    """Builds the MuJoCo model of a scene.

    Args:
        n_radars: N >= 1 radar vehicles.
        n_drones: M >= 0 drones (0 for planner-only models).
        dt: physics timestep [s] = one Euler step of the unicycle / CV model.
        obstacles: static obstacles; contacts are enabled only if there are any.
        hull_margin: growth of each radar's collision sphere [m] (with obstacles only).
        terrain: a :class:`~mjx_radar.scenario.schema.Terrain`: the ground becomes its ``hfield``
            (no contacts: radars follow it kinematically, :func:`add_terrain`).
        radar_z_joint: give each radar an unactuated slide-z joint ``z`` (rendering on
            terrain writes the ground height there; the physics plants never set it).
        moving: moving obstacles (mocap bodies, :mod:`~.moving_bodies`); contacts on.

    Returns:
        The compiled ``MjModel`` (servo gains set) and its :class:`SceneIndex`.
    """
    spec = _spec(n_radars, n_drones, dt, bool(obstacles or moving))
    add_ground(spec, Ground(terrain))
    spec.worldbody.add_light(
        pos=[0, 0, 500], dir=[0, 0, -1], type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL
    )
    for i in range(n_radars):
        child = mujoco.MjSpec.from_string(_model_xml("radar.xml"))
        if obstacles or moving:
            hull = child.geom("hull")
            hull.size[0] += hull_margin
            hull.condim = 1
            hull.solimp = list(CONTACT_SOLIMP)
        if radar_z_joint:
            child.body("radar").add_joint(
                name="z", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0, 0, 1], limited=False
            )
        spec.attach(child, prefix=f"radar{i}/", frame=spec.worldbody.add_frame())
    for j in range(n_drones):
        child = mujoco.MjSpec.from_string(_model_xml("drone.xml"))
        spec.attach(child, prefix=f"drone{j}/", frame=spec.worldbody.add_frame())
    for k, obs in enumerate(obstacles):
        add_obstacle(spec, k, obs)
    mb.add_moving_bodies(spec, moving, CONTACT_SOLIMP)  # the obstacles' contact settings
    model = spec.compile()
    index = _index(model, n_radars, n_drones, len(obstacles))
    if moving:  # the vehicles' geoms collide and count as obstacles (contacts, speed reset)
        geoms = np.concatenate([index.obstacle_geoms, mb.moving_geoms(model, len(moving))])
        index = dataclasses.replace(index, obstacle_geoms=geoms)
    _set_servo_gains(model, index)
    return model, index


def _spec(n_radars: int, n_drones: int, dt: float, contacts: bool) -> mujoco.MjSpec:
    """An empty spec with the scene's options: Euler steps of ``dt``, no gravity, springs
    or dampers; contacts and the solver only with obstacles (``ValueError`` for bad sizes)."""
    if n_radars < 1:
        raise ValueError(f"n_radars: {n_radars} is not allowed; need at least 1 radar")
    if n_drones < 0:
        raise ValueError(f"n_drones: {n_drones} is not allowed; need at least 0 drones")
    if not (np.isfinite(dt) and dt > 0):
        raise ValueError(f"dt: {dt} is not allowed; need a finite timestep > 0")
    spec = mujoco.MjSpec()
    spec.modelname = f"scene_{n_radars}r{n_drones}t"
    spec.option.timestep = dt
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_EULER
    flags = mujoco.mjtDisableBit
    spec.option.disableflags |= (
        flags.mjDSBL_GRAVITY | flags.mjDSBL_SPRING | flags.mjDSBL_DAMPER | flags.mjDSBL_EULERDAMP
    )
    if not contacts:
        spec.option.disableflags |= flags.mjDSBL_CONTACT | flags.mjDSBL_CONSTRAINT
    else:
        spec.option.iterations = SOLVER_ITERATIONS
        spec.option.ls_iterations = SOLVER_ITERATIONS
        spec.add_numeric(name="max_geom_pairs", data=[2 * n_radars])
    return spec


def _index(model: mujoco.MjModel, n: int, m: int, k: int) -> SceneIndex:
    def qpos(prefix, joints):
        return [model.jnt_qposadr[model.joint(f"{prefix}{j}").id] for j in joints]

    def act(prefix, names):
        return [model.actuator_actadr[model.actuator(f"{prefix}{a}").id] for a in names]

    def ctrl(prefix, names):
        return [model.actuator(f"{prefix}{a}").id for a in names]

    radars = [f"radar{i}/" for i in range(n)]
    drones = [f"drone{j}/" for j in range(m)]

    def arr(rows, width):
        return np.asarray(rows, dtype=np.int32).reshape(len(rows), width)

    return SceneIndex(
        radar_qpos=arr([qpos(p, ("x", "y", "yaw")) for p in radars], 3),
        radar_act=arr([act(p, ("speed", "turn")) for p in radars], 2),
        radar_ctrl=arr([ctrl(p, RADAR_ACTUATORS) for p in radars], 5),
        drone_qpos=arr([qpos(p, ("x", "y", "z")) for p in drones], 3),
        drone_act=arr([act(p, ("vx", "vy", "vz")) for p in drones], 3),
        drone_ctrl=arr([ctrl(p, DRONE_ACTUATORS) for p in drones], 6),
        obstacle_geoms=np.asarray([model.geom(f"obstacle{i}").id for i in range(k)], np.int32),
        radar_hull=np.asarray([model.geom(f"{p}hull").id for p in radars], np.int32),
    )


def _set_servo_gains(model: mujoco.MjModel, index: SceneIndex) -> None:
    """Sets kv = M_ii / dt on every velocity servo (deadbeat in one Euler step)."""
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    full_m = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, full_m)
    dt = model.opt.timestep
    for row in index.radar_ctrl:
        for servo in row[2:]:
            _set_kv(model, servo, full_m, dt)
    for row in index.drone_ctrl:
        for servo in row[3:]:
            _set_kv(model, servo, full_m, dt)


def _set_kv(model: mujoco.MjModel, actuator: int, full_m: np.ndarray, dt: float) -> None:
    if model.actuator_trntype[actuator] == mujoco.mjtTrn.mjTRN_SITE:
        # Body-frame drive: the effective mass along the site axis is the body mass
        # (x and y slides share the body, whose centre of mass is on the yaw axis).
        site = model.actuator_trnid[actuator, 0]
        inertia = model.body_subtreemass[model.site_bodyid[site]]
    else:
        dof = model.jnt_dofadr[model.actuator_trnid[actuator, 0]]
        inertia = full_m[dof, dof]
    kv = inertia / dt
    model.actuator_gainprm[actuator, 0] = kv
    model.actuator_biasprm[actuator, :3] = (0.0, 0.0, -kv)
