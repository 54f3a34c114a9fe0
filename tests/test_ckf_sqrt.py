"""Tests of the square-root CKF (issue 26) against the covariance form and a Kalman filter.

Tolerances. In float64 the two forms are the same filter in exact arithmetic, so they
differ by round-off only: eps = 2.2e-16, plus the covariance form's relative Cholesky
jitter δ = 10·eps·scale = 2.2e-15 (``linalg.psd_cholesky``) at each of its two
factorisations per step, amplified by the gain's conditioning over the sequence.
Measured: ≤ 2e-13 relative (covariance) and ≤ 4e-14 (means) over 10 range-only
steps; we allow 1e-11 (≈50× headroom). A bug (a wrong weight, a missing term, a
mask leak) gives O(1e-2..1) differences.
"""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from filterpy.kalman import KalmanFilter

from mjx_radar.engine.run_spec import run_spec
from mjx_radar.env.track_health import min_pivot
from mjx_radar.estimation.filters import ckf, ckf_sqrt, filter_bank, ground_prior
from mjx_radar.estimation.sensor import measurement, sensing
from mjx_radar.physics import motion
from mjx_radar.scenario.schema import RadarEquation

DT = 0.025
TOL = 1e-11  # relative, float64 (module docstring)


def _rel(a, b):
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


def _cov(S):
    S = np.asarray(S, np.float64)
    return S @ np.swapaxes(S, -1, -2)


def _geometry(rng, m, n):
    truth = np.c_[
        rng.uniform(-60, 60, (m, 2)), rng.uniform(40, 80, m), rng.uniform(-20, 20, (m, 3))
    ]
    ang = rng.uniform(0, 2 * np.pi, n)
    rad = rng.uniform(150, 400, n)
    return truth, np.c_[rad * np.cos(ang), rad * np.sin(ang), np.zeros(n)]


def _range_h(radars, m):
    def h(x):
        pos = x.reshape(m, 6)[:, :3]
        return 2.0 * jnp.linalg.norm(pos[None] - radars[:, None], axis=-1).reshape(-1)

    return h


def test_tria_is_a_triangular_factor():
    rng = np.random.default_rng(0)
    A = rng.normal(size=(5, 13))
    with jax.enable_x64(True):
        Q = motion.cv_process_noise(DT, 10.0, 2)
        S, F = jax.jit(lambda A, Q: (ckf_sqrt.tria(A), ckf_sqrt.psd_factor(Q)))(jnp.asarray(A), Q)
        S, F, Q = np.asarray(S), np.asarray(F), np.asarray(Q)
    np.testing.assert_array_equal(np.triu(S, 1), 0.0)
    assert np.all(np.diag(S) > 0)
    np.testing.assert_allclose(S @ S.T, A @ A.T, rtol=0, atol=1e-13 * np.abs(A @ A.T).max())
    # rank-3-per-target CV noise: the eigen-factor is exact to round-off
    np.testing.assert_allclose(F @ F.T, Q, rtol=0, atol=1e-15 * np.abs(Q).max())
    with pytest.raises(ValueError, match="k >= n"):
        ckf_sqrt.tria(jnp.ones((3, 2)))


