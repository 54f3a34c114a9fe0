"""The MHT that branches for the first scans and then gives each hypothesis JPDA's soft
update (``[tracker] branch_scans``, docs/tracking.md) against independent references.

1. A brute-force numpy enumeration (2 targets, 2 radars, 2 scans; a linear measurement,
   so the cubature moments are exact and the CKF is the Kalman filter; P_D depending on
   each hypothesis's current position): every association history of the first scan is a
   hypothesis; at the second scan each one's every joint event is enumerated, its factor
   ``Π (1 − P_D P_G) · Π P_D N(ν; 0, S) / λ`` and its Kalman-updated bank computed, the
   hypothesis's new weight is its old one times the sum of the factors and each target's
   bank the moment-matched mixture of the events' banks (means and covariances with the
   spread of the means). Float64 on both sides: 1e-9.
2. With one hypothesis the soft scan is the JPDA bank (``marginals = "exact"``) and the
   branching scan the GNN bank (range model, 1e-12), switched by ``update_bank``'s scan
   counter.
"""

import itertools

import _range_scene
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.stats import chi2

from mjx_radar.engine.run_spec import run_spec
from mjx_radar.estimation.data_association import jpda, mht
from mjx_radar.io.checks import ScenarioError

DT = 0.1
PG, LAM = 0.99, 0.05
HS = np.array([[1.0, 0.2, 0.0], [0.1, 1.0, 0.3]])  # radar i measures HS[i] . position
R = 0.5
Q6 = np.diag([0.01, 0.01, 0.01, 0.2, 0.2, 0.2])


def _a6():
    a = np.eye(6)
    a[:3, 3:] = DT * np.eye(3)
    return a


def _pd(pos):
    return 0.55 + 0.4 * np.tanh(pos[..., 0] / 4.0) ** 2


def _problem():
    rng = np.random.default_rng(7)
    means = np.array([[0.0, 1.0, 2.0, 1.0, 0.5, 0.0], [1.5, 0.0, 1.0, -0.5, 1.0, 0.2]])
    covs = np.stack([np.diag([2.0, 2.0, 2.0, 1.0, 1.0, 1.0])] * 2)
    scans = []
    for s in range(2):
        truth = means[:, :3] + (s + 1) * DT * means[:, 3:]
        per = [truth @ HS[i] + rng.normal(0, np.sqrt(R), 2) for i in range(2)]
        per[1] = np.append(per[1], per[1][0] + 1.5)  # a clutter return near a target
        scans.append(per)
    return means, covs, scans


def _events(m, n_ret):
    out = []
    for e in itertools.product(range(-1, n_ret), repeat=m):
        used = [j for j in e if j >= 0]
        if len(used) == len(set(used)):
            out.append(e)
    return out


def _kalman(x, P, i, z):
    hrow = np.concatenate([HS[i], np.zeros(3)])
    S = hrow @ P @ hrow + R
    nu = z - hrow @ x
    K = P @ hrow / S
    loglik = -0.5 * (np.log(2 * np.pi * S) + nu**2 / S)
    return x + K * nu, P - np.outer(K, K) * S, loglik


def _event(x, P, i, z, e):
    """One joint event's log factor and banks."""
    x, P, logf = x.copy(), P.copy(), 0.0
    pd = _pd(x[:, :3])
    for t, j in enumerate(e):
        if j < 0:
            logf += np.log1p(-pd[t] * PG)
        else:
            x[t], P[t], ll = _kalman(x[t], P[t], i, z[j])
            logf += np.log(pd[t]) + ll - np.log(LAM)
    return logf, x, P


def _predict(x, P):
    a6 = _a6()
    return x @ a6.T, np.einsum("ij,tjk,lk->til", a6, P, a6) + Q6


def _brute(means, covs, scans):
    """Branch over scan 0 (every history), JPDA-mix over scan 1."""
    hyps = [(0.0, *_predict(means, covs))]
    for i in range(2):  # scan 0: every event of every history is a child
        z = scans[0][i]
        hyps = [
            (lw + f, x2, P2)
            for lw, x, P in hyps
            for f, x2, P2 in [_event(x, P, i, z, e) for e in _events(2, len(z))]
        ]
    out = []
    for lw, x, P in hyps:
        x, P = _predict(x, P)
        for i in range(2):  # scan 1: each hypothesis sums its events
            z = scans[1][i]
            ev = [_event(x, P, i, z, e) for e in _events(2, len(z))]
            f = np.array([e[0] for e in ev])
            lw += np.logaddexp.reduce(f)
            p = np.exp(f - np.logaddexp.reduce(f))
            xs, Ps = np.stack([e[1] for e in ev]), np.stack([e[2] for e in ev])
            x = np.einsum("e,etn->tn", p, xs)
            d = xs - x[None]
            P = np.einsum("e,etnk->tnk", p, Ps + np.einsum("etn,etk->etnk", d, d))
        out.append((lw, x, P))
    lw = np.array([o[0] for o in out])
    xs, Ps = np.stack([o[1] for o in out]), np.stack([o[2] for o in out])
    return lw - np.logaddexp.reduce(lw), xs, Ps


