"""The MHT's hypotheses as one Gaussian per target: what a planner can plan for.

The multiple-hypothesis tracker (:mod:`~mjx_radar.estimation.data_association.mht`)
keeps K weighted hypotheses, each a per-target bank ``(x_{h,t}, P_{h,t})``. Its estimate
is the heaviest hypothesis's bank (MAP). :func:`mixture` moment-matches all of them,
target by target: with the normalised weights ``w_h = exp(log w_h) / Σ_k exp(log w_k)``
and every hypothesis's targets first relabelled to the heaviest's (:func:`align`)::

    x̄_t = Σ_h w_h x_{h,t}
    P̄_t = Σ_h w_h (P_{h,t} + (x_{h,t} − x̄_t)(x_{h,t} − x̄_t)ᵀ)

(the mean and covariance of the Gaussian mixture ``Σ_h w_h N(x_{h,t}, P_{h,t})``: the
spread between hypotheses adds to each target's covariance). The alignment matters
because range-only scans fix the drones' positions before their labels: two hypotheses
that place the same tracks on the drones in another order are one position set, and
averaging them label by label would put every target between the drones. Each
hypothesis's order is the minimum-cost assignment of its targets to the heaviest's
(cost ``‖p_{best,i} − p_{h,j}‖²`` on the position estimates, ``[M, M]``;
:func:`~mjx_radar.estimation.data_association.assignment.hungarian`). Empty slots
(``log w = −inf``) weigh 0 exactly, so a single hypothesis (or one that takes all the
weight) gives the heaviest bank bit for bit. Pure JAX, static shapes, ``vmap``-able.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from mjx_radar.estimation.data_association.assignment import BIG, hungarian

__all__ = ["align", "mixture"]


def align(means, covs, logw):
    """Every hypothesis's targets in the order of the heaviest hypothesis's.

    Args:
        means: ``[K, M, 6]``; covs: ``[K, M, 6, 6]`` the hypotheses' banks.
        logw: ``[K]`` their log weights (−inf: an empty slot).

    Returns:
        ``(means [K, M, 6], covs [K, M, 6, 6])``: hypothesis h's target ``order[h, i]``
        as its target i, ``order[h]`` the minimum-cost assignment of its position
        estimates to the heaviest hypothesis's (the heaviest's own order is the identity).
    """
    ref = means[jnp.argmax(logw), :, :3]  # [M, 3]

    def order(pos):  # [M, 3] -> [M] int32: the target of h aligned to each of ref's
        cost = jnp.sum((ref[:, None, :] - pos[None, :, :]) ** 2, -1)  # [M (ref), M (h)]
        return hungarian(jnp.where(jnp.isfinite(cost), cost, BIG))  # a stale slot: finite

    idx = jax.vmap(order)(means[:, :, :3])  # [K, M]
    take = jax.vmap(lambda a, i: a[i])
    return take(means, idx), take(covs, idx)


def mixture(means, covs, logw):
    """The moment-matched mixture of the hypotheses, per target (module doc).

    Args:
        means: ``[K, M, 6]``; covs: ``[K, M, 6, 6]`` the hypotheses' banks.
        logw: ``[K]`` log weights, normalised or not (−inf: an empty slot, weight 0).

    Returns:
        ``(mean [M, 6], cov [M, 6, 6])``: ``x̄_t`` and ``P̄_t`` of every target, labelled
        like the heaviest hypothesis.
    """
    means, covs = align(means, covs, logw)
    w = jax.nn.softmax(logw)  # exp(-inf) = 0: empty slots weigh nothing
    live = (w > 0)[:, None, None]
    best = jnp.argmax(logw)
    means = jnp.where(live, means, means[best])  # an empty slot's bank may be stale
    covs = jnp.where(live[..., None], covs, covs[best])
    mean = jnp.einsum("k,kmi->mi", w, means)
    d = means - mean  # [K, M, 6]
    spread = covs + d[..., :, None] * d[..., None, :]
    return mean, jnp.einsum("k,kmij->mij", w, spread)
