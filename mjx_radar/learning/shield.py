"""A keep-out shield for learned policies: a radar backs off before it would enter a
drone's keep-out.

A policy trained with the MPC's step penalty either ignores the radar-drone keep-out or
stays tens of metres off it (docs/learning.md). The shield, applied to the policy's
control in training (:class:`~mjx_radar.learning.brax_env.BraxRadarEnv`) and in
evaluation (the planner ``policy:DIR``) alike when the policy was trained with
``shield = True``, turns the keep-out into a property of the actions instead. For each
radar (unicycle, heading ``h = (cos θ, sin θ, 0)``, speed v, position p) it predicts
where the radar stops if it applies the acceleration ``a`` for the control period T and
then brakes at the limit ``ā``::

    v1 = clip(v + a T, -v̄, v̄)
    s  = (v + v1) T / 2 + v1 |v1| / (2 ā)        signed travel along h
    p̂  = p + s h

and where each present drone is by then (its estimate ``q`` moved at its estimated
velocity for ``τ = T + |v1| / ā``: ``q̂ = q + τ q̇``). If the nearest such drone would be
closer than ``R2T + margin`` and closer than it is now (``|p̂ - q̂| < |p - q|``), the
radar's acceleration becomes ``ā`` away from it along the heading,
``a = -ā sign(h · (q̂ - p))``: it brakes (or reverses) when the drone is ahead and speeds
up when it is behind. The angular acceleration stays the policy's. Everything is from
the radars' own estimate (the observation), never the truth; a drone that flies onto a
radar faster than it can leave still enters the keep-out.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

MARGIN = 5.0  # [m] beyond R2T at which the shield acts


def shield(env, obs, control, margin: float = MARGIN) -> jax.Array:
    """``[N, 2]`` the control with the acceleration of endangered radars replaced.

    Args:
        env: the :class:`~mjx_radar.env.environment.RadarEnv` (limits, T, R2T).
        obs: the observation the control was chosen from (radar states ``[N, 6]``
            ``x y z θ v ω``, target estimates ``[6M]``, presence ``[M]``).
        control: ``[N, 2]`` (acceleration, angular acceleration) within the limits.
        margin: metres beyond R2T at which the shield acts.
    """
    task = env.task  # the fleet's limits, the control period
    dt = jnp.float32(task.timing.dt_control)
    # [N] each radar's ā (a fixed site has none: it never moves, the guard keeps 0/0 out)
    amax = jnp.maximum(jnp.asarray(env.action_bounds[1][:, 0], jnp.float32), 1e-6)
    vmax = jnp.float32(task.fleet.limits.speed)
    u = jnp.asarray(control, jnp.float32)
    rs = obs.radar_state.astype(jnp.float32)
    p, th, v = rs[:, :3], rs[:, 3], rs[:, 4]
    head = jnp.stack([jnp.cos(th), jnp.sin(th), jnp.zeros_like(th)], -1)  # [N, 3]
    v1 = jnp.clip(v + u[:, 0] * dt, -vmax, vmax)
    travel = 0.5 * (v + v1) * dt + v1 * jnp.abs(v1) / (2.0 * amax)
    p_stop = p + travel[:, None] * head
    est = obs.mean.astype(jnp.float32).reshape(-1, 6)  # [M, 6]
    tau = dt + jnp.abs(v1) / amax  # [N]
    q_stop = est[None, :, :3] + tau[:, None, None] * est[None, :, 3:]  # [N, M, 3]
    absent = obs.target_weight <= 0
    far = jnp.float32(1e9)
    d_stop = jnp.where(absent[None], far, jnp.linalg.norm(p_stop[:, None] - q_stop, axis=-1))
    d_now = jnp.where(absent[None], far, jnp.linalg.norm(p[:, None] - est[None, :, :3], axis=-1))
    near = jnp.argmin(d_stop, axis=1)  # [N] the nearest drone once stopped
    rows = jnp.arange(p.shape[0])
    closing = d_stop[rows, near] < d_now[rows, near]
    danger = (d_stop[rows, near] < env.params.r2t.astype(jnp.float32) + margin) & closing
    ahead = jnp.sum(head * (q_stop[rows, near] - p), -1)
    away = -amax * jnp.where(ahead >= 0, 1.0, -1.0)
    return u.at[:, 0].set(jnp.where(danger, away, u[:, 0])).astype(control.dtype)
