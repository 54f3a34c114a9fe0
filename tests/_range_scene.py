"""A three-radar, three-drone range-only scan shared by the MHT tests (tests/test_mht*.py).

Radars on the ground around three drones a few metres apart at 50 m height; the priors
(``covs``: 6, 5, 7 m² in position) scattered about the truth (seed 5); each radar's
two-way ranges of the drones with 1.2 m noise and three clutter returns near the first
drone's. Float64 model arguments for ``mht.update_bank`` / ``jpda.update_bank``: the
range model, its noise, CCR (constant variances), Pd 0.9, 0.8, 0.7 per drone.
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

RADARS = np.array([[300.0, 40.0, 0.0], [-50.0, 260.0, 0.0], [100.0, -200.0, 0.0]])
TRUTH = np.array([[0.0, 0, 50, 5, 2, 0], [8.0, 3, 55, 4, 3, 0], [3.0, 9, 48, 6, 1, 0]])


def scene():
    """``(means [3, 6], covs [3, 6, 6], zs [3, 6, 1])``: priors and scans (module doc)."""
    rng = np.random.default_rng(5)
    means = TRUTH + rng.normal(0, [2, 2, 2, 1, 1, 1], TRUTH.shape)
    covs = np.stack([np.diag([6.0, 5.0, 7.0, 2.0, 2.0, 2.0])] * 3)
    d = np.linalg.norm(TRUTH[None, :, :3] - RADARS[:, None], axis=-1)
    zs = 2 * d + rng.normal(0, 1.2, d.shape)
    zs = np.concatenate([zs, zs[:, :1] + rng.normal(0, 3, (3, 3))], 1)[..., None]  # clutter
    return means, covs, zs


def model_args(zs):
    """``(zs, valid, radar_pos, model, noise, ccr)`` and ``pd [N, M]`` (call under x64)."""
    from mjx_radar.estimation.sensor.measurement import RangeModel
    from mjx_radar.estimation.sensor.noise import NoiseParams

    one = jnp.float64(1.0)
    noise = NoiseParams(one, jnp.float64(1.5), one, one)
    valid = jnp.ones(zs.shape[:2], bool)
    pd = jnp.asarray([[0.9, 0.8, 0.7]] * 3)
    return (jnp.asarray(zs), valid, jnp.asarray(RADARS), RangeModel(), noise, True), pd
