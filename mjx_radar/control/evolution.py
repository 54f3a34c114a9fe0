"""Evolution strategies of a control sequence through a kept library: evosax's CMA-ES.

Task-agnostic, like :mod:`mjx_radar.control.sampling`: minimises ``cost_fn(u[H, D]) ->
(cost, aux)`` inside the box ``[lower, upper]`` with ``samples x iterations`` rollouts.
The search runs in the coordinates ``z = (u - u₀) / std`` (``u₀`` the warm start, ``std``
the proposal standard deviation per control dimension), so one isotropic initial step
``σ₀ = std_init`` means "the proposal's spread" in every unit. A candidate is scored
after clipping into the box (as predictive sampling and CEM score theirs); its fitness
adds a quadratic penalty on how far it lay outside, ``(|J(u₀)| + 1) Σ (z − z_box)²``,
so the search distribution is pulled back into the box instead of drifting on the flat
cost beyond a face (boundary handling by penalty, Hansen's CMA-ES tutorial, §B.3).

* ``"cma_es"``: CMA-ES (Hansen & Ostermeier 2001; evosax ``CMA_ES``), full covariance
  of the ``H·D`` dimensions, rank-one and rank-μ updates, cumulative step-size control.
* ``"sep_cma_es"``: separable CMA-ES (Ros & Hansen 2008; evosax ``Sep_CMA_ES``): a
  diagonal covariance, linear in the dimension.

Fitness is minimised (evosax's convention); the best candidate ever scored is returned.
evosax is optional (``pip install -e ".[es]"``); without it importing this module fails
with one line naming the remedy.
"""

from __future__ import annotations

from collections.abc import Callable

import jax
import jax.numpy as jnp

from mjx_radar.control.sampling import SamplingResult

try:  # optional: pip install -e ".[es]"
    from evosax.algorithms import CMA_ES, Sep_CMA_ES
except ImportError as err:  # one line, with the remedy (the registry reports it so)
    raise ImportError("needs evosax, which is not installed: pip install -e '.[es]'") from err

ALGORITHMS = ("cma_es", "sep_cma_es")


def _algorithm(name: str, population: int, dim: int, dtype):
    cls = {"cma_es": CMA_ES, "sep_cma_es": Sep_CMA_ES}[name]
    return cls(population_size=population, solution=jnp.zeros(dim, dtype))


def _box(mean, lower, upper, std):
    """``(u0, lower, upper, scale)``, each ``[H, D]``: the warm start clipped to the box,
    the bounds, the unit of the search (``std``, 1 where it is 0)."""
    u0 = jnp.asarray(mean)
    h, d = u0.shape
    dtype = u0.dtype
    lower = jnp.broadcast_to(jnp.asarray(lower, dtype), (h, d))
    upper = jnp.broadcast_to(jnp.asarray(upper, dtype), (h, d))
    u0 = jnp.clip(u0, lower, upper)
    scale = jnp.broadcast_to(jnp.where(jnp.asarray(std, dtype) > 0, std, 1.0), (h, d))
    return u0, lower, upper, scale


def evolve(
    cost_fn: Callable,
    mean: jax.Array,
    key: jax.Array,
    samples: int,
    iterations: int,
    std: jax.Array,
    lower: jax.Array,
    upper: jax.Array,
    algorithm: str = "cma_es",
    std_init: float = 1.0,
) -> SamplingResult:
    """``iterations`` generations of ``samples`` candidates of an evosax strategy.

    Args:
        cost_fn: ``u[H, D] -> (cost[], aux)`` for one sequence.
        mean: ``[H, D]`` warm start (the search's initial mean, and scored itself).
        key: PRNG key.
        samples: population size (>= 4: CMA-ES's recombination needs a few parents).
        iterations: generations.
        std: ``[D]`` proposal standard deviation per control dimension (the unit of z).
        lower, upper: ``[D]`` control bounds.
        algorithm: ``"cma_es"`` or ``"sep_cma_es"``.
        std_init: initial step size σ₀ in units of ``std``.

    Returns:
        :class:`~mjx_radar.control.sampling.SamplingResult`: the best sequence found, the
        last generation's clipped candidates, their costs, weights 1 on the best of them.
    """
    if algorithm not in ALGORITHMS:
        raise ValueError(f"evolve: algorithm = {algorithm!r} must be one of {ALGORITHMS}")
    if samples < 4:
        raise ValueError(f"evolve: samples = {samples} must be >= 4")
    u0, lower, upper, scale = _box(mean, lower, upper, std)
    (h, d), dtype = u0.shape, u0.dtype
    es = _algorithm(algorithm, samples, h * d, dtype)
    params = es.default_params.replace(std_init=jnp.asarray(std_init, dtype))
    batched = jax.vmap(cost_fn)

    def to_u(z):  # [..., H*D] -> ([..., H, D] inside the box, squared distance outside)
        raw = u0 + scale * z.reshape(z.shape[:-1] + (h, d))
        u = jnp.clip(raw, lower, upper)
        return u, jnp.sum(((raw - u) / scale) ** 2, axis=(-2, -1))

    c0, aux_one = cost_fn(u0)
    c0 = jnp.asarray(c0, dtype)
    weight = jnp.abs(jnp.where(jnp.isfinite(c0), c0, 0.0)) + 1.0  # the penalty's scale
    aux0 = jax.tree_util.tree_map(lambda a: jnp.zeros((samples, *a.shape), a.dtype), aux_one)
    k_init, k_run = jax.random.split(key)
    state = es.init(k_init, jnp.zeros(h * d, dtype), params)

    def generation(carry, k):
        state, best, best_cost = carry[:3]
        k_ask, k_tell = jax.random.split(k)
        z, state = es.ask(k_ask, state, params)
        u, outside = to_u(z)
        costs, aux = batched(u)
        costs = jnp.asarray(costs, dtype).reshape(samples)
        scored = jnp.where(jnp.isfinite(costs), costs, jnp.finfo(dtype).max / 4)
        state, _ = es.tell(k_tell, z, scored + weight * outside, state, params)
        i = jnp.argmin(scored)  # the best is judged on the cost alone (u is in the box)
        better = scored[i] < best_cost
        best = jnp.where(better, u[i], best)
        best_cost = jnp.where(better, scored[i], best_cost)
        w = jax.nn.one_hot(i, samples, dtype=dtype)
        return (state, best, best_cost, u, costs, w, aux), None

    init = (
        state,
        u0,
        c0,
        jnp.zeros((samples, h, d), dtype),
        jnp.zeros(samples, dtype),
        jnp.zeros(samples, dtype),
        aux0,
    )
    (_, best, best_cost, u, costs, w, aux), _ = jax.lax.scan(
        generation, init, jax.random.split(k_run, iterations)
    )
    return SamplingResult(best, u, costs, w, aux, best_cost)
