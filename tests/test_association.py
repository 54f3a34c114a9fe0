"""Joint association rules against independent references (issue 35).

* exact JPDA and JPDA* marginals vs a plain Python enumeration of every joint event
  (``itertools.product`` over all measurements, permutation classes by sets);
* the G-candidate truncation vs the same enumeration restricted to each target's G best;
* GNN vs scipy's ``linear_sum_assignment`` on the standard augmented cost matrix
  (Blackman & Popoli 1999, §6.5: ``−log r`` for pairs, 0 for a target's own miss column);
* loopy BP: exact on graphs without cycles, close to the exact marginals on dense ones.
"""

import itertools

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.optimize import linear_sum_assignment

from mjx_radar.estimation.data_association import association, lbp


def _random_logr(rng, m, n, gated=0.5):
    logr = rng.normal(size=(m, n)) * 1.5 + 1.0
    return np.where(rng.uniform(size=(m, n)) < gated, logr, -np.inf)


def _brute(logr, star=False, allowed=None):
    """Marginals by enumerating every joint event in Python (float64)."""
    m, n = logr.shape
    opts = [[-1] + [j for j in range(n) if allowed is None or j in allowed[t]] for t in range(m)]
    events = []
    for ev in itertools.product(*opts):
        used = [j for j in ev if j >= 0]
        if len(used) != len(set(used)):
            continue
        w = sum(logr[t, j] for t, j in enumerate(ev) if j >= 0)
        if np.isfinite(w):
            events.append((ev, w))
    if star:  # keep the best of each class: same detected targets, same measurements
        best = {}
        for ev, w in events:
            key = (frozenset(t for t, j in enumerate(ev) if j >= 0), frozenset(ev) - {-1})
            if key not in best or w > best[key][1]:
                best[key] = (ev, w)
        events = list(best.values())
    ws = np.array([w for _, w in events])
    p = np.exp(ws - ws.max())
    p /= p.sum()
    beta = np.zeros((m, n + 1))
    for (ev, _), pe in zip(events, p, strict=True):
        for t, j in enumerate(ev):
            beta[t, j + 1] += pe
    return beta[:, 0], beta[:, 1:]


@pytest.mark.parametrize("star", [False, True])
def test_exact_and_star_marginals_match_a_python_enumeration(star):
    rng = np.random.default_rng(1)
    m, n = 3, 5
    fn = jax.jit(lambda lr: association.exact_marginals(lr, n, star=star))
    with jax.enable_x64(True):
        for _ in range(5):
            logr = _random_logr(rng, m, n, gated=0.7)
            b0, b = fn(jnp.asarray(logr))
            w0, w = _brute(logr, star=star)
            np.testing.assert_allclose(np.asarray(b0), w0, rtol=1e-12, atol=1e-14)
            np.testing.assert_allclose(np.asarray(b), w, rtol=1e-12, atol=1e-14)
    if star:  # JPDA* prunes something: it differs from JPDA on the last problem
        assert np.abs(w - _brute(logr)[1]).max() > 1e-3


def test_truncation_keeps_each_targets_g_best_candidates():
    rng = np.random.default_rng(2)
    m, n, g = 3, 6, 2
    with jax.enable_x64(True):
        logr = _random_logr(rng, m, n, gated=1.0)
        b0, b = jax.jit(lambda lr: association.exact_marginals(lr, g))(jnp.asarray(logr))
    allowed = [set(np.argsort(-logr[t])[:g]) for t in range(m)]
    w0, w = _brute(logr, allowed=allowed)
    np.testing.assert_allclose(np.asarray(b0), w0, rtol=1e-12)
    np.testing.assert_allclose(np.asarray(b), w, rtol=1e-12, atol=1e-14)
    outside = np.array([[j not in allowed[t] for j in range(n)] for t in range(m)])
    assert np.all(np.asarray(b)[outside] == 0.0)  # the truncated measurements get nothing
    assert np.abs(w - _brute(logr)[1]).max() > 1e-3  # truncation changed the marginals


def _scipy_gnn(logr):
    m, n = logr.shape
    big = 1e9
    cost = np.full((m, n + m), big)
    cost[:, :n] = np.where(np.isfinite(logr), -logr, big)
    cost[np.arange(m), n + np.arange(m)] = 0.0  # each target's own miss column
    rows, cols = linear_sum_assignment(cost)
    return [int(c) if c < n else -1 for c in cols[np.argsort(rows)]]


def test_gnn_is_the_optimal_assignment_of_scipy():
    """With G = M candidates the enumeration's best event is the global optimum (module doc)."""
    rng = np.random.default_rng(3)
    m, n = 4, 9
    fn = jax.jit(lambda lr: association.gnn_weights(lr, m))
    with jax.enable_x64(True):
        hits = 0
        for _ in range(20):
            logr = _random_logr(rng, m, n, gated=0.6)
            b0, b = fn(jnp.asarray(logr))
            got = [-1 if b0[t] == 1 else int(np.argmax(b[t])) for t in range(m)]
            assert got == _scipy_gnn(logr)
            assert np.all(np.asarray(b0) + np.asarray(b).sum(1) == 1.0)
            hits += sum(j >= 0 for j in got)
    assert hits > 20  # most targets assigned, not all missed


