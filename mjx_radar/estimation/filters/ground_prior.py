"""Optional ground prior for the CKF: targets fly above the radars' plane z = 0.

Range-only measurements from coplanar radars at z = 0 cannot tell a target at
``(x, y, z)`` from its mirror ``(x, y, −z)``: every range, hence the likelihood,
is identical. A filter that has settled on the mirror side (``ẑ < 0``) is
therefore as consistent with the data as the true one, and only the prior
"drones are above ground" breaks the tie (docs/statistics.md).

The prior is applied as an exact reflection, not a truncation: for every
target m whose estimated height ``ẑ_m < 0``, the whole Gaussian is mapped
through ``S = diag(s)`` with ``s = (1, 1, −1, 1, 1, −1)`` on that target's block
(``z → −z``, ``vz → −vz``; the mirror trajectory) and 1 elsewhere::

    x̂ → S x̂,     P → S P S,   i.e.  P_ij → s_i s_j P_ij.

``S`` is orthogonal and symmetric, so ``S P S`` keeps P symmetric positive
definite with the same eigenvalues, and ``S S = I`` (the reflection with a fixed
S is an involution). After one application every ``ẑ_m >= 0``, so
:func:`apply_ground_prior` is idempotent; it is a no-op when all ``ẑ_m >= 0``
(``ẑ_m = 0`` is not reflected). It is the Gaussian of the reflected random
variable, which the symmetric likelihood cannot tell from the unreflected one.

Default off for the reproduction (the paper's filter has no such prior).
Pure JAX, jittable and vmappable, no Python control flow on traced values.
"""

from __future__ import annotations

import jax.numpy as jnp

__all__ = ["reflection_signs", "reflect", "apply_ground_prior"]

_MIRROR = (1.0, 1.0, -1.0, 1.0, 1.0, -1.0)


def reflection_signs(flip):
    """Signs ``s[6M]`` of S for targets to reflect.

    Args:
        flip: ``[M]`` bool, True for the targets to reflect.

    Returns:
        ``[6M]`` entries ±1.
    """
    mirror = jnp.asarray(_MIRROR)
    s = jnp.where(jnp.asarray(flip)[:, None], mirror[None, :], 1.0)
    return s.reshape(-1)


def reflect(mean, cov, s):
    """``(S x̂, S P S)`` for ``S = diag(s)``.

    Args:
        mean: ``[6M]``.
        cov: ``[6M, 6M]``.
        s: ``[6M]`` signs ±1.

    Returns:
        ``(mean, cov)`` of the same shapes and dtypes.
    """
    s = jnp.asarray(s, mean.dtype)
    return mean * s, cov * s[:, None] * s[None, :]


def apply_ground_prior(mean, cov):
    """Reflects every target whose estimated z is below ground (``ẑ < 0``).

    Args:
        mean: ``[6M]`` stacked ``[x, y, z, vx, vy, vz]`` per target.
        cov: ``[6M, 6M]`` covariance.

    Returns:
        ``(mean, cov)`` with every ``ẑ_m >= 0``.
    """
    m = mean.shape[-1] // 6
    flip = mean.reshape(m, 6)[:, 2] < 0
    return reflect(mean, cov, reflection_signs(flip))
