"""The MHT's consensus estimate (``[tracker] estimate = "consensus"``,
:mod:`mjx_radar.estimation.data_association.mht_estimate`) against a numpy reference.

The reference takes the J heaviest hypotheses by sorting, computes every pair's
label-free distance by enumerating the M! target orders in Python loops, normalises the
J weights by hand and picks the argmax of the kernel-weighted sums. Float64 on both
sides; the chosen index must be the same, and the scores of the reference must separate
the winner from the runner-up by far more than rounding (checked), so the comparison
cannot pass by a tie. Then the properties the docs state: a cluster of near-identical
hypotheses outvotes a heavier lone one, a label permutation changes nothing, small
scales give the MAP, an empty slot is never chosen, and only the J heaviest count.
"""

import itertools

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_radar.estimation.data_association import mht, mht_estimate
from mjx_radar.io.checks import ScenarioError


def _reference(means, logw, scale, j_max):
    """``(index, scores [J] in the order of the J heaviest)``, brute force in numpy."""
    k, m = means.shape[:2]
    order = np.argsort(-logw, kind="stable")[: min(j_max, k)]
    lw = logw[order]
    w = np.where(np.isfinite(lw), np.exp(lw - np.max(lw)), 0.0)
    w = w / w.sum()
    pos = means[order, :, :3]
    scores = []
    for a in range(len(order)):
        s = 0.0
        for b in range(len(order)):
            d2 = min(
                sum(np.sum((pos[a, t] - pos[b, p[t]]) ** 2) for t in range(m))
                for p in itertools.permutations(range(m))
            )
            s += w[b] * np.exp(-d2 / (2 * scale**2))
        scores.append(s if np.isfinite(lw[a]) else -np.inf)
    scores = np.array(scores)
    return int(order[np.argmax(scores)]), scores


def _scene(seed, k=12, m=3):
    """K hypotheses of M targets: a heavy lone ghost (slot 0), a cluster of 5 lighter
    near-copies of the truth with their targets in random orders, and scattered others."""
    rng = np.random.default_rng(seed)
    truth = rng.normal(size=(m, 6)) * np.array([30, 30, 10, 3, 3, 1])
    means = np.empty((k, m, 6))
    means[0] = truth + np.array([0, 0, 40, 0, 0, 0])  # a height ghost
    for h in range(1, 6):
        means[h] = (truth + rng.normal(size=(m, 6)))[rng.permutation(m)]
    for h in range(6, k):
        means[h] = truth + rng.normal(size=(m, 6)) * 25
    logw = np.log(np.r_[0.3, [0.12] * 5, rng.uniform(0.001, 0.02, k - 6)])
    return means, logw


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("scale", [2.0, 5.0, 20.0])
def test_consensus_index_matches_the_brute_force_reference(seed, scale):
    means, logw = _scene(seed)
    want, scores = _reference(means, logw, scale, mht_estimate.J_MAX)
    top2 = np.sort(scores)[-2:]
    assert top2[1] - top2[0] > 1e-6  # no tie: the index comparison is meaningful
    with jax.enable_x64(True):
        got = jax.jit(mht_estimate.consensus_index, static_argnums=2)(means, logw, scale)
    assert int(got) == want


def test_a_cluster_outvotes_a_heavier_lone_ghost_and_small_scales_give_the_map():
    means, logw = _scene(7)
    with jax.enable_x64(True):
        assert int(jnp.argmax(logw)) == 0  # MAP: the ghost
        i = int(mht_estimate.consensus_index(means, logw, 5.0))
        assert 1 <= i <= 5  # one of the cluster (0.6 of the weight against 0.3)
        assert int(mht_estimate.consensus_index(means, logw, 1e-3)) == 0  # s -> 0: MAP


def test_label_permutations_and_weight_shifts_change_nothing():
    means, logw = _scene(3)
    rng = np.random.default_rng(0)
    shuffled = np.stack([h[rng.permutation(h.shape[0])] for h in means])
    with jax.enable_x64(True):
        a = int(mht_estimate.consensus_index(means, logw, 5.0))
        b = int(mht_estimate.consensus_index(shuffled, logw - 12.5, 5.0))
    assert a == b


def test_an_empty_slot_is_never_chosen():
    means, logw = _scene(1)
    means = np.concatenate([means, means[1:2]])  # a stale slot sitting on the cluster
    logw = np.r_[logw, -np.inf]
    with jax.enable_x64(True):
        i = int(mht_estimate.consensus_index(means, logw, 5.0))
    assert np.isfinite(logw[i]) and i == _reference(means, logw, 5.0, mht_estimate.J_MAX)[0]


