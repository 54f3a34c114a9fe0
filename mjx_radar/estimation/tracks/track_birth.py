"""Birth of tentative tracks from returns no track explains (issue 35, docs/track_management.md).

Each radar's scan is an unlabelled buffer ``zs [N, L, dim]`` with a ``free [N, L]`` mask
(valid and outside every live track's gate). Births, at most B per scan:

1. **Seeds.** Range-only: every triple of radars and every choice of one free return
   from each (``C = C(N, 3) L³`` candidates) is trilaterated
   (:func:`~mjx_radar.estimation.tracks.multilateration.trilaterate`, the solution above the
   radars). Range-azimuth: every free return of every radar is a point at the
   height prior ``h₀`` (``C = N L``).
2. **Fit.** Gauss-Newton on the seed's returns gives ``x_s, P_s``; every other radar's
   free return nearest in Mahalanobis distance ``d² = νᵀ (R + H P_s Hᵀ)⁻¹ ν`` joins
   when ``d² < γ`` (the scan's gate); Gauss-Newton on all joined returns gives the
   birth position ``x``, its covariance ``P = Λ⁻¹`` and ``χ²``.
   With ``shared = s > 0`` (``[tracker] birth_shared``) the seeds and the joins take
   every valid return, and a candidate may hold at most s returns a live track already
   claims: a drone one of whose returns a ghost holds can still be born (then the joint
   association shares the return between the two).
3. **Select.** Candidates with returns from at least ``birth_radars`` radars, and not
   within ``(x − m_k)ᵀ (P + P_k)⁻¹ (x − m_k) < 16.27`` (χ²₃ at 0.999) of a live
   track k, are ranked by that count, then by ``χ²``; greedily the best is born and
   every candidate sharing one of its returns is dropped (each return starts at most
   one track).

A birth's state is ``[x, 0]`` with covariance ``diag(P, σ_v² I₃)`` (velocity unknown:
zero mean, a wide prior ``σ_v = speed_std``). With N range-only radars on the ground a
seed of three returns of *different* drones can be a consistent point (a ghost); a
fourth radar rejects most, and the M-of-N confirmation the rest.
"""

from __future__ import annotations

import itertools
from typing import NamedTuple

import jax
import jax.numpy as jnp

from mjx_radar.estimation import linalg
from mjx_radar.estimation.sensor.noise import at_radar
from mjx_radar.estimation.tracks import multilateration

__all__ = ["BirthSettings", "scan_variances", "seeds", "fit_seeds", "births", "AVOID_D2"]

AVOID_D2 = 16.27  # χ²₃ quantile 0.999: a candidate this close to a live track is that track


class BirthSettings(NamedTuple):
    """Static birth settings (module docstring)."""

    max_births: int = 2
    birth_radars: int = 4
    height: float = 60.0  # h₀ [m]
    height_std: float = 100.0  # σ_h [m]
    speed_std: float = 30.0  # σ_v [m/s]
    shared: int = 0  # returns of a birth that live tracks already claim, at most


def scan_variances(model, zs, noise, ccr):
    """``[N, L, dim]`` noise variances of every return (the model's at the measured value)."""
    n = zs.shape[0]
    return jnp.stack([model.variance(zs[i], at_radar(noise, i), ccr) for i in range(n)])


def seeds(model, zs, free, radar_pos, height):
    """``(x0 [C, 3], idx [C, N], ok [C])``: seed points and their returns (−1: none)."""
    n, ell = zs.shape[:2]
    if model.dim == 1:
        triples = list(itertools.combinations(range(n), 3))
        picks = jnp.asarray(list(itertools.product(range(ell), repeat=3)), jnp.int32)  # [L³, 3]
        xs, idxs, oks = [], [], []
        for tri in triples:
            t = jnp.asarray(tri)
            r = zs[t[None, :], picks, 0] / 2.0  # [L³, 3] one-way ranges
            x, ok = jax.vmap(multilateration.trilaterate, (None, 0))(radar_pos[t], r)
            ok = ok & jnp.all(free[t[None, :], picks], axis=1)
            idx = jnp.full((picks.shape[0], n), -1, jnp.int32).at[:, t].set(picks)
            xs, idxs, oks = xs + [x], idxs + [idx], oks + [ok]
        return jnp.concatenate(xs), jnp.concatenate(idxs), jnp.concatenate(oks)
    # range-azimuth: one return, at the height prior
    rad = jnp.repeat(jnp.arange(n), ell)
    ret = jnp.tile(jnp.arange(ell), n)
    z = zs[rad, ret]  # [N L, dim]
    x = jax.vmap(multilateration.polar_point, (0, 0, 0, None))(
        radar_pos[rad], z[:, 0] / 2.0, z[:, 1], height
    )
    idx = jnp.full((n * ell, n), -1, jnp.int32).at[jnp.arange(n * ell), rad].set(ret)
    return x, idx, free[rad, ret]


