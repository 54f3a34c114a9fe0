"""Multi-sensor JPDA: every radar's scan associated jointly, one tuple per target (issue 35).

The sequential rules (:mod:`mjx_radar.estimation.data_association.jpda`) associate radar after
radar and
collapse each target's mixture in between; with range-only radars a single radar's
return says nothing about which drone it is, and the collapsed means land between the
drones (ghosts). Here a target's association hypothesis is a *tuple*
``τ = (τ_1, ..., τ_N)``, one return (or a miss, ``τ_n = 0``) per radar, scored with the
stacked innovation of all N radars, whose covariance carries the common prior: only
range tuples consistent with one position near the prediction score high (the
multi-sensor association of Deb, Yeddanapudi, Pattipati & Bar-Shalom, IEEE TAES 33(2),
1997; the factor graph of Meyer et al., Proc. IEEE 106(2), 2018).

Per target, the stacked cubature moments (:func:`stacked_moments`) give ``ẑ[N, p]``,
``S[Np, Np]`` (full: the radars share the prior), ``P_xz[n, Np]`` and the innovations
``ν_nj = z_nj − ẑ_n``. With the detected radars ``D(τ)``, ``ν_τ`` the stacked innovations
of the tuple's returns and ``S_τ`` the block of S on D(τ), the likelihood ratio of the
tuple against "every return of the tuple is clutter and the target is missed" is::

    r(τ) = N(ν_τ; 0, S_τ) Π_{n ∈ D(τ)} P_D,n / (λ (1 − P_D,n P_G))

(the all-missed tuple has r = 1). With one radar it is the JPDA's ``r_tj`` exactly, and
with independent radars (a block-diagonal S) the product of the per-radar ratios. A
joint event gives every target one tuple, no return of any radar to two targets; its
probability is ``∝ Π_t r_t(τ_t)`` and the tuple marginals ``β_t(τ)`` are summed over
the events. Each target takes the mixture of its tuples' Kalman updates::

    x_τ = x + K_τ ν_τ,   P_τ = P − K_τ S_τ K_τᵀ,   K_τ = P_xz,τ S_τ⁻¹
    x⁺ = Σ_τ β(τ) x_τ,   P⁺ = Σ_τ β(τ) (P_τ + (x_τ − x⁺)(x_τ − x⁺)ᵀ)

Truncation (static shapes): each radar's ``G`` best gated returns of the target (by the
marginal ratio), ``(G + 1)^N`` tuples scored, the ``K − 1`` best kept with the
all-missed one, and the ``K^M`` joint events enumerated exactly. Tuples or events
outside those lists are dropped (the rest renormalised). Pure JAX, ``vmap``-able.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import jax
import jax.numpy as jnp

from mjx_radar.estimation import linalg
from mjx_radar.estimation.data_association import association
from mjx_radar.estimation.filters import ckf
from mjx_radar.estimation.sensor.noise import at_radar


class Rule(NamedTuple):
    """The multi-sensor JPDA as a rule of
    :func:`mjx_radar.estimation.data_association.jpda.update_bank`."""

    g: int  # returns per radar and target in the tuples
    k: int  # tuples per target in the joint events (the all-missed one included)


__all__ = [  # noqa: RUF022
    "Rule",
    "stacked_moments",
    "tuple_scores",
    "event_log_weights",
    "exclusive_marginals",
    "joint_marginals",
    "update_bank",
]


def stacked_moments(mean, cov, radar_pos, model, noise, ccr):
    """Cubature moments of one target's measurements by all N radars stacked.

    Returns:
        ``(ẑ[N, p], S[Np, Np], P_xz[n, Np])`` (S with each radar's noise at ``ẑ_n``).
    """
    n_r = radar_pos.shape[0]
    dx = ckf.cubature_offsets(cov)

    def h_all(x):
        return model.predict(radar_pos, x[None, :3])[:, 0, :]  # [N, p]

    ref = h_all(mean)
    dv = jax.vmap(lambda d: model.residual(h_all(mean + d), ref))(dx)  # [2n, N, p]
    m = jnp.mean(dv, axis=0)
    z_hat, dz = ref + m, (dv - m[None]).reshape(dx.shape[0], -1)
    var = jnp.stack([model.variance(z_hat[i], at_radar(noise, i), ccr) for i in range(n_r)])
    w = 1.0 / dx.shape[0]
    S = w * dz.T @ dz + jnp.diag(var.reshape(-1))
    return z_hat, linalg.symmetrize(S), w * dx.T @ dz


def _masked(S, Pxz, det):
    """S with undetected rows/columns the identity, P_xz with those columns zero."""
    both = det[:, None] & det[None, :]
    eye = jnp.eye(S.shape[0], dtype=S.dtype)
    return jnp.where(both, S, eye * ~det[:, None]), jnp.where(det[None, :], Pxz, 0.0)


def tuple_scores(nu, S, Pxz, valid, pd, density, gate, pg, g: int):
    """Each tuple's log ratio and Kalman update of one target.

    Args:
        nu: ``[N, L, p]`` innovations; S: ``[Np, Np]``; Pxz: ``[n, Np]``.
        valid: ``[N, L]``; pd: ``[N]`` (0: radar does not see the target).
        density, gate, pg: λ, γ, P_G; g: candidates per radar (static).

    Returns:
        ``(log r[T], slot[T, N] return index or −1, dx[T, n], dP[T, n, n])`` with
        ``x_τ = x + dx``, ``P_τ = P − dP``; ``T = (g + 1)^N``.
    """
    n_r, n_l, p = nu.shape
    blocks = jnp.stack([S[i * p : (i + 1) * p, i * p : (i + 1) * p] for i in range(n_r)])
    d2 = jnp.einsum(
        "nlp,nlp->nl", nu, jax.vmap(linalg.psd_solve)(blocks, nu.swapaxes(1, 2)).swapaxes(1, 2)
    )
    seen = pd > 0
    pd_ = jnp.where(seen, pd, 1.0)
    lead = jnp.log(pd_) - jnp.log(density) - jnp.log1p(-pd_ * pg)  # [N]
    inside = valid & seen[:, None] & (d2 < gate)
    marg = jnp.where(inside, -0.5 * d2, -jnp.inf)
    top, idx = jax.lax.top_k(marg, g)  # [N, g]
    table = jnp.asarray(association.event_table(n_r, g))  # [T, N] slots, 0: missed
    sel = jnp.maximum(table - 1, 0)
    ok = jnp.where(table > 0, top[jnp.arange(n_r)[None], sel] > -jnp.inf, True)  # [T, N]
    det = table > 0
    slot = jnp.where(det, idx[jnp.arange(n_r)[None], sel], -1)
    nu_t = jnp.where(det[..., None], nu[jnp.arange(n_r)[None], jnp.maximum(slot, 0)], 0.0)

    def one(nu_k, det_k):
        detf = jnp.repeat(det_k, p)
        Sm, Pm = _masked(S, Pxz, detf)
        v = nu_k.reshape(-1)
        K = linalg.psd_solve(Sm, Pm.T).T
        logn = -0.5 * v @ linalg.psd_solve(Sm, v) - 0.5 * linalg.logdet_psd(Sm)
        logn = logn - 0.5 * jnp.sum(detf) * math.log(2.0 * math.pi)
        return logn, K @ v, K @ Sm @ K.T

    logn, dx, dP = jax.vmap(one)(nu_t, det)
    logr = logn + jnp.sum(jnp.where(det, lead[None], 0.0), axis=1)
    logr = jnp.where(jnp.all(ok, axis=1), logr, -jnp.inf).at[0].set(0.0)
    return logr, slot, dx, dP


def event_log_weights(logw, meas):
    """``(log w[E], events[E, M])`` of the ``K^M`` joint events of M targets' options:
    the sum of the chosen options' log weights, −inf where two targets share a return
    (:func:`~mjx_radar.estimation.data_association.association.grid_log_weights`).

    Args:
        logw: ``[M, K]`` log weights of each target's options (−inf: none).
        meas: ``[M, K, N]`` return index of each option per radar (−1: missed).
    """
    m, k = logw.shape

    def clash_of(t, u):  # [K, K]: options of t and u that take one return at some radar
        a, b = meas[t][:, None, :], meas[u][None, :, :]
        return jnp.any((a == b) & (a >= 0), axis=-1)

    ev = jnp.asarray(association.event_table(m, k - 1))  # [E, M]: K options per target
    return association.grid_log_weights(logw, clash_of), ev


def exclusive_marginals(logw, meas):
    """Marginals of M targets' options with exclusive returns per radar (exact, ``K^M`` events).

    Args:
        logw: ``[M, K]`` log weights of each target's options (−inf: none); option 0 of
            every target detects nothing and is finite (so some event always is).
        meas: ``[M, K, N]`` return index of each option per radar (−1: missed).

    Returns:
        ``β[M, K]``, ``Σ_k β = 1`` per target.
    """
    lw, ev = event_log_weights(logw, meas)
    p = jax.nn.softmax(lw)
    return jnp.einsum("e,emk->mk", p, jax.nn.one_hot(ev, logw.shape[1], dtype=p.dtype))


def joint_marginals(logr, slot, k: int):
    """Tuple marginals of M targets with exclusive returns per radar.

    Args:
        logr: ``[M, T]`` log ratios (−inf: not a hypothesis; column 0 all missed, 0).
        slot: ``[M, T, N]`` return index of each tuple per radar (−1: missed).
        k: tuples kept per target (static, ≤ T): the all-missed one and the k − 1 best.

    Returns:
        ``(opt[M, k] tuple indices, β[M, k])``, ``Σ_k β = 1`` per target.
    """
    m = logr.shape[0]
    rest, opt = jax.lax.top_k(logr[:, 1:], k - 1)
    opt = jnp.concatenate([jnp.zeros((m, 1), jnp.int32), opt.astype(jnp.int32) + 1], axis=1)
    lo = jnp.concatenate([jnp.zeros((m, 1), logr.dtype), rest], axis=1)  # [M, k]
    meas = slot[jnp.arange(m)[:, None], opt]  # [M, k, N]
    return opt, exclusive_marginals(lo, meas)


def update_bank(means, covs, zs, valid, radar_pos, model, noise, ccr, pd, density, gate, pg, g, k):
    """Multi-sensor JPDA of every radar's scan at once (the per-target bank).

    Args: as :func:`mjx_radar.estimation.data_association.pda.update_bank`; ``g`` returns per radar
    and
        target in the tuples, ``k`` tuples per target in the joint events (static).

    Returns:
        ``(means[M, 6], covs[M, 6, 6])`` posterior moments.
    """

    def per_target(x, P, pd_t):
        z_hat, S, Pxz = stacked_moments(x, P, radar_pos, model, noise, ccr)
        nu = model.residual(jnp.asarray(zs, x.dtype), z_hat[:, None, :])  # [N, L, p]
        return tuple_scores(nu, S, Pxz, valid, pd_t, density, gate, pg, g)

    logr, slot, dx, dP = jax.vmap(per_target, in_axes=(0, 0, 1))(means, covs, pd)
    opt, beta = joint_marginals(logr, slot, min(k, logr.shape[1]))  # k <= (g + 1)^N
    rows = jnp.arange(means.shape[0])[:, None]
    dx_k, dP_k = dx[rows, opt], dP[rows, opt]  # [M, k, n], [M, k, n, n]
    shift = jnp.einsum("mk,mkn->mn", beta, dx_k)
    dev = dx_k - shift[:, None, :]
    spread = jnp.einsum("mk,mkn,mkl->mnl", beta, dev, dev) - jnp.einsum("mk,mknl->mnl", beta, dP_k)
    return means + shift, jax.vmap(linalg.symmetrize)(covs + spread)
