"""Interacting multiple model (IMM) filter of the per-target bank (issue 22, docs/filters.md).

Bar-Shalom, Li & Kirubarajan, *Estimation with Applications to Tracking and
Navigation* (2001), §11.6.6. Each target keeps r = 3 mode-matched 6-D CKFs on the
state ``x = [px, py, pz, vx, vy, vz]``, all in the same space, so the mixing is exact:

* mode 0: constant velocity, ``F₀ = A_CV(dt)`` (the paper's model);
* modes 1, 2: coordinated turns at the known rates ``ω = +w, −w`` in the horizontal
  plane (z stays CV; :func:`ct_transition`), ``F_j = A_CT(±w, dt)``;

every mode with the same white-acceleration process noise ``Q = σ_W² Q₁`` (linear
models: the CKF prediction is ``F P Fᵀ + Q`` exactly). The mode sequence is a Markov
chain with the transition (mixing) matrix, per filter step::

    Π_ij = P(mode j at k | mode i at k−1) = 1 − p  (i = j),  p / (r − 1)  (i ≠ j),
    p = 1 − (1 − p_s)^dt,

``p_s`` the probability of leaving the current mode within one second
(``filter.imm_switch_prob``); the initial mode probabilities are uniform (the chain's
stationary distribution). One cycle, per target:

1. mixing: ``c̄_j = Σ_i Π_ij μ_i``, ``μ_{i|j} = Π_ij μ_i / c̄_j``,
   ``x̂⁰_j = Σ_i μ_{i|j} x̂_i``, ``P⁰_j = Σ_i μ_{i|j} [P_i + (x̂_i − x̂⁰_j)(x̂_i − x̂⁰_j)ᵀ]``;
2. mode-matched prediction ``(x̂_j⁻, P_j⁻) = CKF-predict(x̂⁰_j, P⁰_j; F_j, Q)``;
3. mode-matched update ``(x̂_j, P_j) = CKF-update(x̂_j⁻, P_j⁻; z)`` with the likelihood
   ``Λ_j = N(ν_j; 0, S_j)`` of the CKF innovation ν_j and its covariance ``S_j = Pzz``
   (the cubature Pzz of the range measurements, R included);
4. mode probabilities ``μ_j = Λ_j c̄_j / Σ_l Λ_l c̄_l`` (in logs; the common ``(2π)^{p/2}``
   dropped; a measurement dropped by a mask adds the same factor to every mode);
5. combination ``x̂ = Σ_j μ_j x̂_j``, ``P = Σ_j μ_j [P_j + (x̂_j − x̂)(x̂_j − x̂)ᵀ]``.

Between prediction and update the state's ``probs`` holds the predicted ``c̄``, so the
combined *predicted* estimate (the planner's when ``mpc.aligned = false``) is the
``c̄``-weighted combination. With ``w = 0`` and ``p_s = 0`` every mode is the CV CKF and
the IMM is exactly the CV bank. Pure JAX, static shapes, ``vmap``-ed over targets.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from mjx_radar.estimation import linalg
from mjx_radar.estimation.filters import ckf

__all__ = [
    "N_MODES",
    "ImmState",
    "ct_transition",
    "mode_transitions",
    "markov_matrix",
    "init",
    "mix",
    "combine",
    "predict",
    "update",
    "predict_bank",
    "update_bank",
    "combine_bank",
]

N_MODES = 3  # CV, CT(+w), CT(−w)


class ImmState(NamedTuple):
    """Mode-conditioned estimates of M targets (r modes)."""

    means: jax.Array  # [M, r, 6]
    covs: jax.Array  # [M, r, 6, 6]
    probs: jax.Array  # [M, r] mode probabilities μ (after a prediction: c̄)


def ct_transition(omega: float, dt: float) -> np.ndarray:
    """``[6, 6]`` coordinated turn at rate ``omega`` [rad/s] in x-y, CV in z (float64).

    ``p' = p + [s/ω, −(1−c)/ω; (1−c)/ω, s/ω] v``, ``v' = [c, −s; s, c] v`` with
    ``s = sin ωdt``, ``c = cos ωdt``; ``omega = 0`` gives the CV matrix exactly.
    """
    F = np.eye(6)
    F[0:3, 3:6] = dt * np.eye(3)
    if omega != 0.0:
        s, c = math.sin(omega * dt), math.cos(omega * dt)
        F[0:2, 3:5] = np.array([[s, -(1.0 - c)], [1.0 - c, s]]) / omega
        F[3:5, 3:5] = np.array([[c, -s], [s, c]])
    return F


def mode_transitions(omega: float, dt: float) -> np.ndarray:
    """``[3, 6, 6]`` the modes' transitions: CV, CT(+omega), CT(−omega)."""
    return np.stack([ct_transition(0.0, dt), ct_transition(omega, dt), ct_transition(-omega, dt)])


def markov_matrix(switch_prob: float, dt: float, r: int = N_MODES) -> np.ndarray:
    """``[r, r]`` mode transition matrix Π per step of ``dt`` (rows sum to 1).

    ``switch_prob`` is the probability of leaving a mode within one second; per step
    ``p = 1 − (1 − switch_prob)^dt``, spread evenly over the other modes.
    """
    p = 1.0 - (1.0 - float(switch_prob)) ** float(dt)
    off = p / (r - 1) if r > 1 else 0.0
    return (1.0 - p) * np.eye(r) + off * (1.0 - np.eye(r))


