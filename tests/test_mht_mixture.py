"""The MHT's hypotheses as one Gaussian per target (``[tracker] plan_on = "mixture"``,
:mod:`mjx_radar.estimation.data_association.mht_mixture`) against a numpy reference.

The reference aligns every hypothesis to the heaviest by enumerating all M! target
orders (not the Hungarian solver) on the squared position distances, normalises the
weights by hand and sums the mixture's moments in loops. Float64 on both sides: the
sums differ only in their order (1e-12). A single hypothesis, or one holding all the
weight, gives the heaviest bank bit for bit (the empty slots weigh exactly 0).
"""

import itertools

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_radar.estimation.data_association import mht_mixture
from mjx_radar.io.checks import ScenarioError


def _spd(rng, n=6):
    a = rng.normal(size=(n, n))
    return a @ a.T + n * np.eye(n)


def _hypotheses(seed=0):
    """K = 4 hypotheses of M = 3 targets; hypothesis 2 is hypothesis 0 (the heaviest)
    with its targets permuted and slightly moved, hypothesis 3 a cyclic permutation of a
    perturbed copy; unnormalised log weights."""
    rng = np.random.default_rng(seed)
    m = 3
    base = rng.normal(size=(m, 6)) * np.array([100, 100, 30, 5, 5, 1])  # targets far apart
    covs0 = np.stack([_spd(rng) for _ in range(m)])
    means = [base]
    covs = [covs0]
    means.append(base + rng.normal(size=(m, 6)) * 3.0)  # same labels, moved
    covs.append(np.stack([_spd(rng) for _ in range(m)]))
    perm = [2, 0, 1]
    means.append((base + rng.normal(size=(m, 6)))[perm])
    covs.append(np.stack([_spd(rng) for _ in range(m)])[perm])
    means.append((base + rng.normal(size=(m, 6)) * 2.0)[[1, 2, 0]])
    covs.append(np.stack([_spd(rng) for _ in range(m)]))
    logw = np.array([2.3, 1.1, 1.9, 0.4])  # not normalised: Σ exp ≠ 1
    return np.stack(means), np.stack(covs), logw


def _reference(means, covs, logw):
    """Brute-force alignment (every target order) and the mixture's moments in numpy."""
    k, m = means.shape[:2]
    w = np.exp(logw - logw.max())
    w = w / w.sum()
    ref = means[np.argmax(logw), :, :3]
    aligned_m, aligned_c = [], []
    for h in range(k):

        def cost(p, h=h):
            return sum(np.sum((ref[i] - means[h, p[i], :3]) ** 2) for i in range(m))

        best = min(itertools.permutations(range(m)), key=cost)
        aligned_m.append(means[h, list(best)])
        aligned_c.append(covs[h, list(best)])
    xs, ps = np.array(aligned_m), np.array(aligned_c)
    mean = np.einsum("k,kmi->mi", w, xs)
    cov = np.zeros((m, 6, 6))
    for h in range(k):
        for t in range(m):
            d = xs[h, t] - mean[t]
            cov[t] += w[h] * (ps[h, t] + np.outer(d, d))
    return mean, cov, xs