@pytest.mark.parametrize("masked", [False, True])
def test_range_sequence_equals_covariance_form(masked):
    """Joint range-only filter, 4 radars × 2 targets (n = 12), DDR R(ẑ), 10 steps."""
    m, n = 2, 4
    rng = np.random.default_rng(1)
    truth, radars = _geometry(rng, m, n)
    c = sensing.noise_constant(RadarEquation(), m)
    mask = rng.uniform(size=n * m) < 0.6 if masked else None
    with jax.enable_x64(True):
        h, R = _range_h(jnp.asarray(radars), m), lambda zh: sensing.ddr_noise_cov(zh, c)
        A, Q = motion.cv_transition(DT, m), motion.cv_process_noise(DT, 10.0, m)
        P = 20.0 * jnp.eye(6 * m)
        x = xs = jnp.asarray(truth.reshape(-1) + rng.normal(size=6 * m) * 4.0)
        S, SQ = jax.jit(lambda P, Q: (ckf_sqrt.factor(P), ckf_sqrt.psd_factor(Q)))(P, Q)
        f = lambda v: A @ v  # noqa: E731

        @jax.jit  # one program per step (suite time: eager ops compile one by one)
        def step(x, P, xs, S, noise):
            x, P = ckf.predict(x, P, f, Q)
            xs, S = ckf_sqrt.predict(xs, S, f, SQ)
            predicted = x, P, xs, S
            z = h(jnp.asarray(truth.reshape(-1))) + noise
            x, P = ckf.update(x, P, z, h, R, mask=mask)
            xs, S = ckf_sqrt.update(xs, S, z, h, R, mask=mask)
            return predicted, (x, P, xs, S)

        for _ in range(10):
            (x, P, xs, S), updated = step(x, P, xs, S, rng.normal(size=n * m))
            assert _rel(_cov(S), P) < TOL and _rel(xs, x) < TOL
            x, P, xs, S = updated
            assert _rel(_cov(S), P) < TOL and _rel(xs, x) < TOL
    assert np.all(np.abs(np.triu(np.asarray(S), 1)) == 0.0) and np.all(np.diag(S) > 0)


def _range_azimuth_pair(r, x6):
    d = x6[:3] - r
    return jnp.stack([2.0 * jnp.linalg.norm(d), jnp.arctan2(d[1], d[0])])


def _wrap_residual(a, b):
    return (a - b).at[1::2].set(measurement.wrap_angle(a[1::2] - b[1::2]))


def test_masked_update_with_residual_equals_removal_and_covariance_form():
    """Range + azimuth across the ±π cut, correlated R, one radar masked (bank, n = 6).

    Tolerance: the covariance form jitters Pzz and the square-root form R, each by
    δ = 2.2e-15·mean diag (≈ 4e-15 here); relative to the azimuth variance 1e-4 rad²
    that is 4.4e-11 of the azimuth information (measured 7.6e-12 of max|P|): 2e-10.
    The masked update equals the update with the rows removed to 4e-15 (TOL).
    """
    rng = np.random.default_rng(2)
    radars = np.array([[300.0, 1.0, 0.0], [-250.0, 80.0, 0.0], [60.0, -320.0, 0.0]])
    means = np.array([[10.0, 2.0, 60.0, 5.0, 1.0, 0.0], [-30.0, 40.0, 50.0, 0.0, 3.0, 1.0]])
    g = rng.normal(size=(2, 6, 6))
    covs = g @ np.swapaxes(g, 1, 2) + 4.0 * np.eye(6)
    noise = rng.normal(size=(3, 2, 2)) * [2.0, 0.01]
    b = rng.normal(size=(6, 6)) * 0.3
    R = np.diag(np.tile([4.0, 1e-4], 3)) + 1e-3 * (b @ b.T)  # correlated
    mask = np.array([[True, True], [False, True], [True, False]])
    keep = np.array([0, 2])  # radars seen by target 0
    with jax.enable_x64(True):
        pair = jax.vmap(jax.vmap(_range_azimuth_pair, (None, 0)), (0, None))
        z = np.asarray(jax.jit(pair)(jnp.asarray(radars), jnp.asarray(means))) + noise  # [N, M, 2]
        args = (jnp.asarray(radars), _range_azimuth_pair)
        S = jnp.asarray(np.linalg.cholesky(covs))
        rows = np.r_[2 * keep, 2 * keep + 1]
        rows.sort()

        @jax.jit  # one program (suite time: eager ops compile one by one)
        def updates(means, covs, S, z):
            cm, cc = filter_bank.update_bank(means, covs, z, *args, R, mask, _wrap_residual)
            sm, ss = filter_bank.update_bank(means, S, z, *args, R, mask, _wrap_residual, "sqrt")
            rm, rs = ckf_sqrt.update(
                means[0], S[0], z[keep, 0].reshape(-1),
                lambda x: jax.vmap(lambda r: _range_azimuth_pair(r, x))(args[0][keep]).reshape(-1),
                R[np.ix_(rows, rows)], residual=_wrap_residual,
            )  # fmt: skip
            return cm, cc, sm, ss, rm, rs

        cm, cc, sm, ss, rm, rs = updates(means, covs, S, z)
    np.testing.assert_allclose(sm, cm, rtol=0, atol=2e-10 * np.abs(cm).max())
    np.testing.assert_allclose(_cov(ss), cc, rtol=0, atol=2e-10 * np.abs(cc).max())
    np.testing.assert_allclose(sm[0], rm, rtol=0, atol=TOL * np.abs(rm).max())
    np.testing.assert_allclose(_cov(ss[0]), _cov(rs), rtol=0, atol=TOL * np.abs(_cov(rs)).max())
    assert np.abs(np.asarray(sm) - means).max() > 0.1  # the update did something


