"""Runtime noise constants of the measurement models (SPEC §1; monopulse azimuth).

``noise_params`` evaluates the radar equation on the host in float64 (the range
constant C, its CCR variance at R2T, and the azimuth constant
``c_az = θ_3dB² / (2 k_m² SNR_ref R_ref⁴)``, see :mod:`mjx_radar.estimation.sensor.measurement`)
and returns them as the :class:`NoiseParams` pytree the programs take at run time.

A mixed fleet (``[[radar_override]]`` with a ``radar_equation``) has one set of constants
per radar: every field is then an ``[N]`` array, and the models take radar ``n``'s
(:func:`at_radar`, :func:`per_row`, :func:`per_pair`) wherever C is used -- the CKF noise,
the SFIM / PFIM costs, the PCRLB and the truth sampler; CCR's variances are each
radar's own ``C_n R2T⁴``.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from mjx_radar.estimation.sensor import sensing
from mjx_radar.scenario.schema import MeasurementConfig, RadarEquation, Scenario


class NoiseParams(NamedTuple):
    """Runtime noise constants (scalars, or ``[N]`` per radar; may be traced)."""

    c: jax.Array  # DDR range constant C: var(2d) = C d⁴ [1/m²]
    sigma_r2: jax.Array  # CCR range variance C·R2T⁴ [m²]
    c_az: jax.Array  # DDR azimuth constant: var(φ) = c_az d⁴ [rad²/m⁴]
    sigma_az2: jax.Array  # CCR azimuth variance c_az·R2T⁴ [rad²]


def noise_params(source, n_targets=None, r2t=None, measurement=None, dtype=None) -> NoiseParams:
    """Noise constants from the radar equation (host float64, returned as ``dtype``).

    Args:
        source: a :class:`Scenario` (then the other arguments default to its
            ``n_targets``, ``mpc.r2t`` and ``measurement``) or a :class:`RadarEquation`.
        n_targets: int M (noise power carries the factor M, SPEC §1).
        r2t: float, CCR reference range R2T [m].
        measurement: MeasurementConfig (beamwidth, monopulse slope); default its defaults.
        dtype: array dtype (default: JAX's default float).

    Returns:
        ``NoiseParams(C, C·R2T⁴, c_az, c_az·R2T⁴)`` with
        ``c_az = θ_3dB² / (2 k_m² SNR_ref R_ref⁴)``, ``SNR_ref = 10^(snr_db/10) / M``.
    """
    if isinstance(source, Scenario) and any(ov.radar_eq for ov in source.radar_override):
        from mjx_radar.scenario.fleet import radar_equation

        each = [
            noise_params(
                radar_equation(source, i),
                source.n_targets,
                source.mpc.r2t,
                source.measurement,
                dtype,
            )
            for i in range(source.n_radars)
        ]
        dt = dtype or jnp.result_type(float)
        return NoiseParams(
            *(jnp.asarray(np.stack([np.asarray(e[k]) for e in each]), dt) for k in range(4))
        )
    if isinstance(source, Scenario):
        n_targets = source.n_targets if n_targets is None else n_targets
        r2t = source.mpc.r2t if r2t is None else r2t
        measurement = source.measurement if measurement is None else measurement
        source = source.radar_eq
    if not isinstance(source, RadarEquation) or n_targets is None or r2t is None:
        raise ValueError("noise_params needs a Scenario, or a RadarEquation with n_targets and r2t")
    meas = measurement or MeasurementConfig()
    if not (meas.beamwidth_deg > 0 and meas.monopulse_slope > 0):
        raise ValueError("beamwidth_deg and monopulse_slope must be > 0")
    if not (math.isfinite(float(r2t)) and float(r2t) > 0):
        raise ValueError(f"r2t must be finite and > 0 m, got {r2t!r}")
    c = sensing.noise_constant(source, n_targets)
    snr_ref = 10.0 ** (float(source.snr_db) / 10.0) / int(n_targets)
    theta, k_m = math.radians(float(meas.beamwidth_deg)), float(meas.monopulse_slope)
    c_az = theta**2 / (2.0 * k_m**2 * snr_ref * float(source.r_ref) ** 4)
    r4 = float(r2t) ** 4
    dt = dtype or jnp.result_type(float)
    return NoiseParams(*(jnp.asarray(v, dt) for v in (c, c * r4, c_az, c_az * r4)))


def at_radar(params: NoiseParams, n: int) -> NoiseParams:
    """Radar ``n``'s constants (unchanged when they are shared scalars)."""
    return NoiseParams(*(a if jnp.ndim(a) == 0 else a[n] for a in params))


def per_row(params: NoiseParams, rows: int) -> NoiseParams:
    """Constants per measurement row ``[rows, 1]`` (rows radar-major, ``rows = N·k``)."""
    if jnp.ndim(params.c) == 0:
        return params
    reps = rows // params.c.shape[0]
    return NoiseParams(*(jnp.repeat(a, reps)[:, None] for a in params))


def per_pair(a, m: int):
    """A constant per radar-target pair, ``[N·M]`` row-major (a scalar stays one)."""
    return a if jnp.ndim(a) == 0 else jnp.repeat(a, m)
