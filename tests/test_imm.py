"""Tests of the IMM filter (``filter.motion = "imm"``, estimation/filters/imm.py) against a
textbook IMM written here in numpy (Bar-Shalom, Li & Kirubarajan 2001, §11.6.6)."""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_radar.engine.run_spec import run_spec
from mjx_radar.estimation.filters import filter_bank, imm
from mjx_radar.io.checks import ScenarioError
from mjx_radar.physics import motion
from mjx_radar.scenario.reader import load_scenario

DT = 0.1


def _gauss(nu, S):
    """N(ν; 0, S) with its full constant (the textbook likelihood)."""
    p = nu.shape[0]
    return math.exp(-0.5 * nu @ np.linalg.solve(S, nu)) / math.sqrt(
        (2 * math.pi) ** p * np.linalg.det(S)
    )


def _textbook_imm(mu, xs, Ps, z, F, Q, H, R, Pi):
    """One textbook IMM cycle with Kalman filters (numpy float64).

    Returns the mixed (cbar, x0, P0), the mode posteriors and μ, and the combination.
    """
    r = len(mu)
    cbar = np.array([sum(Pi[i, j] * mu[i] for i in range(r)) for j in range(r)])
    x0, P0 = [], []
    for j in range(r):
        w = [Pi[i, j] * mu[i] / cbar[j] for i in range(r)]
        xj = sum(w[i] * xs[i] for i in range(r))
        Pj = sum(w[i] * (Ps[i] + np.outer(xs[i] - xj, xs[i] - xj)) for i in range(r))
        x0.append(xj)
        P0.append(Pj)
    xu, Pu, lik = [], [], []
    for j in range(r):
        xp = F[j] @ x0[j]
        Pp = F[j] @ P0[j] @ F[j].T + Q
        S = H @ Pp @ H.T + R
        K = Pp @ H.T @ np.linalg.inv(S)
        nu = z - H @ xp
        xu.append(xp + K @ nu)
        Pu.append(Pp - K @ S @ K.T)
        lik.append(_gauss(nu, S))
    mu_new = np.array(lik) * cbar
    mu_new /= mu_new.sum()
    x = sum(mu_new[j] * xu[j] for j in range(r))
    P = sum(mu_new[j] * (Pu[j] + np.outer(xu[j] - x, xu[j] - x)) for j in range(r))
    return (cbar, np.array(x0), np.array(P0)), (mu_new, np.array(xu), np.array(Pu)), (x, P)


def test_ct_transition_is_the_circle():
    """A CT(ω) step moves a state on the circle of radius v/ω exactly (closed form)."""
    w, v, dt = 0.4, 18.0, 0.37
    F = imm.ct_transition(w, dt)
    x = np.array([0.0, -v / w, 50.0, v, 0.0, 1.5])  # on the circle about 0, at angle -π/2
    y = F @ x
    a = -math.pi / 2 + w * dt
    want = [v / w * math.cos(a), v / w * math.sin(a), 50.0 + 1.5 * dt,
            -v * math.sin(a), v * math.cos(a), 1.5]  # fmt: skip
    np.testing.assert_allclose(y, want, atol=1e-12)
    with jax.enable_x64(True):
        cv = np.asarray(motion.cv_transition(dt, 1))
    np.testing.assert_array_equal(imm.ct_transition(0.0, dt), cv)


def test_markov_matrix():
    """Rows sum to 1; staying in a mode for one second has probability 1 − p_s."""
    Pi = imm.markov_matrix(0.2, 0.025)
    np.testing.assert_allclose(Pi.sum(1), 1.0, atol=1e-15)
    assert abs(Pi[0, 0] ** 40 - 0.8) < 1e-12 and Pi[0, 1] == Pi[2, 1] > 0
    np.testing.assert_array_equal(imm.markov_matrix(0.0, 0.025), np.eye(3))