def test_linear_gaussian_equals_kalman_filter():
    """CV targets, direct position measurements with correlated R: textbook KF, 20 steps.

    Joint SCKF (M = 2, n = 12) and the sqrt bank against filterpy's KalmanFilter (Joseph
    form); measured ≤ 4e-15 relative.
    """
    m = 2
    rng = np.random.default_rng(3)
    b = rng.normal(size=(3, 3))
    R3 = np.eye(3) + 0.2 * b @ b.T  # correlated axes; the bank's R is shared by the targets
    Rj = np.kron(np.eye(m), R3)
    H = np.kron(np.eye(m), np.c_[np.eye(3), np.zeros((3, 3))])
    with jax.enable_x64(True):
        A, Q = motion.cv_transition(DT, m), motion.cv_process_noise(DT, 10.0, m)
        A6 = A[:6, :6]
        kf = KalmanFilter(dim_x=6 * m, dim_z=3 * m)
        kf.F, kf.Q, kf.H, kf.R = np.asarray(A), np.asarray(Q), H, Rj
        kf.x = rng.normal(size=6 * m) * 3.0
        g = rng.normal(size=(6 * m, 6 * m))
        kf.P = g @ g.T + np.eye(6 * m)
        kf.P[:6, 6:] = kf.P[6:, :6] = 0.0
        xs = jnp.asarray(kf.x)

        @jax.jit  # one program (suite time: eager ops compile one by one)
        def start(xs, P, Q):
            S = ckf_sqrt.factor(P)
            F6 = ckf_sqrt.psd_factor(Q[:6, :6])
            return S, filter_bank.joint_to_bank(xs, S), ckf_sqrt.psd_factor(Q), F6

        S, (bm, bs), SQ, F6 = start(xs, kf.P, Q)

        @jax.jit  # one program per step (suite time: eager ops compile one by one)
        def step(xs, S, bm, bs, z):
            xs, S = ckf_sqrt.predict(xs, S, lambda v: A @ v, SQ)
            bm, bs = filter_bank.predict_bank(bm, bs, A6, F6, form="sqrt")
            xs, S = ckf_sqrt.update(xs, S, z, lambda v: jnp.asarray(H) @ v, Rj)
            zb = z.reshape(1, m, 3)
            bm, bs = filter_bank.update_bank(
                bm, bs, zb, jnp.zeros((1, 3)), lambda r, x6: x6[:3] - r, R3, form="sqrt"
            )
            return xs, S, bm, bs, filter_bank.bank_to_joint(bm, bs)

        for _ in range(20):
            kf.predict()
            z = H @ kf.x + rng.normal(size=3 * m)
            kf.update(z)
            xs, S, bm, bs, joint_bank = step(xs, S, bm, bs, z)
            for mean, factor in ((xs, S), joint_bank):
                assert _rel(mean, kf.x) < TOL and _rel(_cov(factor), kf.P) < TOL


