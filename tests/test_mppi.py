"""Task-agnostic MPPI: convergence on a quadratic, clipping, shift, determinism, jit."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_radar.control.mppi import MPPIResult, optimize, sample_weights, shift
from mjx_radar.scenario.schema import MPPIConfig

H, D = 15, 6
LOWER = -jnp.array([3.0, 2.0, 3.0, 2.0, 3.0, 2.0])
UPPER = -LOWER
C0 = 100.0


def _quadratic():
    """``c0 + (u - u*)^T Q (u - u*)`` on vec(u), Q a rotated SPD with eigenvalues in [0.5, 2]."""
    rng = np.random.default_rng(0)
    rot, _ = np.linalg.qr(rng.normal(size=(H * D, H * D)))
    q = jnp.asarray(rot @ np.diag(np.linspace(0.5, 2.0, H * D)) @ rot.T, jnp.float32)
    u_star = jnp.asarray(rng.uniform(-0.8, 0.8, size=(H, D)), jnp.float32) * UPPER  # inside

    def cost(u):
        e = (u - u_star).reshape(-1)
        return C0 + e @ q @ e, {"u": u}

    return cost


# Initial proposal std (per control dim). Each call restarts Sigma here, so it sets
# the noise floor of the refitted mean: about sigma^2 tr(Q) / n_eff ~ 0.3% of C0.
INIT_STD = 0.3 * jnp.array([1.0, 0.7, 1.0, 0.7, 1.0, 0.7])

# Softmax temperature: the std of the sample costs at the initial proposal is
# sigma^2 sqrt(2 tr Q^2) ~ 0.065 * 18 ~ 1.2. T ~ 1 keeps n_eff ~ 100 of 200:
# T << 1 puts all weight on one sample (the weighted covariance collapses), T >> 1
# makes the weights uniform (the mean does not move).
SOFTMAX_T = 1.0


@pytest.mark.parametrize(
    "cfg",
    [MPPIConfig(weighting="ce"), MPPIConfig(weighting="softmax", temperature=SOFTMAX_T)],
    ids=["ce", "softmax"],
)
def test_converges_on_quadratic(cfg):
    cost = _quadratic()
    step = jax.jit(lambda m, k: optimize(cost, m, k, cfg, INIT_STD, LOWER, UPPER))
    mean = jnp.zeros((H, D))
    start = float(cost(mean)[0])
    assert start > 2.0 * C0  # a real distance to cover
    key = jax.random.PRNGKey(0)
    for _ in range(25):  # receding-horizon use: warm-start the mean, restart Sigma
        key, sub = jax.random.split(key)
        res = step(mean, sub)
        mean = res.mean
    final = float(cost(mean)[0])
    # Spec: within 1% of the optimal cost C0 (observed ~0.2-0.4% excess: 2-5x margin).
    assert final <= 1.01 * C0, (start, final)
    assert final >= C0 - 1e-3  # float32 round-off of C0 + e^T Q e near e = 0
    assert step._cache_size() == 1  # compiled once across all 25 calls


def test_result_shapes_and_weights():
    cost = _quadratic()
    cfg = MPPIConfig(samples=200, iterations=3)
    res = optimize(cost, jnp.zeros((H, D)), jax.random.PRNGKey(1), cfg, INIT_STD, LOWER, UPPER)
    assert isinstance(res, MPPIResult)
    assert res.mean.shape == (H, D) and res.samples.shape == (200, H, D)
    assert res.costs.shape == res.weights.shape == (200,)
    assert res.aux["u"].shape == (200, H, D)
    # aux belongs to the returned (last) sub-iteration: the cost saw these samples.
    np.testing.assert_array_equal(np.asarray(res.aux["u"]), np.asarray(res.samples))
    # CE at 0.9: quantile index 0.1 * 199 = 19.9 -> the 20 best of 200 distinct costs.
    w = np.asarray(res.weights)
    order = np.argsort(np.asarray(res.costs))
    assert np.all(w[order[:20]] > 0) and np.all(w[order[20:]] == 0)
    np.testing.assert_allclose(w[order[:20]], 1 / 20, rtol=1e-6)  # float32 1/20
    # mean = sum_s w_s u_s of the returned samples (float32 sum of 20 terms).
    np.testing.assert_allclose(
        np.asarray(res.mean), np.einsum("s,shd->hd", w, np.asarray(res.samples)), atol=1e-5
    )


def test_sample_weights_formulas():
    costs = jnp.array([3.0, 1.0, 2.0, jnp.nan, 1.5, jnp.inf, 4.0, 0.5, 2.5, 5.0])
    sm = sample_weights(costs, MPPIConfig(weighting="softmax", temperature=0.5))
    c = np.asarray(costs)
    ref = np.where(np.isfinite(c), np.exp(-(c - 0.5) / 0.5), 0.0)
    np.testing.assert_allclose(np.asarray(sm), ref / ref.sum(), rtol=1e-6)  # float32 exp
    # CE with threshold 0.7: 0.3 quantile of the finite-first sorted costs -> 3 elites.
    ce = np.asarray(sample_weights(costs, MPPIConfig(weighting="ce", elite_threshold=0.7)))
    np.testing.assert_allclose(ce[[7, 1, 4]], 1 / 3, rtol=1e-6)
    assert ce.sum() == pytest.approx(1.0) and np.count_nonzero(ce) == 3
    # All costs non-finite: all weight on one sample, never NaN.
    bad = sample_weights(jnp.full((5,), jnp.nan), MPPIConfig())
    assert np.isfinite(np.asarray(bad)).all() and float(bad.sum()) == 1.0


@pytest.mark.parametrize("weighting", ["ce", "softmax"])
def test_samples_are_clipped_near_bounds(weighting):
    cfg = MPPIConfig(samples=64, iterations=3, weighting=weighting)
    # Cost pulls the mean beyond the upper bound; the mean starts at / near bounds.
    cost = lambda u: (jnp.sum((u - 2.0 * UPPER) ** 2), u)  # noqa: E731
    mean = jnp.tile(UPPER - 0.01, (H, 1)).at[::2].set(LOWER)
    res = optimize(cost, mean, jax.random.PRNGKey(2), cfg, 2.0 * UPPER, LOWER, UPPER)
    s = np.asarray(res.samples)
    assert np.all(s >= np.asarray(LOWER)) and np.all(s <= np.asarray(UPPER))
    assert np.all(np.asarray(res.aux) <= np.asarray(UPPER))  # the cost saw clipped samples
    assert np.any(s == np.asarray(UPPER))  # clipping was active
    m = np.asarray(res.mean)  # convex combination of clipped samples
    assert np.all(m >= np.asarray(LOWER)) and np.all(m <= np.asarray(UPPER))


def test_shift_repeats_last_control_without_wraparound():
    u = jnp.arange(H * D, dtype=jnp.float32).reshape(H, D)
    v = shift(u)
    assert v.shape == (H, D)
    np.testing.assert_array_equal(np.asarray(v[:-1]), np.asarray(u[1:]))
    np.testing.assert_array_equal(np.asarray(v[-1]), np.asarray(u[-1]))
    assert not np.array_equal(np.asarray(v[-1]), np.asarray(u[0]))


@pytest.mark.parametrize("shrinkage", ["ledoit-wolf", "oas", "none"])
def test_deterministic_and_jits_once(shrinkage):
    cost = _quadratic()
    cfg = MPPIConfig(samples=50, iterations=2, shrinkage=shrinkage)
    step = jax.jit(lambda m, k: optimize(cost, m, k, cfg, INIT_STD, LOWER, UPPER))
    m0 = jnp.zeros((H, D))
    a = step(m0, jax.random.PRNGKey(3))
    b = step(m0, jax.random.PRNGKey(3))
    c = step(m0 + 0.1, jax.random.PRNGKey(4))
    assert step._cache_size() == 1  # one compilation for new keys and means
    for x, y in zip(jax.tree_util.tree_leaves(a), jax.tree_util.tree_leaves(b), strict=True):
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y))  # bitwise identical
    assert not np.array_equal(np.asarray(a.samples), np.asarray(c.samples))
    assert all(np.isfinite(np.asarray(x)).all() for x in jax.tree_util.tree_leaves(a))
