"""Weighted shrinkage covariance estimators in JAX (Ledoit-Wolf, OAS, empirical).

All three estimators share one signature and are pure and jittable::

    estimator(x[n, p], weights[n] | None = None, center[p] | None = None)
        -> (cov[p, p], shrinkage[])

They generalise :func:`sklearn.covariance.ledoit_wolf` and
:func:`sklearn.covariance.oas` (``assume_centered=False``) to weighted samples, so
that the elites of a cross-entropy step can be a *masked* subset of a fixed-size
sample array (static shapes under ``jit``).

Notation. Weights are normalised, ``w_i = weights_i / sum(weights)`` (uniform
``1/n`` when ``weights`` is None); the centre is ``c = center`` or, by default, the
weighted mean ``sum_i w_i x_i``; ``y_i = x_i - c``. Rows with ``w_i = 0`` are zeroed
before any arithmetic, so they never contribute, even if they hold ``inf``/``nan``.

* weighted empirical covariance ``S = sum_i w_i y_i y_i^T``;
* ``mu = tr(S) / p`` (target of the shrinkage is ``mu I``);
* effective sample size ``n_eff = 1 / sum_i w_i^2``;
* the shrunk estimate is ``(1 - rho) S + rho mu I`` with ``rho`` in ``[0, 1]``.

Ledoit-Wolf (2004), with the Frobenius norm scaled by ``1/p`` as in sklearn::

    delta = ||S - mu I||_F^2 / p
    beta  = sum_i w_i^2 ||y_i y_i^T - S||_F^2 / p      (variance of the weighted mean S)
          = (sum_i w_i^2 ||y_i||^4 - 2 sum_i w_i^2 y_i^T S y_i + ||S||_F^2 sum_i w_i^2) / p
    rho   = min(beta, delta) / delta                  (0 when delta == 0)

With uniform weights ``w_i = 1/n`` we have ``sum_i y_i^T S y_i = n ||S||_F^2``, so
``beta = (sum_i ||y_i||^4 / n - ||S||_F^2) / (n p)``, exactly sklearn's expression.

OAS (Chen et al. 2010, as implemented by sklearn) with ``n`` replaced by ``n_eff``::

    alpha = mean(S**2);  num = alpha + mu^2;  den = (n_eff + 1) (alpha - mu^2 / p)
    rho   = min(num / den, 1)                         (1 when den == 0)

Weights that are uniform on a subset of ``k`` rows (zero elsewhere) give
``n_eff = k`` and reproduce sklearn run on those ``k`` rows exactly. With one
feature (``p == 1``) the shrinkage is 0, as in sklearn.
"""

from __future__ import annotations

import jax.numpy as jnp
from jax import Array


def _prepare(x: Array, weights: Array | None, center: Array | None) -> tuple[Array, Array, Array]:
    """Return ``(y[n,p], w[n], S[p,p])``: masked centred rows, normalised weights, emp. cov."""
    x = jnp.asarray(x)
    if not jnp.issubdtype(x.dtype, jnp.floating):
        x = x.astype(jnp.result_type(float))
    n = x.shape[0]
    if weights is None:
        w = jnp.full((n,), 1.0 / n, dtype=x.dtype)
    else:
        w = jnp.asarray(weights, dtype=x.dtype)
        w = w / jnp.sum(w)
    live = w > 0
    x = jnp.where(live[:, None], x, 0.0)  # zero-weight rows: no inf/nan leaks in
    c = w @ x if center is None else jnp.asarray(center, dtype=x.dtype)
    y = jnp.where(live[:, None], x - c, 0.0)
    s = (y * w[:, None]).T @ y
    s = 0.5 * (s + s.T)
    return y, w, s


def _shrink(s: Array, rho: Array) -> Array:
    """``(1 - rho) S + rho mu I`` with ``mu = tr(S)/p``."""
    p = s.shape[0]
    mu = jnp.trace(s) / p
    return (1.0 - rho) * s + rho * mu * jnp.eye(p, dtype=s.dtype)


def empirical(
    x: Array, weights: Array | None = None, center: Array | None = None
) -> tuple[Array, Array]:
    """Weighted empirical covariance, no shrinkage.

    Args:
        x: Samples ``[n, p]``.
        weights: Non-negative weights ``[n]`` (normalised internally); None = uniform.
        center: Centre ``[p]``; None = weighted mean.

    Returns:
        ``(S[p, p], 0.0)`` with ``S = sum_i w_i (x_i - c)(x_i - c)^T``.
    """
    _, _, s = _prepare(x, weights, center)
    return s, jnp.zeros((), dtype=s.dtype)


def ledoit_wolf(
    x: Array, weights: Array | None = None, center: Array | None = None
) -> tuple[Array, Array]:
    """Weighted Ledoit-Wolf shrunk covariance (see the module docstring).

    Equals ``sklearn.covariance.ledoit_wolf(x)`` for uniform weights and no centre.

    Args:
        x: Samples ``[n, p]``.
        weights: Non-negative weights ``[n]``, at least one positive (normalised
            internally); None = uniform.
        center: Centre ``[p]``; None = weighted mean.

    Returns:
        ``(cov[p, p], rho[])``: the shrunk covariance and the shrinkage coefficient.
    """
    y, w, s = _prepare(x, weights, center)
    p = s.shape[0]
    if p == 1:
        return s, jnp.zeros((), dtype=s.dtype)
    w2 = w * w
    s_fro2 = jnp.sum(s * s)
    mu = jnp.trace(s) / p
    delta = (s_fro2 - p * mu * mu) / p
    r = jnp.sum(y * y, axis=1)  # ||y_i||^2
    q = jnp.sum((y @ s) * y, axis=1)  # y_i^T S y_i
    beta = (jnp.sum(w2 * r * r) - 2.0 * jnp.sum(w2 * q) + s_fro2 * jnp.sum(w2)) / p
    beta = jnp.clip(beta, 0.0, None)
    safe = delta > 0
    rho = jnp.where(safe, jnp.minimum(beta, delta) / jnp.where(safe, delta, 1.0), 0.0)
    return _shrink(s, rho), rho


def oas(x: Array, weights: Array | None = None, center: Array | None = None) -> tuple[Array, Array]:
    """Weighted Oracle Approximating Shrinkage covariance (see the module docstring).

    Equals ``sklearn.covariance.oas(x)`` for uniform weights and no centre.

    Args:
        x: Samples ``[n, p]``.
        weights: Non-negative weights ``[n]``, at least one positive (normalised
            internally); None = uniform.
        center: Centre ``[p]``; None = weighted mean.

    Returns:
        ``(cov[p, p], rho[])``: the shrunk covariance and the shrinkage coefficient.
    """
    _, w, s = _prepare(x, weights, center)
    p = s.shape[0]
    if p == 1:
        return s, jnp.zeros((), dtype=s.dtype)
    n_eff = 1.0 / jnp.sum(w * w)
    alpha = jnp.mean(s * s)
    mu = jnp.trace(s) / p
    num = alpha + mu * mu
    den = (n_eff + 1.0) * (alpha - mu * mu / p)
    nonzero = den != 0
    rho = jnp.where(nonzero, jnp.minimum(num / jnp.where(nonzero, den, 1.0), 1.0), 1.0)
    return _shrink(s, rho), rho


ESTIMATORS = {"ledoit-wolf": ledoit_wolf, "oas": oas, "none": empirical}
"""Estimator by name, as used by ``MPPIConfig.shrinkage``."""
