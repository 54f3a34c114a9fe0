"""Pluggable radar measurement models: range (SPEC §1) and range + azimuth.

A model maps radar positions ``[N, 3]`` and target positions ``[M, 3]`` to one
measurement vector of ``dim`` components per pair, ``z[N, M, dim]``; stacked for
the CKF row-major ``(n, m, component)``. With ``d = p_T − p_R``, ``r = ‖d‖``,
``u = d / r``, ``ρ² = d_x² + d_y²``:

* range (``dim = 1``): ``z = 2r + ν_r``, DDR ``var ν_r = C r⁴``, CCR ``σ_R² = C·R2T⁴``.
* range-azimuth (``dim = 2``): additionally ``φ = atan2(d_y, d_x) + ν_φ`` (wrapped to
  (−π, π]), DDR ``var ν_φ = c_az r⁴``, CCR ``σ_φ² = c_az·R2T⁴``; ν_r, ν_φ independent.

Azimuth noise (monopulse). The standard monopulse accuracy is
``σ_φ = θ_3dB / (k_m √(2·SNR(r)))`` with the SNR of the radar equation (SPEC §1,
whose noise power carries the factor M)::

    SNR(r) = P_r(r) / σ_a² = SNR_ref (R_ref / r)⁴,   SNR_ref = 10^(snr_db/10) / M,
    var φ  = θ_3dB² r⁴ / (2 k_m² SNR_ref R_ref⁴) = c_az r⁴.

Fisher information of one pair (positions, 3×3). For a Gaussian ``N(μ(p), v(p))``
``J = ∇μ ∇μᵀ / v + ∇v ∇vᵀ / (2 v²)``. Range: ``∇μ = 2u``, ``∇v = 4 C r³ u`` give
``J_r = (4/(C r⁴) + 8/r²) u uᵀ`` (DDR) and ``4 u uᵀ / σ_R²`` (CCR). Azimuth:
``∇φ = (−d_y, d_x, 0) / ρ²``, ``∇v = 4 c_az r³ u`` give
``J_φ = ∇φ ∇φᵀ / (c_az r⁴) + 8 u uᵀ / r²`` (DDR) and ``∇φ ∇φᵀ / σ_φ²`` (CCR). As
ν_r, ν_φ are independent the log-likelihoods add and the cross terms of the score
covariance vanish: ``J = J_r + J_φ``. (The wrap is ignored: valid while σ_φ ≪ π.)
``ρ²`` is floored by :data:`RHO2_EPS` so a target straight above a radar gives
finite numbers (no NaN); azimuth information still grows like 1/ρ² there.

Adding a model: subclass :class:`MeasurementModel` (frozen dataclass, new ``name``
and ``dim``), implement ``predict``, ``variance``, ``sample``, ``residual``,
``pair_information``, and register it (:func:`mjx_radar.estimation.sensor.sensors.register_sensor`).
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np

from mjx_radar.contracts import placeholder
from mjx_radar.estimation.information import fisher
from mjx_radar.estimation.sensor import sensing, sensor_guard
from mjx_radar.estimation.sensor.noise import NoiseParams, at_radar, noise_params, per_pair

__all__ = [  # noqa: RUF022
    "RHO2_EPS",
    "NoiseParams",
    "MeasurementModel",
    "RangeModel",
    "RangeAzimuthModel",
    "make_model",
    "noise_params",
    "wrap_angle",
    "information",
    "information_components",
    "information_dense",
]

RHO2_EPS = 1e-10
"""Floor [m²] on ρ² in ∇φ: bias < 1e-9 for ρ > 1 cm; float32-safe (ρ = 0: 1/ρ⁴ = 1e20)."""


def wrap_angle(a):
    """Wrap angles to (−π, π]: ``π − mod(π − a, 2π)``."""
    return jnp.pi - jnp.mod(jnp.pi - a, 2.0 * jnp.pi)


def _select(ccr, ddr_value, ccr_value):
    """``ccr ? ccr_value : ddr_value`` for a Python or a traced boolean."""
    if isinstance(ccr, (bool, np.bool_)):
        return ccr_value if ccr else ddr_value
    return jnp.where(ccr, ccr_value, ddr_value)


def _diff(radar_pos, target_pos):
    """``d[..., N, M, 3] = target − radar`` in a floating dtype."""
    radar_pos, target_pos = jnp.asarray(radar_pos), jnp.asarray(target_pos)
    dtype = jnp.result_type(radar_pos, target_pos, float)
    return target_pos[..., None, :, :].astype(dtype) - radar_pos[..., :, None, :].astype(dtype)


def _range_terms(x, y, z, params, ccr):
    """Range information as ``g`` with ``J_r = g d dᵀ`` (same arithmetic as fisher)."""
    r2 = x * x + y * y + z * z
    g_ddr = fisher.ddr_weight(params.c)(r2) / r2
    g_ccr = (4.0 / params.sigma_r2) / r2
    return r2, _select(ccr, g_ddr, g_ccr)


def _pack(g, x, y, z):
    return (g * x * x, g * x * y, g * x * z, g * y * y, g * y * z, g * z * z)


@dataclasses.dataclass(frozen=True)
class MeasurementModel:
    """Base class: measurements of one radar-target pair (hashable, static under jit)."""

    name: str = ""
    dim: int = 0

    @placeholder
    def predict(self, radar_pos, target_pos):
        """Noiseless ``h``: ``[..., N, 3]``, ``[..., M, 3]`` -> ``[..., N, M, dim]``."""
        raise NotImplementedError

    @placeholder
    def variance(self, z_hat, params: NoiseParams, ccr):
        """Filter noise variance at a (predicted) measurement ``[..., dim]`` -> ``[..., dim]``."""
        raise NotImplementedError

    @placeholder
    def sample(self, key, radar_pos, target_pos, params: NoiseParams):
        """Truth draw (DDR variances at the true distance) ``-> [N, M, dim]``."""
        raise NotImplementedError

    @placeholder
    def residual(self, a, b):
        """``a − b`` of measurements ``[..., dim]`` (angles wrapped to (−π, π])."""
        raise NotImplementedError

    @placeholder
    def pair_information(self, dx, dy, dz, params: NoiseParams, ccr):
        """Position FIM of one pair from the components of ``d = target − radar``.

        Args:
            dx, dy, dz: ``[...]`` each (one array per coordinate, so a batch of
                pairs is elementwise arithmetic on contiguous arrays: XLA's CPU
                backend vectorises it, an interleaved ``[..., 3]`` layout it does not).
            params: :class:`NoiseParams`.
            ccr: bool (Python or traced).

        Returns:
            The 6 unique entries ``(xx, xy, xz, yy, yz, zz)`` [1/m²], each ``[...]``.
        """
        raise NotImplementedError


@dataclasses.dataclass(frozen=True)
class RangeModel(MeasurementModel):
    """Round-trip range ``z = 2‖d‖`` (SPEC §1); identical numbers to :mod:`sensing`."""

    name: str = "range"
    dim: int = 1

    def predict(self, radar_pos, target_pos):
        d = _diff(radar_pos, target_pos)
        return (2.0 * jnp.sqrt(jnp.sum(d**2, axis=-1)))[..., None]

    def variance(self, z_hat, params, ccr):  # constants scalars or per row [R, 1]
        z_hat = jnp.asarray(z_hat)
        ccr_var = jnp.broadcast_to(jnp.asarray(params.sigma_r2, z_hat.dtype), z_hat.shape)
        return _select(ccr, params.c * (z_hat / 2.0) ** 4, ccr_var)

    def sample(self, key, radar_pos, target_pos, params):
        c = per_pair(params.c, jnp.shape(target_pos)[0])
        z = sensing.sample_ranges(key, radar_pos, target_pos, c)
        return z.reshape(jnp.shape(radar_pos)[0], jnp.shape(target_pos)[0], 1)

    def residual(self, a, b):
        return a - b

    def pair_information(self, dx, dy, dz, params, ccr):
        _, g = _range_terms(dx, dy, dz, params, ccr)
        return _pack(g, dx, dy, dz)


@dataclasses.dataclass(frozen=True)
class RangeAzimuthModel(MeasurementModel):
    """Round-trip range and azimuth ``atan2(d_y, d_x)`` (monopulse noise, module doc)."""

    name: str = "range-azimuth"
    dim: int = 2

    def predict(self, radar_pos, target_pos):
        d = _diff(radar_pos, target_pos)
        rng = 2.0 * jnp.sqrt(jnp.sum(d**2, axis=-1))
        return jnp.stack([rng, jnp.arctan2(d[..., 1], d[..., 0])], axis=-1)

    def variance(self, z_hat, params, ccr):  # constants scalars or per row [R, 1]
        q = (jnp.asarray(z_hat)[..., :1] / 2.0) ** 4
        ddr = jnp.concatenate([params.c * q, params.c_az * q], axis=-1)
        const = [
            jnp.broadcast_to(jnp.asarray(v, q.dtype), q.shape)
            for v in (params.sigma_r2, params.sigma_az2)
        ]
        return _select(ccr, ddr, jnp.concatenate(const, axis=-1))

    def sample(self, key, radar_pos, target_pos, params):
        """Range draws use ``key`` as :func:`sensing.sample_ranges`; azimuth ``fold_in(key, 1)``."""
        z = self.predict(radar_pos, target_pos)
        d = z[..., 0] / 2.0
        rng = RangeModel().sample(key, radar_pos, target_pos, params)[..., 0]
        eps = jax.random.normal(jax.random.fold_in(key, 1), d.shape, dtype=d.dtype)
        c_az = jnp.asarray(params.c_az, d.dtype)
        c_az = c_az if c_az.ndim == 0 else c_az[:, None]  # per radar: [N, 1]
        az = wrap_angle(z[..., 1] + jnp.sqrt(c_az) * d**2 * eps)
        return jnp.stack([rng, az], axis=-1)

    def residual(self, a, b):
        r = a - b
        return jnp.stack([r[..., 0], wrap_angle(r[..., 1])], axis=-1)

    def pair_information(self, dx, dy, dz, params, ccr):
        x, y, z = dx, dy, dz
        r2, g = _range_terms(x, y, z, params, ccr)
        # ∇φ∇φᵀ = (y², −xy, 0, x², 0, 0) / ρ⁴, scaled by 1/var(φ); plus 8 u uᵀ / r² (DDR).
        # Products of inverses keep float32 in range for ranges from ~1 m to ~100 km.
        ir, irho = 1.0 / r2, 1.0 / (x * x + y * y + RHO2_EPS)
        a_ddr = ((1.0 / params.c_az) * ir * ir) * (irho * irho)
        a = _select(ccr, a_ddr, (1.0 / params.sigma_az2) * (irho * irho))
        g = g + _select(ccr, 8.0 * ir * ir, jnp.zeros_like(r2))
        xx, xy, xz, yy, yz, zz = _pack(g, x, y, z)
        return (xx + a * y * y, xy - a * x * y, xz, yy + a * x * x, yz, zz)


def make_model(name: str) -> MeasurementModel:
    """The sensor called ``name``, made from :data:`mjx_radar.registry.SENSORS`.

    The same as :func:`mjx_radar.estimation.sensor.sensors.make_sensor` (one-line ``ValueError``
    for an unknown name; a registered sensor's own exceptions as one line).
    """
    return sensor_guard.make(name)


def information_components(model: MeasurementModel, radar_pos, target_xyz, params, ccr, mask=None):
    """Position FIM of every target summed over radars, one array per packed entry.

    The fast layout of the planner's objective: targets as three coordinate arrays
    whose last axis runs over many points, accumulated radar by radar in elementwise
    arithmetic (one fused, vectorised loop; no 3×3 or ``[..., 3]`` temporaries).

    Args:
        model: measurement model.
        radar_pos: ``[..., N, 3]`` radar positions.
        target_xyz: ``(x, y, z)`` target coordinates, each ``[..., K]`` (K targets or
            points; the leading dims broadcast against ``radar_pos``'s).
        params: :class:`NoiseParams`.
        ccr: bool (Python or traced): use the CCR constants instead of DDR.
        mask: optional ``[..., N, K]`` bool/0-1; False pairs contribute nothing.

    Returns:
        ``(xx, xy, xz, yy, yz, zz)`` of ``Σ_n J_nk``, each ``[..., K]`` [1/m²].
    """
    radar_pos = jnp.asarray(radar_pos)
    tx, ty, tz = (jnp.asarray(c) for c in target_xyz)
    acc = None
    for n in range(radar_pos.shape[-2]):
        r = radar_pos[..., n, :]
        term = model.pair_information(
            tx - r[..., 0:1], ty - r[..., 1:2], tz - r[..., 2:3], at_radar(params, n), ccr
        )
        if mask is not None:
            keep = jnp.asarray(mask)[..., n, :]
            term = tuple(t * keep.astype(t.dtype) for t in term)
        acc = term if acc is None else tuple(a + t for a, t in zip(acc, term, strict=True))
    return acc


def information(model: MeasurementModel, radar_pos, target_pos, params, ccr, mask=None):
    """Position FIM of every target summed over radars, packed.

    Args:
        model: measurement model.
        radar_pos: ``[..., N, 3]`` radar positions (broadcast against target batch dims).
        target_pos: ``[..., M, 3]`` target positions.
        params: :class:`NoiseParams`.
        ccr: bool (Python or traced): use the CCR constants instead of DDR.
        mask: optional ``[..., N, M]`` bool/0-1; False pairs contribute nothing.

    Returns:
        ``[..., M, 6]``: ``Σ_n J_nm`` as ``(xx, xy, xz, yy, yz, zz)`` [1/m²].
    """
    radar_pos, target_pos = jnp.asarray(radar_pos), jnp.asarray(target_pos)
    dtype = jnp.result_type(radar_pos, target_pos, float)
    xyz = tuple(target_pos[..., c].astype(dtype) for c in range(3))
    comps = information_components(model, radar_pos.astype(dtype), xyz, params, ccr, mask)
    return jnp.stack(comps, axis=-1)


def information_dense(model: MeasurementModel, radar_pos, target_pos, params, ccr, mask=None):
    """:func:`information` unpacked to symmetric ``[..., M, 3, 3]``."""
    return fisher.unpack_sym3(information(model, radar_pos, target_pos, params, ccr, mask))
