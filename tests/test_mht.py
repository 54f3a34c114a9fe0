"""The K-best multiple-hypothesis tracker against a brute-force enumeration (docs/tracking.md).

Reference: a plain numpy Kalman filter per target run along *every* association history
of a small problem (2 targets, 2 radars, 2 scans; each update's joint events: a target
takes one return or none, no return twice), each history scored by the product of its
updates' factors ``(1 − P_D P_G)`` (missed) and ``P_D N(ν; 0, S) / λ`` (detected), then
normalised. With K no smaller than the number of histories, the MHT must keep all of them
with the same weights and banks. The measurement is linear (a projection of the position,
so the cubature moments are exact and the CKF is the Kalman filter) and P_D depends on
each history's predicted position, so the parent-dependent miss term is exercised.
Float64 on both sides: 1e-9 is round-off of a few dozen 6x6 products and 1-D solves.
With K = 1 the MHT is the sequential GNN bank (the range model, 1e-12).
"""

import itertools

import _range_scene
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.stats import chi2

from mjx_radar.estimation.data_association import jpda, mht
from mjx_radar.io.checks import ScenarioError

DT = 0.1
PG, LAM = 0.99, 0.05
HS = np.array([[1.0, 0.2, 0.0], [0.1, 1.0, 0.3]])  # radar i measures HS[i] . position
R = 0.5


def _a6():
    a = np.eye(6)
    a[:3, 3:] = DT * np.eye(3)
    return a


Q6 = np.diag([0.01, 0.01, 0.01, 0.2, 0.2, 0.2])


def _pd(pos, xp=np):
    """P_D of a target at ``pos [..., 3]``: depends on the (predicted) position."""
    return 0.55 + 0.4 * xp.tanh(pos[..., 0] / 4.0) ** 2


def _problem():
    rng = np.random.default_rng(3)
    means = np.array([[0.0, 1.0, 2.0, 1.0, 0.5, 0.0], [1.5, 0.0, 1.0, -0.5, 1.0, 0.2]])
    covs = np.stack([np.diag([2.0, 2.0, 2.0, 1.0, 1.0, 1.0])] * 2)
    scans = []  # [scan][radar] -> returns [L]
    for s in range(2):
        truth = means[:, :3] + (s + 1) * DT * means[:, 3:]
        per = []
        for i in range(2):
            z = truth @ HS[i] + rng.normal(0, np.sqrt(R), 2)
            if (s, i) == (1, 0):  # one target missed, one clutter return and an extra one
                z = np.array([z[1], z[0] + 3.0, z[1] - 1.0])
            per.append(z)
        scans.append(per)
    return means, covs, scans


def _events(m, n_ret):
    """Every joint event: target t takes return e[t] (−1: missed), no return twice."""
    out = []
    for e in itertools.product(range(-1, n_ret), repeat=m):
        used = [j for j in e if j >= 0]
        if len(used) == len(set(used)):
            out.append(e)
    return out


def _brute(means, covs, scans):
    """Every history's normalised weight and final bank (numpy Kalman filters)."""
    a6 = _a6()
    updates = [(s, i) for s in range(2) for i in range(2)]
    options = [_events(2, len(scans[s][i])) for s, i in updates]
    out = []
    for hist in itertools.product(*options):
        x, P, logw = means.copy(), covs.copy(), 0.0
        for u, (s, i) in enumerate(updates):
            if i == 0:  # a new scan: predict
                x = x @ a6.T
                P = np.einsum("ij,tjk,lk->til", a6, P, a6) + Q6
            hrow = np.concatenate([HS[i], np.zeros(3)])
            pd = _pd(x[:, :3])
            for t in range(2):
                j = hist[u][t]
                if j < 0:
                    logw += np.log1p(-pd[t] * PG)
                    continue
                S = hrow @ P[t] @ hrow + R
                nu = scans[s][i][j] - hrow @ x[t]
                K = P[t] @ hrow / S
                logw += np.log(pd[t]) - 0.5 * (np.log(2 * np.pi * S) + nu**2 / S) - np.log(LAM)
                x[t] = x[t] + K * nu
                P[t] = P[t] - np.outer(K, K) * S
        out.append((logw, x, P))
    lw = np.array([o[0] for o in out])
    lw = lw - np.logaddexp.reduce(lw)
    return lw, np.stack([o[1] for o in out]), np.stack([o[2] for o in out])


