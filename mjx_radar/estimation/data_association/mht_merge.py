"""Merging near-duplicate hypotheses of the MHT (:mod:`mjx_radar.estimation.data_association.mht`).

With a fixed budget K, a hypothesis tree degenerates: the K heaviest children of a scan
are mostly one parent's, differing in assignments that barely move its bank (two
returns close together, a clutter return or a miss at the edge of a gate), and the
competing histories the dynamics have not yet decided between are pruned. Before
pruning, the MHT screens its ``C = screen · K`` heaviest children and merges each into
the heaviest earlier one whose bank it nearly duplicates (Blackman, IEEE AES Magazine
19(1), 2004, §3: hypotheses with similar tracks are combined)::

    d²(a, b) = max_t Σ_i (x_{a,t,i} − x_{b,t,i})² / (P_{a,t,ii} + P_{b,t,ii})   (6 coordinates)
    b duplicates a  ⟺  a is heavier than b and d²(a, b) < τ

The merged hypothesis keeps the heavier bank and the sum of the weights (mass is kept
where the evidence put it; a chain b → a → a' ends at the first kept one). τ = 0 merges
nothing. With ``perms`` (the M! target permutations π) the distance is label-free,
``min_π max_t Σ_i (x_{a,t,i} − x_{b,π(t),i})² / (P_{a,t,ii} + P_{b,π(t),ii})``: two
hypotheses that put the same tracks on the drones in another order are one position set,
and the heavier labelling is kept (range-only scans fix positions long before labels, so
the early hypotheses are largely label permutations of each other). Pure JAX, static
shapes (``[C, C, M]`` distances per order, the orders in a ``lax.map``).
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp

__all__ = ["merge_duplicates"]


def merge_duplicates(means, covs, logw, tau: float, perms=None):
    """Log weights after merging near-duplicates (module doc).

    Args:
        means: ``[C, M, 6]``; covs: ``[C, M, 6, 6]`` the screened children's banks.
        logw: ``[C]`` their log weights, sorted descending (``lax.top_k``), ``logw[0]``
            finite; −inf for an empty child.
        tau: the merge threshold τ (static, > 0).
        perms: optional ``[P, M]`` int target permutations (label-free distance).

    Returns:
        ``[C]`` log weights: a kept child's the log of its own weight plus those merged
        into it, a merged child's −inf.
    """
    c, m = logw.shape[0], means.shape[1]
    var = jnp.diagonal(covs, axis1=-2, axis2=-1)  # [C, M, 6]
    perms = jnp.arange(m)[None] if perms is None else jnp.asarray(perms)  # [P, M]

    def order(pi):  # [C, C]: b's targets in the order π (one order at a time: memory C² M)
        diff = means[:, None] - means[None, :, pi]
        return jnp.max(jnp.sum(diff**2 / (var[:, None] + var[None, :, pi]), -1), -1)

    d2 = jnp.min(jax.lax.map(order, perms), 0)  # [C, C]
    order = jnp.arange(c)
    alive = jnp.isfinite(logw)
    hit = (d2 < tau) & (order[:, None] < order[None, :]) & alive[:, None] & alive[None, :]
    dup = jnp.any(hit, 0)  # [C]: a heavier child is (nearly) the same
    owner = jnp.where(dup, jnp.argmax(hit, 0), order)  # the first (heaviest) such one
    for _ in range(max(1, math.ceil(math.log2(c)))):  # owner[j] < j: pointer jumping
        owner = owner[owner]
    w = jnp.where(alive, jnp.exp(logw - logw[0]), 0.0)
    total = jnp.zeros_like(w).at[owner].add(w)
    return jnp.where(dup | ~alive, -jnp.inf, jnp.log(total) + logw[0])
