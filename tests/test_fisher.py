"""Tests of SFIM / PFIM against Monte-Carlo score covariances and a linear Kalman filter."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_radar.estimation.information import fisher
from mjx_radar.estimation.sensor import sensing
from mjx_radar.physics import motion
from mjx_radar.scenario.schema import RadarEquation

C4 = sensing.noise_constant(RadarEquation(), 4)
C3 = sensing.noise_constant(RadarEquation(), 3)

GEOMETRIES = {
    # 3 radars / 4 targets, paper C
    "3r4t": (
        np.array([[-200.0, 150.0, 0.0], [300.0, -50.0, 0.0], [10.0, -350.0, 0.0]]),
        np.array([[0.0, 0.0, 55.0], [15.4, 15.32, 70.0], [10.0, 10.0, 55.0], [20.0, 20.0, 45.0]]),
        C4,
    ),
    # 6 radars / 3 targets, paper C
    "6r3t": (
        np.array(
            [
                [-300, 0, 0],
                [300, 10, 0],
                [0, 300, 0],
                [5, -300, 0],
                [200, 200, 0],
                [-250, -150, 0.0],
            ]
        ),
        np.array([[0.0, 0.0, 70.0], [-100.4, -30.32, 45.0], [30.0, 30.0, 80.0]]),
        C3,
    ),
    # 2 radars / 1 target with inflated C so the variance term 8/r^2 is ~50% of J.
    "variance_dominated": (
        np.array([[-150.0, 20.0, 0.0], [120.0, 90.0, 0.0]]),
        np.array([[10.0, -5.0, 60.0]]),
        1.0e-5,
    ),
}
N_MC = 200_000


def _rel_frob(a, b):
    return np.linalg.norm(a - b, axis=(-2, -1)) / np.linalg.norm(b, axis=(-2, -1))


def _mc_fisher(radar, target, var_fn, seed):
    """Monte-Carlo E[s sᵀ] of the score of log N(z; 2d, var_fn(d)) w.r.t. target positions."""
    radar = jnp.asarray(radar)
    target = jnp.asarray(target)

    def loglik(tp, z):
        d = jnp.sqrt(jnp.sum((tp[None, :, :] - radar[:, None, :]) ** 2, axis=-1))
        v = var_fn(d)
        return jnp.sum(-0.5 * jnp.log(2 * jnp.pi * v) - 0.5 * (z - 2 * d) ** 2 / v)

    @jax.jit  # one program (eagerly, each of its ops compiles on its own)
    def score_covariance():
        d0 = jnp.sqrt(jnp.sum((target[None] - radar[:, None]) ** 2, axis=-1))
        eps = jax.random.normal(jax.random.key(seed), (N_MC, *d0.shape), dtype=d0.dtype)
        z = 2 * d0 + jnp.sqrt(var_fn(d0)) * eps  # samples drawn from the model itself
        scores = jax.vmap(jax.grad(loglik), in_axes=(None, 0))(target, z)  # [S, M, 3]
        return jnp.einsum("smi,smj->mij", scores, scores) / N_MC

    return np.asarray(score_covariance())


@pytest.mark.parametrize("name", list(GEOMETRIES))
def test_sfim_matches_monte_carlo_score_covariance(name):
    radar, target, c = GEOMETRIES[name]
    with jax.enable_x64(True):
        mc = _mc_fisher(radar, target, lambda d: c * d**4, seed=1)
        j = np.asarray(jax.jit(lambda r, t: fisher.sfim(r, t, c))(radar, target))
    assert j.shape == (len(target), 3, 3)
    # MC relative error of E[s sᵀ] ~ sqrt(2/S) ~ 0.3% (S = 2e5): 2% is > 5 MC sigmas.
    assert np.all(_rel_frob(j, mc) < 0.02), _rel_frob(j, mc)
    if name == "variance_dominated":
        # the test can tell: dropping the variance term 8 d dᵀ/‖d‖⁴ is far outside 2%.
        d = np.linalg.norm(target[None] - radar[:, None], axis=-1)
        u = (target[None] - radar[:, None]) / d[..., None]
        mean_only = np.einsum("nm,nmi,nmj->mij", 4 / (c * d**4), u, u)
        assert np.all(_rel_frob(mean_only, mc) > 0.2)


@pytest.mark.parametrize("name", ["3r4t", "6r3t"])
def test_sfim_ccr_matches_monte_carlo_score_covariance(name):
    radar, target, c = GEOMETRIES[name]
    sigma_r2 = sensing.ccr_variance(c, 125.0)
    with jax.enable_x64(True):
        mc = _mc_fisher(radar, target, lambda d: sigma_r2 * jnp.ones_like(d), seed=2)
        j = np.asarray(jax.jit(lambda r, t: fisher.sfim_ccr(r, t, sigma_r2))(radar, target))
    assert np.all(_rel_frob(j, mc) < 0.02), _rel_frob(j, mc)  # same MC argument as above


def test_sfim_batched_and_vmap():
    radar, target, c = GEOMETRIES["3r4t"]
    rb = np.stack([radar, radar + 5.0])
    tb = np.stack([target, target - 3.0])
    sfim = jax.jit(lambda r, t: fisher.sfim(r, t, c))  # one program per shape
    batched = np.asarray(sfim(rb, tb))
    mapped = np.asarray(jax.jit(jax.vmap(lambda r, t: fisher.sfim(r, t, c)))(rb, tb))
    single = np.asarray(sfim(rb[1], tb[1]))
    assert batched.shape == (2, 4, 3, 3)
    np.testing.assert_allclose(batched, mapped, rtol=1e-6)  # float32, same maths
    np.testing.assert_allclose(batched[1], single, rtol=1e-6)


def test_pfim_equals_linear_kalman_information():
    dt, sw2, p0, steps = 0.025, 10.0, 50.0, 30
    radar, target, c = GEOMETRIES["3r4t"]
    with jax.enable_x64(True):
        A = np.asarray(motion.cv_transition(dt, 1))
        W = np.asarray(motion.cv_process_noise(dt, sw2, 1))
        x = np.r_[target[0], 20.0, 10.0, 0.0]
        P = p0 * np.eye(6)
        J = jnp.asarray(np.eye(6) / p0)
        step = jax.jit(fisher.pfim_step)
        data_information = jax.jit(fisher.data_information)
        for _ in range(steps):
            x = A @ x
            diff = x[:3] - radar
            d = np.linalg.norm(diff, axis=1)
            H = np.zeros((len(radar), 6))
            H[:, :3] = 2 * diff / d[:, None]  # Jacobian of 2d at the true position
            R = np.diag(c * d**4)  # DDR variance at the true range, held fixed
            # textbook covariance-form KF (Joseph update)
            P = A @ P @ A.T + W
            S = H @ P @ H.T + R
            K = P @ H.T @ np.linalg.inv(S)
            IKH = np.eye(6) - K @ H
            P = IKH @ P @ IKH.T + K @ R @ K.T
            j3 = H[:, :3].T @ np.linalg.inv(R) @ H[:, :3]
            J = step(J, A, W, data_information(j3))
            # info form == inverse KF covariance; float64, cond(P) ~ 1e6: 1e-6 >> eps*cond.
            ref = np.linalg.inv(P)
            assert _rel_frob(np.asarray(J), ref) < 1e-6
        # same data information from the module: CCR and DDR-minus-variance-term forms
        sig2 = 3.0
        np.testing.assert_allclose(
            np.asarray(jax.jit(lambda t: fisher.sfim_ccr(radar, t, sig2))(x[None, :3]))[0],
            H[:, :3].T @ H[:, :3] / sig2,
            rtol=1e-12,
        )
        var_term = np.einsum("n,ni,nj->ij", 8 / d**4, diff, diff)
        sfim = jax.jit(lambda t: fisher.sfim(radar, t, c))
        np.testing.assert_allclose(np.asarray(sfim(x[None, :3]))[0] - var_term, j3, rtol=1e-10)


def test_data_information_and_logdet():
    j3 = np.array([[2.0, 0.5, 0.0], [0.5, 1.0, 0.1], [0.0, 0.1, 0.3]])
    # jitted: eagerly, each of their small ops compiles on its own
    data_information, logdet = jax.jit(fisher.data_information), jax.jit(fisher.logdet)
    j6 = np.asarray(data_information(jnp.asarray(j3)))
    assert j6.shape == (6, 6)
    np.testing.assert_array_equal(j6[:3, :3], j3.astype(np.float32))
    np.testing.assert_array_equal(j6[3:], 0.0)
    np.testing.assert_array_equal(j6[:, 3:], 0.0)
    assert data_information(np.zeros((5, 2, 3, 3))).shape == (5, 2, 6, 6)
    with jax.enable_x64(True):
        ld = float(logdet(jnp.asarray(j3)))
    # floor 1e-6 shifts log det by ~tr(J^-1)*1e-6 ~ 5e-6; compare with the floored numpy value.
    assert ld == pytest.approx(np.linalg.slogdet(j3 + 1e-6 * np.eye(3))[1], abs=1e-10)
    # single radar: rank-1 FIM -> finite log det thanks to the information floor
    radar = np.array([[100.0, 0.0, 0.0]])
    j1 = jax.jit(lambda r, t: fisher.sfim(r, t, C4))(radar, np.array([[0.0, 0.0, 50.0]]))
    assert np.isfinite(float(logdet(j1)[0]))


def test_bad_inputs_raise():
    with pytest.raises(ValueError, match="radar_pos"):
        fisher.sfim(np.zeros((3, 2)), np.zeros((1, 3)), C4)
    with pytest.raises(ValueError, match="range"):
        fisher.sfim(np.zeros((1, 3)), np.zeros((1, 3)), C4)
    with pytest.raises(ValueError, match="J3"):
        fisher.data_information(np.zeros((2, 2)))


def test_entry_form_pfim_recursion_matches_the_matrix_recursion():
    """fisher.pfim_logdets (the planner's entry-wise recursion) against the textbook matrix
    recursion ``J <- (W + A J^-1 A^T)^-1 + [[J_D, 0], [0, 0]]`` in numpy float64 (a second
    implementation, LAPACK inverses and slogdet): float64 to 1e-11 (3e-13 seen), float32
    to 1e-3 (1.6e-4 seen: log det values of O(10), and the float32 Cholesky of matrices
    with condition numbers ~1e4 loses about 4 digits)."""
    from mjx_radar.physics import motion

    rng = np.random.default_rng(3)
    m, t = 5, 12
    B = rng.normal(size=(m, 6, 6))
    J0 = B @ B.transpose(0, 2, 1) * 0.1 + 0.01 * np.eye(6)
    C = rng.normal(size=(t, m, 3, 3)) * 0.3
    J3 = C @ np.swapaxes(C, -1, -2)
    a, w = motion.cv_transition(0.1, 1), motion.cv_process_noise(0.1, 1.0, 1)
    a, w = np.asarray(a, float), np.asarray(w, float)
    j, want = J0.copy(), []
    for k in range(t):
        j = np.linalg.inv(4.0 * w + a @ np.linalg.inv(j) @ a.T)
        j[:, :3, :3] += J3[k]
        want.append(np.linalg.slogdet(j + fisher.INFO_FLOOR * np.eye(6))[1])
    for x64, tol in ((True, 1e-11), (False, 1e-3)):
        with jax.enable_x64(x64):
            jd = tuple(jnp.asarray(J3[..., i, j]) for i, j in
                       ((0, 0), (1, 0), (2, 0), (1, 1), (2, 1), (2, 2)))  # fmt: skip
            # jitted: eagerly, each of the entry form's thousands of small ops compiles alone
            got = jax.jit(lambda j0, d: fisher.pfim_logdets(j0, a, w, 4.0, d))(J0, jd)
            np.testing.assert_allclose(np.asarray(got), np.stack(want), atol=tol)