def test_lbp_is_exact_without_cycles_and_close_on_dense_graphs():
    """Loopy BP (Williams & Lau 2014) on a chain t0-z1-t1-z2-t2 (a tree: the fixed point is
    the exact marginal, to round-off) and on 100 dense random problems (4 targets, 8
    measurements, half the pairs gated: many cycles). There the approximation error is
    the method's, not a bug: the mean of each problem's largest error is 0.011 and the
    largest 0.085 (seed 0); the bounds 0.02 and 0.15 fail on a wrong message (e.g. a
    dropped miss weight gives errors > 0.2). 20 sweeps are converged (to 200: < 1e-6)."""
    with jax.enable_x64(True):
        chain = np.full((3, 4), -np.inf)
        chain[0, [0, 1]] = [0.5, 1.2]
        chain[1, [1, 2]] = [0.8, -0.3]
        chain[2, [2, 3]] = [1.5, 0.1]
        b0, b = lbp.lbp_marginals(jnp.asarray(chain), 50)
        w0, w = _brute(chain)
        np.testing.assert_allclose(np.asarray(b0), w0, rtol=1e-10)
        np.testing.assert_allclose(np.asarray(b), w, rtol=1e-10, atol=1e-14)

        rng = np.random.default_rng(0)
        m, n, k = 4, 8, 100
        logr = np.stack([_random_logr(rng, m, n) for _ in range(k)])
        ex = jax.jit(jax.vmap(lambda lr: association.exact_marginals(lr, n)))
        approx = jax.jit(jax.vmap(lambda lr, it=20: lbp.lbp_marginals(lr, it)))
        long = jax.jit(jax.vmap(lambda lr: lbp.lbp_marginals(lr, 200)))
        e = np.asarray(ex(jnp.asarray(logr))[1])
        a = np.asarray(approx(jnp.asarray(logr))[1])
        err = np.abs(a - e).max(axis=(1, 2))
        assert err.mean() < 0.02 and err.max() < 0.15
        assert np.abs(a - np.asarray(long(jnp.asarray(logr))[1])).max() < 1e-6


def test_lbp_float32_with_sure_assignments():
    """Targets sure of their returns (large log r: weights span e^-40 after scaling, and
    e^-150 underflows float32 altogether): finite weights summing to one, and on this
    tree (t0 - z0 - t1 - z1) the exact marginals while nothing underflows."""
    for top, exact in ((40.0, True), (200.0, False)):
        logr = np.array([[top, -np.inf, -np.inf], [top - 2.0, 2.0, -np.inf]])
        b0, b = jax.jit(lambda lr: lbp.lbp_marginals(lr, 20))(jnp.asarray(logr, jnp.float32))
        b0, b = np.asarray(b0), np.asarray(b)
        assert np.all(np.isfinite(b)) and np.allclose(b0 + b.sum(1), 1.0, atol=1e-6)
        assert b[0, 0] > 0.5  # exact: 1 / (1 + 1 / (e^4 + e^2)) = 0.984
        if exact:
            np.testing.assert_allclose(b, _brute(logr)[1], rtol=1e-5, atol=1e-7)


def test_event_weights_against_a_python_loop():
    """Every joint event's log weight (an outer sum over the event grid, masked by the
    target pairs' shared measurements) against a plain loop: −inf exactly when two
    detected targets take one measurement or a detected target a padded candidate, else
    the sum of its log ratios (to float32 round-off, 1e-6: numpy sums in another order).
    Candidate lists that share measurements, M up to 5, G up to 4."""
    rng = np.random.default_rng(7)
    for m, g in itertools.product(range(1, 6), range(1, 5)):
        events = association.event_table(m, g)
        weights = jax.jit(lambda r, i, ev=events: association.event_log_weights(r, i, ev))
        for _ in range(2):
            idx = rng.integers(0, g + 2, (m, g)).astype(np.int32)  # shared across targets
            logr = np.where(rng.random((m, g)) < 0.8, rng.normal(size=(m, g)), -np.inf)
            logr = logr.astype(np.float32)
            out = weights(jnp.asarray(logr), jnp.asarray(idx))
            got, meas = map(np.asarray, out)
            for e, slots in enumerate(events):
                taken = [idx[t, s - 1] for t, s in enumerate(slots) if s > 0]
                terms = [logr[t, s - 1] if s > 0 else np.float32(0) for t, s in enumerate(slots)]
                want = -np.inf if len(set(taken)) < len(taken) else np.sum(terms, dtype=np.float32)
                assert np.isneginf(got[e]) == np.isneginf(want)
                if np.isfinite(want):
                    np.testing.assert_allclose(got[e], want, rtol=1e-6, atol=1e-6)
                assert list(meas[e]) == [
                    idx[t, s - 1] if s > 0 else -1 for t, s in enumerate(slots)
                ]


def test_event_weights_need_the_event_table():
    """The weights are laid on the event table's grid: another table is refused by name."""
    idx, logr = jnp.zeros((2, 2), jnp.int32), jnp.zeros((2, 2))
    with pytest.raises(ValueError, match=r"event_table\(2, 2\)"):
        association.event_log_weights(logr, idx, association.event_table(2, 2)[::-1])
