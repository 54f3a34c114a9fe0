"""The association bound's hypothesis algebra (benchmarks/studies/association_bound.py, issue 35)
against a plain enumeration of the joint hypotheses."""

import importlib.util
import itertools
from pathlib import Path

import numpy as np
import pytest

SCRIPT = Path(__file__).resolve().parents[1] / "benchmarks" / "studies" / "association_bound.py"


@pytest.fixture(scope="module")
def bound():
    spec = importlib.util.spec_from_file_location("association_bound_script", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_joint_hypotheses_are_the_per_radar_permutations(bound):
    m, n = 3, 2
    col = bound.joint_hypotheses(m, n)
    assert col.shape == (6**n, m)
    np.testing.assert_array_equal(col[0], np.arange(m) * (m + 1))  # drone m at each radar
    digits = np.stack([col // m ** (n - 1 - i) % m for i in range(n)], -1)  # [H, M, N]
    for i in range(n):  # each radar's drones are a permutation of the tracks
        assert (np.sort(digits[:, :, i], axis=1) == np.arange(m)).all()
    assert len({tuple(r) for r in col}) == len(col)


def test_posterior_matches_enumeration(bound):
    rng = np.random.default_rng(3)
    k, m, n = 4, 3, 2
    t = m**n
    ll = rng.normal(0.0, 3.0, (k, m, t))
    pos = rng.normal(0.0, 10.0, (k, m, t, 3))
    a = rng.normal(size=(k, m, t, 3, 3))
    cov = a @ np.swapaxes(a, -1, -2) + np.eye(3)
    col = bound.joint_hypotheses(m, n)
    est = bound.estimates(ll, pos, cov, col)
    perms = list(itertools.permutations(range(m)))
    for s in range(k):  # enumerate every permutation per radar by hand
        hyps, logp = [], []
        for pr in itertools.product(perms, repeat=n):
            tau = [sum(pr[i][j] * m ** (n - 1 - i) for i in range(n)) for j in range(m)]
            hyps.append(tau)
            logp.append(sum(ll[s, j, tau[j]] for j in range(m)))
        p = np.exp(np.array(logp) - max(logp))
        p /= p.sum()
        mean = sum(p[h] * pos[s, np.arange(m), hyps[h]] for h in range(len(hyps)))
        second = sum(
            p[h] * (cov[s, np.arange(m), hyps[h]]
                    + np.einsum("md,me->mde", *(2 * [pos[s, np.arange(m), hyps[h]] - mean])))
            for h in range(len(hyps))
        )  # fmt: skip
        best = hyps[int(np.argmax(logp))]
        np.testing.assert_allclose(est["p_true"][s], p[0], rtol=1e-5)
        np.testing.assert_allclose(est["mmse"][0][s], mean, rtol=1e-5, atol=1e-5)
        np.testing.assert_allclose(est["mmse"][1][s], second, rtol=1e-5, atol=1e-4)
        np.testing.assert_allclose(est["map"][0][s], pos[s, np.arange(m), best])
        np.testing.assert_allclose(est["true"][0][s], pos[s, np.arange(m), np.arange(m) * (m + 1)])


def test_trial_metrics_lost_and_unmatched(bound):
    truth = np.zeros((5, 2, 3))
    truth[:, 1, 0] = 100.0  # two drones 100 m apart
    cov = np.broadcast_to(np.eye(3), (5, 2, 3, 3))
    swapped = truth[:, ::-1]  # labels swapped, the set right
    est = {"true": (truth, cov), "mmse": (truth, cov), "map": (swapped, cov),
           "p_true": np.full(5, 0.3)}  # fmt: skip
    out = bound.trial_metrics(est, truth)
    assert not out["lost_true"] and out["rmse_true"] == 0.0
    assert out["lost_map"] and not out["unmatched_map"]  # lost by label, matched as a set
    assert out["rmse_map"] == pytest.approx(100.0)
