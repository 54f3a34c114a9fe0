"""Probabilistic data association (PDA) of one target's scan, in the CKF (issue 23).

With false alarms a radar's scan is an unlabelled set of measurements ``z_1..z_L``
(fixed buffer, ``valid`` mask). For one target with predicted measurement ``ẑ``,
innovation covariance ``S``, cross covariance ``P_xz`` and gain ``K = P_xz S⁻¹`` (the
cubature moments of :func:`mjx_radar.estimation.filters.ckf.update`), the PDA filter
(Bar-Shalom, Daum & Huang, "The probabilistic data association filter", IEEE Control
Systems Magazine 29(6), 2009, eqs. 33-47; Bar-Shalom & Li, *Multitarget-Multisensor
Tracking*, 1995, §6.4) is::

    ν_i = z_i − ẑ,   d_i² = ν_iᵀ S⁻¹ ν_i,   validated iff d_i² < γ  (gate P_G)
    e_i = exp(−d_i²/2) (validated, else 0),   b = λ √det(2πS) (1 − P_D P_G) / P_D
    β_i = e_i / (b + Σ_j e_j),   β_0 = b / (b + Σ_j e_j)
    x⁺ = x + K ν,   ν = Σ_i β_i ν_i
    P⁺ = β_0 P + (1 − β_0)(P − K S Kᵀ) + K (Σ_i β_i ν_i ν_iᵀ − ν νᵀ) Kᵀ

with λ the clutter density per unit measurement volume (Poisson clutter, the
parametric PDA). A target seen by N radars is updated radar after radar (sequential
PDA). Pure JAX, static shapes, ``vmap``-able over targets and trials.
"""

from __future__ import annotations

import functools
import math

import jax
import jax.numpy as jnp
import numpy as np

from mjx_radar.estimation import linalg
from mjx_radar.estimation.filters import ckf
from mjx_radar.estimation.sensor.noise import NoiseParams, at_radar

__all__ = [  # noqa: RUF022
    "pda_update",
    "association_weights",
    "innovations",
    "miss_ratio",
    "mixture",
    "miss_inflation",
    "update_bank",
    "irf_table",
    "irf",
    "planner_factor",
]


def association_weights(d2, valid, b, gate):
    """PDA weights ``(β_0, β[L])`` from squared Mahalanobis distances ``d2[L]``.

    Args:
        d2: ``[L]`` ``ν_iᵀ S⁻¹ ν_i``.
        valid: ``[L]`` bool, measurements present in the buffer.
        b: ``[]`` ``λ √det(2πS) (1 − P_D P_G) / P_D`` (> 0).
        gate: ``[]`` γ.
    """
    inside = valid & (d2 < gate)
    e = jnp.where(inside, jnp.exp(-0.5 * jnp.where(inside, d2, 0.0)), 0.0)
    den = b + jnp.sum(e)
    return b / den, e / den


def innovations(mean, cov, z, h, R, residual=None):
    """Cubature moments of one target and its innovations to a scan's measurements.

    Args:
        mean: ``[n]``; cov: ``[n, n]`` predicted moments.
        z: ``[L, p]`` the scan's measurements (buffer).
        h: ``h(x[n]) -> [p]``; R: ``[p, p]`` or ``R(ẑ[p]) -> [p, p]``.
        residual: optional ``(a[p], b[p]) -> a − b`` (angles wrapped).

    Returns:
        ``(K[n, p], S[p, p], ν[L, p], d²[L], log det(2πS))`` with ``ν_i = z_i − ẑ`` and
        ``d_i² = ν_iᵀ S⁻¹ ν_i``.
    """
    mean = jnp.asarray(mean)
    dx = ckf.cubature_offsets(cov)
    w = 1.0 / dx.shape[0]
    ref = h(mean)
    diff = (lambda a, b: a - b) if residual is None else residual
    dv = jax.vmap(diff, in_axes=(0, None))(jax.vmap(h)(mean[None, :] + dx), ref)
    m = jnp.mean(dv, axis=0)
    z_hat, dz = ref + m, dv - m[None, :]
    S = w * dz.T @ dz + (R(z_hat) if callable(R) else R)
    Pxz = w * dx.T @ dz
    K = linalg.psd_solve(S, Pxz.T).T  # [n, p]
    nu = jax.vmap(diff, in_axes=(0, None))(jnp.asarray(z, mean.dtype), z_hat)  # [L, p]
    d2 = jnp.sum(nu * linalg.psd_solve(S, nu.T).T, axis=-1)
    logdet = linalg.logdet_psd(S) + nu.shape[-1] * jnp.log(2.0 * jnp.pi)
    return K, S, nu, d2, logdet


