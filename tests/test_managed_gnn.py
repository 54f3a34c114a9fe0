"""The managed table's joint GNN associator (``association = "gnn"``).

References: scipy's ``linear_sum_assignment`` (the Hungarian solver), brute-force
enumeration of the joint events (itertools) and association.py's enumerated GNN.
"""

import itertools

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from _table_scene import MANAGED_GNN, PER_TARGET, table_scene
from scipy.optimize import linear_sum_assignment

from mjx_radar.env import environment
from mjx_radar.estimation.data_association import assignment, association
from mjx_radar.estimation.tracks import track_table, track_update
from mjx_radar.scenario.reader import load_scenario


def test_hungarian_matches_scipy():
    rng = np.random.default_rng(0)
    solve = jax.jit(assignment.hungarian)
    for _ in range(40):
        n = int(rng.integers(1, 7))
        m = n + int(rng.integers(0, 5))
        c = rng.normal(size=(n, m)).astype(np.float32)
        col = np.asarray(solve(jnp.asarray(c)))
        r, cc = linear_sum_assignment(c)
        assert len(set(col.tolist())) == n  # distinct columns
        assert abs(c[np.arange(n), col].sum() - c[r, cc].sum()) < 1e-5


def _brute_force(logr):
    """The best joint event by enumerating every assignment (−1: missed)."""
    k, ell = logr.shape
    best, arg = -np.inf, None
    for ev in itertools.product(range(-1, ell), repeat=k):
        taken = [j for j in ev if j >= 0]
        if len(taken) != len(set(taken)):
            continue
        score = sum(logr[t, j] for t, j in enumerate(ev) if j >= 0)
        if score > best:
            best, arg = score, ev
    return best, np.asarray(arg)


def _random_logr(rng, k, ell):
    logr = rng.normal(1.0, 2.0, (k, ell))
    logr[rng.random((k, ell)) < 0.35] = -np.inf  # gated out
    logr[int(rng.integers(k))] = -np.inf  # an empty slot takes no return
    logr[:, int(rng.integers(ell))] = -np.inf  # an invalid return
    return logr.astype(np.float32)


def test_gnn_assignment_is_the_best_joint_event():
    """Against brute force (all events) and association.py's enumeration (G = L): the
    same event; an empty slot and a gated-out pair are never assigned."""
    rng = np.random.default_rng(1)
    gnn = jax.jit(assignment.gnn_assignment)
    weights = jax.jit(association.gnn_weights, static_argnums=1)  # eager: 16 s of dispatch
    batch = []
    for _ in range(30):
        k, ell = int(rng.integers(2, 5)), int(rng.integers(2, 5))
        logr = _random_logr(rng, k, ell)
        beta0, beta = map(np.asarray, gnn(jnp.asarray(logr)))
        best, arg = _brute_force(logr)
        got = np.where(beta0 > 0.5, -1, np.argmax(beta, axis=1))
        np.testing.assert_array_equal(got, arg)
        assert (beta.sum(0) <= 1).all() and np.isfinite(logr[beta > 0.5]).all()
        e0, e = weights(jnp.asarray(logr), ell)
        np.testing.assert_array_equal(np.asarray(e), beta)
        np.testing.assert_array_equal(np.asarray(e0), beta0)
        batch.append((logr, beta))
    k = ell = 3  # vmap over trials: the while loops of the batch
    same = [(lg, b) for lg, b in batch if lg.shape == (k, ell)]
    _, vb = jax.vmap(assignment.gnn_assignment)(jnp.asarray(np.stack([lg for lg, _ in same])))
    np.testing.assert_array_equal(np.asarray(vb), np.stack([b for _, b in same]))


def test_two_tracks_one_return_pda_shares_gnn_assigns():
    """Per-track PDA (without exclusivity): drone and ghost both update with the drone's
    return; the joint GNN gives it to the drone's track only (the ghost keeps its
    prediction), takes no return into the empty slot, and only the drone earns a hit."""
    scene, args = table_scene()
    means, covs = scene[0], scene[1]
    m_pda, _, nll_pda = jax.jit(track_update.pda_associator(*args, exclusive=False))(*scene)
    assert np.isfinite(np.asarray(nll_pda[:2, :, 0])).all()  # both gate every drone return
    assert float(jnp.abs(m_pda[1] - means[1]).max()) > 1.0  # the ghost moved
    gnn = track_update.gnn_associator(*args)
    m_gnn, c_gnn, nll = jax.jit(gnn)(*scene)  # jitted: eagerly the loops take seconds
    nll = np.asarray(nll)
    assert np.isfinite(nll[0, :, 0]).all() and not np.isfinite(nll[1:]).any()
    np.testing.assert_array_equal(np.asarray(m_gnn[1:]), np.asarray(means[1:]))
    np.testing.assert_array_equal(np.asarray(c_gnn[1:]), np.asarray(covs[1:]))
    assert float(jnp.abs(m_gnn[0, :2]).max()) < 1.0  # the drone's track stays at the truth
    table = track_table.empty(3, scene[5].shape[0], jnp.float32)
    table = track_table.insert(table, means[:2], covs[:2], jnp.array([True, True]))
    update = jax.jit(lambda tb, zs, valid, pos: track_update.update(tb, zs, valid, pos, gnn, 2))
    _, hit, explained = update(table, scene[3], scene[4], scene[5])
    np.testing.assert_array_equal(np.asarray(hit), [True, False, False])
    assert bool(explained[:, 0].all()) and not bool(explained[:, 1].any())


def test_managed_gnn_options():
    s = load_scenario("raid_4r8t").replace(tracker=MANAGED_GNN, filter=PER_TARGET)
    assert s.tracker.association == "gnn" and not s.detection.clutter  # no clutter needed


@pytest.mark.slow  # compiles the closed loop with births (~3 min on a shared CPU)
def test_managed_gnn_closed_loop_is_finite():
    """raid_4r8t managed with the GNN, 1 trial, a few steps: finite metrics."""
    s = load_scenario("raid_4r8t").replace(
        tracker=MANAGED_GNN, filter=PER_TARGET, timing={"steps": 40}
    )
    env = environment.make(s, "stationary")
    state = jax.jit(env.reset)(env.trial_key(0, 0))
    step = jax.jit(env.transition)
    for _ in range(env.episode_length):
        state, rec = step(state, jnp.zeros((s.n_radars, 2)))
    assert np.isfinite(np.asarray(rec.track_pos)).all()
    assert np.isfinite(float(state.reward)) and np.isfinite(np.asarray(rec.rmse_pos)).all()