def test_mixture_moments_match_numpy_and_undo_label_permutations():
    means, covs, logw = _hypotheses()
    with jax.enable_x64(True):
        am, _ = jax.jit(mht_mixture.align)(means, covs, logw)
        mean, cov = jax.jit(mht_mixture.mixture)(means, covs, logw)
    rm, rc, xs = _reference(means, covs, logw)
    np.testing.assert_array_equal(np.asarray(am), xs)  # the same orders, the same rows
    # the permuted hypotheses are put back: each aligned target near the heaviest's
    assert np.max(np.abs(np.asarray(am)[:, :, :3] - means[0, None, :, :3])) < 15.0
    np.testing.assert_allclose(np.asarray(mean), rm, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(np.asarray(cov), rc, rtol=1e-12, atol=1e-9)
    # without the alignment the permuted hypotheses would put targets between the drones
    w = np.exp(logw - logw.max()) / np.exp(logw - logw.max()).sum()
    naive = np.einsum("k,kmi->mi", w, means)
    assert np.max(np.abs(naive[:, :3] - rm[:, :3])) > 20.0


def test_weights_are_normalised():
    means, covs, logw = _hypotheses(1)
    with jax.enable_x64(True):
        a = mht_mixture.mixture(means, covs, logw)
        b = mht_mixture.mixture(means, covs, logw - 37.5)  # the same weights, shifted logs
        norm = logw - np.log(np.sum(np.exp(logw)))
        c = mht_mixture.mixture(means, covs, norm)
    for x, y in ((a, b), (a, c)):
        np.testing.assert_allclose(np.asarray(x[0]), np.asarray(y[0]), rtol=1e-13, atol=1e-10)
        np.testing.assert_allclose(np.asarray(x[1]), np.asarray(y[1]), rtol=1e-13, atol=1e-10)


@pytest.mark.parametrize("heavy", [0, 2])
def test_one_dominant_hypothesis_is_the_best_bank_exactly(heavy):
    means, covs, _ = _hypotheses(2)
    means = means.copy()
    logw = np.full(4, -np.inf)
    logw[heavy] = 0.0
    logw[(heavy + 1) % 4] = -1000.0  # exp underflows to 0: weight 0 exactly
    means[(heavy + 3) % 4] = np.nan  # a stale empty slot
    for x64 in (True, False):
        with jax.enable_x64(x64):
            dt = jnp.float64 if x64 else jnp.float32
            m_, c_ = (jnp.asarray(a, dt) for a in (means, covs))
            mean, cov = jax.jit(mht_mixture.mixture)(m_, c_, jnp.asarray(logw, dt))
            np.testing.assert_array_equal(np.asarray(mean), np.asarray(m_[heavy]))
            np.testing.assert_array_equal(np.asarray(cov), np.asarray(c_[heavy]))


def test_mixture_vmaps_over_trials():
    means, covs, logw = _hypotheses(3)
    stack = lambda a: np.stack([a, a[::-1]])  # noqa: E731
    with jax.enable_x64(True):
        out = jax.vmap(mht_mixture.mixture)(stack(means), stack(covs), stack(logw))
        one = mht_mixture.mixture(means[::-1], covs[::-1], logw[::-1])
    np.testing.assert_allclose(np.asarray(out[0][1]), np.asarray(one[0]), rtol=1e-13)
    np.testing.assert_allclose(np.asarray(out[1][1]), np.asarray(one[1]), rtol=1e-13)


def test_plan_on_off_by_default_and_refused_in_one_line():
    import mjx_radar

    s = mjx_radar.load_scenario("clutter_3r4t")
    assert s.tracker.plan_on == "best"
    s.replace(tracker={"association": "mht", "plan_on": "mixture"})
    with pytest.raises(ScenarioError, match=r"tracker.plan_on = 'mean': must be one of best, mix"):
        s.replace(tracker={"association": "mht", "plan_on": "mean"})
    for assoc in ("pda", "jpda", "gnn"):  # no hypotheses: the option would be ignored
        with pytest.raises(ScenarioError, match='plan_on = "mixture": read only with') as e:
            s.replace(tracker={"association": assoc, "plan_on": "mixture"})
        assert "\n" not in str(e.value)


@pytest.mark.slow  # one closed-loop environment program (~40 s on a busy CPU)
def test_the_planner_sees_the_mixture_the_metrics_the_heaviest():
    import mjx_radar
    from mjx_radar.env import environment
    from mjx_radar.estimation.data_association import mht
    from mjx_radar.estimation.filters import filter_bank

    s = mjx_radar.load_scenario("clutter_3r4t")
    s = s.replace(tracker={"association": "mht", "hypotheses": 4, "plan_on": "mixture"})
    env = environment.make(s)
    state = jax.jit(env.reset)(env.trial_key(env.params.seed, 0))
    step = jax.jit(env.step)
    for _ in range(3):  # a few scans: several hypotheses with weight
        state = step(state, jnp.zeros((env.n_radars, 2)))
    loop = state.loop
    modes = loop.modes
    if not env.task.mpc.aligned:
        modes = env._tracker.predict(loop.mean, loop.cov, modes)[2]
    assert np.sum(np.exp(np.asarray(modes.logw)) > 1e-3) >= 2
    want = filter_bank.bank_to_joint(*mht_mixture.mixture(modes.means, modes.covs, modes.logw))
    np.testing.assert_allclose(np.asarray(state.obs.mean), np.asarray(want[0]), atol=1e-4)
    np.testing.assert_allclose(np.asarray(state.obs.cov), np.asarray(want[1]), rtol=1e-5)
    best = filter_bank.bank_to_joint(*mht.best(loop.modes))  # what the metrics score
    np.testing.assert_array_equal(np.asarray(loop.mean), np.asarray(best[0]))
    assert np.max(np.abs(np.asarray(state.obs.mean) - np.asarray(loop.mean))) > 1e-3