def test_only_the_j_heaviest_are_compared():
    """80 hypotheses: a lone one of weight 1.5, 63 scattered of weight 1 and, beyond the 64
    heaviest, 16 of weight 0.99 on scattered hypothesis 10. Counting all 80 would choose 10's
    cluster; the J = 64 heaviest choose the lone heaviest."""
    rng = np.random.default_rng(2)
    means = rng.normal(size=(80, 3, 6)) * 200.0
    means[64:] = means[10] + rng.normal(size=(16, 3, 6)) * 0.1
    logw = np.log(np.r_[1.5, np.ones(63), np.full(16, 0.99)])
    assert mht_estimate.J_MAX == 64
    with jax.enable_x64(True):
        i = int(mht_estimate.consensus_index(means, logw, 5.0))
    assert i == _reference(means, logw, 5.0, 64)[0] == 0
    assert _reference(means, logw, 5.0, 80)[0] in (10, *range(64, 80))


def test_one_hypothesis_gives_the_heaviest_bank_bit_for_bit():
    rng = np.random.default_rng(5)
    means = rng.normal(size=(8, 4, 6))
    covs = np.broadcast_to(np.eye(6), (8, 4, 6, 6)).copy()
    logw = np.full(8, -np.inf)
    logw[3] = 0.0
    hyp = mht.HypState(jnp.asarray(means), jnp.asarray(covs), jnp.asarray(logw))
    m_, c_ = mht_estimate.consensus(hyp.means, hyp.covs, hyp.logw, 5.0)
    b_m, b_c = mht.best(hyp)
    np.testing.assert_array_equal(np.asarray(m_), np.asarray(b_m))
    np.testing.assert_array_equal(np.asarray(c_), np.asarray(b_c))


def test_estimate_off_by_default_and_refused_in_one_line():
    import mjx_radar

    s = mjx_radar.load_scenario("clutter_3r4t")
    assert (s.tracker.estimate, s.tracker.consensus_scale) == ("best", 5.0)
    ok = s.replace(tracker={"association": "mht", "estimate": "consensus", "consensus_scale": 8})
    assert ok.tracker.consensus_scale == 8.0
    cases = [
        ({"association": "jpda", "estimate": "consensus"}, 'estimate = "consensus": read only'),
        ({"association": "mht", "consensus_scale": 3.0}, "consensus_scale = 3.0: read only"),
        ({"association": "mht", "estimate": "consensus", "consensus_scale": 0.0}, "(0.0, "),
        ({"association": "mht", "estimate": "mean"}, "must be one of best, consensus"),
    ]
    for edit, msg in cases:
        with pytest.raises(ScenarioError, match=msg.replace("(", r"\(")) as e:
            s.replace(tracker=edit)
        assert "\n" not in str(e.value)
    raid = mjx_radar.load_scenario("raid_4r8t")  # 8 drones: 8! orders
    edit = {"association": "mht", "candidates": 1, "estimate": "consensus"}
    with pytest.raises(ScenarioError, match="M! = 40320 target orders .* at most 6") as e:
        raid.replace(
            filter={"structure": "per-target"}, detection={"clutter_density": 0.001}, tracker=edit
        )
    assert "\n" not in str(e.value)


@pytest.mark.slow  # one closed-loop environment program (~40 s on a busy CPU)
def test_the_loop_carries_the_consensus_hypothesis():
    import mjx_radar
    from mjx_radar.env import environment
    from mjx_radar.estimation.filters import filter_bank

    s = mjx_radar.load_scenario("clutter_3r4t")
    edit = {"association": "mht", "hypotheses": 8, "estimate": "consensus", "consensus_scale": 20}
    env = environment.make(s.replace(tracker=edit))
    state = jax.jit(env.reset)(env.trial_key(env.params.seed, 2))
    state = jax.jit(env.step)(state, jnp.zeros((env.n_radars, 2)))  # one scan: trial 2's
    modes = state.loop.modes  # consensus is not its heaviest hypothesis (so this can fail)
    i = int(mht_estimate.consensus_index(modes.means, modes.logw, 20.0))
    assert i != int(jnp.argmax(modes.logw))
    want = filter_bank.bank_to_joint(modes.means[i], modes.covs[i])
    np.testing.assert_array_equal(np.asarray(state.loop.mean), np.asarray(want[0]))
    np.testing.assert_array_equal(np.asarray(state.loop.cov), np.asarray(want[1]))
