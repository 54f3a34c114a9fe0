"""Closed-form (pure JAX) motion models of SPEC §2 and §3.

These are the analytic references the MJX physics is tested against, and the
fast alternative rollout behind ``analytic=True`` in the planner.

Radar state ``[x, y, z, theta, v, omega]``, control ``[a, alpha]`` (SPEC §3)::

    a, alpha = clip(u)
    x'     = x + cos(theta) (v dt + a dt^2 / 2)
    y'     = y + sin(theta) (v dt + a dt^2 / 2)
    theta' = theta + omega dt + alpha dt^2 / 2
    v'     = clip(v + a dt),  omega' = clip(omega + alpha dt)

Target state ``[x, y, z, vx, vy, vz]``, white acceleration ``w`` (SPEC §2)::

    p' = p + v dt + w dt^2 / 2,   v' = v + w dt
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from mjx_radar.scenario.schema import RadarLimits


def control_bounds(limits: RadarLimits) -> tuple[jax.Array, jax.Array]:
    """Lower and upper bounds [2] of the radar control ``[a, alpha]``."""
    hi = jnp.array([limits.accel, limits.alpha])
    return -hi, hi


def unicycle_step(state: jax.Array, u: jax.Array, dt: float, limits: RadarLimits) -> jax.Array:
    """One Euler step of the second-order unicycle.

    Args:
        state: [..., 6] radar states ``[x, y, z, theta, v, omega]``.
        u: [..., 2] controls ``[a, alpha]`` (clipped to the limits here).
        dt: step [s].
        limits: control and state limits.

    Returns:
        [..., 6] next states.
    """
    x, y, z, th, v, w = jnp.moveaxis(state, -1, 0)
    a = jnp.clip(u[..., 0], -limits.accel, limits.accel)
    al = jnp.clip(u[..., 1], -limits.alpha, limits.alpha)
    ds = v * dt + 0.5 * a * dt**2
    return jnp.stack(
        [
            x + jnp.cos(th) * ds,
            y + jnp.sin(th) * ds,
            z,
            th + w * dt + 0.5 * al * dt**2,
            jnp.clip(v + a * dt, -limits.speed, limits.speed),
            jnp.clip(w + al * dt, -limits.omega, limits.omega),
        ],
        axis=-1,
    )


def unicycle_rollout(
    state: jax.Array, controls: jax.Array, dt: float, limits: RadarLimits
) -> jax.Array:
    """Rolls radars out over a control sequence.

    Args:
        state: [N, 6] initial radar states.
        controls: [H, N, 2] controls.

    Returns:
        [H, N, 6] the state after each step.
    """

    def body(s, u):
        s = unicycle_step(s, u, dt, limits)
        return s, s

    return jax.lax.scan(body, state, controls)[1]


def cv_step(state: jax.Array, accel: jax.Array, dt: float) -> jax.Array:
    """One step of the constant-velocity model driven by a piecewise-constant acceleration.

    Args:
        state: [..., 6] ``[x, y, z, vx, vy, vz]``.
        accel: [..., 3] acceleration held over the step (the white-noise draw).

    Returns:
        [..., 6] next states.
    """
    p, v = state[..., :3], state[..., 3:]
    return jnp.concatenate([p + v * dt + 0.5 * accel * dt**2, v + accel * dt], axis=-1)


def sample_white_accel(key: jax.Array, n_targets: int, sigma_w2: float) -> jax.Array:
    """[M, 3] white acceleration draws ``w ~ N(0, sigma_w2 I)`` for one step (SPEC §2)."""
    return jnp.sqrt(sigma_w2) * jax.random.normal(key, (n_targets, 3))