def miss_ratio(pd, density, logdet, pg):
    """``b = λ √det(2πS) (1 − P_D P_G) / P_D`` (floored > 0) and the flag ``P_D > 0``."""
    seen = pd > 0
    pd_ = jnp.where(seen, pd, 1.0)
    b = density * jnp.exp(0.5 * logdet) * (1.0 - pd_ * pg) / pd_
    return jnp.maximum(b, jnp.finfo(jnp.result_type(logdet)).tiny), seen


def mixture(mean, cov, K, S, nu, beta0, beta):
    """The PDA posterior of weights ``β_0 + Σ_i β_i = 1`` (module doc)::

    x⁺ = x + K ν,   P⁺ = β_0 P + (1 − β_0)(P − K S Kᵀ) + K (Σ_i β_i ν_i ν_iᵀ − ν νᵀ) Kᵀ
    """
    nu_c = beta @ nu
    spread = (nu * beta[:, None]).T @ nu - jnp.outer(nu_c, nu_c)
    new_mean = mean + K @ nu_c
    new_cov = cov - (1.0 - beta0) * (K @ S @ K.T) + K @ spread @ K.T
    return new_mean, linalg.symmetrize(new_cov)


def miss_inflation(mean, cov, h, weight, q):
    """``P + q w u uᵀ`` on the position block: a scan in which the target takes none of a
    radar's returns though the radar should see it (``w = P_D β_0``) lets the track's
    position spread by ``q`` [m²] along that radar's line of sight ``u`` (the unit gradient
    of the range ``h(x)[0]`` at ``mean``), so a track that a wrong early return moved off
    a radar's range can take that radar's returns again."""
    grad = jnp.nan_to_num(jax.grad(lambda x: h(x)[0])(mean)[:3])  # 0 at the radar itself
    u = grad / jnp.maximum(jnp.linalg.norm(grad), 1e-12)
    return cov.at[:3, :3].add(q * weight * jnp.outer(u, u))


def pda_update(mean, cov, z, valid, h, R, pd, density, gate, pg, residual=None):
    """PDA measurement update of one target from one radar's scan (covariance form).

    Args:
        mean: ``[n]`` predicted mean; cov: ``[n, n]`` predicted covariance.
        z: ``[L, p]`` the scan's measurements (buffer); valid: ``[L]`` bool.
        h: ``h(x[n]) -> [p]`` the target's noiseless measurement.
        R: ``[p, p]`` noise covariance or callable ``R(ẑ[p]) -> [p, p]``.
        pd: ``[]`` detection probability of the target (> 0; 0 skips the update).
        density: ``[]`` clutter density λ per unit measurement volume.
        gate: ``[]`` γ (chi-square quantile of ``pg`` with p degrees of freedom).
        pg: ``[]`` gate probability P_G.
        residual: optional ``(a[p], b[p]) -> a − b`` (angles wrapped).

    Returns:
        ``(mean[n], cov[n, n])`` and the weights ``(β_0, β[L])``.
    """
    mean = jnp.asarray(mean)
    K, S, nu, d2, logdet = innovations(mean, cov, z, h, R, residual)
    b, seen = miss_ratio(pd, density, logdet, pg)
    beta0, beta = association_weights(d2, valid & seen, b, gate)
    return mixture(mean, cov, K, S, nu, beta0, beta), (beta0, beta)


