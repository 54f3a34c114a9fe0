"""Moving obstacles in the truth plant: MJCF mocap bodies posed each step (docs/maps.md).

Each ``[[moving_obstacles]]`` table becomes a mocap body ``moving{k}`` holding one geom
(a box of half extents ``(l, w, h/2)`` or a cylinder ``(r, h/2)``) with the static
obstacles' contact settings (``contype=1, conaffinity=2``, frictionless, near-hard:
:mod:`mjx_radar.physics.scene`), so the radars' collision spheres collide with it
exactly as with a building (MJX collides geoms of mocap bodies like any other: their
poses come from ``mocap_pos`` / ``mocap_quat`` in the kinematics stage).

Before the MJX step that takes the world from ``t_{k-1}`` to ``t_k = k dt`` the bodies
are put at their closed-form pose at ``t_k`` (:func:`pose_bodies`, called by
:func:`mjx_radar.physics.target_motion.step_plant`; :func:`mjx_radar.world.moving.pose`):
the contacts of that step see the vehicle where it is at the step's end (a one-step
look-ahead, as the radars' grown collision spheres), and line of sight at ``t_k`` sees
the same pose. A vehicle is kinematic (infinite mass): it pushes a radar it drives into;
a radar driving into it is stopped and its speed reset (:mod:`~.contacts`).
"""

from __future__ import annotations

import jax.numpy as jnp
import mujoco
import numpy as np

MOVING_RGBA = (0.75, 0.2, 0.15, 1.0)


def add_moving_bodies(spec: mujoco.MjSpec, moving, solimp) -> None:
    """Adds one mocap body with its geom per moving obstacle (parked far below the ground;
    posed every step) with the static obstacles' contact bits, ``condim`` and ``solimp``."""
    common = dict(contype=1, conaffinity=2, condim=1, solimp=list(solimp))
    for k, m in enumerate(moving):
        body = spec.worldbody.add_body(name=f"moving{k}", mocap=True, pos=[0.0, 0.0, -1e4])
        if m.kind == "box":
            size, typ = [m.size[0], m.size[1], 0.5 * m.height], mujoco.mjtGeom.mjGEOM_BOX
        else:
            size, typ = [m.size[0], 0.5 * m.height, 0.0], mujoco.mjtGeom.mjGEOM_CYLINDER
        body.add_geom(name=f"moving{k}", type=typ, size=size, rgba=list(MOVING_RGBA), **common)


def moving_geoms(model: mujoco.MjModel, count: int) -> np.ndarray:
    """``[K]`` geom ids of the moving obstacles."""
    return np.asarray([model.geom(f"moving{k}").id for k in range(count)], np.int32)


def mocap_ids(model: mujoco.MjModel, count: int) -> np.ndarray:
    """``[K]`` mocap indices of the moving obstacles' bodies."""
    return np.asarray(
        [model.body_mocapid[model.body(f"moving{k}").id] for k in range(count)], np.int32
    )


def mocap_pose(moving, xy, unit):
    """``(pos [K, 3], quat [K, 4])`` of the bodies for centres ``xy`` and axes ``unit``
    ``[K, 2]`` (the body centre at half height, yaw = the axis's angle)."""
    h = jnp.asarray([0.5 * m.height for m in moving], xy.dtype)
    half = 0.5 * jnp.arctan2(unit[:, 1], unit[:, 0])
    z = jnp.zeros_like(half)
    quat = jnp.stack([jnp.cos(half), z, z, jnp.sin(half)], -1)
    return jnp.concatenate([xy, h[:, None]], -1), quat


def pose_bodies(plant, data, mp, t):
    """``data`` with the moving obstacles' mocap bodies at their pose at time ``t``."""
    from mjx_radar.world.moving import pose

    moving = plant.moving
    ids = mocap_ids(plant.mj_model, len(moving))
    pos, quat = mocap_pose(moving, *pose(mp, t))
    return data.replace(
        mocap_pos=data.mocap_pos.at[ids].set(pos.astype(data.mocap_pos.dtype)),
        mocap_quat=data.mocap_quat.at[ids].set(quat.astype(data.mocap_quat.dtype)),
    )
