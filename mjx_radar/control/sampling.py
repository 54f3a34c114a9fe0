"""Sampling optimisers of a control sequence: predictive sampling and the cross-entropy method.

Task-agnostic, like :mod:`mjx_radar.control.mppi` (hydrax / MJPC's baselines): each
minimises ``cost_fn(u[H, D]) -> (cost, aux)`` over sequences inside the box
``[lower, upper]`` with a fixed budget of ``samples x iterations`` rollouts, pure and
traceable (``lax.scan`` over iterations, ``vmap`` over samples).

* :func:`predictive_sampling`: every iteration draws ``samples`` Gaussian perturbations
  of the incumbent (one of them the incumbent itself) and keeps the best; the noise
  scale is fixed (``std``).
* :func:`cross_entropy`: every iteration draws ``samples`` sequences from a diagonal
  Gaussian, keeps the ``elite`` best and refits the mean and the standard deviation
  to them (with a floor ``std_min`` so the search never collapses to a point).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import jax
import jax.numpy as jnp

Array = jax.Array


class SamplingResult(NamedTuple):
    """Output of a sampling optimiser (same fields as :class:`~mjx_radar.control.mppi.MPPIResult`).

    Attributes:
        mean: ``[H, D]`` the optimised sequence (the best found, or CEM's last mean).
        samples: ``[S, H, D]`` the last iteration's clipped samples.
        costs: ``[S]`` their costs.
        weights: ``[S]`` 1 for the kept sample(s) (the best / the elites, normalised).
        aux: ``cost_fn``'s pytree for those samples, batched over S.
        best_cost: ``[]`` the cost of ``mean`` as evaluated (PS: the best found).
    """

    mean: Array
    samples: Array
    costs: Array
    weights: Array
    aux: object
    best_cost: Array


def _setup(cost_fn, mean, samples, lower, upper):
    mean = jnp.asarray(mean)
    if not jnp.issubdtype(mean.dtype, jnp.floating):
        mean = mean.astype(jnp.result_type(float))
    h, d = mean.shape
    lower = jnp.broadcast_to(jnp.asarray(lower, mean.dtype), (h, d))
    upper = jnp.broadcast_to(jnp.asarray(upper, mean.dtype), (h, d))
    batched = jax.vmap(cost_fn)
    aux_shape = jax.eval_shape(batched, jax.ShapeDtypeStruct((samples, h, d), mean.dtype))[1]
    aux0 = jax.tree_util.tree_map(lambda s: jnp.zeros(s.shape, s.dtype), aux_shape)
    return jnp.clip(mean, lower, upper), lower, upper, batched, aux0


def predictive_sampling(
    cost_fn: Callable,
    mean: Array,
    key: Array,
    samples: int,
    iterations: int,
    std: Array,
    lower: Array,
    upper: Array,
) -> SamplingResult:
    """Best of ``samples`` Gaussian perturbations of the incumbent, ``iterations`` times.

    Args:
        cost_fn: ``u[H, D] -> (cost[], aux)`` for one sequence.
        mean: ``[H, D]`` warm start (the first incumbent).
        key: PRNG key.
        samples: candidates per iteration (sample 0 is the incumbent, never lost).
        iterations: rounds of sampling.
        std: ``[D]`` perturbation standard deviation per control dimension.
        lower, upper: ``[D]`` control bounds (samples are clipped into them).
    """
    best, lower, upper, batched, aux0 = _setup(cost_fn, mean, samples, lower, upper)
    h, d = best.shape
    std = jnp.asarray(std, best.dtype)
    c0 = jnp.asarray(cost_fn(best)[0], best.dtype)

    def step(carry, k):
        best, best_cost = carry[:2]
        noise = std * jax.random.normal(k, (samples, h, d), best.dtype)
        u = jnp.clip(best + noise.at[0].set(0.0), lower, upper)  # sample 0: the incumbent
        costs, aux = batched(u)
        costs = jnp.asarray(costs, best.dtype).reshape(samples)
        i = jnp.argmin(costs)
        better = costs[i] < best_cost
        best = jnp.where(better, u[i], best)
        best_cost = jnp.where(better, costs[i], best_cost)
        w = jax.nn.one_hot(i, samples, dtype=best.dtype)
        return (best, best_cost, u, costs, w, aux), None

    init = (
        best,
        c0,
        jnp.zeros((samples, h, d), best.dtype),
        jnp.zeros(samples, best.dtype),
        jnp.zeros(samples, best.dtype),
        aux0,
    )
    (best, best_cost, u, costs, w, aux), _ = jax.lax.scan(
        step, init, jax.random.split(key, iterations)
    )
    return SamplingResult(best, u, costs, w, aux, best_cost)


def cross_entropy(
    cost_fn: Callable,
    mean: Array,
    key: Array,
    samples: int,
    iterations: int,
    std: Array,
    lower: Array,
    upper: Array,
    elite: int,
    std_min: Array | float = 0.0,
) -> SamplingResult:
    """The cross-entropy method with a diagonal Gaussian over the sequence.

    Args:
        cost_fn, mean, key, samples, iterations, lower, upper: as :func:`predictive_sampling`.
        std: ``[D]`` initial standard deviation per control dimension.
        elite: sequences kept per iteration (``1 <= elite <= samples``).
        std_min: ``[D]`` (or scalar) floor of the refitted standard deviation.
    """
    if not 1 <= elite <= samples:
        raise ValueError(f"cross_entropy: elite = {elite} must be in [1, {samples}]")
    m, lower, upper, batched, aux0 = _setup(cost_fn, mean, samples, lower, upper)
    h, d = m.shape
    s0 = jnp.broadcast_to(jnp.asarray(std, m.dtype), (h, d))
    floor = jnp.broadcast_to(jnp.asarray(std_min, m.dtype), (h, d))

    def step(carry, k):
        m, s = carry[:2]
        u = jnp.clip(m + s * jax.random.normal(k, (samples, h, d), m.dtype), lower, upper)
        costs, aux = batched(u)
        costs = jnp.asarray(costs, m.dtype).reshape(samples)
        idx = jnp.argsort(costs)[:elite]
        e = u[idx]
        m_new = jnp.mean(e, axis=0)
        s_new = jnp.maximum(jnp.std(e, axis=0), floor)
        w = jnp.zeros(samples, m.dtype).at[idx].set(1.0 / elite)
        return (m_new, s_new, u, costs, w, aux, jnp.min(costs)), None

    init = (
        m,
        s0,
        jnp.zeros((samples, h, d), m.dtype),
        jnp.zeros(samples, m.dtype),
        jnp.zeros(samples, m.dtype),
        aux0,
        jnp.asarray(jnp.inf, m.dtype),
    )
    (m, _, u, costs, w, aux, best), _ = jax.lax.scan(step, init, jax.random.split(key, iterations))
    return SamplingResult(jnp.clip(m, lower, upper), u, costs, w, aux, best)
