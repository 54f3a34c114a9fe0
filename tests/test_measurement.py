"""Tests of the pluggable measurement models (range, range + azimuth)."""

import functools
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_radar.estimation.filters import ckf
from mjx_radar.estimation.filters import measurement_filter as mf
from mjx_radar.estimation.information import fisher
from mjx_radar.estimation.sensor import measurement as me
from mjx_radar.estimation.sensor import sensing
from mjx_radar.scenario.schema import MeasurementConfig, RadarEquation, Scenario

RADARS = np.array([[0.0, 0.0, 0.0], [200.0, 100.0, 0.0], [-150.0, 250.0, 0.0]])
TARGETS = np.array([[10.0, 20.0, 50.0], [-300.0, 5.0, 60.0], [40.0, -80.0, 70.0], [5, 300, 45]])
RA = me.RangeAzimuthModel()


def _params(c=7.285e-10, sigma_r2=0.18, c_az=3.43e-12, sigma_az2=8.4e-4):
    return me.NoiseParams(*(jnp.asarray(v) for v in (c, sigma_r2, c_az, sigma_az2)))


def test_noise_params_from_radar_equation():
    """C is SPEC §1's; c_az follows sigma_phi = theta / (k_m sqrt(2 SNR(d)))."""
    scen = Scenario(name="t", n_radars=3, target_init=((0.0,) * 6,) * 4)
    with jax.enable_x64(True):
        p = me.noise_params(scen)
        assert float(p.c) == pytest.approx(sensing.noise_constant(RadarEquation(), 4), rel=1e-12)
        assert float(p.sigma_r2) == pytest.approx(float(p.c) * 125.0**4, rel=1e-12)
        # SNR at 300 m from the radar equation directly: P_r(d) / sigma_a^2.
        eq, d = RadarEquation(), 300.0
        snr = sensing.radar_constant(eq) / d**4 / sensing.noise_power(eq, 4)
        sigma_phi = math.radians(3.0) / (1.6 * math.sqrt(2.0 * snr))
        assert float(p.c_az) * d**4 == pytest.approx(sigma_phi**2, rel=1e-12)
        assert float(p.sigma_az2) == pytest.approx(float(p.c_az) * 125.0**4, rel=1e-12)
        wide = me.noise_params(eq, 4, 125.0, MeasurementConfig(beamwidth_deg=6.0))
        assert float(wide.c_az) == pytest.approx(4.0 * float(p.c_az), rel=1e-12)
    with pytest.raises(ValueError):
        me.make_model("doppler")


def test_range_model_reproduces_sensing_and_fisher():
    """RangeModel is the existing SPEC §1/§5 code: bit-identical h, R, draws; same FIM."""
    m, p = me.make_model("range"), _params()
    x = jnp.asarray(np.concatenate([TARGETS, np.ones_like(TARGETS)], 1).reshape(-1), jnp.float32)
    radars = jnp.asarray(RADARS, jnp.float32)
    key = jax.random.PRNGKey(3)
    targets = jnp.asarray(TARGETS, jnp.float32)

    @jax.jit  # one program per side (suite time: eager ops compile one by one)
    def old(x, radars, key, targets, p):
        h_old = sensing.range_model(radars)(x)
        ddr, ccr = sensing.ddr_noise_cov(h_old, p.c), sensing.ccr_noise_cov(12, p.sigma_r2)
        return h_old, ddr, ccr, sensing.sample_ranges(key, radars, targets, p.c)

    @jax.jit
    def new(x, radars, h_old, key, targets, p, true):
        ddr, ccr = mf.noise_cov_fn(m, p, False)(h_old), mf.noise_cov_fn(m, p, true)(h_old)
        z_new = m.sample(key, radars, targets, p)
        z_ra = RA.sample(key, radars, targets, p)
        return mf.measurement_function(m, radars)(x), ddr, ccr, z_new, z_ra

    h_old, ddr_old, ccr_old, z_old = old(x, radars, key, targets, p)
    h_new, ddr_new, ccr_new, z_new, z_ra = new(x, radars, h_old, key, targets, p, jnp.asarray(True))
    np.testing.assert_array_equal(h_new, h_old)
    np.testing.assert_array_equal(ddr_new, ddr_old)
    np.testing.assert_array_equal(ccr_new, ccr_old)
    assert z_new.shape == (3, 4, 1)
    np.testing.assert_array_equal(z_new.reshape(-1), z_old)
    # The range part of the range-azimuth draw uses the key identically (common random numbers).
    np.testing.assert_array_equal(z_ra[..., 0], z_new[..., 0])
    mask = np.array([[1, 0, 1, 1], [1, 1, 0, 1], [0, 1, 1, 1]], bool)

    @jax.jit  # one program per side (suite time: eager ops compile one by one)
    def information(p, mask):
        dense = functools.partial(me.information_dense, m, RADARS, TARGETS, p)
        return dense(False), dense(True), dense(False, mask)

    @jax.jit
    def references(p, mask):
        sfim = functools.partial(fisher.sfim, RADARS, TARGETS, p.c)
        return sfim(), fisher.sfim_ccr(RADARS, TARGETS, p.sigma_r2), sfim(mask)

    with jax.enable_x64(True):
        p64 = _params()
        got, want = information(p64, mask), references(p64, mask)
    for dense, ref in zip(got, want, strict=True):  # DDR, CCR, DDR with a mask
        np.testing.assert_allclose(dense, ref, rtol=1e-12)