def test_imm_matches_textbook_on_linear_gaussian():
    """Five IMM cycles, linear position measurements (the CKF is the KF exactly on a linear
    h), float64: mixing, mode posteriors, μ and the combination equal the textbook IMM.

    Tolerance 1e-9 relative: float64 round-off of 6×6 / 3×3 solves (condition ≲ 1e4) and
    the linalg jitter of the Cholesky factors (~1e-13 relative in float64).
    """
    rng = np.random.default_rng(3)
    F = imm.mode_transitions(0.5, DT)
    Q = np.asarray(motion.cv_process_noise(DT, 4.0, 1))
    H = np.hstack([np.eye(3), np.zeros((3, 3))])
    R = np.diag([4.0, 9.0, 1.0])
    Pi = imm.markov_matrix(0.3, DT)
    mu = np.array([0.6, 0.3, 0.1])
    xs = np.array([[0.0, 0.0, 50.0, 10.0, 2.0, 0.0]] * 3) + rng.normal(size=(3, 6))
    Ps = np.array([np.eye(6) * s for s in (5.0, 8.0, 3.0)])
    truth = np.array([0.0, 0.0, 50.0, 10.0, 2.0, 0.0])
    with jax.enable_x64(True):
        state = (jnp.asarray(mu), jnp.asarray(xs), jnp.asarray(Ps))

        @jax.jit
        def cycle(state, z):
            cbar, xp, Pp = imm.predict(*state, jnp.asarray(F), jnp.asarray(Q), jnp.asarray(Pi))
            post = imm.update(cbar, xp, Pp, z, lambda x: x[:3], jnp.asarray(R))
            return imm.mix(*state, jnp.asarray(Pi)), post, imm.combine(*post)

        for _ in range(5):
            truth = F[1] @ truth
            z = H @ truth + rng.normal(size=3) * np.sqrt(np.diag(R))
            mixed, post, comb = _textbook_imm(mu, xs, Ps, z, F, Q, H, R, Pi)
            got_mix, state, (x, P) = cycle(state, jnp.asarray(z))
            for a, b in zip(got_mix, mixed, strict=True):
                np.testing.assert_allclose(np.asarray(a), b, rtol=1e-9, atol=1e-9)
            assert state[0].dtype == jnp.float64
            for a, b in zip(state, post, strict=True):
                np.testing.assert_allclose(np.asarray(a), b, rtol=1e-9, atol=1e-9)
            np.testing.assert_allclose(np.asarray(x), comb[0], rtol=1e-9, atol=1e-9)
            np.testing.assert_allclose(np.asarray(P), comb[1], rtol=1e-9, atol=1e-9)
            mu, xs, Ps = post
        assert 0.0 < mu.min() and mu.max() < 1.0  # the probabilities moved (not a trivial case)
        assert abs(mu[0] - 0.6) > 1e-3


