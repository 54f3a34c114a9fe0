"""Radar–obstacle contacts of the truth plant: detection and the speed reset (SPEC §2).

A radar's collision sphere that penetrates an obstacle (contact distance < 0) is held
back by MuJoCo's contact solver; :func:`contact_speed` then resets its forward speed
``v`` to the speed it made good, so the unicycle state stays consistent with ``qpos``.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp


def _contact(data):
    impl = getattr(data, "_impl", None)
    return impl.contact if impl is not None and hasattr(impl, "contact") else data.contact


def radar_touching(plant, data) -> jax.Array:
    """[N] bool: the radar's collision sphere penetrates an obstacle (contact dist < 0)."""
    con = _contact(data)
    if con.dist.shape[0] == 0:
        return jnp.zeros(plant.n_radars, bool)
    hull = jnp.asarray(plant.index.radar_hull)
    hit = (con.geom[:, None, :] == hull[None, :, None]).any(-1)  # [C, N]
    return jnp.any(hit & (con.dist < 0)[:, None], axis=0)


def contact_speed(plant, data, commanded):
    """Resets v of radars in contact: v' - (commanded - achieved) mean speed, clipped.

    Without a contact the deadbeat servo makes the achieved mean speed over the
    step equal the commanded ``v + a dt / 2`` and v' is left as integrated.
    """
    idx = plant.index
    theta = data.qpos[idx.radar_qpos[:, 2]]
    qv = data.qvel[idx.radar_qpos[:, :2]]  # slide joints: qvel address = qpos address
    achieved = qv[:, 0] * jnp.cos(theta) + qv[:, 1] * jnp.sin(theta)
    v = data.act[idx.radar_act[:, 0]]
    lim = plant.limits.speed
    fixed = jnp.clip(v - (commanded - achieved), -lim, lim)
    v = jnp.where(radar_touching(plant, data), fixed.astype(v.dtype), v)
    return data.replace(act=data.act.at[idx.radar_act[:, 0]].set(v))


def obstacle_contacts(plant, data) -> jax.Array:
    """[] int32: radars whose collision sphere penetrates an obstacle (0 without obstacles)."""
    if not plant.index.obstacle_geoms.size:
        return jnp.zeros((), jnp.int32)
    return jnp.sum(radar_touching(plant, data)).astype(jnp.int32)