def test_ground_prior_reflects_the_factor():
    """``S P S`` of the ground prior applied to a factor gives the factor of the reflection."""
    rng = np.random.default_rng(4)
    g = rng.normal(size=(12, 12))
    P = g @ g.T + np.eye(12)
    mean = rng.normal(size=12) * 10.0
    mean[2], mean[8] = -5.0, 7.0  # target 0 below ground, target 1 above
    with jax.enable_x64(True):
        prior = ground_prior.apply_ground_prior
        (rm, rp), (sm, ss) = jax.jit(  # one program (suite time: eager ops compile one by one)
            lambda mean, P: (prior(mean, P), prior(mean, ckf_sqrt.factor(P)))
        )(jnp.asarray(mean), jnp.asarray(P))
    np.testing.assert_array_equal(sm, rm)
    np.testing.assert_allclose(_cov(ss), rp, rtol=0, atol=TOL * np.abs(P).max())
    assert np.all(np.triu(np.asarray(ss), 1) == 0.0) and np.all(np.diag(ss) > 0)


def _ill_conditioned_runs(steps=600, p0=1e4, r=1e-6, sigma_w2=1e-6):
    """One CV target, position measured directly, P0/R = 1e10, float32 (both forms)."""
    A, Q = motion.cv_transition(DT, 1), motion.cv_process_noise(DT, sigma_w2, 1)
    SQ, Rm = jax.jit(ckf_sqrt.psd_factor)(Q), r * jnp.eye(3)
    rng = np.random.default_rng(5)
    truth = np.array([0.0, 0.0, 50.0, 10.0, 5.0, 0.0])
    truth = np.stack([np.linalg.matrix_power(np.asarray(A, np.float64), k + 1) @ truth
                      for k in range(steps)])  # fmt: skip
    zs = jnp.asarray(truth[:, :3] + rng.normal(size=(steps, 3)) * np.sqrt(r), jnp.float32)
    x0 = jnp.asarray([1.0, 1.0, 51.0, 9.0, 4.0, 0.5])
    h, f = (lambda v: v[:3]), (lambda v: A @ v)

    def run(mod, c0, q):
        def body(c, z):
            x, C = mod.predict(*c, f, q)
            c = mod.update(x, C, z, h, Rm)
            return c, c[1]

        return np.asarray(jax.lax.scan(body, (x0, c0), zs)[1], np.float64)

    P = run(ckf, p0 * jnp.eye(6), Q)
    S = run(ckf_sqrt, np.sqrt(p0) * jnp.eye(6), SQ)
    ref, Pk = [], p0 * np.eye(6)  # float64 Kalman filter
    A64, Q64, H = np.asarray(A, np.float64), np.asarray(Q, np.float64), np.eye(3, 6)
    for _ in range(steps):
        Pk = A64 @ Pk @ A64.T + Q64
        Szz = H @ Pk @ H.T + r * np.eye(3)
        K = Pk @ H.T @ np.linalg.inv(Szz)
        Pk = Pk - K @ Szz @ K.T
        ref.append(0.5 * (Pk + Pk.T))
    return P, _cov(S), np.array(ref)


def test_float32_ill_conditioned_sqrt_stays_positive_definite():
    """P0/R = 1e10: the covariance form's ``P − K Pzz Kᵀ`` cancels catastrophically.

    After the second update (P drops from 1e4 to ~1e-6) the float32 covariance form
    returns an indefinite P (min eigenvalue ≈ −6e-3, relative error ~1e4; the closed
    loop's detector would flag it diverged); its next factorisation's jitter heals it.
    The square-root form's S Sᵀ is PD at every one of the 600 steps (also by the
    detector's float32 pivots) and accurate to 1.2e-3 in those first steps (measured;
    asserted < 1e-2, the covariance form's error is > 1).
    Later both are limited alike (≈10 %) by float32 cubature points about a 50 m mean.
    """
    P, Ps, ref = _ill_conditioned_runs()
    eig = lambda C: np.linalg.eigvalsh(0.5 * (C + np.swapaxes(C, -1, -2))).min(-1)  # noqa: E731
    pivots = jax.jit(min_pivot)  # unrolled LDLᵀ: one program instead of its eager ops
    assert eig(P).min() <= 0.0
    assert np.asarray(pivots(jnp.asarray(P, jnp.float32))).min() <= 0.0
    assert eig(Ps).min() > 0.0
    assert np.asarray(pivots(jnp.asarray(Ps, jnp.float32))).min() > 0.0
    err = lambda C: np.abs(C - ref).max((1, 2)) / np.abs(ref).max((1, 2))  # noqa: E731
    assert err(Ps)[:3].max() < 1e-2 and err(P)[:3].max() > 1.0


