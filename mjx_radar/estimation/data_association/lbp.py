"""JPDA marginals by loopy belief propagation (Williams & Lau 2014), fixed iterations.

J. L. Williams and R. A. Lau, "Approximate evaluation of marginal association
probabilities with belief propagation", IEEE Trans. Aerospace and Electronic Systems
50(4), 2014. The joint events of :mod:`mjx_radar.estimation.data_association.association` form a
bipartite graph of targets t (choose a measurement j or miss, weights ``w_t0``,
``w_tj = r_tj`` against clutter) and measurements j (taken by at most one target; the
clutter alternative has weight 1). With ``ν_{j→t} = 1`` initially, one iteration is::

    μ_{t→j} = w_tj / (w_t0 + Σ_{j' ≠ j} w_tj' ν_{j'→t})
    ν_{j→t} = 1 / (1 + Σ_{t' ≠ t} μ_{t'→j})

and the marginals are ``β_tj = w_tj ν_{j→t} / (w_t0 + Σ_j' w_tj' ν_{j'→t})``, ``β_t0 =
w_t0 / (same)``. Each target's row may be scaled by any constant (every event holds one
factor of each target), so each row is divided by its largest weight (log domain in,
nothing overflows), and leave-one-out sums come from prefix and suffix sums (no
cancellation). The iteration converges (the paper's Theorem 1); on a graph without
cycles (e.g. a single target, or targets that share at most a chain of measurements) the
fixed point is the exact marginal. Cost ``O(iterations · M · L)``, against ``(G+1)^M``
events of the exact enumeration: this is the scalable one.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

__all__ = ["lbp_marginals"]


def lbp_marginals(logr, iterations: int):
    """Approximate JPDA marginals of ``log r[M, L]`` (−inf: not gated).

    Args:
        logr: ``[M, L]`` log likelihood ratios (:func:`association.log_ratios`).
        iterations: message-passing sweeps (static, ≥ 1).

    Returns:
        ``(β_0[M], β[M, L])``, ``β_0 + Σ_j β_j = 1`` per target.
    """
    top = jnp.maximum(jnp.max(logr, axis=1, keepdims=True), 0.0)  # [M, 1]
    w = jnp.exp(logr - top)  # [M, L], 0 outside the gates
    w0 = jnp.exp(-top[:, 0])  # [M] the miss weight 1, scaled alike

    def sweep(_, nu):  # nu[M, L]: ν_{j→t}
        den = jnp.maximum(w0[:, None] + _others(w * nu, axis=1), jnp.finfo(w.dtype).tiny)
        mu = jnp.where(w > 0, w / den, 0.0)  # μ ≤ 1/tiny: finite
        return 1.0 / (1.0 + _others(mu, axis=0))

    nu = jax.lax.fori_loop(0, iterations, sweep, jnp.ones_like(w))
    wn = w * nu
    den = jnp.maximum(w0 + jnp.sum(wn, axis=1), jnp.finfo(w.dtype).tiny)
    return w0 / den, wn / den[:, None]


def _others(a, axis):
    """``Σ_{k ≠ i} a_k`` along ``axis`` for every i, from exclusive prefix and suffix sums
    (no ``total − a_i``: that cancels when a_i dominates, e.g. a target sure of its return)."""
    zero = jnp.zeros_like(jax.lax.slice_in_dim(a, 0, 1, axis=axis))
    pre = jnp.cumsum(a, axis=axis)
    pre = jnp.concatenate([zero, jax.lax.slice_in_dim(pre, 0, a.shape[axis] - 1, axis=axis)], axis)
    suf = jnp.flip(jnp.cumsum(jnp.flip(a, axis), axis=axis), axis)
    suf = jnp.concatenate([jax.lax.slice_in_dim(suf, 1, a.shape[axis], axis=axis), zero], axis)
    return pre + suf