_information_dense = jax.jit(me.information_dense, static_argnums=0)  # ccr traced


@functools.partial(jax.jit, static_argnums=(0, 4))  # one program for every pair
def _closed_form(model, radar, target, params, ccr):
    """Second implementation: J = Jμᵀ R⁻¹ Jμ + ½ tr(R⁻¹ ∂R R⁻¹ ∂R), derivatives by autodiff."""

    def mu(p):
        return model.predict(radar[None], p[None])[0, 0]

    def var(p):
        return model.variance(mu(p), params, ccr)

    jm, jv, v = jax.jacobian(mu)(target), jax.jacobian(var)(target), var(target)
    return jm.T @ (jm / v[:, None]) + 0.5 * jv.T @ (jv / v[:, None] ** 2)


@pytest.mark.parametrize("ccr", [False, True])
def test_range_azimuth_information_matches_autodiff_closed_form(ccr):
    """pair_information/information == Σ_n Jμᵀ R⁻¹ Jμ + ½ tr-terms (x64, rtol 1e-10)."""
    with jax.enable_x64(True):
        for params in (_params(), _params(c=2e-5, sigma_r2=4.0, c_az=4e-8, sigma_az2=0.3)):
            want = sum(
                jnp.stack([_closed_form(RA, r, t, params, ccr) for t in jnp.asarray(TARGETS)])
                for r in jnp.asarray(RADARS)
            )
            got = _information_dense(RA, RADARS, TARGETS, params, jnp.asarray(ccr))
            np.testing.assert_allclose(got, want, rtol=1e-10, atol=1e-12 * float(jnp.max(want)))
            jitted = jax.jit(me.information, static_argnums=0)
            packed = jitted(RA, RADARS, TARGETS, params, jnp.asarray(ccr))
            np.testing.assert_allclose(fisher.unpack_sym3(packed), want, rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("ccr", [False, True])
def test_range_azimuth_information_is_score_covariance(ccr):
    """J equals E[s sᵀ] of the Gaussian log-likelihood score (200k draws, x64, ≤ 4.5 SE).

    Large noise constants make the variance terms (8 u uᵀ/r², range and azimuth) a sizeable
    part of J, and the test shows that J without them is rejected by the same criterion.
    """
    radar, target = jnp.array([30.0, -20.0, 0.0]), jnp.array([-60.0, 55.0, 40.0])
    n = 200_000

    @jax.jit  # one program (suite time: eager ops compile one by one)
    def score_moments(radar, target, params):
        var_true = RA.variance(RA.predict(radar[None], target[None])[0, 0], params, ccr)

        def loglik(p, z):
            mu = RA.predict(radar[None], p[None])[0, 0]
            v = RA.variance(mu, params, ccr)
            return -0.5 * jnp.sum((z - mu) ** 2 / v + jnp.log(v))

        eps = jax.random.normal(jax.random.PRNGKey(11), (n, 2), jnp.float64)
        zs = RA.predict(radar[None], target[None])[0, 0] + jnp.sqrt(var_true) * eps  # unwrapped
        s = jax.vmap(jax.grad(loglik), in_axes=(None, 0))(target, zs)  # [n, 3]
        prods = (s[:, :, None] * s[:, None, :]).reshape(n, 9)
        est, se = jnp.mean(prods, 0), jnp.std(prods, 0) / math.sqrt(n)
        J = me.information_dense(RA, radar[None], target[None], params, ccr)[0].reshape(9)
        return est, se, J

    with jax.enable_x64(True):
        params = _params(c=3e-5, sigma_r2=4.0e2, c_az=5e-8, sigma_az2=0.05)
        est, se, J = score_moments(radar, target, params)
        z_score = np.abs(np.asarray(est - J)) / np.asarray(se)
        assert np.all(z_score < 4.5), z_score
        if not ccr:  # power: dropping the 8 u uᵀ / r² variance terms is detected
            d = target - radar
            r2 = jnp.sum(d**2)
            J_mean_only = J - (2 * 8.0 / r2**2 * jnp.outer(d, d)).reshape(9)
            assert np.max(np.abs(np.asarray(est - J_mean_only)) / np.asarray(se)) > 20.0


def test_residual_wraps_azimuth():
    a, b = jnp.array([[10.0, math.pi - 0.1]]), jnp.array([[4.0, -math.pi + 0.1]])
    np.testing.assert_allclose(RA.residual(a, b), [[6.0, -0.2]], atol=1e-6)
    assert float(me.wrap_angle(jnp.asarray(-math.pi))) == pytest.approx(math.pi)
    r = mf.flat_residual(RA)(a.reshape(-1), b.reshape(-1))
    np.testing.assert_allclose(r, [6.0, -0.2], atol=1e-6)


def _rot(theta, n_targets):
    c, s = math.cos(theta), math.sin(theta)
    r3 = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return r3, np.kron(np.eye(2 * n_targets), r3)


def test_ckf_azimuth_branch_cut_is_rotation_invariant():
    """Branch cut at ±π: wrapped update == the pi/2-rotated geometry's update, rotated back.

    With P isotropic in x-y a rotation by pi/2 permutes the cubature points, so the two
    updates see the same point set and must agree to round-off. The naive (unwrapped)
    update averages azimuths ≈ ±π to ≈ 0 and lands far away.
    """
    with jax.enable_x64(True):
        params = _params(c_az=1e-13)
        # Radar 0 (near) fixes the cross-range y through its azimuth; radar 1 is far.
        radars = np.array([[0.0, 0.0, 0.0], [400.0, 400.0, 0.0]])
        truth = np.array([-150.0, 1.0, 50.0, 3.0, -1.0, 0.0])
        mean = truth + np.array([2.0, -8.0, 1.0, 1.0, 0.5, 0.0])
        cov = np.diag([50.0, 50.0, 20.0, 5.0, 5.0, 5.0])
        z = mf.measurement_function(RA, radars)(truth) + jnp.array([0.05, 0.003, -0.3, -0.004])
        z = jnp.asarray(z).at[1].set(me.wrap_angle(z[1]))
        R = mf.noise_cov_fn(RA, params, False)
        res = mf.flat_residual(RA)

        @jax.jit  # one program for both geometries (suite time: eager ops compile one by one)
        def updates(mean, cov, z, radars):
            h = mf.measurement_function(RA, radars)
            zs = jax.vmap(h)(mean + ckf.cubature_offsets(cov))
            naive = ckf.update(mean, cov, z, h, R)  # no residual (asserted below for geometry a)
            return zs, ckf.update(mean, cov, z, h, R, residual=res), naive

        zs, (m_a, P_a), (m_naive, P_naive) = (
            jax.tree_util.tree_map(np.asarray, out) for out in updates(mean, cov, z, radars)
        )
        assert float(np.max(zs[:, 1])) > 3.0 and float(np.min(zs[:, 1])) < -3.0  # straddles

        r3, r6 = _rot(math.pi / 2, 1)
        radars_b = radars @ r3.T
        z_b = (
            z.at[1]
            .set(me.wrap_angle(z[1] + math.pi / 2))
            .at[3]
            .set(me.wrap_angle(z[3] + math.pi / 2))
        )
        _, (m_b, P_b), _ = updates(r6 @ mean, r6 @ cov @ r6.T, z_b, radars_b)
        np.testing.assert_allclose(r6 @ m_a, m_b, atol=1e-8)
        np.testing.assert_allclose(r6 @ P_a @ r6.T, P_b, atol=1e-8 * float(np.max(P_b)))
        assert float(np.linalg.norm(m_a[:3] - truth[:3])) < 1.5  # prior error 8.3 m

        # Naive: ẑ_φ ≈ 0, Pzz_φ ≈ π², the azimuth is ignored; y stays ~7.7 m off (P_yy 20 vs 1.3).
        assert float(np.linalg.norm(m_naive[:3] - m_a[:3])) > 5.0
        assert float(P_naive[1, 1]) > 5.0 * float(P_a[1, 1])


def test_ckf_without_residual_is_unchanged_by_identity_residual():
    """An identity residual (plain subtraction) gives the same update up to round-off."""
    with jax.enable_x64(True):
        h = mf.measurement_function(RA, RADARS)
        x = np.concatenate([TARGETS[:2], np.zeros((2, 3))], 1).reshape(-1)
        cov = np.eye(12) * 30.0
        z = h(x + 1.0)
        R = mf.noise_cov_fn(RA, _params(), False)
        # one program per side (suite time: eager ops compile one by one)
        m0, P0 = jax.jit(lambda x, cov, z: ckf.update(x, cov, z, h, R))(x, cov, z)
        m1, P1 = jax.jit(
            lambda x, cov, z: ckf.update(x, cov, z, h, R, residual=lambda a, b: a - b)
        )(x, cov, z)
        np.testing.assert_allclose(m0, m1, rtol=1e-12)
        np.testing.assert_allclose(P0, P1, rtol=1e-10, atol=1e-12)


def test_ckf_range_azimuth_static_targets_converge():
    """100 DDR range-azimuth updates of two static targets (one on the ±π cut), 16 seeds.

    Median position error falls from ≈ √150 ≈ 12 m (prior draw) to < 25% of it, every
    run stays finite, and every posterior position std falls below 35% of the prior √50 m
    (the worst, z, ends ≈ 1.9 m). (No NEES bound:
    with no process noise and ground radars the CKF is overconfident in z for the range
    model as well: mean NEES ≈ 6 and ≈ 70 for range, ≈ 6 and ≈ 55 for range-azimuth.)
    """
    with jax.enable_x64(True):
        scen = Scenario(name="t", n_radars=3, target_init=((0.0,) * 6,) * 2)
        params = me.noise_params(scen)
        radars = jnp.array([[0.0, 0.0, 0.0], [150.0, -200.0, 0.0], [-50.0, 150.0, 0.0]])
        truth_pos = jnp.array([[-180.0, 0.5, 60.0], [60.0, 170.0, 45.0]])
        truth = jnp.concatenate([truth_pos, jnp.zeros((2, 3))], 1).reshape(-1)
        pos_mask = jnp.tile(jnp.array([1.0, 1, 1, 0, 0, 0]), 2)
        cov0 = jnp.diag(jnp.tile(jnp.array([50.0, 50, 50, 1e-6, 1e-6, 1e-6]), 2))
        h = mf.measurement_function(RA, radars)
        R, res = mf.noise_cov_fn(RA, params, False), mf.flat_residual(RA)

        def run(key):
            mean0 = truth + jnp.sqrt(50.0) * jax.random.normal(key, (12,)) * pos_mask

            def body(carry, k):
                z = RA.sample(k, radars, truth_pos, params).reshape(-1)
                return ckf.update(*carry, z, h, R, residual=res), None

            keys = jax.random.split(jax.random.fold_in(key, 1), 100)
            (m, P), _ = jax.lax.scan(body, (mean0, cov0), keys)
            err = lambda x: jnp.linalg.norm((x - truth).reshape(2, 6)[:, :3], axis=1)  # noqa: E731
            return err(mean0), err(m), jnp.diag(P).reshape(2, 6)[:, :3], m

        e0, e1, var, m = jax.jit(jax.vmap(run))(jax.random.split(jax.random.PRNGKey(0), 16))
        assert bool(jnp.all(jnp.isfinite(m))) and bool(jnp.all(jnp.isfinite(var)))
        e0, e1 = np.median(np.asarray(e0), 0), np.median(np.asarray(e1), 0)
        assert np.all(e1 < 0.25 * e0), (e0, e1)
        assert float(jnp.max(jnp.sqrt(var))) < 0.35 * math.sqrt(50.0)  # z: ≈ 1.9 m


def test_information_float32_finite_above_radar_and_batched():
    """ρ = 0 (target straight above a radar) gives finite float32 info; batch dims broadcast."""
    p = _params()
    radars = jnp.asarray(RADARS, jnp.float32)
    targets = jnp.asarray(TARGETS, jnp.float32).at[0].set(jnp.array([0.0, 0.0, 60.0]))
    information = jax.jit(me.information, static_argnums=(0, 4))  # ccr static, as a bool
    for ccr in (False, True):
        info = information(RA, radars, targets, p, ccr)
        assert info.dtype == jnp.float32 and bool(jnp.all(jnp.isfinite(info)))
    batch = jnp.stack([targets, targets + 5.0])  # [2, M, 3] against radars [N, 3]
    got = jax.jit(me.information, static_argnums=0)(RA, radars, batch, p, jnp.asarray(False))
    assert got.shape == (2, 4, 6)
    np.testing.assert_allclose(got[1], information(RA, radars, batch[1], p, False), rtol=1e-6)
