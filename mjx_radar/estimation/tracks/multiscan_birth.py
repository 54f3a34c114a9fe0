"""Multi-scan births: a seed becomes a track only if it moves like a CV point over S scans.

``[tracker] birth_scans = S > 1`` (docs/track_management.md "Multi-scan births"). The
one-scan births of :mod:`~mjx_radar.estimation.tracks.track_birth` turn the best fitted seed
of a scan into a tentative track; with range-only radars three or four returns of
*different* drones can fit one point (a ghost), and a ghost born first claims the
drone's returns. Here the scan's screened seed fits (``x_j [C, 3]``, ``P_j``, their
returns and residual ``χ²_j``, :func:`~mjx_radar.estimation.tracks.track_birth.fit_seeds`)
feed a fixed table of Kc **candidates** (:class:`Candidates`), each a constant-velocity
least-squares fit of the seeds it collected on consecutive scans (the multiple-scan
initiation of Blackman & Popoli 1999, §3.4, with the velocity gate of two- and
three-point initiation). Per scan:

1. **predict** each candidate ``m ← F m``, ``P ← F P Fᵀ`` (no process noise: over S
   scans of 25 ms the fit is the least-squares line through the seeds, tested against
   numpy in tests/test_multiscan_birth.py);
2. **associate**: each candidate takes the seed minimising ``d² + χ²_j`` among those
   inside its gate ``d² = (x_j − H m)ᵀ (P_j + H P Hᵀ)⁻¹ (x_j − H m) < γ_cv`` (χ²₃ at
   0.999); returns may be shared between candidates (a ghost and the drone it borrows
   from both grow); two candidates on seeds with the same returns merge into the
   older (then lower χ²);
3. **update**: the Kalman update with the position ``x_j``, ``R = P_j``; the candidate
   dies unless its accumulated ``χ² = Σ χ²_j + Σ d²`` stays below the 0.999 quantile of
   its degrees of freedom (Wilson–Hilferty), or when no seed falls in its gate;
4. **promote**: candidates of age ``S`` away from every live track are born (at most
   ``max_births``, lowest ``χ²/dof`` first; a promoted candidate's rivals of age S
   sharing one of its returns are dropped), with the fitted ``[x, v]`` and its
   covariance;
5. **seed** empty slots with seeds no candidate holds (not within ``AVOID_D2`` of one,
   χ²_j below its 0.999 quantile): at most ``new_per_scan`` disjoint seeds (no shared
   return) chosen by a pilot greedy packing (:func:`_pack`: the most seeds, then the
   least χ²), state ``[x_j, 0]``, covariance ``diag(P_j, σ_v² I)``.

A ghost made of different drones' returns keeps fitting only as long as every range
it borrows stays consistent with one CV point, and its misfit adds up over the scans
while the drone's noise averages; the packing prefers the drones' disjoint seeds to
the ghost that borrows one return from each (docs/track_management.md: what the CV
gate can and cannot tell apart at 25 ms scans).
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp

from mjx_radar.estimation import linalg
from mjx_radar.estimation.tracks.track_birth import AVOID_D2

__all__ = ["Candidates", "MultiScanSettings", "empty", "cv_update", "chi2_bound", "step"]

CV_GATE = 16.27  # χ²₃ quantile 0.999: a seed this close to a candidate's prediction
Z999 = 3.0902  # standard normal quantile 0.999


class Candidates(NamedTuple):
    """Kc birth candidates (a pytree; leading axis Kc; vmaps over trials).

    Attributes:
        mean: ``[Kc, 6]`` CV fit ``[x, v]`` at the current scan.
        cov: ``[Kc, 6, 6]`` its covariance (``p_empty I`` in empty slots).
        age: ``[Kc]`` int32 consecutive scans fitted (0: empty slot).
        chi2: ``[Kc]`` accumulated χ² (seed residuals and CV innovations).
        dof: ``[Kc]`` its degrees of freedom.
        joined: ``[Kc, N]`` int32 the returns of the last scan (−1: none).
    """

    mean: jax.Array
    cov: jax.Array
    age: jax.Array
    chi2: jax.Array
    dof: jax.Array
    joined: jax.Array


class MultiScanSettings(NamedTuple):
    """Static settings of the multi-scan births (module docstring)."""

    scans: int = 3  # S
    capacity: int = 16  # Kc
    new_per_scan: int = 4
    gate: float = CV_GATE
    max_births: int = 2
    speed_std: float = 30.0  # σ_v [m/s] of a new candidate's velocity
    dim: int = 1  # measurement dimension: a seed of n returns has n·dim − 3 dof
    starts: int = 16  # first seeds tried by the packing


def empty(capacity: int, n_radars: int, dtype=jnp.float32, p_empty: float = 1.0) -> Candidates:
    """``capacity`` empty candidate slots."""
    z = jnp.zeros(capacity, jnp.int32)
    return Candidates(
        mean=jnp.zeros((capacity, 6), dtype),
        cov=jnp.broadcast_to(p_empty * jnp.eye(6, dtype=dtype), (capacity, 6, 6)),
        age=z,
        chi2=jnp.zeros(capacity, dtype),
        dof=jnp.zeros(capacity, dtype),
        joined=jnp.full((capacity, n_radars), -1, jnp.int32),
    )


def cv_update(mean, cov, x, r):
    """The Kalman update of a CV state with a position measurement.

    ``S = H P Hᵀ + R``, ``K = P Hᵀ S⁻¹``, ``m ← m + K ν``, ``P ← P − K S Kᵀ`` with
    ``H = [I₃ 0]``, ``ν = x − H m``.

    Args:
        mean: ``[6]``; cov: ``[6, 6]``; x: ``[3]`` the position; r: ``[3, 3]`` its covariance.

    Returns:
        ``(mean [6], cov [6, 6], d2 [])`` with ``d² = νᵀ S⁻¹ ν``.
    """
    s = linalg.symmetrize(cov[:3, :3] + r)
    nu = x - mean[:3]
    gain = linalg.psd_solve(s, cov[:3, :]).T  # [6, 3] = P Hᵀ S⁻¹
    mean = mean + gain @ nu
    cov = linalg.symmetrize(cov - gain @ s @ gain.T)
    return mean, cov, nu @ linalg.psd_solve(s, nu)


def chi2_bound(dof, z: float = Z999):
    """Wilson–Hilferty chi-square quantile ``k (1 − 2/(9k) + z √(2/(9k)))³`` (``+∞`` for k ≤ 0)."""
    k = jnp.maximum(dof, 1e-9)
    q = k * (1.0 - 2.0 / (9.0 * k) + z * jnp.sqrt(2.0 / (9.0 * k))) ** 3
    return jnp.where(dof > 0, q, jnp.inf)


def _before(age, chi2, dof):
    """``[Kc, Kc]`` bool: candidate a ranks before b (older, then lower χ²/dof, then slot)."""
    kc = age.shape[0]
    r = chi2 / jnp.maximum(dof, 1.0)
    idx = jnp.arange(kc)
    older = age[:, None] > age[None, :]
    same = age[:, None] == age[None, :]
    better = (r[:, None] < r[None, :]) | ((r[:, None] == r[None, :]) & (idx[:, None] < idx[None]))
    return older | (same & better)


def _shares(a, b):
    """``[...]`` bool: the return sets ``a [..., N]`` and ``b [..., N]`` share a return."""
    return jnp.any((a == b) & (a >= 0), axis=-1)


def _associate(cands: Candidates, fits, f6, s: MultiScanSettings):
    """Steps 1-3: predict, take the best gated seed, update, merge duplicates."""
    x, p, chi2, joined, good, _ = fits
    on = cands.age > 0
    m = cands.mean @ f6.T
    cov = jnp.einsum("ij,kjl,ml->kim", f6, cands.cov, f6)
    dv = x[None] - m[:, None, :3]  # [Kc, C, 3]
    d2 = jnp.sum(dv * linalg.psd_solve(p[None] + cov[:, None, :3, :3], dv), -1)  # [Kc, C]
    cost = jnp.where(good[None] & on[:, None] & (d2 < s.gate), d2 + chi2[None], jnp.inf)
    j = jnp.argmin(cost, axis=1)
    kc = cost.shape[0]
    matched = jnp.isfinite(cost[jnp.arange(kc), j])
    m, cov, dj = jax.vmap(cv_update)(m, cov, x[j], p[j])
    count = jnp.sum(joined[j] >= 0, axis=1)
    tot = cands.chi2 + dj + chi2[j]
    dof = cands.dof + 3.0 + jnp.maximum(count * s.dim - 3, 0)
    matched = matched & (tot < chi2_bound(dof)) & jnp.all(jnp.isfinite(m), -1)
    jj = joined[j]
    same = jnp.all(jj[:, None] == jj[None], -1) & matched[:, None] & matched[None]
    worse = same & _before(cands.age, tot, dof).T  # b before a on the same returns
    matched = matched & ~jnp.any(worse & ~jnp.eye(kc, dtype=bool), axis=1)
    age = jnp.where(matched, cands.age + 1, 0)
    return Candidates(m, cov, age, jnp.where(matched, tot, 0.0), jnp.where(matched, dof, 0.0), jj)


def _promote(c: Candidates, s: MultiScanSettings, avoid):
    """Step 4: ``(births (mean [B, 6], cov [B, 6, 6], ok [B]), candidates left)``."""
    ready = c.age >= s.scans
    if avoid is not None:
        pos, pc, on = avoid
        dv = c.mean[:, None, :3] - pos[None]  # [Kc, K, 3]
        d2 = jnp.sum(dv * linalg.psd_solve(c.cov[:, None, :3, :3] + pc[None], dv), -1)
        near = jnp.any(on[None, :] & (d2 < AVOID_D2), axis=1)
        ready = ready & ~near
    else:
        near = jnp.zeros_like(ready)
    rank = c.chi2 / jnp.maximum(c.dof, 1.0)
    keep = (c.age > 0) & ~near  # a candidate on a live track is that track
    idx, oks = [], []
    for _ in range(s.max_births):  # greedy: best ready candidate, then drop its rivals
        b = jnp.argmin(jnp.where(ready, rank, jnp.inf))
        take = ready[b]
        rival = _shares(c.joined, c.joined[b][None]) & (c.age >= s.scans) & take
        ready, keep = ready & ~rival, keep & ~rival
        idx.append(b)
        oks.append(take)
    b = jnp.stack(idx)
    c = c._replace(age=jnp.where(keep, c.age, 0))
    return (c.mean[b], c.cov[b], jnp.stack(oks)), c


def _greedy(good, score, joined, first, picks: int):
    """Seeds picked greedily from ``first`` on, each sharing no return with the earlier."""
    sel, oks = [], []
    j = first
    for t in range(picks):
        if t:
            j = jnp.argmax(jnp.where(good, score, -jnp.inf))
        take = good[j]
        good = good & ~(_shares(joined, joined[j][None]) & take)
        sel.append(j)
        oks.append(take)
    return jnp.stack(sel), jnp.stack(oks)


def _pack(good, score, chi2, joined, s: MultiScanSettings):
    """``(j [P], ok [P])``: disjoint seeds explaining the most returns (pilot greedy).

    The greedy packing is run from each of the ``s.starts`` best seeds; the run with the
    most seeds (then the lowest total χ²) wins: a ghost borrowing one return of each of
    several drones leaves their other returns unable to form seeds, so the packing of
    the true drones holds more seeds (the S-D assignment of multi-sensor initiation).
    """
    starts = jax.lax.top_k(jnp.where(good, score, -jnp.inf), min(s.starts, good.shape[0]))[1]
    sel, ok = jax.vmap(lambda f: _greedy(good, score, joined, f, s.new_per_scan))(starts)
    value = jnp.sum(ok, 1) * 1e6 - jnp.sum(jnp.where(ok, jnp.minimum(chi2[sel], 9e3), 0.0), 1)
    best = jnp.argmax(value)
    return sel[best], ok[best]


def _taken(c: Candidates, fits):
    """``[C]`` bool: seeds within ``AVOID_D2`` of a live candidate (the same point)."""
    x, p = fits[:2]
    dv = x[None] - c.mean[:, None, :3]  # [Kc, C, 3]
    d2 = jnp.sum(dv * linalg.psd_solve(p[None] + c.cov[:, None, :3, :3], dv), -1)
    return jnp.any((c.age > 0)[:, None] & (d2 < AVOID_D2), axis=0)


def _seed(c: Candidates, fits, taken, s: MultiScanSettings, p_empty):
    """Step 5: the best seeds not ``taken [C]`` into the empty slots."""
    x, p, chi2, joined, good, score = fits
    on = c.age > 0
    good = good & ~taken
    count = jnp.sum(joined >= 0, axis=1)
    good = good & (chi2 < chi2_bound(jnp.maximum(count * s.dim - 3, 0).astype(chi2.dtype)))
    j, ok = _pack(good, score, chi2, joined, s)
    free = ~on
    slot_rank = jnp.cumsum(free) - 1
    new_rank = jnp.cumsum(ok) - 1
    match = free[:, None] & ok[None, :] & (slot_rank[:, None] == new_rank[None, :])  # [Kc, B]
    take = jnp.any(match, axis=1)
    pick = j[jnp.argmax(match, axis=1)]
    dtype = c.mean.dtype
    vel = jnp.eye(3, dtype=dtype) * s.speed_std**2
    cov = jnp.zeros((c.age.shape[0], 6, 6), dtype).at[:, :3, :3].set(linalg.symmetrize(p[pick]))
    cov = cov.at[:, 3:, 3:].set(vel)
    mean = jnp.concatenate([x[pick], jnp.zeros_like(x[pick])], -1)
    count = jnp.sum(joined[pick] >= 0, axis=1)
    eye = p_empty * jnp.eye(6, dtype=dtype)
    return Candidates(
        mean=jnp.where(take[:, None], mean, jnp.where(on[:, None], c.mean, 0.0)),
        cov=jnp.where(take[:, None, None], cov, jnp.where(on[:, None, None], c.cov, eye)),
        age=jnp.where(take, 1, c.age),
        chi2=jnp.where(take, chi2[pick], jnp.where(on, c.chi2, 0.0)),
        dof=jnp.where(
            take, jnp.maximum(count * s.dim - 3, 0).astype(dtype), jnp.where(on, c.dof, 0.0)
        ),
        joined=jnp.where(take[:, None], joined[pick], jnp.where(on[:, None], c.joined, -1)),
    )


def step(cands: Candidates, fits, f6, s: MultiScanSettings, avoid=None, p_empty: float = 1.0):
    """One scan of the candidate table (module docstring).

    Args:
        cands: the table; fits: :func:`~mjx_radar.estimation.tracks.track_birth.fit_seeds`'s
            ``(x [C, 3], P [C, 3, 3], chi2 [C], joined [C, N], good [C], score [C])``.
        f6: ``[6, 6]`` the CV transition of one scan; s: :class:`MultiScanSettings`.
        avoid: optional ``(pos [K, 3], cov [K, 3, 3], live [K])`` the live tracks.
        p_empty: the covariance scale of empty slots.

    Returns:
        ``((mean [B, 6], cov [B, 6, 6], ok [B]), cands)``: the births, the table.
    """
    f6 = f6.astype(cands.mean.dtype)
    cands = _associate(cands, fits, f6, s)
    taken = _taken(cands, fits)  # before promotion: a born candidate's seed is no new one
    born, cands = _promote(cands, s, avoid)
    return born, _seed(cands, fits, taken, s, p_empty)