def radar_model(model, noise, ccr, radar_pos, i):
    """``(h, R)`` of radar ``i``: ``h(x6) -> [dim]`` its noiseless measurement of a target
    state and ``R(ẑ) -> [dim, dim]`` its noise covariance there (the sequential updates'
    per-radar model, shared by PDA and JPDA)."""
    r = radar_pos[i]
    own = at_radar(noise, i)

    def h(x6):
        return model.predict(r[None], x6[None, :3]).reshape(model.dim)

    def R(zh):
        return jnp.diag(model.variance(zh, own, ccr))

    return h, R


def update_bank(means, covs, zs, valid, radar_pos, model, noise, ccr, pd, density, gate, pg):
    """Sequential PDA of every target from every radar's scan (the per-target bank).

    Args:
        means: ``[M, 6]``; covs: ``[M, 6, 6]`` predicted moments.
        zs: ``[N, L, p]`` scans; valid: ``[N, L]`` (:func:`clutter.scan_buffer`).
        radar_pos: ``[N, 3]``.
        model: :class:`~mjx_radar.estimation.sensor.measurement.MeasurementModel` (static).
        noise: :class:`~mjx_radar.estimation.sensor.noise.NoiseParams`; ccr: filter noise flag.
        pd: ``[N, M]`` the filter's detection probability of each pair (0: not seen).
        density, gate, pg: clutter density per unit volume, gate γ, gate probability.

    Returns:
        ``(means[M, 6], covs[M, 6, 6])`` posterior moments.
    """
    n = radar_pos.shape[0]

    def one(x, P, pd_m):
        for i in range(n):  # radar after radar (static N)
            h, R = radar_model(model, noise, ccr, radar_pos, i)
            (x, P), _ = pda_update(
                x, P, zs[i], valid[i], h, R, pd_m[i], density, gate, pg, residual=model.residual
            )
        return x, P

    return jax.vmap(one, in_axes=(0, 0, 1))(means, covs, pd)


# --- the planner's information-reduction factor -----------------------------------------

IRF_PD = np.linspace(0.0, 1.0, 11)  # grid of P_D
IRF_X = np.linspace(-4.0, 1.0, 21)  # grid of x = log10(1e-4 + λ_w)
IRF_SAMPLES = 8000


@functools.cache
def irf_table(dim: int, pg: float, samples: int = IRF_SAMPLES, seed: int = 0) -> np.ndarray:
    """Information-reduction factor ``q(P_D, λ_w)`` of PDA on the grid (host, float64).

    Whitened measurement coordinates (``R = I``): the target's return ``z ~ N(0, I)``
    with probability P_D (kept if inside the gate ``|z|² < γ``), false alarms uniform in
    the gate, their number ``Poisson(λ_w V_γ)`` with ``λ_w = λ √det R`` the clutter
    density per whitened volume. The score of a shift θ of the mean along axis 1 is
    (Niu, Willett & Bar-Shalom 2001; Kershaw & Evans 1994)::

        s = P_D Σ_i z_i1 φ(z_i) / ((1 − P_D P_G) λ_w + P_D Σ_j φ(z_j))

    and ``q = E[s²]``: the expected Fisher information of the scan is ``q · J`` with J
    the information of one clutter-free detected measurement (isotropic in whitened
    coordinates, so one scalar per pair). Monte Carlo with ``samples`` draws per grid
    point (common random numbers across the grid; relative error ~1/√samples).

    Returns:
        ``[len(IRF_PD), len(IRF_X)]`` q, with ``q(P_D, 0) = P_D E[z_1²; |z|² < γ]``.
    """
    from scipy.stats import chi2

    rng = np.random.default_rng(seed)
    gamma = chi2.ppf(pg, dim)
    g = math.sqrt(gamma)
    vol = 2.0 * g if dim == 1 else math.pi * gamma
    lam = 10.0**IRF_X - 1e-4
    cap = int(np.ceil(lam.max() * vol + 8.0 * math.sqrt(lam.max() * vol) + 10))
    zt = rng.normal(size=(samples, dim))
    u_det = rng.uniform(size=samples)
    u_cnt = rng.uniform(size=samples)
    # clutter uniform in the gate: [-g, g] (dim 1) or the disc of radius g (dim 2)
    if dim == 1:
        zc = rng.uniform(-g, g, size=(samples, cap, 1))
    else:
        rad = g * np.sqrt(rng.uniform(size=(samples, cap)))
        ang = rng.uniform(0, 2 * np.pi, size=(samples, cap))
        zc = np.stack([rad * np.cos(ang), rad * np.sin(ang)], -1)
    from scipy.stats import poisson

    phi = lambda z: np.exp(-0.5 * np.sum(z**2, -1)) / (2 * np.pi) ** (dim / 2)  # noqa: E731
    phi_c, phi_t = phi(zc), phi(zt)
    in_gate = np.sum(zt**2, -1) < gamma
    out = np.zeros((IRF_PD.size, IRF_X.size))
    for j, lw in enumerate(lam):
        n_c = poisson.ppf(u_cnt, lw * vol).astype(int).clip(0, cap)
        keep = np.arange(cap)[None, :] < n_c[:, None]
        num_c = np.sum(np.where(keep, zc[..., 0] * phi_c, 0.0), -1)
        den_c = np.sum(np.where(keep, phi_c, 0.0), -1)
        for i, pd in enumerate(IRF_PD):
            hit = (u_det < pd) & in_gate
            num = pd * (num_c + np.where(hit, zt[:, 0] * phi_t, 0.0))
            den = (1 - pd * pg) * lw + pd * (den_c + np.where(hit, phi_t, 0.0))
            s = np.where(den > 0, num / np.where(den > 0, den, 1.0), 0.0)
            out[i, j] = np.mean(s**2)
    return out


