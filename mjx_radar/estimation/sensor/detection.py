"""Detection probability of each radar-target pair (issue 23, docs/detection.md).

Model (``detection.model``):

* ``"perfect"`` (default): every pair is detected at every scan (the paper).
* ``"swerling1"``: Swerling I target, square-law detector, one pulse (Skolnik,
  *Introduction to Radar Systems*, 3rd ed., §2.8; Richards, *Fundamentals of Radar
  Signal Processing*, §6.3)::

      Pd = Pfa ** (1 / (1 + SNR))

  The echo power of a Swerling I target is exponential with mean ``σ_n² (1 + SNR)``;
  the threshold ``T = −σ_n² ln Pfa`` gives ``Pfa = exp(−T/σ_n²)`` on noise alone and
  ``Pd = exp(−T / (σ_n² (1 + SNR)))`` with a target.
* ``"fixed"``: ``Pd = fixed_pd`` for every pair (studies that want a constant Pd).

SNR at one-way range d from the radar equation (SPEC §1, noise power carries M)::

    SNR(d) = 10^((snr_db + gain_db)/10) / M · (R_ref / d)⁴ = k_snr / d⁴

``gain_db`` (``detection.gain_db``, default 0) is the processing gain of the detector
over the SNR that calibrates the range noise (coherent integration of a dwell);
``k_snr`` [m⁴] is computed on the host in float64 (:func:`detection_params`).

Draws: pair (n, m) at scan k is detected iff ``U_nmk < Pd_nm`` with
``U ~ Uniform[0, 1)`` from the trial's detection stream
(:func:`mjx_radar.env.streams.detection_streams`), so ``Pd = 1`` detects
every pair and the filter sees exactly the paper's measurements.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

__all__ = [
    "DetectionParams",
    "detection_probability",
    "snr_constant",
    "detection_params",
    "pair_probability",
    "sample_detections",
    "draw_pairs",
    "planner_weights",
]


class DetectionParams(NamedTuple):
    """Runtime numbers of the detection and clutter models (scalars, may be traced)."""

    k_snr: jax.Array  # SNR(d) = k_snr / d⁴ [m⁴]; [] or [N, 1] per radar (a mixed fleet)
    pfa: jax.Array  # false-alarm probability per resolution cell of the detector
    fixed_pd: jax.Array  # Pd of model "fixed"
    clutter_rate: jax.Array  # expected false alarms per scan per radar (λ_c·(r_max − r_min))
    clutter_min: jax.Array  # clutter range window [m] (one-way range)
    clutter_max: jax.Array
    gate: jax.Array  # validation gate γ: ν² / S < γ (chi-square quantile of gate_probability)
    gate_probability: jax.Array  # P_G


def detection_probability(snr_linear, pfa):
    """Swerling I, square-law, one pulse: ``Pd = pfa ** (1 / (1 + snr))``.

    Args:
        snr_linear: ``[...]`` mean SNR (linear, >= 0).
        pfa: false-alarm probability in (0, 1), scalar or broadcastable.

    Returns:
        ``[...]`` detection probability in [pfa, 1).
    """
    snr = jnp.asarray(snr_linear)
    pfa = jnp.asarray(pfa, jnp.result_type(snr, float))
    return jnp.exp(jnp.log(pfa) / (1.0 + snr))


def snr_constant(radar_eq, n_targets: int, gain_db: float = 0.0) -> float:
    """``k_snr = 10^((snr_db + gain_db)/10) / M · R_ref⁴`` [m⁴] (host float64)."""
    snr_ref = 10.0 ** ((float(radar_eq.snr_db) + float(gain_db)) / 10.0) / int(n_targets)
    return snr_ref * float(radar_eq.r_ref) ** 4


def chi2_quantile(p: float, dof: int) -> float:
    """Chi-square quantile (host): the validation gate ``γ`` of gate probability ``p``.

    Closed forms for the measurement dimensions used here (no scipy.stats import, ~1 s
    of every start): ``dof = 1``: ``γ = Φ⁻¹((1 + p)/2)²``; ``dof = 2``:
    ``γ = −2 ln(1 − p)``; other ``dof`` through scipy.
    """
    p, dof = float(p), int(dof)
    if dof == 1:
        from statistics import NormalDist

        return NormalDist().inv_cdf(0.5 * (1.0 + p)) ** 2
    if dof == 2:
        return -2.0 * math.log1p(-p)
    from scipy.stats import chi2

    return float(chi2.ppf(p, dof))


def detection_params(det, radar_eq, n_targets: int, dim: int, dtype=None) -> DetectionParams:
    """The :class:`DetectionParams` of a ``[detection]`` table (host float64, returned as
    ``dtype``).

    Args:
        det: the :class:`~mjx_radar.scenario.schema.DetectionConfig`.
        radar_eq: the :class:`~mjx_radar.scenario.schema.RadarEquation` of every radar, or
            a tuple of N, one per radar (a mixed fleet: ``k_snr`` ``[N, 1]``).
        n_targets: M (the noise power carries the factor M, SPEC §1).
        dim: the measurement's dimension (1: range, 2: range and azimuth; the gate).
    """
    dt = dtype or jnp.result_type(float)
    if isinstance(radar_eq, tuple | list):  # a mixed fleet: k_snr [N, 1]
        k = np.array([[snr_constant(eq, n_targets, det.gain_db)] for eq in radar_eq])
    else:
        k = snr_constant(radar_eq, n_targets, det.gain_db)
    width = max(det.clutter_range_max - det.clutter_range_min, 0.0)
    vals = (
        k,
        det.pfa,
        det.fixed_pd,
        det.clutter_density * width,
        det.clutter_range_min,
        det.clutter_range_max,
        chi2_quantile(det.gate_probability, dim),
        det.gate_probability,
    )
    if not all(np.all(np.isfinite(v)) for v in vals):
        raise ValueError("detection parameters must be finite")
    return DetectionParams(*(jnp.asarray(v, dt) for v in vals))


def pair_probability(model: str, params: DetectionParams, d2):
    """Pd of pairs at squared one-way ranges ``d2`` [m²] (any shape).

    Args:
        model: ``"swerling1"`` or ``"fixed"`` (static; ``"perfect"`` gives ones).
        params: :class:`DetectionParams`.
        d2: ``[...]`` squared ranges.

    Returns:
        ``[...]`` Pd.
    """
    d2 = jnp.asarray(d2)
    if model == "perfect":
        return jnp.ones_like(d2)
    if model == "fixed":
        return jnp.broadcast_to(jnp.asarray(params.fixed_pd, d2.dtype), d2.shape)
    if model != "swerling1":
        raise ValueError(f"detection model {model!r} not in perfect, swerling1, fixed")
    # k/d⁴ as (k/d²)/d² keeps float32 in range for d from ~1 m to ~1e5 m.
    snr = (params.k_snr.astype(d2.dtype) / d2) / d2
    return detection_probability(snr, params.pfa)


def sample_detections(key, pd):
    """Detection draws ``U < Pd`` with ``U ~ Uniform[0, 1)`` of ``pd``'s shape (bool)."""
    pd = jnp.asarray(pd)
    return jax.random.uniform(key, pd.shape, pd.dtype) < pd


