"""Radar equation and round-trip range measurement model (SPEC §1).

Radar equation and noise calibration::

    P_r(d) = K / d⁴,     K = Pt·Gt·Gr·λ²·σ_rcs / ((4π)³·L),   λ = c / fc,
    σ_a²   = M · P_r(R_ref) / 10^(snr_db/10),
    C      = c² σ_a² / (8π² fc² K).

Range measurement of target m by radar n (round trip, 3-D distance)::

    z_nm ~ N(2 d_nm, C d_nm⁴)            (DDR, truth model)
    σ_R² = C · R2T⁴                       (CCR, constant baseline variance)

Stacked measurements are flattened row-major: index ``n*M + m``. The stacked
target state is ``x[6M]`` = concatenation of per-target ``[x, y, z, vx, vy, vz]``.

Input validation raises :class:`ValueError` with a one-line message. Values are
only checked when concrete (Python/NumPy/concrete JAX arrays); traced values
inside ``jit``/``vmap`` cannot be checked by value, but shapes always are.
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np

from mjx_radar.scenario.schema import RadarEquation

__all__ = [
    "SPEED_OF_LIGHT",
    "radar_constant",
    "received_power",
    "noise_power",
    "noise_constant",
    "ccr_variance",
    "ranges",
    "range_model",
    "ddr_variance",
    "ddr_noise_cov",
    "ccr_noise_cov",
    "sample_ranges",
]

SPEED_OF_LIGHT = 299792458.0  # c [m/s]

_POSITIVE_FIELDS = ("fc", "loss", "gain_tx", "gain_rx", "r_ref", "rcs", "power_tx")


def _concrete(x) -> bool:
    return not isinstance(x, jax.core.Tracer)


def _check_params(params: RadarEquation) -> None:
    for name in _POSITIVE_FIELDS:
        v = getattr(params, name)
        if _concrete(v) and not (math.isfinite(float(v)) and float(v) > 0.0):
            raise ValueError(f"radar equation '{name}' must be finite and > 0, got {v!r}")
    v = params.snr_db
    if _concrete(v) and not math.isfinite(float(v)):
        raise ValueError(f"radar equation 'snr_db' must be finite (dB), got {v!r}")


def _check_n_targets(n_targets) -> int:
    if isinstance(n_targets, bool) or int(n_targets) != n_targets or int(n_targets) < 1:
        raise ValueError(f"n_targets must be an integer >= 1, got {n_targets!r}")
    return int(n_targets)


def _check_positive_range(d, name: str = "range") -> None:
    if _concrete(d):
        a = np.asarray(d, dtype=np.float64)
        if not np.all(np.isfinite(a) & (a > 0.0)):
            raise ValueError(f"{name} must be finite and > 0 m, got min {np.min(a)!r}")


def _check_points(x, name: str):
    x = jnp.asarray(x)
    if x.ndim != 2 or x.shape[-1] != 3 or x.shape[0] < 1:
        raise ValueError(f"{name} must have shape [K, 3] with K >= 1, got {tuple(x.shape)}")
    return x if jnp.issubdtype(x.dtype, jnp.floating) else x.astype(jnp.result_type(float))


def radar_constant(params: RadarEquation) -> float:
    """``K = Pt·Gt·Gr·λ²·σ_rcs / ((4π)³·L)`` [W·m⁴], computed in float64 on the host."""
    _check_params(params)
    lam = SPEED_OF_LIGHT / float(params.fc)
    num = float(params.power_tx) * float(params.gain_tx) * float(params.gain_rx)
    return num * lam**2 * float(params.rcs) / ((4.0 * math.pi) ** 3 * float(params.loss))


def received_power(params: RadarEquation, d):
    """Received echo power ``P_r(d) = K / d⁴`` [W].

    Args:
        params: radar-equation parameters.
        d: one-way range(s) [m], any shape, > 0.

    Returns:
        Power with the shape of ``d``.
    """
    _check_positive_range(d)
    return radar_constant(params) / jnp.asarray(d) ** 4


def noise_power(params: RadarEquation, n_targets: int) -> float:
    """Noise power ``σ_a² = M · P_r(R_ref) / 10^(snr_db/10)`` [W] (float64, host)."""
    m = _check_n_targets(n_targets)
    k = radar_constant(params)
    return m * k / float(params.r_ref) ** 4 / 10.0 ** (float(params.snr_db) / 10.0)


def noise_constant(params: RadarEquation, n_targets: int) -> float:
    """Range-noise constant ``C = c² σ_a² / (8π² fc² K)`` [1/m²] (float64, host).

    The DDR range variance is ``C d⁴``. Defaults give C ≈ 7.285e-10 for M = 4
    and ≈ 5.464e-10 for M = 3.

    Args:
        params: radar-equation parameters (all positive, snr_db finite).
        n_targets: number of targets M (>= 1).

    Returns:
        C as a Python float.
    """
    sigma_a2 = noise_power(params, n_targets)
    k = radar_constant(params)
    fc = float(params.fc)
    return SPEED_OF_LIGHT**2 * sigma_a2 / (8.0 * math.pi**2 * fc**2 * k)


def ccr_variance(C, r2t):
    """Constant (CCR) range variance ``σ_R² = C · R2T⁴`` [m²]."""
    _check_positive_range(r2t, "r2t")
    return C * r2t**4


def ranges(radar_pos, target_pos):
    """3-D Euclidean radar–target distances.

    Args:
        radar_pos: ``[N, 3]`` radar positions [m].
        target_pos: ``[M, 3]`` target positions [m].

    Returns:
        ``d[N, M]``, ``d[n, m] = ‖p_Tm − p_Rn‖``.
    """
    radar_pos = _check_points(radar_pos, "radar_pos")
    target_pos = _check_points(target_pos, "target_pos")
    diff = target_pos[None, :, :] - radar_pos[:, None, :]
    return jnp.sqrt(jnp.sum(diff**2, axis=-1))


def range_model(radar_pos):
    """Noiseless measurement function of the stacked target state.

    Args:
        radar_pos: ``[N, 3]`` radar positions [m].

    Returns:
        ``h(x[6M]) -> [N*M]`` with ``h(x)[n*M + m] = 2 d_nm``.
    """
    radar_pos = _check_points(radar_pos, "radar_pos")

    def h(x):
        if x.ndim != 1 or x.shape[0] % 6 != 0:
            raise ValueError(f"state must have shape [6M], got {tuple(x.shape)}")
        pos = jnp.reshape(x, (-1, 6))[:, :3]
        return 2.0 * ranges(radar_pos, pos).reshape(-1)

    return h


def ddr_variance(z_hat, C):
    """DDR variance evaluated at a round-trip range: ``C (ẑ/2)⁴`` [m²]."""
    return C * (jnp.asarray(z_hat) / 2.0) ** 4


def ddr_noise_cov(z_hat, C):
    """DDR measurement covariance ``diag(C (ẑ/2)⁴)``.

    Args:
        z_hat: ``[p]`` (predicted) round-trip ranges [m].
        C: noise constant (scalar).

    Returns:
        ``[p, p]`` diagonal covariance.
    """
    z_hat = jnp.asarray(z_hat)
    if z_hat.ndim != 1:
        raise ValueError(f"z_hat must have shape [p], got {tuple(z_hat.shape)}")
    return jnp.diag(ddr_variance(z_hat, C))


def ccr_noise_cov(p: int, sigma_r2, dtype=None):
    """CCR measurement covariance ``σ_R² I_p`` (``[p, p]``)."""
    if int(p) != p or int(p) < 1:
        raise ValueError(f"p must be an integer >= 1, got {p!r}")
    return sigma_r2 * jnp.eye(int(p), dtype=dtype or jnp.result_type(float))


def sample_ranges(key, radar_pos, target_pos, C):
    """Draw noisy DDR round-trip ranges, one independent draw per radar–target pair.

    Args:
        key: PRNG key.
        radar_pos: ``[N, 3]`` radar positions [m].
        target_pos: ``[M, 3]`` true target positions [m].
        C: noise constant.

    Returns:
        ``z[N*M] = 2d + sqrt(C) d² ε``, ``ε ~ N(0, I)`` (row-major ``n*M + m``).
    """
    d = ranges(radar_pos, target_pos).reshape(-1)
    eps = jax.random.normal(key, d.shape, dtype=d.dtype)
    return 2.0 * d + jnp.sqrt(jnp.asarray(C, d.dtype)) * d**2 * eps
