"""Tests of the radar equation and range measurement model (SPEC §1)."""

import dataclasses
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_radar.estimation.sensor import sensing
from mjx_radar.scenario.schema import RadarEquation

P = RadarEquation()
RADARS = np.array([[-200.0, 150.0, 0.0], [300.0, -50.0, 0.0], [10.0, -350.0, 0.0]])
TARGETS = np.array([[0.0, 0.0, 55.0], [15.4, 15.32, 70.0], [10.0, 10.0, 55.0], [20.0, 20.0, 45.0]])


@pytest.mark.parametrize("m, expected", [(4, 7.285e-10), (3, 5.464e-10)])
def test_noise_constant_matches_spec(m, expected):
    c = sensing.noise_constant(P, m)
    assert isinstance(c, float)
    # SPEC quotes 4 significant digits: 0.1% is the stated tolerance.
    assert abs(c / expected - 1.0) < 1e-3


def test_snr_calibration_and_spec_sigmas():
    m = 4
    k = sensing.radar_constant(P)
    lam = sensing.SPEED_OF_LIGHT / P.fc
    assert k == pytest.approx(1000 * 200 * 200 * lam**2 / (4 * math.pi) ** 3, rel=1e-12)
    pr = float(sensing.received_power(P, P.r_ref))
    assert pr == pytest.approx(k / P.r_ref**4, rel=1e-6)  # float32 division
    # SNR at R_ref equals snr_db once the factor M is accounted for (float64 host maths).
    snr = 10 * math.log10(m * k / P.r_ref**4 / sensing.noise_power(P, m))
    assert snr == pytest.approx(P.snr_db, abs=1e-9)
    c = sensing.noise_constant(P, m)
    # SPEC §1 quotes sigma(z) ~ 0.42 m at 125 m and ~ 6.7 m at 500 m (2 significant digits).
    assert math.sqrt(c * 125.0**4) == pytest.approx(0.42, abs=0.005)
    assert math.sqrt(c * 500.0**4) == pytest.approx(6.7, abs=0.05)
    assert sensing.ccr_variance(c, 125.0) == pytest.approx(c * 125.0**4, rel=1e-12)


def test_ranges_and_range_model_order():
    d = np.asarray(sensing.ranges(RADARS, TARGETS))
    ref = np.array([[np.linalg.norm(t - r) for t in TARGETS] for r in RADARS])
    np.testing.assert_allclose(d, ref, rtol=1e-6)  # float32 rounding of O(400 m) values
    x = np.concatenate([np.r_[t, 1.0, 2.0, 3.0] for t in TARGETS])
    z = np.asarray(sensing.range_model(RADARS)(jnp.asarray(x)))
    assert z.shape == (12,)
    for n in range(3):
        for m in range(4):
            assert z[n * 4 + m] == pytest.approx(2 * ref[n, m], rel=1e-6)


def test_noise_covariances():
    c = 7e-10
    zh = jnp.array([250.0, 1000.0])
    np.testing.assert_allclose(
        np.asarray(sensing.ddr_noise_cov(zh, c)),
        np.diag(c * np.array([125.0, 500.0]) ** 4),
        rtol=1e-6,
    )
    np.testing.assert_allclose(np.asarray(sensing.ccr_noise_cov(3, 0.5)), 0.5 * np.eye(3))


def test_sample_ranges_independent_per_pair():
    c = 1e-8  # sigma ~ 2-16 m here
    s = 20000
    keys = jax.random.split(jax.random.key(0), s)
    z = np.asarray(
        jax.vmap(lambda k: sensing.sample_ranges(k, RADARS, TARGETS, c))(keys), dtype=np.float64
    )
    d = np.array([[np.linalg.norm(t - r) for t in TARGETS] for r in RADARS]).reshape(-1)
    eps = (z - 2 * d) / np.sqrt(c * d**4)
    # MC standard errors with 20000 samples: mean 0.007, var 0.01, corr 0.007; use ~5 sigma.
    assert np.all(np.abs(eps.mean(0)) < 0.04)
    assert np.all(np.abs(eps.var(0) - 1.0) < 0.05)
    corr = np.corrcoef(eps.T)
    assert np.max(np.abs(corr - np.eye(12))) < 0.04


def test_jit_with_traced_inputs_does_not_validate_values():
    f = jax.jit(lambda d: sensing.received_power(P, d))
    assert np.isfinite(float(f(100.0)))


@pytest.mark.parametrize(
    "field, value",
    [
        ("power_tx", -1.0),
        ("gain_tx", 0.0),
        ("gain_rx", -3.0),
        ("fc", 0.0),
        ("rcs", -1.0),
        ("r_ref", 0.0),
        ("loss", -2.0),
        ("snr_db", float("nan")),
    ],
)
def test_bad_radar_equation_raises(field, value):
    bad = dataclasses.replace(P, **{field: value})
    with pytest.raises(ValueError, match=field):
        sensing.noise_constant(bad, 4)
    with pytest.raises(ValueError, match=field):
        sensing.received_power(bad, 100.0)


@pytest.mark.parametrize("m", [0, -1, 2.5])
def test_bad_n_targets_raises(m):
    with pytest.raises(ValueError, match="n_targets"):
        sensing.noise_constant(P, m)


@pytest.mark.parametrize("d", [0.0, -5.0, np.array([10.0, 0.0])])
def test_nonpositive_range_raises(d):
    with pytest.raises(ValueError, match="range"):
        sensing.received_power(P, d)


def test_wrong_shapes_raise():
    with pytest.raises(ValueError, match="radar_pos"):
        sensing.ranges(np.zeros((3, 2)), TARGETS)
    with pytest.raises(ValueError, match="target_pos"):
        sensing.ranges(RADARS, np.zeros(3))
    with pytest.raises(ValueError, match="radar_pos"):
        sensing.range_model(np.zeros(3))
    with pytest.raises(ValueError, match="state"):
        sensing.range_model(RADARS)(jnp.zeros(7))
    with pytest.raises(ValueError, match="z_hat"):
        sensing.ddr_noise_cov(jnp.zeros((2, 2)), 1e-9)
    with pytest.raises(ValueError, match="radar_pos"):
        sensing.sample_ranges(jax.random.key(0), np.zeros((2, 4)), TARGETS, 1e-9)