def test_imm_without_turns_or_switches_is_the_cv_bank():
    """ω = 0, p_s = 0: every mode is the CV CKF, so the IMM bank equals the CV bank on the
    nonlinear DDR range model (float64, 8 steps, 3 radars, 2 targets, one masked pair)."""
    rng = np.random.default_rng(5)
    radars = jnp.asarray([[300.0, 0.0, 0.0], [-200.0, 250.0, 0.0], [0.0, -300.0, 0.0]])
    with jax.enable_x64(True):
        A6 = jnp.asarray(motion.cv_transition(DT, 1))
        Q6 = jnp.asarray(motion.cv_process_noise(DT, 10.0, 1))
        F = jnp.asarray(imm.mode_transitions(0.0, DT))
        Pi = jnp.asarray(imm.markov_matrix(0.0, DT))
        means = jnp.asarray([[0.0, 0.0, 55.0, 20.0, 10.0, 0.0],
                             [15.0, 15.0, 70.0, 15.0, 20.0, 0.0]])  # fmt: skip
        covs = jnp.broadcast_to(50.0 * jnp.eye(6), (2, 6, 6))
        state = imm.init(means, covs)
        R = filter_bank.ddr_R(1e-9)
        mask = jnp.asarray([[True, True], [True, False], [True, True]])

        @jax.jit
        def step(means, covs, state, noise):
            means, covs = filter_bank.predict_bank(means, covs, A6, Q6)
            state = imm.predict_bank(state, F, Q6, Pi)
            z = 2 * jnp.linalg.norm(means[None, :, :3] - radars[:, None], axis=-1)[..., None]
            z = z + noise
            means, covs = filter_bank.update_bank(means, covs, z, radars, filter_bank.range_pair,
                                                  R, mask=mask)  # fmt: skip
            state = imm.update_bank(state, z, radars, filter_bank.range_pair, R, mask=mask)
            return means, covs, state, imm.combine_bank(state)

        for _ in range(8):
            means, covs, state, (xm, Pm) = step(means, covs, state, rng.normal(size=(3, 2, 1)))
            np.testing.assert_allclose(np.asarray(xm), np.asarray(means), rtol=1e-12, atol=1e-9)
            np.testing.assert_allclose(np.asarray(Pm), np.asarray(covs), rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(np.asarray(state.probs), 1.0 / 3.0, rtol=1e-12)


def test_imm_scenario_rules():
    """The IMM needs the per-target bank in covariance form; probabilities in [0, 1]."""
    s = load_scenario("smoke")
    ok = s.replace(filter={"structure": "per-target", "motion": "imm", "imm_switch_prob": 0.0})
    assert ok.filter.motion == "imm" and s.filter.motion == "cv"
    for bad, needle in (
        ({"motion": "imm"}, 'filter.structure = "per-target"'),
        ({"structure": "per-target", "motion": "imm", "form": "sqrt"}, "covariance form only"),
        ({"structure": "per-target", "imm_switch_prob": 1.2}, "imm_switch_prob"),
    ):
        with pytest.raises(ScenarioError, match=needle):  # fmt: skip
            s.replace(filter=bad)


def test_appearing_targets_restart_their_modes():
    """The IMM form: a drone appearing at step k gets every mode at its fresh (combined)
    estimate and uniform probabilities; the other drones' modes are untouched."""
    import dataclasses

    from mjx_radar.env import trackers
    from mjx_radar.task.task import build

    s = load_scenario("waypoints_3r4t")
    late = dataclasses.replace(s.target_motion[3], appear=0.5)  # step 20 at dt = 25 ms
    s = s.replace(filter={"structure": "per-target", "motion": "imm"},
                  target_motion=(*s.target_motion[:3], late))  # fmt: skip
    task, params = build(s, "stationary")
    fops = trackers.make(task, params)
    rng = np.random.default_rng(0)
    modes = imm.ImmState(
        jnp.asarray(rng.normal(size=(4, 3, 6)), jnp.float32),
        jnp.broadcast_to(jnp.eye(6, dtype=jnp.float32), (4, 3, 6, 6)),
        jnp.asarray(rng.dirichlet(np.ones(3), size=4), jnp.float32),
    )
    mean = jnp.arange(24.0)
    cov = jnp.diag(jnp.arange(1.0, 25.0))
    begin = jax.jit(fops.begin, static_argnums=3)  # one program per k (a Python int, as before)
    for k, new in ((19, False), (20, True), (21, False)):
        out = jax.tree_util.tree_map(np.asarray, begin(modes, mean, cov, k))
        for a, b in zip(out, modes, strict=True):
            np.testing.assert_array_equal(a[:3], np.asarray(b)[:3])
        if not new:
            for a, b in zip(out, modes, strict=True):
                np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
            continue
        np.testing.assert_array_equal(
            np.asarray(out.means[3]), np.tile(np.arange(18.0, 24.0), (3, 1))
        )
        np.testing.assert_array_equal(np.asarray(out.covs[3, 1]), np.diag(np.arange(19.0, 25.0)))
        np.testing.assert_allclose(np.asarray(out.probs[3]), 1.0 / 3.0, rtol=1e-7)


@pytest.mark.slow  # the IMM itself: the textbook test above (suite time)
@pytest.mark.parametrize("method", ["stationary", "ddr-sfim"])
def test_closed_loop_waypoints_imm_tracks(method):
    """waypoints_3r4t with the per-target IMM bank (analytic rollouts, 1 trial, 80 steps =
    2 s; drone 3 appears at 0.5 s, so its modes restart mid-run): runs, stays finite and
    tracks (final RMSE well below the initial sqrt(3 p0) = 12 m, no lost track); the new
    track's x variance grows to > 50 m^2 while absent (prediction only) and ends < 1 m^2
    (measured: 61 -> 0.3 m^2 with DDR-SFIM)."""
    import dataclasses

    from mjx_radar.engine import runner

    s = load_scenario("waypoints_3r4t")
    late = dataclasses.replace(s.target_motion[3], appear=0.5)
    s = s.replace(
        filter={"structure": "per-target", "motion": "imm"},
        mpc={"horizon": 3, "rollout": "analytic"},
        mppi={"samples": 32, "iterations": 1},
        target_motion=(*s.target_motion[:3], late),
    )
    out = runner.run_trials(run_spec(s), method, 0, [0], 80)
    assert np.all(np.isfinite(out["mean"])) and np.all(out["cov_diag"] > 0)
    assert not out["diverged"].any() and not out["lost"].any()
    present = out["targets_present"][0]
    assert present[18] == 3 and present[19] == 4 == present[-1]  # step 20: t = 0.5 s
    assert out["cov_diag"][0, 18, 18] > 50.0 > 1.0 > out["cov_diag"][0, -1, 18]
    assert out["rmse_pos"][0, -20:].mean() < 6.0
    moved = np.abs(out["radar"][0, -1, :, :2] - out["radar"][0, 0, :, :2]).max()
    assert (moved > 0.1) == (method != "stationary")  # the planner ran on the IMM's estimate
