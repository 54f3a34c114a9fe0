"""Cubature Kalman filter (Arasaratnam & Haykin 2009), predictor/updater split (SPEC §4).

Third-degree spherical-radial rule: for a state of dimension n with mean x̂ and
covariance P = S Sᵀ the 2n equally weighted (1/(2n)) cubature points are
``x̂ ± √n·S_i`` (S_i the i-th column of the Cholesky factor).

Predict (``f`` maps one state vector to one state vector)::

    X_i' = f(X_i),  x̂⁻ = mean X_i',  P⁻ = 1/(2n) Σ (X_i'−x̂⁻)(X_i'−x̂⁻)ᵀ + Q.

Update (points redrawn from (x̂⁻, P⁻), as in the standard CKF)::

    Z_i = h(X_i),  ẑ = mean Z_i,
    Pzz = 1/(2n) Σ (Z_i−ẑ)(Z_i−ẑ)ᵀ + R,  Pxz = 1/(2n) Σ (X_i−x̂)(Z_i−ẑ)ᵀ,
    K = Pxz Pzz⁻¹,  x̂⁺ = x̂ + K (z − ẑ),  P⁺ = P − K Pzz Kᵀ.

``R`` is an array ``[p, p]`` or a callable ``R(ẑ) -> [p, p]`` (the DDR model
evaluates its variance ``C (ẑ/2)⁴`` at the predicted measurement).

An optional ``residual(a[p], b[p]) -> [p]`` replaces the subtraction of
measurements (e.g. wrapping azimuth differences to (−π, π]). With it the
deviations about the reference are ``dZ_i = residual(Z_i, h(x̂))``, the predicted
measurement is ``ẑ = h(x̂) + mean dZ_i`` (not re-wrapped: only differences are
used), the deviations are centred on their mean and the innovation is
``residual(z, ẑ)``. So a point cloud straddling a branch cut is averaged in the
tangent space at ``h(x̂)`` rather than across the cut. Without it the update is
the plain (bit-identical) subtraction.

An optional boolean ``mask[p]`` drops measurements (False: e.g. line of sight
blocked) exactly: their rows/columns of Pzz become the identity, their columns
of Pxz and their innovations zero, so their gain columns vanish and the update
equals the update with those measurements removed (static shapes under jit).

Numerical choices (the filter must stay PD and finite over 600 float32 steps):

* Every Cholesky and solve goes through :mod:`mjx_radar.estimation.linalg`: P is symmetrised
  and factored with a relative jitter (≈1e-6 in float32) and a Gershgorin
  fallback, so a P made slightly indefinite by round-off still yields finite
  cubature points instead of NaN. The gain uses a Cholesky solve with Pzz, which
  is PD because R is.
* Every returned covariance is symmetrised.
* Float32 cancellation: ranges are O(1e3) m while the point spread may be O(0.1) m.
  Deviations are therefore formed about a reference ``f(x̂)`` / ``h(x̂)`` first
  (small numbers), then re-centred on their mean; state deviations use the exact
  offsets ``±√n·S_i`` rather than ``X_i − x̂``.
* Joseph form is *not* used: with statistical linearisation ``H = Pxzᵀ P⁻¹`` the
  Joseph expression equals ``P − K Pzz Kᵀ − K (Pzz − R − H P Hᵀ) Kᵀ``, i.e. it is
  not the CKF covariance for a nonlinear h (it drops the linearisation-error term
  and is less conservative), and it needs P⁻¹. The plain form plus symmetrisation
  and the jittered factor is the standard CKF (matches filterpy) and is kept PD
  by the relative jitter at the next factorisation.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from mjx_radar.estimation import linalg

__all__ = ["cubature_offsets", "cubature_points", "predict", "update", "horizon_points"]


def cubature_offsets(cov):
    """Offsets ``±√n·S_i`` of the 2n cubature points.

    Args:
        cov: ``[n, n]`` covariance.

    Returns:
        ``[2n, n]``: rows ``√n·S_i`` (i = 1..n) then ``−√n·S_i``.
    """
    L = linalg.psd_cholesky(cov)
    n = L.shape[-1]
    u = jnp.sqrt(jnp.asarray(n, L.dtype)) * L.T
    return jnp.concatenate([u, -u], axis=0)


def cubature_points(mean, cov):
    """Cubature points ``x̂ ± √n·S_i`` with ``S = psd_cholesky(cov)``.

    Args:
        mean: ``[n]`` mean.
        cov: ``[n, n]`` covariance.

    Returns:
        ``[2n, n]`` points (equal weights 1/(2n)).
    """
    mean = jnp.asarray(mean)
    return mean[None, :] + cubature_offsets(jnp.asarray(cov, mean.dtype))


def _moments(values, ref):
    """Mean and centred deviations of ``values[2n, k]`` computed about ``ref[k]``."""
    dv = values - ref[None, :]
    m = jnp.mean(dv, axis=0)
    return ref + m, dv - m[None, :]


def predict(mean, cov, f, Q):
    """CKF time update.

    Args:
        mean: ``[n]`` posterior mean.
        cov: ``[n, n]`` posterior covariance.
        f: transition ``f(x[n]) -> [n]`` of one state vector.
        Q: ``[n, n]`` process-noise covariance.

    Returns:
        ``(mean[n], cov[n, n])`` predicted moments.
    """
    mean = jnp.asarray(mean)
    points = cubature_points(mean, cov)
    xp = jax.vmap(f)(points)
    m, dx = _moments(xp, f(mean))
    P = dx.T @ dx / dx.shape[0] + Q
    return m, linalg.symmetrize(P)


def update(mean, cov, z, h, R, mask=None, residual=None, with_innovation=False):
    """CKF measurement update.

    Args:
        mean: ``[n]`` predicted mean.
        cov: ``[n, n]`` predicted covariance.
        z: ``[p]`` measurement.
        h: measurement function ``h(x[n]) -> [p]`` of one state vector.
        R: ``[p, p]`` noise covariance, or a callable ``R(z_hat[p]) -> [p, p]``.
        mask: optional ``[p]`` bool, True where the measurement is used (default all).
        residual: optional ``residual(a[p], b[p]) -> [p]``, the difference ``a − b``
            of two measurements (angles wrapped); default plain subtraction.
        with_innovation: also return the innovation ``ν[p]`` and its covariance
            ``Pzz[p, p]`` (masked rows: ν = 0, identity rows/columns), e.g. for the
            IMM's mode likelihood ``N(ν; 0, Pzz)`` (:mod:`mjx_radar.estimation.filters.imm`).

    Returns:
        ``(mean[n], cov[n, n])`` posterior moments (``+ (ν, Pzz)`` with ``with_innovation``).
    """
    mean = jnp.asarray(mean)
    cov = jnp.asarray(cov, mean.dtype)
    dx = cubature_offsets(cov)
    zs = jax.vmap(h)(mean[None, :] + dx)
    if residual is None:
        z_hat, dz = _moments(zs, h(mean))
    else:
        ref = h(mean)
        dv = jax.vmap(residual, in_axes=(0, None))(zs, ref)
        m = jnp.mean(dv, axis=0)
        z_hat, dz = ref + m, dv - m[None, :]
    w = 1.0 / dx.shape[0]
    Rm = R(z_hat) if callable(R) else R
    Pzz = w * dz.T @ dz + Rm
    Pxz = w * dx.T @ dz
    z = jnp.asarray(z, mean.dtype)
    innov = z - z_hat if residual is None else residual(z, z_hat)
    if mask is not None:
        keep = jnp.asarray(mask, bool)
        eye = jnp.eye(keep.shape[0], dtype=Pzz.dtype)
        Pzz = jnp.where(keep[:, None] & keep[None, :], Pzz, eye)
        Pxz = jnp.where(keep[None, :], Pxz, 0.0)
        innov = jnp.where(keep, innov, 0.0)
    K = linalg.psd_solve(Pzz, Pxz.T).T
    new_mean = mean + K @ innov
    new_cov = cov - K @ Pzz @ K.T
    if with_innovation:
        return new_mean, linalg.symmetrize(new_cov), innov, Pzz
    return new_mean, linalg.symmetrize(new_cov)


def horizon_points(mean, cov, f, steps: int):
    """Current cubature points propagated through ``f`` over a horizon.

    Args:
        mean: ``[n]`` current mean.
        cov: ``[n, n]`` current covariance.
        f: transition ``f(x[n]) -> [n]``.
        steps: horizon length T (static Python int >= 1).

    Returns:
        ``[T, 2n, n]`` with ``points_t = f(points_{t−1})``, t = 1..T, and
        ``points_0`` the current cubature points.
    """
    if int(steps) != steps or steps < 1:
        raise ValueError(f"steps must be an integer >= 1, got {steps!r}")
    pts0 = cubature_points(mean, cov)

    def body(p, _):
        p = jax.vmap(f)(p)
        return p, p

    _, out = jax.lax.scan(body, pts0, None, length=int(steps))
    return out