def _jax(means, covs, scans, k):
    with jax.enable_x64(True):
        hyp = mht.init(jnp.asarray(means), jnp.asarray(covs), k)
        a6, q6 = jnp.asarray(_a6()), jnp.asarray(Q6)
        for s in range(2):
            hyp = mht.predict(hyp, a6, q6)
            for i in range(2):
                z = jnp.asarray(scans[s][i])[:, None]
                hrow = jnp.asarray(np.concatenate([HS[i], np.zeros(3)]))
                pd = jnp.asarray(_pd(np.asarray(hyp.means[..., :3])))
                args = (z, jnp.ones(z.shape[0], bool), lambda x, hrow=hrow: (hrow @ x)[None])
                args = (*args, jnp.eye(1) * R, pd, LAM, 1e12, PG, z.shape[0])
                hyp = mht.radar_update(hyp, *args)[0] if s == 0 else mht.soft_update(hyp, *args)
        return jax.tree_util.tree_map(np.asarray, hyp)


@pytest.mark.slow  # ~95 s on 2 cores: 91 histories enumerated (CI keeps the K = 1 reference)
def test_soft_scan_after_branching_matches_enumeration():
    means, covs, scans = _problem()
    lw, xs, Ps = _brute(means, covs, scans)
    n = len(lw)  # 7 x 13 histories of the first scan
    assert n == 91
    hyp = _jax(means, covs, scans, k=96)
    assert np.isfinite(hyp.logw).sum() == n  # every history kept, empty slots stay empty
    live = np.isfinite(hyp.logw)
    got, ref = np.sort(hyp.logw[live])[::-1], np.sort(lw)[::-1]
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-9)
    for h in np.argsort(-hyp.logw)[:30]:  # the heaviest: match each to its enumerated twin
        j = np.argmin(np.abs(lw - hyp.logw[h]))
        np.testing.assert_allclose(hyp.means[h], xs[j], rtol=0, atol=1e-9)
        np.testing.assert_allclose(hyp.covs[h], Ps[j], rtol=0, atol=1e-9)
    # the soft scan mixed: the posterior covariances carry the spread of the events
    assert np.abs(np.asarray(hyp.means) - means).max() > 0.1


def test_one_hypothesis_branches_then_is_the_jpda_bank():
    means, covs, zs = _range_scene.scene()
    with jax.enable_x64(True):
        args, pd = _range_scene.model_args(zs)
        tail = (jnp.float64(0.02), jnp.float64(chi2.ppf(PG, 1)), jnp.float64(PG))

        def bank(rule):  # jitted: eagerly the radar loop's dispatch takes seconds
            return jax.jit(lambda x, p: jpda.update_bank(x, p, *args, pd, *tail, rule))

        x, P = bank(jpda.rule("gnn", 4))(jnp.asarray(means), jnp.asarray(covs))
        x2, P2 = bank(jpda.rule("exact", 4))(x, P)
        hyp = mht.init(jnp.asarray(means), jnp.asarray(covs), 1)
        pd_fn = lambda pos: pd[:, None]  # noqa: E731
        upd = jax.jit(lambda h: mht.update_bank(h, *args, pd_fn, *tail, 4, branch=1))
        hyp = upd(hyp)  # scan 0 < branch: the best child (GNN)
        np.testing.assert_allclose(hyp.means[0], x, rtol=0, atol=1e-12)
        hyp = upd(hyp)  # scan 1: soft (JPDA)
    assert int(hyp.scans) == 2
    np.testing.assert_allclose(hyp.means[0], x2, rtol=0, atol=1e-12)
    np.testing.assert_allclose(hyp.covs[0], P2, rtol=0, atol=1e-12)
    assert np.abs(np.asarray(x2) - np.asarray(x)).max() > 0.1


def test_branch_scans_option_off_by_default_and_refused_out_of_range():
    import mjx_radar

    s = mjx_radar.load_scenario("clutter_3r4t")
    assert s.tracker.branch_scans == 0
    s.replace(tracker={"association": "mht", "branch_scans": 20})
    with pytest.raises(ScenarioError, match="tracker.branch_scans"):
        s.replace(tracker={"association": "mht", "branch_scans": -1})


@pytest.mark.slow  # three closed-loop programs (~1-2 min each on a busy CPU)
def test_branch_scans_in_the_closed_loop(tiny):
    """The loop's step counter drives the phase: a branch count past the run is the MHT
    (float32 round-off of the program under ``lax.cond``), one branching scan is not."""
    from mjx_radar.engine import runner

    det = {"model": "fixed", "fixed_pd": 0.9, "clutter_range_max": 500.0, "clutter_density": 0.002}
    base = tiny.replace(filter={"structure": "per-target"}, detection=det)
    trials = np.arange(2)

    def run(**kw):
        s = base.replace(tracker={"association": "mht", "hypotheses": 4, **kw})
        return runner.run_trials(run_spec(s), "stationary", 2, trials, 32)

    tree, late, soft = run(), run(branch_scans=100000), run(branch_scans=1)
    np.testing.assert_allclose(late["rmse_pos"], tree["rmse_pos"], rtol=1e-4, atol=1e-4)
    assert np.all(np.isfinite(soft["rmse_pos"])) and not soft["diverged"].any()
    assert np.abs(soft["rmse_pos"] - tree["rmse_pos"]).max() > 1e-3
