"""Radars on terrain in the truth plant: kinematic z and the slope stop (docs/terrain.md).

The path taken: MJX does collide height fields with spheres (the radar's hull), capsules,
boxes and meshes (``mujoco/mjx/_src/collision_driver.py``), but riding on the hfield by
contact needs a z degree of freedom, gravity and the constraint solver in every truth
step, which forfeits the contact-free fast step (contacts cost ~100x, MJX-NOTES) and
makes z depend on the solver's penetration. So the radar's MJX model stays planar and

* its z is the bilinear ground height at (x, y) plus the antenna height
  (:meth:`mjx_radar.world.components.Ground.on_ground`, read by ``plant.radar_state``): the same
  lookup as the planner's rollouts and the line-of-sight test;
* :func:`slope_stop`: a step that would end (at the speed it commands, along the
  current heading) on ground steeper than ``terrain.max_slope_deg`` *and* steeper than
  where the radar stands stops it: ``v = 0`` and ``a = 0`` for that step. It may still
  turn, and it can always move to gentler ground (down off a slope).
"""

from __future__ import annotations

import jax.numpy as jnp


def slope_stop(plant, data, u):
    """``(data, u)`` with the radars that would drive onto too steep ground stopped.

    Args:
        plant: a truth :class:`~mjx_radar.physics.plant.Plant` on terrain (its
            ``ground`` says which steps are too steep,
            :meth:`~mjx_radar.world.components.Ground.too_steep`).
        data: MJX data before the step.
        u: ``[N, 2]`` clipped controls ``[a, alpha]``.
    """
    idx, dt = plant.index, plant.dt
    q, v = data.qpos[idx.radar_qpos], data.act[idx.radar_act[:, 0]]
    step = dt * (v + 0.5 * dt * u[:, 0])
    nxt = q[:, :2] + step[:, None] * jnp.stack([jnp.cos(q[:, 2]), jnp.sin(q[:, 2])], -1)
    stop = plant.ground.too_steep(q[:, :2], nxt)
    act = data.act.at[idx.radar_act[:, 0]].set(jnp.where(stop, 0.0, v).astype(data.act.dtype))
    return data.replace(act=act), u.at[:, 0].set(jnp.where(stop, 0.0, u[:, 0]))
