"""Lost-track detector (mirror lock, divergence, k-sigma rule) and the ground prior."""

import functools
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_radar.env import track_health as th
from mjx_radar.estimation.filters.ground_prior import apply_ground_prior, reflect, reflection_signs

DT = 0.025
TRUTH = np.array([[0, 0, 55, 20, 10, 0], [15.4, 15.32, 70, 15, 20, 0]], np.float32)
COV = np.kron(np.eye(2), np.diag([4.0, 4, 4, 1, 1, 1])).astype(np.float32)  # sqrt(tr P_pos) = 3.5


def run(means, covs, truth=TRUTH, cfg=th.DEFAULT):
    """Scans the detector over K steps (jitted, as in the closed loop); flags [K] each."""

    def body(state, xs):
        mean, cov = xs
        state, flags = th.step_health(state, jnp.asarray(truth), mean, cov, DT, cfg)
        return state, flags

    state, flags = jax.jit(lambda m, c: jax.lax.scan(body, th.init_health(2), (m, c)))(
        jnp.asarray(means), jnp.asarray(covs)
    )
    return state, jax.tree_util.tree_map(np.asarray, flags)


def test_mirror_lock_flags_after_exactly_ceil_steps():
    need = math.ceil(1.0 / DT)  # 40 steps for the default 1 s
    k = need + 10
    rng = np.random.default_rng(0)
    mirror = TRUTH.copy()
    mirror[1, 2] *= -1  # target 1 at (x, y, -z), velocities unchanged
    means = mirror.reshape(-1) + rng.normal(0, 0.5, (k, 12)).astype(np.float32)
    covs = np.broadcast_to(COV, (k, 12, 12))
    # beyond_sigma would also fire (error 140 m); isolate the mirror rule with a huge floor
    cfg = th.HealthConfig(error_floor_m=1e6, k_sigma=1e6)
    state, f = run(means, covs, cfg=cfg)
    assert not f.mirror[: need - 1].any() and f.mirror[need - 1 :].all()
    assert (f.lost == f.mirror).all() and not f.diverged.any() and not f.beyond_sigma.any()
    assert int(state.mirror_steps[1]) == k and int(state.mirror_steps[0]) == 0
    assert bool(state.ever_lost)
    # the run resets when the estimate comes back: a 39-step excursion never flags
    means2 = np.concatenate([means[: need - 1], np.tile(TRUTH.reshape(-1), (3, 1)), means[:20]])
    _, f2 = run(means2, np.broadcast_to(COV, (len(means2), 12, 12)), cfg=cfg)
    assert not f2.lost.any()


def test_mirror_time_rounds_up():
    cfg = th.HealthConfig(mirror_time_s=0.06, error_floor_m=1e6, k_sigma=1e6)  # 2.4 -> 3 steps
    mirror = TRUTH.copy()
    mirror[0, 2] = -1.0
    _, f = run(np.tile(mirror.reshape(-1), (5, 1)), np.broadcast_to(COV, (5, 12, 12)), cfg=cfg)
    np.testing.assert_array_equal(f.mirror, [False, False, True, True, True])


def test_healthy_stays_unflagged():
    rng = np.random.default_rng(1)
    k = 200
    means = TRUTH.reshape(-1) + rng.normal(0, 2.0, (k, 12)).astype(np.float32)
    state, f = run(means, np.broadcast_to(COV, (k, 12, 12)))
    assert not f.lost.any() and not bool(state.ever_lost)


@functools.partial(jax.jit, static_argnames="cfg")  # one program per cfg (eager ops compile)
def _first_step(mean, cov, cfg=None):
    """``th.step_health`` from a fresh state against ``TRUTH``."""
    return th.step_health(th.init_health(2), jnp.asarray(TRUTH), mean, cov, DT, cfg)


@pytest.mark.parametrize(
    "corrupt",
    [
        lambda m, c: (m.at[3].set(jnp.nan), c),
        lambda m, c: (m, c.at[7, 7].set(jnp.inf)),
        # indefinite 6x6 block: corr(x, y) = 1.5 (finite, symmetric, diagonal > 0)
        lambda m, c: (m, c.at[6, 7].set(6.0).at[7, 6].set(6.0)),
    ],
)
def test_diverged(corrupt):
    mean, cov = corrupt(jnp.asarray(TRUTH.reshape(-1)), jnp.asarray(COV))
    _, f = _first_step(mean, cov)
    assert bool(f.diverged) and bool(f.lost)