def _mht(means, covs, scans, k):
    """The MHT over the two scans, one jitted program (eagerly, each of its small ops
    compiles on its own: hundreds of compilations)."""

    def run(means, covs, scans):
        hyp = mht.init(means, covs, k)
        a6, q6 = jnp.asarray(_a6()), jnp.asarray(Q6)
        for s in range(2):
            hyp = mht.predict(hyp, a6, q6)
            for i in range(2):
                z = scans[s][i][:, None]
                hrow = jnp.asarray(np.concatenate([HS[i], np.zeros(3)]))
                pd = _pd(hyp.means[..., :3], jnp)
                hyp, _ = mht.radar_update(
                    hyp, z, jnp.ones(z.shape[0], bool), lambda x, hrow=hrow: (hrow @ x)[None],
                    jnp.eye(1) * R, pd, LAM, 1e12, PG, z.shape[0],
                )  # fmt: skip
        return hyp

    with jax.enable_x64(True):
        zs = [[jnp.asarray(z) for z in per] for per in scans]
        hyp = jax.jit(run)(jnp.asarray(means), jnp.asarray(covs), zs)
        return jax.tree_util.tree_map(np.asarray, hyp)


def test_weights_and_banks_match_enumeration_of_every_history():
    means, covs, scans = _problem()
    lw, xs, Ps = _brute(means, covs, scans)
    n = len(lw)  # 7 x 7 x 13 x 7 = 4459 histories
    assert n == 4459
    hyp = _mht(means, covs, scans, k=4608)
    finite = np.isfinite(hyp.logw)
    assert finite.sum() == n  # every history kept, the empty slots stay empty
    order = np.argsort(-lw)
    np.testing.assert_allclose(hyp.logw[:n], lw[order], rtol=0, atol=1e-9)  # top_k: sorted
    top = order[:50]  # the heaviest hypotheses' banks (no ties there)
    np.testing.assert_allclose(hyp.means[:50], xs[top], rtol=0, atol=1e-9)
    np.testing.assert_allclose(hyp.covs[:50], Ps[top], rtol=0, atol=1e-9)


def test_pruned_weights_are_the_best_children_of_the_kept_parents():
    """K = 8: the kept weights are the 8 best of the enumerated histories after the
    first update (exact there: one parent), and always normalised and sorted."""
    means, covs, scans = _problem()
    hyp = _mht(means, covs, scans, k=8)
    assert np.all(np.diff(hyp.logw) <= 0)
    np.testing.assert_allclose(np.logaddexp.reduce(hyp.logw), 0.0, atol=1e-12)
    lw, xs, _ = _brute(means, covs, scans)
    np.testing.assert_allclose(hyp.means[0], xs[np.argmax(lw)], atol=1e-9)  # MAP found


def test_one_hypothesis_is_the_sequential_gnn_bank():
    means, covs, zs = _range_scene.scene()
    with jax.enable_x64(True):
        args, pd = _range_scene.model_args(zs)
        tail = (jnp.float64(0.02), jnp.float64(chi2.ppf(PG, 1)), jnp.float64(PG))
        x, P = jax.jit(  # jitted, both (eagerly, each small op compiles on its own)
            lambda m, c: jpda.update_bank(m, c, *args, pd, *tail, jpda.rule("gnn", 4))
        )(jnp.asarray(means), jnp.asarray(covs))
        hyp = jax.jit(
            lambda m, c: mht.update_bank(
                mht.init(m, c, 1), *args, lambda pos: pd[:, None, :], *tail, 4
            )
        )(jnp.asarray(means), jnp.asarray(covs))
    np.testing.assert_allclose(hyp.means[0], x, rtol=0, atol=1e-12)
    np.testing.assert_allclose(hyp.covs[0], P, rtol=0, atol=1e-12)
    assert np.abs(np.asarray(x) - means).max() > 0.1