def draw_pairs(model: str, params: DetectionParams, key, radar_pos, target_pos):
    """Detections of every radar-target pair at one scan (truth geometry).

    Args:
        model: ``"swerling1"`` or ``"fixed"`` (static).
        params: :class:`DetectionParams`.
        key: the scan's key of the detection stream.
        radar_pos: ``[N, 3]``; target_pos: ``[M, 3]`` true positions.

    Returns:
        ``[N, M]`` bool, True where the pair is detected.
    """
    diff = target_pos[None, :, :] - radar_pos[:, None, :]
    return sample_detections(key, pair_probability(model, params, jnp.sum(diff**2, -1)))


def planner_weights(model: str, params: DetectionParams, radar_pos, target_xyz, factor=None):
    """Expected-information weights of every radar and point: ``w = Pd(d) · q``.

    A measurement that arrives with probability Pd carries the Fisher information J of
    a detected pair, so the expected FIM of the scan is ``Σ_n Pd_n J_n`` (the
    information-reduction factor of Pd < 1 without clutter, Niu, Willett & Bar-Shalom
    2001). ``factor`` (clutter) multiplies it by the PDA reduction ``q(Pd, λ)``
    (:mod:`mjx_radar.estimation.data_association.pda`).

    Args:
        model: ``"swerling1"`` or ``"fixed"`` (static).
        params: :class:`DetectionParams`.
        radar_pos: ``[..., N, 3]`` radar positions.
        target_xyz: ``(x, y, z)`` point coordinates, each ``[..., K]``.
        factor: optional ``factor(pd[..., N, K], d2[..., N, K]) -> [..., N, K]`` replacing
            Pd (clutter: :func:`mjx_radar.estimation.data_association.pda.planner_factor`).

    Returns:
        ``[..., N, K]`` weights (the ``mask`` of
        :func:`mjx_radar.estimation.sensor.measurement.information_components`).
    """
    radar_pos = jnp.asarray(radar_pos)
    d2 = sum(
        (jnp.asarray(target_xyz[c])[..., None, :] - radar_pos[..., :, c : c + 1]) ** 2
        for c in range(3)
    )  # [..., N, K]
    pd = pair_probability(model, params, d2)
    return pd if factor is None else factor(pd, d2)
