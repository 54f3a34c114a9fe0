"""A measurement model as the CKF's functions (docs/measurement.md, "CKF"): the stacked
measurement function ``h``, the diagonal noise covariance ``R`` and the residual of flat
stacked measurements (angle components wrapped) for
:func:`mjx_radar.estimation.filters.ckf.update`."""

from __future__ import annotations

import jax.numpy as jnp

from mjx_radar.estimation.sensor.measurement import MeasurementModel
from mjx_radar.estimation.sensor.noise import NoiseParams, per_row


def measurement_function(model: MeasurementModel, radar_pos):
    """CKF measurement function ``h(x[6M]) -> [N·M·dim]`` (row-major n, m, component)."""
    radar_pos = jnp.asarray(radar_pos)

    def h(x):
        return model.predict(radar_pos, jnp.reshape(x, (-1, 6))[:, :3]).reshape(-1)

    return h


def noise_cov_fn(model: MeasurementModel, params: NoiseParams, ccr):
    """``R(ẑ[p]) -> [p, p]`` diagonal, ``p = N·M·dim``, for :func:`ckf.update`."""

    def R(z_hat):  # rows radar-major: a mixed fleet's constants per row
        z = z_hat.reshape(-1, model.dim)
        return jnp.diag(model.variance(z, per_row(params, z.shape[0]), ccr).reshape(-1))

    return R


def flat_residual(model: MeasurementModel):
    """Residual of flat stacked measurements ``(a[p], b[p]) -> [p]`` for :func:`ckf.update`."""

    def residual(a, b):
        a, b = jnp.asarray(a), jnp.broadcast_to(jnp.asarray(b), jnp.shape(a))
        return model.residual(a.reshape(-1, model.dim), b.reshape(-1, model.dim)).reshape(-1)

    return residual