def test_scenario_selects_and_refuses_mht():
    import mjx_radar
    from mjx_radar.scenario.tracker_roles import composed

    s = mjx_radar.load_scenario("clutter_3r4t")
    assert s.tracker.association == "pda" and s.tracker.hypotheses == 16  # off by default
    assert composed(s.replace(tracker={"association": "mht"})) == "mht"
    with pytest.raises(ScenarioError, match="tracker.hypotheses"):
        s.replace(tracker={"association": "mht", "hypotheses": 0})
    with pytest.raises(ScenarioError, match="tracker.hypotheses = 1024"):
        s.replace(tracker={"association": "mht", "hypotheses": 1024, "candidates": 5})
    seven = [[30.0 * i, 0.0, 55.0, 10.0, 0.0, 0.0] for i in range(7)]
    with pytest.raises(ScenarioError, match="tracker.merge_labels = true"):
        s.replace(
            targets=seven,
            tracker={"association": "mht", "merge_labels": True, "candidates": 2},
        )
    with pytest.raises(ScenarioError, match='tracker.association = "mht": needs clutter'):
        s.replace(tracker={"association": "mht"}, detection={"clutter_density": 0.0})


def _merge_reference(means, covs, logw, tau, labels=False):
    """Plain loops: each child joins the first heavier kept child it nearly duplicates
    (the first heavier one it duplicates, followed to a kept one); with ``labels`` in any
    order of its targets."""
    c, m = len(logw), means.shape[1]
    var = np.diagonal(covs, axis1=-2, axis2=-1)
    orders = list(itertools.permutations(range(m))) if labels else [tuple(range(m))]
    owner = list(range(c))
    for j in range(c):
        for i in range(j):
            d2 = min(
                np.max(np.sum((means[i] - means[j][list(p)]) ** 2 / (var[i] + var[j][list(p)]), -1))
                for p in orders
            )
            if np.isfinite(logw[i]) and np.isfinite(logw[j]) and d2 < tau:
                owner[j] = owner[i]
                break
    out = np.full(c, -np.inf)
    for j in range(c):
        if np.isfinite(logw[j]):
            out[owner[j]] = np.logaddexp(out[owner[j]], logw[j])
    return out


@pytest.mark.parametrize("labels", [False, True])
def test_merge_matches_a_loop_reference_and_keeps_the_mass(labels):
    from mjx_radar.estimation.data_association.association import permutations
    from mjx_radar.estimation.data_association.mht_merge import merge_duplicates

    rng = np.random.default_rng(11)
    c, m = 24, 3
    base = rng.normal(0, 3, (4, m, 6))  # 4 distinct banks, each copied with small offsets
    means = base[rng.integers(0, 4, c)] + rng.normal(0, 0.3, (c, m, 6))
    means = np.stack([x[rng.permutation(m)] for x in means])  # in any target order
    covs = np.stack([np.eye(6) * rng.uniform(0.5, 2.0)] * m)[None].repeat(c, 0)
    logw = np.sort(rng.normal(0, 2, c))[::-1].copy()
    logw[-3:] = -np.inf  # empty children
    with jax.enable_x64(True):
        perms = permutations(m) if labels else None
        got = merge_duplicates(jnp.asarray(means), jnp.asarray(covs), logw, 1.0, perms)
    got = np.asarray(got)
    ref = _merge_reference(means, covs, logw, 1.0, labels)
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-12)
    kept = np.isfinite(got).sum()
    assert 4 <= kept < c - 3  # merged, down to at least the 4 banks
    np.testing.assert_allclose(np.logaddexp.reduce(got), np.logaddexp.reduce(logw), atol=1e-12)
