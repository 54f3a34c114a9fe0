"""Task-agnostic MPPI with adaptive importance sampling (SPEC §7).

The optimiser works on a control sequence ``U[H, D]`` (H horizon steps, D control
dimensions) and knows nothing about radars: the task supplies
``cost_fn(u[H, D]) -> (cost[], aux)`` for ONE sequence, and the box limits and
initial proposal std per control dimension.

Each call of :func:`optimize` runs ``cfg.iterations`` sub-iterations of adaptive
importance sampling on the flattened sequence ``u = vec(U)`` (``P = H*D`` dims,
row-major, i.e. index ``h*D + d``):

1. ``Sigma_0 = diag(tile(init_std, H)**2)`` (restarted on every call; the mean is
   warm-started by the caller, see :func:`shift`).
2. Sample ``u_s ~ N(m, Sigma)``, ``s = 1..S`` with ``S = cfg.samples``; clip each
   step of each sample to ``[lower, upper]``. Sigma is kept factored as
   ``F F^T + diag(b^2)`` (initially ``F = 0``, ``b = std``; after a refit ``F`` is
   ``sqrt(1 - rho)`` times the weighted centred samples and ``b = sqrt(rho mu)``),
   so ``u_s = m + F e1_s + b * e2_s`` with standard normal ``e1, e2`` is an exact
   draw with no ``P x P`` Cholesky (P up to 180 for six radars; a factorisation per
   sub-iteration was the slowest sequential step on the GPU).
3. Score ``c_s = cost_fn(u_s)`` (vmapped over samples). Non-finite costs count as
   worst (zero weight).
4. Weight (normalised, ``sum_s w_s = 1``):

   * ``"ce"``: ``w_s ∝ 1[c_s <= q]`` with ``q`` the ``1 - cfg.elite_threshold``
     quantile of the costs (linear interpolation, as ``numpy.quantile``), i.e.
     the best 10% at 0.9;
   * ``"softmax"``: ``w_s ∝ exp(-(c_s - min c) / cfg.temperature)``.

   If every weight vanishes (all costs non-finite) the best sample gets weight 1.
5. Refit ``m' = sum_s w_s u_s`` and ``Sigma' = shrink(sum_s w_s (u_s - m')(u_s - m')^T)``
   with the weighted estimator named by ``cfg.shrinkage`` (:mod:`mjx_radar.control.shrinkage`:
   Ledoit-Wolf, OAS or none). Zero-weight samples do not enter the fit.

The loop is a ``jax.lax.scan``: wrap the caller's step function in ``jax.jit``
(with ``cost_fn`` closed over) and the whole optimisation is one XLA program.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
from jax import Array

from mjx_radar.batching import batched_like
from mjx_radar.control.shrinkage import ESTIMATORS
from mjx_radar.scenario.schema import MPPIConfig

CostFn = Callable[[Array], tuple[Array, Any]]


class MPPIResult(NamedTuple):
    """Output of :func:`optimize`.

    Attributes:
        mean: ``[H, D]`` optimised control sequence after the last sub-iteration.
        samples: ``[S, H, D]`` clipped samples of the last sub-iteration.
        costs: ``[S]`` their costs.
        weights: ``[S]`` their normalised weights.
        aux: The pytree returned by ``cost_fn`` for those samples, batched over S.
    """

    mean: Array
    samples: Array
    costs: Array
    weights: Array
    aux: Any


def sample_weights(costs: Array, cfg: MPPIConfig) -> Array:
    """Normalised importance weights ``[S]`` of costs ``[S]`` (see module docstring).

    Args:
        costs: ``[S]`` sample costs; ``nan``/``inf`` get zero weight.
        cfg: Uses ``weighting``, ``elite_threshold`` and ``temperature``.

    Returns:
        ``[S]`` non-negative weights summing to one.
    """
    finite = jnp.isfinite(costs)
    c = jnp.where(finite, costs, jnp.inf)
    best = jnp.argmin(c)
    if cfg.weighting == "ce":
        thr = jnp.quantile(c, 1.0 - cfg.elite_threshold)
        w = jnp.where(finite & (c <= thr), 1.0, 0.0)
    elif cfg.weighting == "softmax":
        cmin = c[best]
        w = jnp.where(finite, jnp.exp(-(jnp.where(finite, c, cmin) - cmin) / cfg.temperature), 0.0)
    else:
        raise ValueError(f"unknown MPPI weighting {cfg.weighting!r}")
    w = w.astype(costs.dtype)
    total = jnp.sum(w)
    fallback = jax.nn.one_hot(best, c.shape[0], dtype=w.dtype)
    return jnp.where(total > 0, w / jnp.where(total > 0, total, 1.0), fallback)


def _estimator(cfg: MPPIConfig):
    """The covariance estimator of ``cfg.shrinkage``; ``ValueError`` for a bad config."""
    if cfg.iterations < 1 or cfg.samples < 1:
        raise ValueError("MPPIConfig.iterations and .samples must be >= 1")
    if cfg.shrinkage not in ESTIMATORS:
        raise ValueError(f"unknown MPPI shrinkage {cfg.shrinkage!r}")
    return ESTIMATORS[cfg.shrinkage]


def _aux_placeholder(batched_cost, shape, dtype, ref):
    """Zeros shaped like ``batched_cost``'s aux output for samples ``u[shape]``.

    The probe's samples have the type of MPPI's step's (batched like the key, the mean
    and the std ``ref``: inside ``shard_map``, the same varying axes), so a jitted cost
    traced here is reused by the step rather than traced a second time; the probe's own
    trace is discarded (``jax.eval_shape``).
    """
    key, *rest = ref
    probe = lambda: batched_cost(  # noqa: E731
        batched_like(jnp.zeros(shape, dtype), (jax.random.split(key), *rest))
    )
    aux_shape = jax.eval_shape(probe)[1]
    return jax.tree_util.tree_map(lambda s: jnp.zeros(s.shape, s.dtype), aux_shape)


def optimize(
    cost_fn: CostFn,
    mean: Array,
    key: Array,
    cfg: MPPIConfig,
    init_std: Array,
    lower: Array,
    upper: Array,
) -> MPPIResult:
    """Run ``cfg.iterations`` sub-iterations of adaptive-importance-sampling MPPI.

    Pure and traceable; ``cost_fn`` and ``cfg`` are static (Python objects).

    Args:
        cost_fn: ``u[H, D] -> (cost[], aux)`` for one sequence (vmapped here).
        mean: ``[H, D]`` warm-start mean of the proposal.
        key: PRNG key; the same key gives the same result.
        cfg: Uses ``samples``, ``iterations``, ``weighting``, ``elite_threshold``,
            ``temperature``, ``shrinkage``.
        init_std: ``[D]`` initial proposal std per control dimension (every step).
        lower: ``[D]`` lower control bound, broadcast over steps.
        upper: ``[D]`` upper control bound, broadcast over steps.

    Returns:
        :class:`MPPIResult` of the last sub-iteration.
    """
    estimator = _estimator(cfg)
    mean = jnp.asarray(mean)
    if not jnp.issubdtype(mean.dtype, jnp.floating):
        mean = mean.astype(jnp.result_type(float))
    dtype = mean.dtype
    h, d = mean.shape
    n = cfg.samples
    lower = jnp.asarray(lower, dtype)
    upper = jnp.asarray(upper, dtype)
    std = jnp.tile(jnp.asarray(init_std, dtype), h)
    flat_lo = jnp.broadcast_to(lower, (h, d)).reshape(h * d)
    flat_hi = jnp.broadcast_to(upper, (h, d)).reshape(h * d)
    batched_cost = jax.vmap(cost_fn)

    def step(carry, k):
        # Proposal covariance in factored form: Sigma = F F^T + diag(b^2).
        m, f, b = carry[0], carry[1], carry[2]
        k1, k2 = jax.random.split(k)
        e1 = jax.random.normal(k1, (n, n), dtype)
        e2 = jax.random.normal(k2, (n, h * d), dtype)
        u = jnp.clip((m + e1 @ f.T + e2 * b).reshape(n, h, d), lower, upper)
        costs, aux = batched_cost(u)
        costs = jnp.asarray(costs, dtype).reshape(n)
        w = sample_weights(costs, cfg)
        flat = u.reshape(n, h * d)
        # A convex combination of clipped samples; the clip removes float round-off.
        m_new = jnp.clip(w @ flat, flat_lo, flat_hi)
        _, rho = estimator(flat, w, m_new)
        # Shrunk covariance (1 - rho) S + rho mu I with S = Y^T Y, Y = sqrt(w) (u - m'):
        # factor F = sqrt(1 - rho) Y^T, b = sqrt(rho mu). No P x P factorisation.
        y = jnp.sqrt(w)[:, None] * jnp.where(w[:, None] > 0, flat - m_new, 0.0)
        mu = jnp.sum(y * y) / (h * d)
        f_new = jnp.sqrt(1.0 - rho) * y.T
        b_new = jnp.full((h * d,), jnp.sqrt(rho * mu), dtype)
        return (m_new, f_new, b_new, u, costs, w, aux), None

    # Placeholders for the per-iteration outputs, so that cost_fn is compiled once.
    aux0 = _aux_placeholder(batched_cost, (n, h, d), dtype, (key, mean, std))
    init = (
        mean.reshape(h * d),
        jnp.zeros((h * d, n), dtype),
        std,
        jnp.zeros((n, h, d), dtype),
        jnp.zeros((n,), dtype),
        jnp.zeros((n,), dtype),
        aux0,
    )
    keys = jax.random.split(key, cfg.iterations)
    init = batched_like(init, (keys, init))  # the placeholders: one batching of the body
    (m, _, _, u, costs, w, aux), _ = jax.lax.scan(step, init, keys)
    return MPPIResult(mean=m.reshape(h, d), samples=u, costs=costs, weights=w, aux=aux)


def shift(mean: Array) -> Array:
    """Receding-horizon shift: drop the first control, repeat the last one.

    Args:
        mean: ``[H, D]`` control sequence.

    Returns:
        ``[H, D]`` with row ``t`` equal to ``mean[t + 1]`` and the last row equal to
        ``mean[H - 1]`` (no wrap-around of the first control).
    """
    return jnp.concatenate([mean[1:], mean[-1:]], axis=0)