def test_form_option_and_dispatch():
    from mjx_radar.io.checks import ScenarioError
    from mjx_radar.scenario.reader import scenario_from_dict

    good = {"name": "t", "n_radars": 2, "targets": [[0.0, 0.0, 55.0, 20.0, 10.0, 0.0]]}
    assert scenario_from_dict(good).filter.form == "covariance"
    assert scenario_from_dict(good | {"filter": {"form": "sqrt"}}).filter.form == "sqrt"
    with pytest.raises(ScenarioError, match="must be one of covariance, sqrt"):
        scenario_from_dict(good | {"filter": {"form": "cholesky"}})
    assert ckf_sqrt.form_ops("sqrt").update is ckf_sqrt.update
    assert ckf_sqrt.form_ops("covariance").update is ckf.update
    with pytest.raises(ValueError, match="form"):
        ckf_sqrt.form_ops("information")


@pytest.fixture(scope="module")
def smoke():
    from mjx_radar.scenario.reader import load_scenario

    sc = load_scenario("smoke")  # analytic planner rollouts: compiles faster (test_closed_loop)
    return dataclasses.replace(sc, mpc=dataclasses.replace(sc.mpc, rollout="analytic"))


def _runs(sc, structure, methods=("stationary", "ddr-sfim")):
    from mjx_radar.engine import runner

    out = {}
    for form in ("covariance", "sqrt"):
        s = dataclasses.replace(sc, filter=dataclasses.replace(sc.filter, structure=structure,
                                                               form=form))  # fmt: skip
        for method in methods:  # programs of kinds "none" and "sfim"
            out[form, method] = runner.run_trials(run_spec(s), method, 0, [0, 1], 80)
    return out


@pytest.mark.parametrize(
    "structure, methods",
    [("joint", ("stationary",)),  # CI: the filter alone (two cheap no-planner programs)
     pytest.param("joint", ("stationary", "ddr-sfim"), marks=pytest.mark.slow),
     pytest.param("per-target", ("stationary", "ddr-sfim"), marks=pytest.mark.slow)],
)  # fmt: skip
def test_closed_loop_sqrt_matches_covariance_form(smoke, structure, methods):
    """smoke, same seed, 2 trials × 80 steps, both forms; stationary and DDR-SFIM radars.

    Stationary radars isolate the filter: the float32 forms differ by the covariance
    form's Cholesky jitter (1.2e-6 relative, twice a step) and round-off, measured
    ≤ 2.6e-4 relative (mean, cov_diag), 8e-4 (rmse_pos), 1.1e-2 (nees: P⁻¹ of a
    poorly observed z). With MPPI (ddr-sfim) the elite selection amplifies those into
    different radar paths (measured ≤ 2 % on the time-mean rmse_pos / nees).
    """
    out = _runs(smoke, structure, methods)
    for method in methods:
        a, b = out["covariance", method], out["sqrt", method]
        for k in ("rmse_pos", "nees", "cov_diag", "mean"):
            assert np.all(np.isfinite(b[k])), k
        assert not b["diverged"].any() and not a["diverged"].any()
    a, b = out["covariance", "stationary"], out["sqrt", "stationary"]
    for k, tol in (("mean", 2e-3), ("cov_diag", 2e-3), ("rmse_pos", 1e-2), ("nees", 5e-2)):
        assert _rel(b[k], a[k]) < tol, (k, _rel(b[k], a[k]))
    if "ddr-sfim" not in methods:
        return
    a, b = out["covariance", "ddr-sfim"], out["sqrt", "ddr-sfim"]
    for k, tol in (("rmse_pos", 0.05), ("nees", 0.1)):
        assert abs(b[k].mean() / a[k].mean() - 1.0) < tol, k
