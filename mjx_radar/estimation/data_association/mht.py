"""Hypothesis-oriented multiple-hypothesis tracking with a fixed budget of K hypotheses.

A global hypothesis h is one association history of every return so far (which return
of each radar's scan each target took, or none); given it, the M targets' posteriors
are independent CKFs (the per-target bank). The tracker keeps the K most probable
hypotheses, each a full bank ``(x_{h,t}, P_{h,t})`` with its log weight ``log w_h``,
across scans (Reid, IEEE TAC 24(6), 1979; Cox & Hingorani's K-best pruning, IEEE PAMI
18(2), 1996; Blackman, IEEE AES Magazine 19(1), 2004).

Radar after radar (sequential, like the JPDA bank), every hypothesis h and joint event
θ (each target one of its ``G`` best gated returns or none, no return twice:
:func:`mjx_radar.estimation.data_association.association.event_table`) make a child with

    log w_{h,θ} = log w_h + Σ_t log(1 − P_D,ht P_G) + Σ_{t detected in θ} log r_{ht θ(t)}

where ``r_htj = P_D,ht N(ν_htj; 0, S_ht) / (λ (1 − P_D,ht P_G))`` is the JPDA's likelihood
ratio under hypothesis h (:func:`~mjx_radar.estimation.data_association.association.log_ratios`), so
``w_{h,θ} ∝ w_h p(Z_n, θ | h)`` up to a factor every child of the scan shares (Poisson
clutter ``λ^L``). The ``(Π_t (1 − P_D,ht P_G))`` term differs between parents and is
kept. Each child's targets take the Kalman update with their return (``x + K ν_j``,
``P − K S Kᵀ``) or the prediction (missed). Of the ``K · (G + 1)^M`` children the K
heaviest survive (``lax.top_k``: the exact K best, no Murty needed at this size), and
the weights are renormalised (log-sum-exp). With K no smaller than the number of
feasible histories and G no smaller than the returns, this is the exact Bayesian
posterior over association histories (``tests/test_mht.py`` enumerates it); with K = 1
it is the sequential GNN. Optionally the ``screen · K`` heaviest children are screened and
near-duplicates merged before the K heaviest are kept (:mod:`.mht_merge`). The estimate is
the heaviest hypothesis's bank (MAP). With ``branch > 0`` (:func:`update_bank`) only the
first scans branch; afterwards each hypothesis sums its children (:func:`soft_update`: its
JPDA update, its weight times the scan's likelihood), a bank of JPDA filters started from
the first scans' K best associations, and optionally only the K₂ heaviest from a later
scan on (:func:`settled`).

Pure JAX on pytrees, static shapes (K, M, G, L), ``vmap``-able over trials.
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from mjx_radar.estimation import linalg
from mjx_radar.estimation.data_association import association, mht_merge, pda
from mjx_radar.estimation.data_association.mht_settle import live_only, settled
from mjx_radar.estimation.filters import filter_bank

__all__ = [  # noqa: RUF022
    "HypState",
    "init",
    "predict",
    "radar_update",
    "soft_update",
    "update_bank",
    "settled",
    "best",
]


class HypState(NamedTuple):
    """K global hypotheses: ``means [K, M, 6]``, ``covs [K, M, 6, 6]``, ``logw [K]``
    (normalised, ``logsumexp(logw) = 0``; −inf for an empty slot), and ``scans []`` int32,
    the scans updated so far (counted only with ``branch > 0``, :func:`update_bank`): the
    same in every trial of a batch (``BATCH_SHARED``: the loop hands it to the vmapped
    step unbatched, so the branching and settled phases stay ``lax.cond`` branches)."""

    BATCH_SHARED = ("scans",)

    means: jax.Array
    covs: jax.Array
    logw: jax.Array
    scans: jax.Array | int = 0


def init(means, covs, k: int) -> HypState:
    """One hypothesis (the prior bank ``means [M, 6]``, ``covs [M, 6, 6]``) and K − 1 empty
    slots (copies with weight −inf)."""
    means = jnp.asarray(means)
    rep = lambda a: jnp.broadcast_to(a, (k, *a.shape))  # noqa: E731
    logw = jnp.full((k,), -jnp.inf, means.dtype).at[0].set(0.0)
    scans = jnp.zeros((), jnp.int32)
    return HypState(rep(means), rep(jnp.asarray(covs, means.dtype)), logw, scans)


def predict(hyp: HypState, A6, Q6, settle=(0, 0)) -> HypState:
    """CKF time update of every target of every hypothesis (weights unchanged); with
    ``settle = (S, K₂)`` (static, :func:`update_bank`'s) only the K₂ live ones once the
    settled scans have begun (:func:`~.mht_settle.live_only`)."""

    def step(h):
        fn = jax.vmap(filter_bank.predict_bank, (0, 0, None, None))
        means, covs = fn(h.means, h.covs, A6, Q6)
        return h._replace(means=means, covs=covs)

    return live_only(hyp, settle, step)


def best(hyp: HypState):
    """The heaviest hypothesis's bank ``(means [M, 6], covs [M, 6, 6])``."""
    i = jnp.argmax(hyp.logw)
    return hyp.means[i], hyp.covs[i]


def _children(hyp, z, valid, h, R, pd, density, gate, pg, g, residual):
    """Every child's log weight ``[K, E]`` and what it needs to build its bank."""
    moments = jax.vmap(jax.vmap(lambda x, P: pda.innovations(x, P, z, h, R, residual)))
    K, S, nu, d2, logdet = moments(hyp.means, hyp.covs)  # [K, M, ...]
    b, seen = pda.miss_ratio(pd, density, logdet, pg)  # [K, M]
    logr = jax.vmap(association.log_ratios, (0, None, 0, 0, None))(d2, valid, b, seen, gate)
    idx, top = association.candidates(logr, g)  # [K, M, G] (top_k on the last axis)
    events = association.event_table(hyp.means.shape[1], g)
    ev_w, _ = jax.vmap(association.event_log_weights, (0, 0, None))(top, idx, events)  # [K, E]
    miss = jnp.sum(jnp.where(seen, jnp.log1p(-jnp.where(seen, pd, 0.0) * pg), 0.0), -1)
    return hyp.logw[:, None] + miss[:, None] + ev_w, (K, S, nu, idx)


def radar_update(
    hyp: HypState,
    z,
    valid,
    h,
    R,
    pd,
    density,
    gate,
    pg,
    g: int,
    residual=None,
    merge=(0.0, 1, False),
):
    """One radar's scan: the K best children of every hypothesis and joint event.

    Args:
        hyp: :class:`HypState` (predicted).
        z: ``[L, p]`` the scan; valid: ``[L]`` bool.
        h: ``h(x[6]) -> [p]``; R: ``[p, p]`` or ``R(ẑ) -> [p, p]`` (the radar's).
        pd: ``[K, M]`` each hypothesis's detection probability of each target (0: unseen).
        density, gate, pg: clutter density λ, gate γ, gate probability P_G.
        g: candidates per target G (static, ``≤ L``).
        residual: optional measurement residual (angles wrapped).
        merge: ``(τ, screen, labels)`` static: with τ > 0 the ``screen · K`` heaviest
            children are merged
            (:func:`~mjx_radar.estimation.data_association.mht_merge.merge_duplicates`,
            label-free with ``labels``) before the K heaviest are kept; τ = 0: no merging
            (the exact K best).

    Returns:
        The K heaviest children (:class:`HypState`, weights renormalised) and each one's
        parent ``[K]`` int32.
    """
    k, m = hyp.logw.shape[0], hyp.means.shape[1]
    score, (K, S, nu, idx) = _children(hyp, z, valid, h, R, pd, density, gate, pg, g, residual)
    n_ev = score.shape[1]
    tau, screen, labels = merge
    n_c = min(k * screen, score.size) if tau > 0 else k
    top, flat = jax.lax.top_k(score.reshape(-1), n_c)
    parent, ev = flat // n_ev, flat % n_ev
    slot = jnp.asarray(association.event_table(m, g))[ev]  # [K, M]: 0 missed, s: s-th best
    tgt = jnp.arange(m)[None, :]
    j = idx[parent[:, None], tgt, jnp.maximum(slot - 1, 0)]  # [K, M] return index
    gain, innov = K[parent[:, None], tgt], nu[parent[:, None], tgt, j]  # [K,M,6,p], [K,M,p]
    x0, P0 = hyp.means[parent], hyp.covs[parent]
    hit = (slot > 0)[..., None]
    means = x0 + jnp.where(hit, jnp.einsum("kmnp,kmp->kmn", gain, innov), 0.0)
    kskt = jnp.einsum("kmnp,kmpq,kmrq->kmnr", gain, S[parent[:, None], tgt], gain)
    covs = linalg.symmetrize(P0 - jnp.where(hit[..., None], kskt, 0.0))
    if n_c > k:  # merge near-duplicates, then the K heaviest
        perms = association.permutations(m) if labels else None
        top, keep = jax.lax.top_k(mht_merge.merge_duplicates(means, covs, top, tau, perms), k)
        means, covs, parent = means[keep], covs[keep], parent[keep]
    return _clean(HypState(means, covs, top, hyp.scans)), parent


def _clean(hyp: HypState) -> HypState:
    """Renormalised weights; a hypothesis with a non-finite bank is dropped (−inf) and
    holds the heaviest finite one's (so no NaN reaches the loop)."""
    ok = jnp.all(jnp.isfinite(hyp.means), (1, 2)) & jnp.all(jnp.isfinite(hyp.covs), (1, 2, 3))
    logw = jnp.where(ok, hyp.logw, -jnp.inf)
    logw = logw - jax.scipy.special.logsumexp(logw)
    i = jnp.argmax(logw)
    sel = lambda a: jnp.where(ok.reshape((-1,) + (1,) * (a.ndim - 1)), a, a[i][None])  # noqa: E731
    return HypState(sel(hyp.means), sel(hyp.covs), logw, hyp.scans)


def soft_update(hyp, z, valid, h, R, pd, density, gate, pg, g: int, residual=None, miss=0.0):
    """One radar's scan without branching: every hypothesis takes the JPDA update.

    Hypothesis h's children (the events θ of :func:`radar_update`, weights
    ``w_{h,θ} ∝ w_h p(Z_n, θ | h)``) are summed instead of pruned: its new weight is
    ``w_h p(Z_n | h) = Σ_θ w_{h,θ}`` (the scan's predictive likelihood under h, up to the
    factor every hypothesis shares), and each target takes the moment-matched mixture of
    its children's Kalman updates, which is the exact JPDA's PDA mixture with
    ``β_htj = Σ_{θ: θ(t) = j} w_{h,θ} / Σ_θ w_{h,θ}`` (:func:`pda.mixture`). With K = 1 it
    is the JPDA bank (``marginals = "exact"``, G candidates). Arguments as
    :func:`radar_update` (no merging, no parents: the K hypotheses stay in their slots);
    ``miss`` (static, m²): :func:`pda.miss_inflation` of every target by ``P_D β_0``.

    Returns:
        The updated :class:`HypState` (weights renormalised).
    """
    m = hyp.means.shape[1]
    score, (K, S, nu, idx) = _children(hyp, z, valid, h, R, pd, density, gate, pg, g, residual)
    logw = jax.scipy.special.logsumexp(score, axis=1)  # [K]
    alive = jnp.isfinite(logw)[:, None]
    p = jnp.where(alive, jnp.exp(score - jnp.where(alive, logw[:, None], 0.0)), 0.0)
    p = jnp.where(alive, p, jnp.zeros_like(p).at[:, 0].set(1.0))  # empty: all missed
    onehot = jnp.asarray(np.eye(g + 1)[association.event_table(m, g)], p.dtype)  # [E, M, G+1]
    beta = jnp.einsum("ke,etg->ktg", p, onehot)  # [K, M, G + 1]
    n_meas = z.shape[0]
    full = jax.vmap(lambda b, i: association.scatter(b, i, n_meas))(beta[..., 1:], idx)
    mix = jax.vmap(jax.vmap(pda.mixture))
    means, covs = mix(hyp.means, hyp.covs, K, S, nu, beta[..., 0], full)
    if miss > 0:  # at the predicted means, weighted P_D β_0
        grow = jax.vmap(jax.vmap(lambda x, P, w: pda.miss_inflation(x, P, h, w, miss)))
        covs = grow(hyp.means, covs, jnp.clip(pd, 0.0, 1.0) * beta[..., 0])
    return _clean(HypState(means, covs, logw, hyp.scans))


def _scan(hyp, pd, update, radars, branching):
    """Radar after radar; ``pd [N, K, M]`` follows each child's parent when branching."""
    for i in range(radars):  # static N
        if branching:
            hyp, parent = update(hyp, i, pd[i])
            pd = pd[:, parent]
        else:
            hyp = update(hyp, i, pd[i])
    return hyp


def update_bank(
    hyp: HypState,
    zs,
    valid,
    radar_pos,
    model,
    noise,
    ccr,
    pd_fn,
    density,
    gate,
    pg,
    g,
    merge=(0.0, 1, False),
    branch: int = 0,
    settle=(0, 0),
    miss: float = 0.0,
):
    """Every radar's scan, radar after radar, each pruned to the K best.

    Args:
        hyp: :class:`HypState` (predicted).
        zs: ``[N, L, p]`` scans; valid: ``[N, L]``; radar_pos: ``[N, 3]``.
        model, noise, ccr: the filter's measurement model (as :func:`pda.update_bank`).
        pd_fn: ``pd_fn(pos [K, M, 3]) -> [N, K, M]`` the radars' detection probabilities
            at the predicted positions (each child keeps its parent's).
        density, gate, pg: clutter density λ, gate γ, gate probability P_G.
        g: candidates per target G (static; capped at L).
        merge: ``(τ, screen, labels)`` (:func:`radar_update`).
        branch: static; 0: every scan branches (:func:`radar_update`); B > 0: the first B
            scans branch (``hyp.scans < B``), the later ones take :func:`soft_update`
            (each hypothesis a JPDA bank weighted by its likelihood).
        settle: static ``(S, K₂)``; with ``branch > 0``, ``S > 0`` and ``K₂ < K`` the scans
            after the first S update only the K₂ heaviest hypotheses (:func:`settled`).
        miss: static; the soft scans' :func:`pda.miss_inflation` [m²] (0: none).

    Returns:
        The posterior :class:`HypState` (``scans`` one more when ``branch > 0``).
    """
    g = min(g, zs.shape[1])
    pd = pd_fn(hyp.means[..., :3])  # [N, K, M], as the PDA and JPDA banks: at the prediction
    n = radar_pos.shape[0]

    def one(rule, extra):
        def upd(hyp, i, pd_i):
            h, R = pda.radar_model(model, noise, ccr, radar_pos, i)
            args = (zs[i], valid[i], h, R, pd_i, density, gate, pg, g, model.residual)
            return rule(hyp, *args, *extra)

        return upd

    tree = lambda h: _scan(h, pd, one(radar_update, (merge,)), n, True)  # noqa: E731
    if branch <= 0:
        return tree(hyp)
    upd = one(soft_update, (miss,))
    run = lambda h, p: _scan(h, p, upd, n, False)  # noqa: E731  (the soft scans)
    late, k2 = settle
    if late <= 0 or k2 >= hyp.logw.shape[0]:
        hyp = jax.lax.cond(hyp.scans < branch, tree, lambda h: run(h, pd), hyp)
    else:
        phase = jnp.where(hyp.scans < branch, 0, jnp.where(hyp.scans < late, 1, 2))
        few = lambda h: settled(h, pd, k2, run)  # noqa: E731
        hyp = jax.lax.switch(phase, (tree, lambda h: run(h, pd), few), hyp)
    return hyp._replace(scans=hyp.scans + 1)