def test_min_pivot_matches_eigenvalue_sign():
    rng = np.random.default_rng(2)
    min_pivot = jax.jit(th.min_pivot)  # unrolled LDLᵀ: one program instead of its eager ops
    for _ in range(50):
        b = rng.normal(size=(6, 6))
        a = b @ b.T + rng.uniform(-3, 1) * np.eye(6)
        pd = np.linalg.eigvalsh(a).min() > 0
        assert (float(min_pivot(jnp.asarray(a))) > 0) == pd


def test_k_sigma_boundary():
    # error exactly at the bound is not lost, just above it is (bound = 5 * 3.4641 = 17.32 m)
    cfg = th.HealthConfig(k_sigma=5.0, error_floor_m=1.0, mirror_time_s=1.0)
    bound = 5.0 * math.sqrt(12.0)
    for err, lost in ((bound * 0.999, False), (bound * 1.001, True)):
        mean = TRUTH.copy()
        mean[0, 0] += err
        _, f = _first_step(jnp.asarray(mean.reshape(-1)), COV, cfg)
        assert bool(f.beyond_sigma) is lost and bool(f.lost) is lost
    # the floor wins when k sqrt(tr P) is smaller: 40 m error with a 50 m floor is kept
    mean = TRUTH.copy()
    mean[1, 1] += 40.0
    _, f = _first_step(jnp.asarray(mean.reshape(-1)), COV)
    assert not bool(f.lost)


def test_vmaps_over_trials():
    means = jnp.stack([jnp.asarray(TRUTH.reshape(-1)), jnp.full(12, jnp.nan)])
    state = jax.jit(jax.vmap(lambda _: th.init_health(2)))(jnp.arange(2))
    step = jax.jit(jax.vmap(th.step_health, (0, None, 0, None, None)), static_argnums=4)
    _, f = step(state, TRUTH, means, COV, DT)  # one program (eager ops compile one by one)
    np.testing.assert_array_equal(f.lost, [False, True])


# --- ground prior ------------------------------------------------------------------------


def _random_gaussian(seed, m=3):
    rng = np.random.default_rng(seed)
    b = rng.normal(size=(6 * m, 6 * m))
    return jnp.asarray(rng.normal(0, 30, 6 * m)), jnp.asarray(b @ b.T + 0.1 * np.eye(6 * m))


_reflect = jax.jit(reflect)  # one program per shape (eager ops compile one by one)
_ground_prior = jax.jit(apply_ground_prior)


def test_reflection_is_an_involution_and_keeps_pd():
    mean, cov = _random_gaussian(0)
    s = jax.jit(reflection_signs)(jnp.array([True, False, True]))
    m1, c1 = _reflect(mean, cov, s)
    m2, c2 = _reflect(m1, c1, s)
    np.testing.assert_array_equal(m2, mean)
    np.testing.assert_array_equal(c2, cov)
    np.testing.assert_array_equal(c1, c1.T)
    np.testing.assert_allclose(np.linalg.eigvalsh(c1), np.linalg.eigvalsh(cov), rtol=1e-12)


def test_ground_prior_reflects_only_below_ground():
    mean, cov = _random_gaussian(1)
    mean = mean.at[2].set(-40.0).at[8].set(12.0).at[14].set(-0.5)
    out_m, out_c = _ground_prior(mean, cov)
    exp_s = np.ones(18)
    exp_s[[2, 5, 14, 17]] = -1  # z and vz of targets 0 and 2
    np.testing.assert_array_equal(out_m, mean * exp_s)
    np.testing.assert_array_equal(out_c, cov * np.outer(exp_s, exp_s))
    assert np.all(np.asarray(out_m).reshape(3, 6)[:, 2] >= 0)
    again = _ground_prior(out_m, out_c)  # idempotent: nothing left below ground
    np.testing.assert_array_equal(again[0], out_m)
    np.testing.assert_array_equal(again[1], out_c)


def test_ground_prior_noop_above_ground():
    mean, cov = _random_gaussian(2)
    mean = mean.at[jnp.array([2, 8, 14])].set(jnp.array([0.0, 3.0, 70.0]))
    out_m, out_c = _ground_prior(mean, cov)
    np.testing.assert_array_equal(out_m, mean)
    np.testing.assert_array_equal(out_c, cov)
