"""Gradient MPC: a control sequence optimised by ``jax.grad`` through the rollouts (optax).

Task-agnostic: minimises a differentiable ``cost_fn(u[H, D]) -> (cost, aux)`` inside the
box ``[lower, upper]`` by projected first-order steps. The sequence is optimised in
normalised coordinates ``z = (u - c) / r`` (``c``, ``r`` the box's centre and half
width), so one learning rate suits controls of different units (m/s², rad/s²), and
projected back into ``[-1, 1]`` after every step (the box handled by projection).
Through MJX rollouts without contacts, and through the closed-form rollouts, the cost
is smooth; where contacts switch (obstacles, the terrain's slope stop) its gradient
jumps or vanishes, and the step falls back on the best sequence seen (docs/extending.md).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import jax
import jax.numpy as jnp

Array = jax.Array


class GradientResult(NamedTuple):
    """Output of :func:`descend`.

    Attributes:
        mean: ``[H, D]`` the best sequence visited (lowest cost, within the box).
        best_cost: ``[]`` its cost.
        costs: ``[steps]`` the cost at every step (before the step's update).
        aux: ``cost_fn``'s pytree of ``mean``.
    """

    mean: Array
    best_cost: Array
    costs: Array
    aux: object


def descend(
    cost_fn: Callable,
    mean: Array,
    steps: int,
    lower: Array,
    upper: Array,
    learning_rate: float = 0.05,
    optimizer: str = "adam",
) -> GradientResult:
    """Projected gradient descent (optax ``adam``, ``sgd`` or ``lbfgs``) from ``mean``.

    Args:
        cost_fn: ``u[H, D] -> (cost[], aux)``, differentiable in ``u``.
        mean: ``[H, D]`` warm start.
        steps: gradient steps (>= 1).
        lower, upper: ``[D]`` control bounds (a zero-width dimension stays fixed).
        learning_rate: step size in normalised coordinates (the box is [-1, 1]).
        optimizer: ``"adam"``, ``"sgd"`` or ``"lbfgs"`` (optax's L-BFGS with its zoom
            line search, ``learning_rate`` unused: each step costs the line search's
            extra cost evaluations, up to 20 forward rollouts).

    Returns:
        :class:`GradientResult` with the best sequence visited.
    """
    import optax

    if steps < 1:
        raise ValueError(f"descend: steps = {steps} must be >= 1")
    if optimizer == "lbfgs":
        opt = optax.lbfgs(linesearch=optax.scale_by_zoom_linesearch(max_linesearch_steps=20))
    else:
        opt = {"adam": optax.adam, "sgd": optax.sgd}[optimizer](learning_rate)
    mean = jnp.asarray(mean, jnp.result_type(float))
    h, d = mean.shape
    lower = jnp.broadcast_to(jnp.asarray(lower, mean.dtype), (h, d))
    upper = jnp.broadcast_to(jnp.asarray(upper, mean.dtype), (h, d))
    centre, half = (upper + lower) / 2, (upper - lower) / 2
    safe = jnp.where(half > 0, half, 1.0)

    def to_u(z):
        return centre + half * z

    def loss(z):
        cost, aux = cost_fn(to_u(z))
        return jnp.asarray(cost, mean.dtype), aux

    grad = jax.value_and_grad(loss, has_aux=True)
    z0 = jnp.clip((mean - centre) / safe, -1.0, 1.0) * (half > 0)

    def step(carry, _):
        z, state, best_z, best_cost, best_aux = carry
        (cost, aux), g = grad(z)
        better = cost < best_cost
        best_z = jnp.where(better, z, best_z)
        best_aux = jax.tree_util.tree_map(lambda a, b: jnp.where(better, a, b), aux, best_aux)
        best_cost = jnp.where(better, cost, best_cost)
        g = jnp.where(jnp.isfinite(g), g, 0.0)  # a contact's non-smooth point: no step
        if optimizer == "lbfgs":  # the line search evaluates the cost along the step
            value_fn = lambda zz: loss(zz)[0]  # noqa: E731
            updates, state = opt.update(g, state, z, value=cost, grad=g, value_fn=value_fn)
        else:
            updates, state = opt.update(g, state, z)
        z = jnp.clip(optax.apply_updates(z, updates), -1.0, 1.0) * (half > 0)
        return (z, state, best_z, best_cost, best_aux), cost

    _, aux0 = jax.eval_shape(loss, z0)
    aux0 = jax.tree_util.tree_map(lambda s: jnp.zeros(s.shape, s.dtype), aux0)
    init = (z0, opt.init(z0), z0, jnp.asarray(jnp.inf, mean.dtype), aux0)
    (z, _, best_z, best_cost, best_aux), costs = jax.lax.scan(step, init, None, length=steps)
    (last_cost, last_aux) = loss(z)  # the last step's sequence counts too
    better = last_cost < best_cost
    best_z = jnp.where(better, z, best_z)
    best_aux = jax.tree_util.tree_map(lambda a, b: jnp.where(better, a, b), last_aux, best_aux)
    return GradientResult(to_u(best_z), jnp.minimum(last_cost, best_cost), costs, best_aux)
