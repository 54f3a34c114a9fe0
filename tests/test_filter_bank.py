"""Tests of the per-target CKF bank against the joint CKF and a textbook Kalman filter."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_radar.estimation.filters import ckf, filter_bank
from mjx_radar.estimation.sensor import sensing
from mjx_radar.physics import motion
from mjx_radar.scenario.schema import RadarEquation

N, M = 3, 4


def _problem(rng, m=M, n=N, p0=None):
    """Targets near the origin, radars at z = 0 >= 150 m away, SPD 6×6 prior blocks."""
    truth = np.c_[
        rng.uniform(-80, 80, (m, 2)), rng.uniform(40, 80, m), rng.uniform(-20, 20, (m, 3))
    ]
    ang = rng.uniform(0, 2 * np.pi, n)
    rad = rng.uniform(150, 400, n)
    radars = np.c_[rad * np.cos(ang), rad * np.sin(ang), np.zeros(n)]
    if p0 is None:
        g = rng.normal(size=(m, 6, 6))
        covs = g @ np.swapaxes(g, 1, 2) + 2.0 * np.eye(6)
    else:
        covs = np.stack([p0 * np.eye(6)] * m)
    means = truth + np.stack([rng.multivariate_normal(np.zeros(6), c) for c in covs])
    return truth, radars, means, covs


def _linear_pair(r, x6):
    """Direct 3-D position measurement relative to the radar (linear, p = 3)."""
    return x6[:3] - r


def _joint_linear_h(radars, m):
    def h(x):
        pos = x.reshape(m, 6)[:, :3]
        return (pos[None, :, :] - radars[:, None, :]).reshape(-1)  # [N*M*3], (n, m, i)

    return h


def _kalman(mean, cov, z, H, R):
    """Textbook KF update in numpy float64 (the Kalman gain form)."""
    S = H @ cov @ H.T + R
    K = cov @ H.T @ np.linalg.inv(S)
    return mean + K @ (z - H @ mean), cov - K @ S @ K.T


def _linear_setup(rng, mask=None):
    truth, radars, means, covs = _problem(rng)
    var = rng.uniform(0.5, 4.0, (N, 3))  # per radar and axis, shared by targets
    z = truth[None, :, :3] - radars[:, None, :] + rng.normal(size=(N, M, 3)) * np.sqrt(var)[:, None]
    r_target = np.diag(var.reshape(-1))  # [N*3, N*3], rows n*3 + i
    r_joint = np.diag(np.broadcast_to(var[:, None, :], (N, M, 3)).reshape(-1))
    H = np.zeros((N, M, 3, M, 6))  # z[n, m, i] = x[m, i] - r[n, i]
    for m in range(M):
        H[:, m, :, m, :3] = np.eye(3)
    H = H.reshape(N * M * 3, 6 * M)
    offs = np.broadcast_to(-radars[:, None, :], (N, M, 3)).reshape(-1)
    return radars, means, covs, z, r_target, r_joint, H, offs


@jax.jit  # one program per test (suite time: eager ops compile one by one)
def _linear_updates(radars, means, covs, z, r_t, r_j):
    mean, cov = filter_bank.bank_to_joint(means, covs)
    jm, jc = ckf.update(mean, cov, z.reshape(-1), _joint_linear_h(jnp.asarray(radars), M), r_j)
    bm, bc = filter_bank.update_bank(
        jnp.asarray(means), jnp.asarray(covs), z, jnp.asarray(radars), _linear_pair, r_t
    )
    return mean, cov, jm, jc, filter_bank.bank_to_joint(bm, bc)


def test_linear_bank_equals_joint_ckf_and_kalman():
    rng = np.random.default_rng(1)
    radars, means, covs, z, r_t, r_j, H, offs = _linear_setup(rng)
    with jax.enable_x64(True):
        mean, cov, jm, jc, (bm, bc) = _linear_updates(radars, means, covs, z, r_t, r_j)
        assert bm.dtype == jnp.float64
    km, kc = _kalman(np.asarray(mean), np.asarray(cov), z.reshape(-1) - offs, H, r_j)
    # float64 round-off of 6x6 / 12x12 solves with condition numbers ~1e2: 1e-11 is tight.
    np.testing.assert_allclose(bm, km, rtol=0, atol=1e-11 * np.abs(km).max())
    np.testing.assert_allclose(jm, km, rtol=0, atol=1e-11 * np.abs(km).max())
    np.testing.assert_allclose(bc, kc, rtol=0, atol=1e-11 * np.abs(kc).max())
    np.testing.assert_allclose(jc, kc, rtol=0, atol=1e-11 * np.abs(kc).max())
    assert np.abs(km - np.asarray(mean)).max() > 0.1  # the update did something


def test_predict_bank_equals_joint_and_closed_form():
    rng = np.random.default_rng(2)
    _, _, means, covs = _problem(rng)
    with jax.enable_x64(True):
        a6 = motion.cv_transition(0.025, 1)
        q6 = motion.cv_process_noise(0.025, 10.0, 1)
        a, q = motion.cv_transition(0.025, M), motion.cv_process_noise(0.025, 10.0, M)

        @jax.jit  # one program (suite time: eager ops compile one by one)
        def predictions(means, covs):
            mean, cov = filter_bank.bank_to_joint(means, covs)
            jm, jc = ckf.predict(mean, cov, lambda x: a @ x, q)
            return mean, cov, (jm, jc), filter_bank.predict_joint(mean, cov, a6, q6)

        mean, cov, (jm, jc), (bm, bc) = predictions(means, covs)
    a, q = np.asarray(a), np.asarray(q)
    cov = np.asarray(cov)
    km, kc = a @ np.asarray(mean), a @ cov @ a.T + q
    for got_m, got_c in ((bm, bc), (jm, jc)):
        np.testing.assert_allclose(got_m, km, rtol=0, atol=1e-12 * np.abs(km).max())
        np.testing.assert_allclose(got_c, kc, rtol=0, atol=1e-12 * np.abs(kc).max())


def test_joint_bank_round_trip():
    rng = np.random.default_rng(3)
    _, _, means, covs = _problem(rng)
    mean, cov = jax.jit(filter_bank.bank_to_joint)(means, covs)
    assert cov.shape == (6 * M, 6 * M)
    dense = np.zeros((6 * M, 6 * M), np.float32)
    for m in range(M):
        dense[6 * m : 6 * m + 6, 6 * m : 6 * m + 6] = covs[m]
    np.testing.assert_array_equal(np.asarray(cov), dense)
    back_m, back_c = _joint_to_bank(mean, cov)
    np.testing.assert_array_equal(back_m, np.asarray(means, np.float32))
    np.testing.assert_array_equal(back_c, np.asarray(covs, np.float32))


_joint_to_bank = jax.jit(filter_bank.joint_to_bank)  # one program per shape and dtype


@jax.jit  # one program for every p0 (suite time: eager ops compile one by one)
def _range_update_pair(seed, radars, truth, means, covs, c):
    z = sensing.sample_ranges(jax.random.PRNGKey(seed), radars, truth[:, :3], c)
    mean, cov = filter_bank.bank_to_joint(means, covs)
    jm, jc = ckf.update(
        mean, cov, z, sensing.range_model(radars), lambda zh: sensing.ddr_noise_cov(zh, c)
    )
    bm, bc = filter_bank.update_ranges(mean, cov, z, jnp.asarray(radars), filter_bank.ddr_R(c))
    return mean, jm, jc, bm, bc


def _range_updates(p0, seed=4):
    rng = np.random.default_rng(seed)
    truth, radars, means, covs = _problem(rng, p0=p0)
    c = sensing.noise_constant(RadarEquation(), M)
    with jax.enable_x64(True):
        out = _range_update_pair(seed, radars, truth, means, covs, c)
    return tuple(np.asarray(a) for a in out)


def _rel_diffs(p0, **kw):
    mean, jm, jc, bm, bc = _range_updates(p0, **kw)
    _, jblocks = _joint_to_bank(jm, jc)
    _, bblocks = _joint_to_bank(bm, bc)
    d_mean = np.abs(jm - bm).max() / np.abs(bm - mean).max()  # relative to the update
    d_cov = np.abs(np.asarray(jblocks) - np.asarray(bblocks)).max() / np.abs(bc).max()
    return d_mean, d_cov


def test_range_model_joint_and_bank_agree_to_cubature_order():
    """Both rules are exact to degree 3; they differ by the 4th-order terms of the range.

    The joint rule's points lie at ``√(6M)·σ`` from the mean, so the relative
    difference is about ``(√(6M)·σ / d)²``: with p0 = 0.05 (σ = 0.22 m), M = 4 and
    d >= ~100 m this is ~2e-5; we allow 1e-4 (measured: mean 2.0e-6 of the update,
    cov blocks 2.9e-7; at p0 = 0.5: 2.3e-5 and 2.0e-5). The difference must fall at
    least like σ² (x10 per decade of p0; >= 5 asserted): a bug in the bank would leave
    an O(1) difference that does not vanish.
    """
    dm_small, dc_small = _rel_diffs(0.05)
    dm_big, dc_big = _rel_diffs(0.5)
    assert dm_small < 1e-4 and dc_small < 1e-4, (dm_small, dc_small)
    assert dm_big / dm_small > 5 and dc_big / dc_small > 5, (dm_big, dm_small, dc_big, dc_small)


def test_masks_drop_measurements_like_the_joint_filter():
    rng = np.random.default_rng(5)
    mask = rng.uniform(size=(N, M)) < 0.6
    mask[:, 0] = False  # target 0 unseen: its prior must come back unchanged
    mask[0, 1] = True
    radars, means, covs, z, r_t, r_j, H, offs = _linear_setup(rng)
    keep3 = np.repeat(mask.reshape(-1), 3)
    with jax.enable_x64(True):

        @jax.jit  # one program (suite time: eager ops compile one by one)
        def updates(radars, means, covs, z):
            mean, cov = filter_bank.bank_to_joint(means, covs)
            h = _joint_linear_h(jnp.asarray(radars), M)
            jm, jc = ckf.update(mean, cov, z.reshape(-1), h, r_j, mask=keep3)
            bm, bc = filter_bank.update_bank(
                jnp.asarray(means), jnp.asarray(covs), z, jnp.asarray(radars), _linear_pair, r_t,
                mask,
            )  # fmt: skip
            return mean, cov, jm, jc, filter_bank.bank_to_joint(bm, bc)

        mean, cov, jm, jc, (bm, bc) = updates(radars, means, covs, z)
    # Textbook KF with the masked rows removed.
    km, kc = _kalman(
        np.asarray(mean),
        np.asarray(cov),
        (z.reshape(-1) - offs)[keep3],
        H[keep3],
        r_j[keep3][:, keep3],
    )
    tol = 1e-11 * np.abs(km).max()
    np.testing.assert_allclose(bm, km, rtol=0, atol=tol)
    np.testing.assert_allclose(jm, km, rtol=0, atol=tol)
    np.testing.assert_allclose(bc, kc, rtol=0, atol=1e-11 * np.abs(kc).max())
    np.testing.assert_array_equal(np.asarray(bm)[:6], means[0])
    np.testing.assert_array_equal(np.asarray(bc)[:6, :6], covs[0])


@jax.jit  # one program for both radars (suite time: eager ops compile one by one)
def _mask_and_removal(radars, truth, means, covs, c, mask, others):
    z = sensing.sample_ranges(jax.random.PRNGKey(0), radars, truth[:, :3], c)
    z = z.reshape(N, M, 1)
    args = (jnp.asarray(means), jnp.asarray(covs))
    r = filter_bank.ddr_R(c)
    am, ac = filter_bank.update_bank(*args, z, jnp.asarray(radars), filter_bank.range_pair, r, mask)
    rm, rc = filter_bank.update_bank(
        *args, z[others], jnp.asarray(radars[others]), filter_bank.range_pair, r
    )
    return am, ac, rm, rc


@pytest.mark.parametrize("radar", [0, 2])
def test_range_mask_equals_removing_the_radar(radar):
    """Masking every pair of one radar == the bank run without that radar (DDR, float64)."""
    rng = np.random.default_rng(6)
    truth, radars, means, covs = _problem(rng, p0=20.0)
    c = sensing.noise_constant(RadarEquation(), M)
    mask = np.ones((N, M), bool)
    mask[radar] = False
    others = np.delete(np.arange(N), radar)
    with jax.enable_x64(True):
        am, ac, rm, rc = _mask_and_removal(radars, truth, means, covs, c, mask, others)
    np.testing.assert_allclose(am, rm, rtol=0, atol=1e-10 * np.abs(rm).max())
    np.testing.assert_allclose(ac, rc, rtol=0, atol=1e-10 * np.abs(rc).max())
    assert np.abs(np.asarray(am) - means).max() > 0.1