def irf(table, pd, lam_w):
    """Bilinear interpolation of :func:`irf_table` at ``pd``, ``λ_w`` (JAX, any shape)."""
    t = jnp.asarray(table, jnp.result_type(pd, float))
    fi = jnp.clip(pd, 0.0, 1.0) * (IRF_PD.size - 1)
    x = jnp.log10(1e-4 + jnp.maximum(lam_w, 0.0))
    fj = jnp.clip((x - IRF_X[0]) / (IRF_X[1] - IRF_X[0]), 0.0, IRF_X.size - 1.0)
    i0 = jnp.clip(jnp.floor(fi).astype(jnp.int32), 0, IRF_PD.size - 2)
    j0 = jnp.clip(jnp.floor(fj).astype(jnp.int32), 0, IRF_X.size - 2)
    a, b = fi - i0, fj - j0
    return (
        (1 - a) * (1 - b) * t[i0, j0]
        + a * (1 - b) * t[i0 + 1, j0]
        + (1 - a) * b * t[i0, j0 + 1]
        + a * b * t[i0 + 1, j0 + 1]
    )


def planner_factor(det, model, params):
    """``factor(pd, d2) -> q`` for :func:`detection.planner_weights` with clutter, else None.

    ``det`` is the ``[detection]`` table, ``model`` the measurement model.

    The whitened clutter density of a pair at squared range ``d2`` is
    ``λ_w = λ √det R(d)`` with R the filter's noise at that range (DDR or CCR, the
    method's flag), so clutter costs more information where the noise is larger.
    """
    if not det.clutter:
        return None
    from mjx_radar.estimation.sensor import clutter

    table = irf_table(model.dim, float(det.gate_probability))
    lam = clutter.density(params.detection, model.dim)
    # a mixed fleet's [N] constants broadcast over the pairs' [..., N, K, dim]
    noise = NoiseParams(*(a if jnp.ndim(a) == 0 else a[:, None, None] for a in params.noise))

    def factor(pd, d2):
        z_hat = (2.0 * jnp.sqrt(d2))[..., None]
        if model.dim == 2:
            z_hat = jnp.concatenate([z_hat, jnp.zeros_like(z_hat)], -1)
        var = model.variance(z_hat, noise, params.method.ccr)  # [..., dim]
        return irf(table, pd, lam * jnp.sqrt(jnp.prod(var, -1)))

    return factor