def init(means, covs, r: int = N_MODES) -> ImmState:
    """Every mode at the given estimate ``means [M, 6], covs [M, 6, 6]``, μ uniform."""
    m = means.shape[0]
    probs = jnp.full((m, r), 1.0 / r, means.dtype)
    rep = lambda a: jnp.broadcast_to(a[:, None], (m, r) + a.shape[1:])  # noqa: E731
    return ImmState(rep(means), rep(covs), probs)


def _spread(w, means, covs, center):
    """``Σ_i w_i [P_i + (x_i − c)(x_i − c)ᵀ]`` for ``w [r]``, ``means [r, n]``."""
    d = means - center[None, :]
    return linalg.symmetrize(jnp.einsum("i,ijk->jk", w, covs) + (w[:, None] * d).T @ d)


def mix(probs, means, covs, Pi):
    """IMM interaction (mixing) step of one target.

    Args:
        probs: ``[r]`` mode probabilities μ at k−1.
        means: ``[r, n]``; covs: ``[r, n, n]`` mode-conditioned estimates at k−1.
        Pi: ``[r, r]`` Markov matrix, ``Pi[i, j] = P(j | i)``.

    Returns:
        ``(c̄[r], x⁰[r, n], P⁰[r, n, n])``: predicted mode probabilities and the mixed
        initial conditions. A mode with ``c̄_j = 0`` (possible only with Π diagonal)
        keeps its own estimate.
    """
    Pi = jnp.asarray(Pi, probs.dtype)
    cbar = probs @ Pi  # [r]
    tiny = jnp.finfo(probs.dtype).tiny
    w = Pi * probs[:, None] / jnp.maximum(cbar, tiny)[None, :]  # [i, j] = μ_{i|j}
    w = jnp.where(cbar[None, :] > tiny, w, jnp.eye(probs.shape[0], dtype=probs.dtype))
    x0 = w.T @ means  # [r, n]
    P0 = jax.vmap(lambda wj, cj: _spread(wj, means, covs, cj), (1, 0))(w, x0)
    return cbar, x0, P0


def combine(probs, means, covs):
    """Combined estimate ``(x̂[n], P[n, n])`` of the modes (step 5)."""
    mean = probs @ means
    return mean, _spread(probs, means, covs, mean)


def predict(probs, means, covs, F, Q, Pi):
    """Mixing and mode-matched CKF prediction of one target.

    Args:
        probs: ``[r]``; means: ``[r, n]``; covs: ``[r, n, n]`` (at k−1).
        F: ``[r, n, n]`` the modes' transitions; Q: ``[n, n]`` process noise.
        Pi: ``[r, r]`` Markov matrix.

    Returns:
        ``(c̄[r], means[r, n], covs[r, n, n])`` predicted.
    """
    cbar, x0, P0 = mix(probs, means, covs, Pi)
    F = jnp.asarray(F, means.dtype)
    xp, Pp = jax.vmap(lambda x, P, Fj: ckf.predict(x, P, lambda v: Fj @ v, Q))(x0, P0, F)
    return cbar, xp, Pp


def log_likelihood(innov, Pzz):
    """``log N(ν; 0, S) + (p/2) log 2π = −(νᵀ S⁻¹ ν + log det S) / 2``."""
    return -0.5 * (innov @ linalg.psd_solve(Pzz, innov) + linalg.logdet_psd(Pzz))


def update(cbar, means, covs, z, h, R, mask=None, residual=None):
    """Mode-matched CKF updates and the mode-probability update of one target.

    Args:
        cbar: ``[r]`` predicted mode probabilities; means ``[r, n]``, covs ``[r, n, n]``
            predicted; z, h, R, mask, residual: as :func:`ckf.update`.

    Returns:
        ``(probs[r], means[r, n], covs[r, n, n])`` posterior.
    """

    def one(x, P):
        return ckf.update(x, P, z, h, R, mask=mask, residual=residual, with_innovation=True)

    xs, Ps, innov, Pzz = jax.vmap(one)(means, covs)
    logl = jax.vmap(log_likelihood)(innov, Pzz)
    probs = jax.nn.softmax(logl + jnp.log(cbar))
    return probs, xs, Ps


def predict_bank(state: ImmState, F, Q, Pi) -> ImmState:
    """:func:`predict` of every target (``state.probs`` becomes c̄)."""
    cbar, xs, Ps = jax.vmap(lambda p, x, P: predict(p, x, P, F, Q, Pi))(
        state.probs, state.means, state.covs
    )
    return ImmState(xs, Ps, cbar)


def update_bank(state: ImmState, z, radar_pos, h_pair, R_fn, mask=None, residual=None):
    """:func:`update` of every target from its N radars (arguments as
    :func:`mjx_radar.estimation.filters.filter_bank.update_bank`: ``z [N, M, p]``, ``mask [N,
    M]``)."""
    n, m, p = z.shape
    zm = jnp.swapaxes(jnp.asarray(z, state.means.dtype), 0, 1).reshape(m, n * p)

    def h_target(x6):
        return jax.vmap(lambda r: h_pair(r, x6))(radar_pos).reshape(n * p)

    keep = None if mask is None else jnp.repeat(jnp.asarray(mask, bool).T, p, axis=1)

    def one(c, x, P, zz, kk):
        return update(c, x, P, zz, h_target, R_fn, mask=kk, residual=residual)

    axes = (0, 0, 0, 0, None if keep is None else 0)
    probs, xs, Ps = jax.vmap(one, axes)(state.probs, state.means, state.covs, zm, keep)
    return ImmState(xs, Ps, probs)


def combine_bank(state: ImmState):
    """Combined ``(means[M, 6], covs[M, 6, 6])`` of every target."""
    return jax.vmap(combine)(state.probs, state.means, state.covs)
