"""The MHT's reported hypothesis: the heaviest (MAP) or the consensus of the heaviest few.

The multiple-hypothesis tracker (:mod:`~mjx_radar.estimation.data_association.mht`) keeps
K weighted hypotheses, each a per-target bank. Its estimate (what the loop carries: the
metrics, the lost-track detector, and the planner with ``plan_on = "best"``) is one of
them. The heaviest one (:func:`~mjx_radar.estimation.data_association.mht.best`) is the
MAP history, but the posterior of a range-only scene is often a cluster of near-identical
hypotheses (histories that differ in a return or two and put every drone at the same
place) beside a single ghost set. The MAP then picks the ghost when it outweighs each
member of the cluster, although the cluster holds more of the weight.

The consensus estimate (:func:`consensus`) is the minimum Bayes risk choice for a loss
that counts how far the reported position set is from the true one, with a Gaussian
kernel of scale s: of the J heaviest hypotheses (``lax.top_k``, J = min(K, ``J_MAX``)),
the one with the most posterior weight near it,

    ĥ = argmax_h Σ_h' w_h' exp(−D²(h, h') / (2 s²)),
    D²(h, h') = min_π Σ_t ‖p_{h,t} − p_{h',π(t)}‖²

with ``w`` the J weights normalised among themselves, ``p`` the position estimates and π
over the M! orders of the targets (label-free: range-only scans fix the drones' positions
long before their labels, so hypotheses that place the same tracks in another order are
one position set). As s → 0 only exact duplicates share weight and ĥ is the MAP; a
single hypothesis (or one far from every other) gives the MAP's bank bit for bit. Cost:
``J² M!`` sums of M squared distances a scan. Pure JAX, static shapes, ``vmap``-able.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from mjx_radar.estimation.data_association import association

__all__ = ["J_MAX", "distances", "consensus_index", "consensus"]

#: hypotheses the consensus compares at most (the heaviest J)
J_MAX = 64


def distances(pos):
    """Label-free squared distances between position sets.

    Args:
        pos: ``[J, M, 3]`` the hypotheses' target positions.

    Returns:
        ``D² [J, J]``: ``min_π Σ_t ‖pos[a, t] − pos[b, π(t)]‖²`` over the M! orders π.
    """
    m = pos.shape[1]
    d = jnp.sum((pos[:, None, :, None, :] - pos[None, :, None, :, :]) ** 2, -1)  # [J, J, M, M]
    perms = jnp.asarray(association.permutations(m))  # [P, M]
    return jnp.min(jnp.sum(d[:, :, jnp.arange(m)[None, :], perms], -1), -1)


def consensus_index(means, logw, scale: float):
    """The index (into K) of the consensus hypothesis ĥ (module docstring).

    Args:
        means: ``[K, M, 6]`` the hypotheses' banks' means; logw: ``[K]`` log weights
            (normalised or not; −inf: an empty slot, never chosen).
        scale: the kernel's s [m] (static, > 0).

    Returns:
        ``[]`` int32.
    """
    j = min(J_MAX, logw.shape[0])
    lw, top = jax.lax.top_k(logw, j)
    w = jax.nn.softmax(lw)  # exp(-inf) = 0: empty slots weigh nothing
    near = jnp.exp(-distances(means[top, :, :3]) / (2.0 * scale * scale))
    score = jnp.where(jnp.isfinite(lw), near @ w, -jnp.inf)
    return top[jnp.argmax(score)].astype(jnp.int32)


def consensus(means, covs, logw, scale: float):
    """The consensus hypothesis's bank ``(means [M, 6], covs [M, 6, 6])``.

    Args:
        means: ``[K, M, 6]``; covs: ``[K, M, 6, 6]``; logw: ``[K]``; scale: s [m].
    """
    i = consensus_index(means, logw, scale)
    return means[i], covs[i]
