"""Per-step lost-track detector for the closed loop (issue 13, docs/statistics.md).

A trial's track is *lost* at filter step k when any of

* **diverged**: the mean or covariance is non-finite, or some target's 6×6
  covariance block is not positive definite (a pivot ``D_jj <= 0`` of its
  unrolled LDLᵀ factorisation, computed on the symmetrised block);
* **mirror**: some target's estimate has been nearer its z-mirror
  ``(x, y, −z)`` than its truth for at least ``ceil(mirror_time_s / dt)``
  consecutive filter steps. Since
  ``‖p̂ − (x, y, −z)‖² − ‖p̂ − (x, y, z)‖² = 4 ẑ z``, this is ``ẑ·z < 0``:
  coplanar radars at z = 0 measure ranges that are identical for ``z`` and
  ``−z``, so a filter can settle on the mirror with a perfectly consistent
  innovation sequence;
* **beyond_sigma**: some target's position error exceeds
  ``max(k_sigma·sqrt(tr P_pos,m), error_floor_m)``.

Each flag is per step (a trial may recover: a mirror run resets when the
estimate returns to the right side); :class:`HealthState` also carries the
sticky ``ever_lost``.

Defaults (:class:`HealthConfig`):

* ``k_sigma = 5``: for a consistent filter ``‖e‖² / tr P`` is a weighted sum of
  χ²₁ variables with weights summing to one, so
  ``P(‖e‖ > 5 sqrt(tr P)) <= P(χ²₁ > 25) = 5.7e-7`` (worst case: all variance in
  one direction; 4e-16 for isotropic P). Over 500 trials × 600 steps × 4 targets
  that is < 1 false alarm in the worst case.
* ``error_floor_m = 50``: an error below 50 m is never "lost", however small
  the filter's own P (an over-confident but usable track). 50 m is 4× the
  initial position spread ``sqrt(tr P0_pos) = sqrt(150) ≈ 12 m`` and exceeds
  the spread of the paper's initial target positions (≈ 30 m): an estimate
  that far off no longer tells the targets apart.
* ``mirror_time_s = 1.0`` (40 filter steps at 25 ms): an estimate crossing
  z = 0 transiently (large P early on) is not a lock; a drone flying at
  45-80 m whose estimate stays below ground for a full second is.

All functions are pure JAX without Python control flow on traced values:
``step_health`` runs inside ``lax.scan`` and vmaps over trials.
"""

from __future__ import annotations

from typing import NamedTuple

import jax.numpy as jnp

from mjx_radar.estimation import linalg

__all__ = ["HealthConfig", "HealthState", "StepHealth", "init_health", "step_health"]


class HealthConfig(NamedTuple):
    """Thresholds of the lost-track rule (see the module docstring for the defaults)."""

    k_sigma: float = 5.0
    mirror_time_s: float = 1.0
    error_floor_m: float = 50.0


DEFAULT = HealthConfig()


class HealthState(NamedTuple):
    """Carry of the detector.

    Attributes:
        mirror_steps: ``[M]`` int32, consecutive filter steps for which target m's
            estimate has been nearer its z-mirror than its truth (0 when not).
        ever_lost: ``[]`` bool, sticky: lost at this or any earlier step.
    """

    mirror_steps: jnp.ndarray
    ever_lost: jnp.ndarray


class StepHealth(NamedTuple):
    """Per-step flags (each ``[]`` bool); ``lost = diverged | mirror | beyond_sigma``."""

    lost: jnp.ndarray
    diverged: jnp.ndarray
    mirror: jnp.ndarray
    beyond_sigma: jnp.ndarray


def init_health(m: int) -> HealthState:
    """Initial detector state for ``m`` targets (no mirror run, never lost)."""
    return HealthState(jnp.zeros((int(m),), jnp.int32), jnp.zeros((), bool))


def _blocks(cov, m: int):
    """``[6M, 6M]`` -> the ``[M, 6, 6]`` diagonal blocks."""
    return jnp.stack([cov[6 * i : 6 * i + 6, 6 * i : 6 * i + 6] for i in range(m)])


def min_pivot(block):
    """Smallest pivot ``min_j D_jj`` of the unrolled LDLᵀ of symmetric ``[..., n, n]`` blocks.

    ``A`` is positive definite iff every pivot is > 0 (Sylvester, through the
    LDLᵀ factorisation without pivoting). No flooring (unlike
    :func:`mjx_radar.estimation.linalg.psd_cholesky`, which must never fail and
    therefore cannot tell), elementwise and unrolled: cheap under vmap.
    A non-positive pivot poisons the later ones (division), which is fine: the
    minimum is then non-positive or NaN and either counts as "not PD".

    Args:
        block: ``[..., n, n]``.

    Returns:
        ``[...]`` smallest pivot.
    """
    a = linalg.symmetrize(block)
    n = a.shape[-1]
    L = [[None] * n for _ in range(n)]
    d = []
    for j in range(n):
        dj = a[..., j, j] - sum(L[j][k] * L[j][k] * d[k] for k in range(j))
        d.append(dj)
        for i in range(j + 1, n):
            L[i][j] = (a[..., i, j] - sum(L[i][k] * L[j][k] * d[k] for k in range(j))) / dj
    return jnp.min(jnp.stack(d, axis=-1), axis=-1)


def step_health(
    state: HealthState, truth, mean, cov, dt, cfg: HealthConfig = None
) -> tuple[HealthState, StepHealth]:
    """One step of the detector, after the CKF update of that step.

    Args:
        state: :class:`HealthState` of the previous step.
        truth: ``[M, 6]`` true target states.
        mean: ``[6M]`` filter mean.
        cov: ``[6M, 6M]`` filter covariance.
        dt: filter step [s] (scalar).
        cfg: thresholds; default :data:`DEFAULT`.

    Returns:
        ``(state, StepHealth)``; the mirror flag rises at the
        ``ceil(mirror_time_s / dt)``-th consecutive mirror step.
    """
    cfg = DEFAULT if cfg is None else cfg
    m = truth.shape[0]
    est = mean.reshape(m, 6)
    finite = jnp.all(jnp.isfinite(mean)) & jnp.all(jnp.isfinite(cov))
    blocks = _blocks(cov, m)
    pd = jnp.all(min_pivot(blocks) > 0)  # NaN > 0 is False
    diverged = ~(finite & pd)

    on_mirror = est[:, 2] * truth[:, 2] < 0  # nearer (x, y, -z) than (x, y, z)
    mirror_steps = jnp.where(on_mirror, state.mirror_steps + 1, 0).astype(jnp.int32)
    # ceil(T / dt), robust to float32 round-off of the ratio (1.0 / 0.025 -> 40, not 41)
    need = jnp.ceil(
        jnp.asarray(cfg.mirror_time_s, jnp.float32) / jnp.asarray(dt, jnp.float32) - 1e-4
    )
    mirror = jnp.any(mirror_steps >= jnp.maximum(need, 1.0))

    err = jnp.sqrt(jnp.sum((est[:, :3] - truth[:, :3]) ** 2, axis=-1))
    sig = jnp.sqrt(jnp.maximum(jnp.trace(blocks[:, :3, :3], axis1=-2, axis2=-1), 0.0))
    bound = jnp.maximum(cfg.k_sigma * sig, cfg.error_floor_m)
    beyond = jnp.any(err > bound)

    lost = diverged | mirror | beyond
    new = HealthState(mirror_steps, state.ever_lost | lost)
    return new, StepHealth(lost, diverged, mirror, beyond)