def _fit(model, x0, idx, zs, r_var, free, radar_pos, gate, s: BirthSettings):
    """One candidate: fit its seed, join the other radars' nearest returns, refit."""
    n = zs.shape[0]
    rows = jnp.arange(n)
    sh2 = s.height_std**2
    use = idx >= 0
    pick = jnp.maximum(idx, 0)
    x_s, p_s, _ = multilateration.gauss_newton(
        model, x0, radar_pos, zs[rows, pick], r_var[rows, pick], use, s.height, sh2
    )

    def pred(x, p):
        return model.predict(p[None], x[None]).reshape(model.dim)

    zh = jax.vmap(pred, (None, 0))(x_s, radar_pos)  # [N, dim]
    hj = jax.vmap(jax.jacfwd(pred), (None, 0))(x_s, radar_pos)  # [N, dim, 3]
    spread = jnp.einsum("nda,ab,neb->nde", hj, p_s, hj)  # [N, dim, dim]
    nu = jax.vmap(jax.vmap(model.residual, (0, None)))(zs, zh)  # [N, L, dim]
    cov = spread[:, None] + jax.vmap(jax.vmap(jnp.diag))(r_var)  # [N, L, dim, dim]
    d2 = jnp.sum(nu * linalg.psd_solve(cov, nu), -1)  # [N, L]
    d2 = jnp.where(free, d2, jnp.inf)
    best = jnp.argmin(d2, axis=1).astype(jnp.int32)
    joined = jnp.where(use, idx, jnp.where(d2[rows, best] < gate, best, -1))
    take = joined >= 0
    pick = jnp.maximum(joined, 0)
    x, p, chi2 = multilateration.gauss_newton(
        model, x_s, radar_pos, zs[rows, pick], r_var[rows, pick], take, s.height, sh2
    )
    return x, p, chi2, joined


def fit_seeds(model, zs, free, r_var, radar_pos, gate, s: BirthSettings, avoid=None, valid=None):
    """Every seed fitted and screened (steps 1-2 and the screen of step 3).

    Args: as :func:`births`.

    Returns:
        ``(x [C, 3], P [C, 3, 3], chi2 [C], joined [C, N], good [C], score [C])``:
        the fits, their returns (−1: none), whether each is a birth candidate (returns
        from ``birth_radars`` radars, finite, away from every live track) and its rank
        ``1e4 · count − min(χ², 9e3)``.
    """
    if s.shared and valid is None:
        raise ValueError("births with shared returns need the valid returns (valid=)")
    pool = valid if s.shared else free  # the returns seeds and joins may take
    x0, idx, ok = seeds(model, zs, pool, radar_pos, s.height)
    fit = jax.vmap(_fit, (None, 0, 0, None, None, None, None, None, None))
    x, p, chi2, joined = fit(model, x0, idx, zs, r_var, pool, radar_pos, gate, s)
    count = jnp.sum(joined >= 0, axis=1)
    good = ok & (count >= s.birth_radars) & jnp.all(jnp.isfinite(x), -1)
    if s.shared:  # at most s.shared of its returns claimed by a live track
        held = (joined >= 0) & ~free[jnp.arange(zs.shape[0])[None, :], jnp.maximum(joined, 0)]
        good = good & (jnp.sum(held, axis=1) <= s.shared)
    if avoid is not None:
        pos, pc, on = avoid
        dv = x[:, None, :] - pos[None]  # [C, K, 3]
        d2 = jnp.sum(dv * linalg.psd_solve(p[:, None] + pc[None], dv), -1)
        good = good & ~jnp.any(on[None, :] & (d2 < AVOID_D2), axis=1)
    score = count * 1e4 - jnp.minimum(chi2, 9e3)
    return x, p, chi2, joined, good, score


def births(model, zs, free, r_var, radar_pos, gate, s: BirthSettings, avoid=None, valid=None):
    """Up to ``s.max_births`` new tracks from the free returns (module docstring).

    Args:
        model: the measurement model (static); zs: ``[N, L, dim]`` scans.
        free: ``[N, L]`` bool returns valid and explained by no live track.
        r_var: ``[N, L, dim]`` their noise variances (:func:`scan_variances`).
        radar_pos: ``[N, 3]``; gate: γ of the scan's gate (chi-square, ``dim`` dof).
        s: :class:`BirthSettings`.
        avoid: optional ``(pos [K, 3], cov [K, 3, 3], live [K])`` the live tracks.
        valid: ``[N, L]`` bool the valid returns (needed with ``s.shared > 0``).

    Returns:
        ``(mean [B, 6], cov [B, 6, 6], ok [B])`` the births in order of rank.
    """
    args = (model, zs, free, r_var, radar_pos, gate, s, avoid, valid)
    x, p, _, joined, good, score = fit_seeds(*args)
    n, ell = free.shape
    rows = jnp.arange(n)
    dtype = x.dtype
    vel = jnp.eye(3, dtype=dtype) * s.speed_std**2
    means, covs, oks = [], [], []
    for _ in range(s.max_births):  # greedy: best candidate, then drop its rivals
        c = jnp.argmax(jnp.where(good, score, -jnp.inf))
        take = good[c]
        mine = joined[c]
        used = jnp.zeros((n, ell), bool).at[rows, jnp.maximum(mine, 0)].set(mine >= 0) & take
        clash = jnp.any((joined >= 0) & used[rows[None, :], jnp.maximum(joined, 0)], axis=1)
        good = good & ~clash
        means.append(jnp.concatenate([x[c], jnp.zeros(3, dtype)]))
        cov = jnp.zeros((6, 6), dtype).at[:3, :3].set(linalg.symmetrize(p[c]))
        covs.append(cov.at[3:, 3:].set(vel))
        oks.append(take)
    return jnp.stack(means), jnp.stack(covs), jnp.stack(oks)
