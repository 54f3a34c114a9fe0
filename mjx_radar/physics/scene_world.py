"""The scene's world in MJCF: the ground plane or the terrain's height field, static obstacles.

Used by :func:`mjx_radar.physics.scene.build_scene`. The ground and the terrain are
contact-free (radars follow the terrain kinematically, :mod:`~.terrain_follow`); static
obstacles collide with the radars' hulls (``contype=1``, ``conaffinity=2``) with the
contact settings :data:`CONTACT_SOLIMP`.
"""

from __future__ import annotations

import mujoco
import numpy as np

from mjx_radar.scenario.schema import Obstacle
from mjx_radar.world.components import Ground

CONTACT_SOLIMP = (0.99, 0.999, 0.001, 0.5, 2.0)


def add_ground(spec: mujoco.MjSpec, ground: Ground) -> None:
    """The ``ground``'s terrain (:func:`add_terrain`), or the flat ``ground`` plane (no
    contacts) when the component is empty."""
    if ground.present:
        add_terrain(spec, ground.config)
    else:
        spec.worldbody.add_geom(
            name="ground",
            type=mujoco.mjtGeom.mjGEOM_PLANE,
            size=[0.0, 0.0, 1.0],
            rgba=[0.82, 0.80, 0.74, 1.0],
            contype=0,
            conaffinity=0,
        )


def add_obstacle(spec: mujoco.MjSpec, i: int, obs: Obstacle) -> None:
    """Adds one static obstacle geom to the world body."""
    half_yaw = 0.5 * obs.yaw
    quat = [np.cos(half_yaw), 0.0, 0.0, np.sin(half_yaw)]
    common = dict(
        name=f"obstacle{i}",
        pos=list(obs.pos),
        quat=quat,
        contype=1,
        conaffinity=2,
        condim=1,
        solimp=list(CONTACT_SOLIMP),
    )
    rgba = [0.55, 0.45, 0.35, 1.0]
    if obs.kind == "box":
        spec.worldbody.add_geom(
            type=mujoco.mjtGeom.mjGEOM_BOX, size=list(obs.size), rgba=rgba, **common
        )
    elif obs.kind == "cylinder":
        spec.worldbody.add_geom(
            type=mujoco.mjtGeom.mjGEOM_CYLINDER,
            size=[obs.size[0], obs.size[1], 0.0],
            rgba=[0.2, 0.45, 0.2, 1.0],
            **common,
        )
    elif obs.kind == "mesh":
        import trimesh  # host-side, only when meshes are used

        mesh = trimesh.load(obs.path, force="mesh")
        spec.add_mesh(
            name=f"obstacle_mesh{i}",
            uservert=(np.asarray(mesh.vertices) * obs.scale).ravel().tolist(),
            userface=np.asarray(mesh.faces).ravel().tolist(),
        )
        spec.worldbody.add_geom(
            type=mujoco.mjtGeom.mjGEOM_MESH, meshname=f"obstacle_mesh{i}", rgba=rgba, **common
        )
    else:
        raise ValueError(f"obstacle.kind: {obs.kind!r} is not one of box, cylinder, mesh")


def add_terrain(spec: mujoco.MjSpec, terrain) -> None:
    """Adds the terrain as an ``hfield`` asset and a contact-free world geom named ``terrain``.

    MuJoCo stores normalised elevations ``(H - min H) / (max H - min H)`` (row 0 at
    -y, column 0 at -x, as :mod:`mjx_radar.world.terrain`) scaled by ``size[2]``; the
    geom sits at ``z = min H`` so the rendered nodes are at the grid's heights.
    """
    from mjx_radar.world.terrain import node_heights

    h = node_heights(terrain)
    lo, top = float(h.min()), float(h.max() - h.min())
    data = (h - lo) / top if top > 0 else np.zeros_like(h)
    spec.add_hfield(
        name="terrain",
        size=[0.5 * terrain.extent_x, 0.5 * terrain.extent_y, max(top, 1e-3), 1.0],
        nrow=h.shape[0],
        ncol=h.shape[1],
        userdata=data.ravel().tolist(),
    )
    spec.worldbody.add_geom(
        name="terrain",
        type=mujoco.mjtGeom.mjGEOM_HFIELD,
        hfieldname="terrain",
        pos=[0.0, 0.0, lo],
        rgba=[0.62, 0.66, 0.50, 1.0],
        contype=0,
        conaffinity=0,
    )
