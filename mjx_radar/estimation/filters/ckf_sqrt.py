"""Square-root cubature Kalman filter (SCKF; Arasaratnam & Haykin 2009, §VI; issue 26).

The SCKF propagates a square-root factor ``S`` of the covariance, ``P = S Sᵀ``
(``S`` lower triangular, positive diagonal), instead of P itself. ``Tria(A)`` of a
compound matrix ``A[n, k]`` (k >= n) is the lower-triangular ``S[n, n]`` with
``S Sᵀ = A Aᵀ``, computed from the R factor of the QR decomposition of ``Aᵀ``
(``Aᵀ = Q R`` ⇒ ``A Aᵀ = Rᵀ R``, so ``S = Rᵀ`` with its column signs fixed so
that ``diag(S) > 0``). Weighted, centred cubature matrices (2n points, weight
``1/(2n)``, ``w = 1/√(2n)``)::

    X_i = x̂ ± √n·S_i (offsets ξ_i),  𝒳 = w [ξ_1 … ξ_2n]                  [n, 2n]

Predict (``f`` one state vector → one; ``S_Q S_Qᵀ = Q``, S_Q may be ``[n, q]``)::

    X_i' = f(X_i),  x̂⁻ = mean X_i',  𝒳* = w [X_i' − x̂⁻]_i,  S⁻ = Tria([𝒳*, S_Q]).

Update (points from (x̂⁻, S⁻); ``S_R S_Rᵀ = R``)::

    Z_i = h(X_i),  ẑ = mean Z_i,  𝒵 = w [Z_i − ẑ]_i                       [p, 2n]
    S_zz = Tria([𝒵, S_R]),  P_xz = 𝒳 𝒵ᵀ,  K = (P_xz / S_zzᵀ) / S_zz,
    x̂⁺ = x̂ + K (z − ẑ),  S⁺ = Tria([𝒳 − K 𝒵, K S_R]).

In exact arithmetic this is the covariance-form CKF of :mod:`mjx_radar.estimation.filters.ckf`:
``S⁻S⁻ᵀ = 𝒳*𝒳*ᵀ + Q``, ``S_zz S_zzᵀ = Pzz``, and
``(𝒳 − K𝒵)(𝒳 − K𝒵)ᵀ + K R Kᵀ = P − K Pxzᵀ − Pxz Kᵀ + K Pzz Kᵀ = P − K Pzz Kᵀ``.
``P`` is never formed or subtracted, so ``S Sᵀ`` is PSD by construction and the
factor's condition number is the square root of P's (float32 keeps ~7 digits of
S, i.e. ~14 of P's dynamic range).

Everything else follows :func:`mjx_radar.estimation.filters.ckf.update`: ``R`` may be a
callable ``R(ẑ)`` (DDR noise), ``residual`` wraps angle differences (deviations
about ``h(x̂)``), and ``mask[p]`` drops measurements exactly: their rows of 𝒵 and
innovations are zeroed and their rows/columns of R replaced by the identity, so
``S_zz`` (= chol of the masked Pzz) has a unit row/column there, the gain column
vanishes and the update equals the update with those measurements removed. R is
factored with :func:`mjx_radar.estimation.linalg.psd_cholesky` (relative jitter
≈1e-6 in float32, 2e-15 in float64, as the covariance form's Pzz solve).

Matmuls use ``Precision.HIGHEST`` (the GPU default TF32 breaks filters). The
closed loop carries ``S`` in place of ``P`` (same ``[6M, 6M]`` shape, see
docs/filters.md); :func:`covariance` gives ``P = S Sᵀ`` to its consumers.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import NamedTuple

import jax
import jax.numpy as jnp
from jax.scipy.linalg import solve_triangular

from mjx_radar.estimation import linalg
from mjx_radar.estimation.filters import ckf

__all__ = ["tria", "covariance", "factor", "psd_factor", "predict", "update", "Form", "form_ops"]

_HI = jax.lax.Precision.HIGHEST
_mm = functools.partial(jnp.matmul, precision=_HI)


def tria(A):
    """Triangularisation: lower-triangular ``S`` with ``S Sᵀ = A Aᵀ``.

    Args:
        A: ``[n, k]`` compound matrix, ``k >= n``.

    Returns:
        ``[n, n]`` lower triangular with a non-negative diagonal (positive when A
        has full row rank): ``Rᵀ`` of ``qr(Aᵀ)`` with the column signs fixed.
    """
    if A.shape[-1] < A.shape[-2]:
        raise ValueError(f"tria needs A[n, k] with k >= n, got {A.shape}")
    S = jnp.linalg.qr(A.T, mode="r").T
    sign = jnp.where(jnp.diagonal(S) < 0, -1.0, 1.0).astype(S.dtype)
    return S * sign[None, :]


def covariance(S):
    """``P = S Sᵀ`` (symmetrised), ``S[..., n, k] -> [..., n, n]``."""
    P = _mm(S, jnp.swapaxes(S, -1, -2))
    return linalg.symmetrize(P)


def factor(P):
    """Lower Cholesky factor of a covariance (``linalg.psd_cholesky``): ``[n, n] -> [n, n]``."""
    return linalg.psd_cholesky(P)


def psd_factor(A):
    """A square factor ``F`` with ``F Fᵀ = A`` of a possibly singular PSD matrix.

    For a rank-deficient process noise (the CV model's ``W = G Σ Gᵀ`` has rank 3
    per target) a Cholesky factor needs jitter; the eigen-factor
    ``F = V diag(√max(λ, 0))`` is exact to round-off. Use it once per run (eigh),
    not per step.

    Args:
        A: ``[n, n]`` symmetric PSD.

    Returns:
        ``[n, n]`` factor (not triangular).
    """
    lam, V = jnp.linalg.eigh(linalg.symmetrize(A))
    return V * jnp.sqrt(jnp.maximum(lam, 0.0))[None, :]


class Form(NamedTuple):
    """What a filter loop needs of a form; the carried matrix ``C`` is P or S.

    Attributes:
        predict: ``(mean, C, f, q) -> (mean, C)``, ``q`` from :attr:`noise`.
        update: ``(mean, C, z, h, R, mask=None, residual=None) -> (mean, C)``.
        carry: ``P -> C`` (initial covariance to carried matrix).
        cov: ``C -> P``.
        noise: ``Q -> q`` (process noise as :attr:`predict` takes it; call once per run).
    """

    predict: Callable
    update: Callable
    carry: Callable
    cov: Callable
    noise: Callable


def form_ops(form: str) -> Form:
    """The :class:`Form` of ``filter.form``: "covariance" (:mod:`ckf`) or "sqrt" (this module)."""
    if form == "sqrt":
        return Form(predict, update, factor, covariance, psd_factor)
    if form == "covariance":
        ident = lambda a: a  # noqa: E731
        return Form(ckf.predict, ckf.update, ident, ident, ident)
    raise ValueError(f"filter form must be 'covariance' or 'sqrt', got {form!r}")


def _offsets(S):
    """``[2n, n]`` cubature offsets ``±√n·S_i`` (rows) of a factor ``S[n, n]``."""
    n = S.shape[-1]
    u = jnp.sqrt(jnp.asarray(n, S.dtype)) * S.T
    return jnp.concatenate([u, -u], axis=0)


def _moments(values, ref):
    """Mean and centred deviations of ``values[2n, k]`` computed about ``ref[k]``."""
    dv = values - ref[None, :]
    m = jnp.mean(dv, axis=0)
    return ref + m, dv - m[None, :]


def predict(mean, S, f, sqrt_Q):
    """SCKF time update.

    Args:
        mean: ``[n]`` posterior mean.
        S: ``[n, n]`` lower-triangular factor of the posterior covariance.
        f: transition ``f(x[n]) -> [n]`` of one state vector.
        sqrt_Q: ``[n, q]`` factor of the process noise, ``sqrt_Q sqrt_Qᵀ = Q``
            (e.g. :func:`psd_factor` of Q).

    Returns:
        ``(mean[n], S[n, n])``: predicted mean and ``S⁻ = Tria([𝒳*, S_Q])``.
    """
    mean = jnp.asarray(mean)
    S = jnp.asarray(S, mean.dtype)
    xp = jax.vmap(f)(mean[None, :] + _offsets(S))
    m, dx = _moments(xp, f(mean))
    w = jax.lax.rsqrt(jnp.asarray(dx.shape[0], mean.dtype))
    comp = jnp.concatenate([w * dx.T, jnp.asarray(sqrt_Q, mean.dtype)], axis=1)
    return m, tria(comp)


def update(mean, S, z, h, R, mask=None, residual=None):
    """SCKF measurement update (same arguments as :func:`ckf.update`, with S for P).

    Args:
        mean: ``[n]`` predicted mean.
        S: ``[n, n]`` lower-triangular factor of the predicted covariance.
        z: ``[p]`` measurement.
        h: measurement function ``h(x[n]) -> [p]`` of one state vector.
        R: ``[p, p]`` noise covariance, or a callable ``R(z_hat[p]) -> [p, p]``.
        mask: optional ``[p]`` bool, True where the measurement is used (default all).
        residual: optional ``residual(a[p], b[p]) -> [p]`` (angles wrapped).

    Returns:
        ``(mean[n], S[n, n])``: posterior mean and ``S⁺ = Tria([𝒳 − K𝒵, K S_R])``.
    """
    mean = jnp.asarray(mean)
    S = jnp.asarray(S, mean.dtype)
    dx = _offsets(S)  # centred exactly (± pairs)
    zs = jax.vmap(h)(mean[None, :] + dx)
    ref = h(mean)
    if residual is None:
        z_hat, dz = _moments(zs, ref)
    else:
        dv = jax.vmap(residual, in_axes=(0, None))(zs, ref)
        m = jnp.mean(dv, axis=0)
        z_hat, dz = ref + m, dv - m[None, :]
    w = jax.lax.rsqrt(jnp.asarray(dx.shape[0], mean.dtype))
    X, Z = w * dx.T, w * dz.T  # [n, 2n], [p, 2n]
    Rm = jnp.asarray(R(z_hat) if callable(R) else R, mean.dtype)
    z = jnp.asarray(z, mean.dtype)
    innov = z - z_hat if residual is None else residual(z, z_hat)
    if mask is not None:
        keep = jnp.asarray(mask, bool)
        eye = jnp.eye(keep.shape[0], dtype=Rm.dtype)
        Rm = jnp.where(keep[:, None] & keep[None, :], Rm, eye)
        Z = jnp.where(keep[:, None], Z, 0.0)
        innov = jnp.where(keep, innov, 0.0)
    SR = linalg.psd_cholesky(Rm)
    Szz = tria(jnp.concatenate([Z, SR], axis=1))  # [p, p]
    Pxz = _mm(X, Z.T)  # [n, p]
    # K = Pxz Szz⁻ᵀ Szz⁻¹, i.e. Kᵀ = Szz⁻ᵀ (Szz⁻¹ Pxzᵀ): two triangular solves.
    Y = solve_triangular(Szz, Pxz.T, lower=True)
    K = solve_triangular(Szz, Y, lower=True, trans="T").T  # [n, p]
    new_mean = mean + _mm(K, innov)
    comp = jnp.concatenate([X - _mm(K, Z), _mm(K, SR)], axis=1)  # [n, 2n + p]
    return new_mean, tria(comp)
