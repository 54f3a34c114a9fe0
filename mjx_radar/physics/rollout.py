"""Batched radar rollouts (the planner's physics) and the public ``rollout_radars``.

A radar-only plant is rolled out over a horizon of controls with ``lax.scan``. A fast
scene with a fused step (:mod:`~mjx_radar.physics.fused_step`) carries only the radars'
``q, qd [N, 3]`` and ``act [N, 2]`` through the loop; otherwise the MJX data, stepped by
:func:`~mjx_radar.physics.plant.step`. A one-radar plant (:func:`planner_plant`) serves
any N: its radars do not interact without contacts.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from mjx_radar.batching import batched_like
from mjx_radar.physics import fused_step
from mjx_radar.physics.plant import (
    Plant,
    check_finite,
    check_shape,
    clip_controls,
    init_data,
    planar_state,
    planner_plant,
    radar_ctrl,
    radar_state,
    step,
)
from mjx_radar.scenario.schema import Scenario
from mjx_radar.world.components import Ground

ROLLOUT_UNROLL: int = 1
"""Rollout steps per loop iteration of :func:`radar_rollout` (``lax.scan``'s ``unroll``).
H100, ``benchmarks/bench_mppi.py --unroll 1,15``: with MJX's stages, unrolled 15 steps took
an SFIM MPPI call from 6.06 to 5.58 ms but its compilation from 12 to 30 s; benchmarks
may change it."""


def radar_rollout(plant: Plant, state: jax.Array, controls: jax.Array) -> jax.Array:
    """Rolls the radars of a radar-only plant out through its physics step.

    Args:
        plant: a plant without drones and with N radars, or with one radar (e.g.
            :func:`planner_plant`), which then serves the N radars (valid for a
            contact-free plant, where radars do not interact).
        state: [N, 6] initial radar states.
        controls: [H, N, 2] controls, one per physics step.

    Returns:
        [H, N, 6] radar states after each step.
    """
    unroll = max(1, min(int(ROLLOUT_UNROLL), controls.shape[0]))
    if plant.fused is not None and plant.n_drones == 0 and not plant.ground.present:
        return _fused_rollout(plant, state, controls, unroll)
    if plant.n_radars == 1 and state.shape[0] != 1:
        if plant.index.obstacle_geoms.size:
            raise ValueError("plant: a one-radar plant with obstacles cannot roll out N radars")

        def one(s, u):  # [6], [H, 2] -> [H, 6]
            return radar_rollout(plant, s[None], u[:, None])[:, 0]

        return jax.vmap(one, (0, 1), 1)(state, controls)
    data = init_data(plant, state)

    def body(d, u):
        d = step(plant, d, u)
        return d, radar_state(plant, d)

    data = batched_like(data, (controls, state))  # a start shared by the samples
    return jax.lax.scan(body, data, controls, unroll=unroll)[1]


def _fused_rollout(plant: Plant, state: jax.Array, controls: jax.Array, unroll: int):
    """:func:`radar_rollout` through the fused step: the same map as MJX's stages (tests
    compare them), with ``qd = 0`` at the start as in fresh MJX data."""
    if plant.n_radars not in (1, state.shape[0]):
        raise ValueError(f"state: {state.shape[0]} radars for a plant of {plant.n_radars}")
    (block,) = plant.fused.blocks
    q, act = state[:, jnp.array([0, 1, 3])], state[:, 4:6]

    def body(carry, u):
        q, qd, act = carry
        u = clip_controls(plant, u)
        q, qd, act = fused_step.block_step(
            jnp, block, plant.dt, q, qd, act, radar_ctrl(plant, act, u)
        )
        return (q, qd, act), planar_state(q, act)

    init = batched_like((q, jnp.zeros_like(q), act), (controls, state))  # mjx_radar.batching
    return jax.lax.scan(body, init, controls, unroll=unroll)[1]


def rollout_radars(scenario: Scenario, radar_state: jax.Array, controls: jax.Array) -> jax.Array:
    """Public SPEC §11 entry point: MJX rollout at the scenario's control step.

    ``radar_state [N, 6]`` = ``[x, y, z, theta, v, omega]``, ``controls [H, N, 2]`` =
    ``[a, alpha]`` -> ``[H, N, 6]`` states after each control step (the scenario's N,
    limits and control step; obstacles are ignored, terrain sets z).
    """
    plant = planner_plant(scenario.timing.dt_control, scenario.limits)
    check_shape("controls", controls, (jnp.shape(controls)[0], scenario.n_radars, 2))
    check_shape("radar_state", radar_state, (scenario.n_radars, 6))
    check_finite("controls", controls)
    check_finite("radar_state", radar_state)
    out = _jit_radar_rollout(plant, jnp.asarray(radar_state), jnp.asarray(controls))
    return Ground(scenario.terrain).on_ground(out)  # the planner's lookup (flat: z = 0)


_jit_radar_rollout = jax.jit(radar_rollout, static_argnums=0)
