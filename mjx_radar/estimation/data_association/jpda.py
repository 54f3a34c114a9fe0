"""Joint association update of the per-target bank: JPDA, JPDA*, GNN (issue 35).

Radar after radar (sequential, like :func:`mjx_radar.estimation.data_association.pda.update_bank`),
the
M targets' cubature moments against radar n's scan (:func:`pda.innovations`: ``K_t``,
``S_t``, innovations ``ν_tj``, ``d_tj²``) give the log likelihood ratios ``log r[M, L]``
(:func:`association.log_ratios`); an association rule turns them into weights
``(β_t0, β_tj)`` and each target takes the PDA mixture of them (:func:`pda.mixture`)::

    x_t⁺ = x_t + K_t Σ_j β_tj ν_tj
    P_t⁺ = β_t0 P_t + (1 − β_t0)(P_t − K_t S_t K_tᵀ) + K_t (Σ_j β_tj ν_tj ν_tjᵀ − ν_t ν_tᵀ) K_tᵀ

The rules (:func:`rule`): ``"exact"`` JPDA marginals by enumeration
(:func:`association.exact_marginals`, optionally JPDA*), ``"lbp"`` loopy belief
propagation (:func:`lbp.lbp_marginals`), ``"gnn"`` the best joint event (hard weights:
the Kalman update with the assigned measurement, or none), and ``"multisensor"``, which
is not sequential: every radar's scan at once, over radar tuples
(:mod:`mjx_radar.estimation.data_association.multisensor`). With one target every rule
but GNN is the PDA of that target. Pure JAX, static shapes, ``vmap``-able over trials.
"""

from __future__ import annotations

import functools

import jax

from mjx_radar.estimation.data_association import association, lbp, multisensor, pda

__all__ = ["rule", "joint_update", "update_bank"]


def rule(kind: str, candidates: int = 4, iterations: int = 20, star: bool = False, tuples=8):
    """The association rule ``logr[M, L] -> (β_0[M], β[M, L])`` by name, or for
    ``"multisensor"`` a :class:`~mjx_radar.estimation.data_association.multisensor.Rule` (every
    radar at once).

    Args:
        kind: ``"exact"`` (JPDA, enumeration), ``"lbp"`` (JPDA, loopy BP), ``"gnn"`` or
            ``"multisensor"`` (JPDA over radar tuples,
            :mod:`~mjx_radar.estimation.data_association.multisensor`).
        candidates: G, measurements per target in the enumeration (exact, gnn; capped at
            L), per radar and target in the tuples (multisensor).
        iterations: loopy-BP sweeps.
        star: JPDA* (exact only).
        tuples: multisensor: tuples per target in the joint events, K.
    """
    if kind == "multisensor":
        return multisensor.Rule(candidates, tuples)
    if kind == "exact":
        return lambda logr: association.exact_marginals(
            logr, min(candidates, logr.shape[1]), star=star
        )
    if kind == "gnn":
        return lambda logr: association.gnn_weights(logr, min(candidates, logr.shape[1]))
    if kind == "lbp":
        return functools.partial(lbp.lbp_marginals, iterations=iterations)
    raise ValueError(f"association rule {kind!r}: one of exact, lbp, gnn")


def joint_update(means, covs, z, valid, h, R, pd, density, gate, pg, assoc, residual=None):
    """One scan of one radar for all M targets jointly.

    Args:
        means: ``[M, n]``; covs: ``[M, n, n]`` predicted moments.
        z: ``[L, p]`` the scan; valid: ``[L]`` bool.
        h: ``h(x[n]) -> [p]`` (the radar's); R: ``[p, p]`` or ``R(ẑ) -> [p, p]``.
        pd: ``[M]`` detection probabilities (0: not seen, no update).
        density, gate, pg: clutter density λ, gate γ, gate probability P_G.
        assoc: the rule (:func:`rule`).
        residual: optional measurement residual (angles wrapped).

    Returns:
        ``(means[M, n], covs[M, n, n])`` and the weights ``(β_0[M], β[M, L])``.
    """
    moments = jax.vmap(lambda x, P: pda.innovations(x, P, z, h, R, residual))
    K, S, nu, d2, logdet = moments(means, covs)
    b, seen = pda.miss_ratio(pd, density, logdet, pg)  # elementwise over targets
    beta0, beta = assoc(association.log_ratios(d2, valid, b, seen, gate))
    post = jax.vmap(pda.mixture)(means, covs, K, S, nu, beta0, beta)
    return post, (beta0, beta)


def update_bank(means, covs, zs, valid, radar_pos, model, noise, ccr, pd, density, gate, pg, assoc):
    """Sequential joint association of every radar's scan (the per-target bank).

    Args: as :func:`mjx_radar.estimation.data_association.pda.update_bank`, and ``assoc`` the rule
    (a
        :class:`~mjx_radar.estimation.data_association.multisensor.Rule`: all radars at once).

    Returns:
        ``(means[M, 6], covs[M, 6, 6])`` posterior moments.
    """
    if isinstance(assoc, multisensor.Rule):
        args = (means, covs, zs, valid, radar_pos, model, noise, ccr, pd, density, gate, pg)
        return multisensor.update_bank(*args, min(assoc.g, zs.shape[1]), assoc.k)
    for i in range(radar_pos.shape[0]):  # radar after radar (static N)
        h, R = pda.radar_model(model, noise, ccr, radar_pos, i)
        (means, covs), _ = joint_update(
            means, covs, zs[i], valid[i], h, R, pd[i], density, gate, pg, assoc, model.residual
        )
    return means, covs
