"""The MHT's settling budget (``[tracker] settle_scans``, ``settled_hypotheses``,
docs/tracking.md): after S scans only the K₂ heaviest hypotheses go on.

The reference is a second implementation of the same step by hand: the K-slot state after
the branching scan is pruned in numpy to its K₂ heaviest hypotheses (``argsort`` of the log
weights), which then take the soft scan as a K₂-slot MHT of their own. The settled K-slot
update must hold exactly those K₂ hypotheses, in their slots, with the same weights and
banks (float64, 1e-12: the same operations on the same numbers), and every other slot
empty (−inf). Before S scans the option changes nothing.
"""

import functools

import _range_scene
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.stats import chi2

from mjx_radar.estimation.data_association import mht, mht_settle
from mjx_radar.io.checks import ScenarioError

PG, K, K2 = 0.99, 8, 3


def _scene():
    means, covs, zs = _range_scene.scene()
    args, pd = _range_scene.model_args(zs)
    args = (*args, lambda pos: jnp.broadcast_to(pd[:, None], (3, *pos.shape[:2])))
    tail = (jnp.float64(0.02), jnp.float64(chi2.ppf(PG, 1)), jnp.float64(PG), 4)
    return means, covs, (*args, *tail)


def test_settled_scan_is_the_k2_heaviest_as_their_own_mht():
    with jax.enable_x64(True):
        means, covs, args = _scene()
        hyp = mht.init(jnp.asarray(means), jnp.asarray(covs), K)

        @functools.cache  # one program per setting (eagerly, the radar loop's dispatch is slow)
        def upd(settle):
            return jax.jit(lambda h: mht.update_bank(h, *args, branch=1, settle=settle))

        hyp = upd((0, 0))(hyp)  # scan 0: branches into K hypotheses
        assert np.isfinite(np.asarray(hyp.logw)).all()
        soft = upd((0, 0))(hyp)
        early = upd((2, K2))(hyp)  # scan 1 < S = 2: not settled yet
        late = upd((1, K2))(hyp)  # scan 1 >= S = 1: settled
        keep = np.argsort(-np.asarray(hyp.logw))[:K2]
        sub = mht.HypState(hyp.means[keep], hyp.covs[keep], hyp.logw[keep], hyp.scans)
        ref = upd((0, 0))(sub)  # the K2 heaviest as their own MHT
    for a, b in zip(early, soft, strict=True):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    logw = np.asarray(late.logw)
    assert np.isfinite(logw).sum() == K2
    assert set(np.flatnonzero(np.isfinite(logw))) == set(keep)
    np.testing.assert_allclose(logw[keep], ref.logw, rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.asarray(late.means)[keep], ref.means, rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.asarray(late.covs)[keep], ref.covs, rtol=0, atol=1e-12)
    assert int(late.scans) == 2
    # renormalised among the K2: they weigh more than in the unsettled K-slot update
    assert np.all(logw[keep] > np.asarray(soft.logw)[keep])


def test_settle_options_off_by_default_and_refused_in_one_line():
    import mjx_radar

    s = mjx_radar.load_scenario("clutter_3r4t")
    assert s.tracker.settle_scans == 0
    mht_ = {"association": "mht", "hypotheses": 64, "branch_scans": 1}
    s.replace(tracker={**mht_, "settle_scans": 40, "settled_hypotheses": 8})
    bad = [
        ({"settle_scans": 40, "branch_scans": 0}, "tracker.settle_scans = 40: needs"),
        ({"settle_scans": 2, "branch_scans": 4}, "tracker.settle_scans = 2: needs"),
        ({"settle_scans": 40, "settled_hypotheses": 65}, "tracker.settled_hypotheses = 65"),
        ({"settled_hypotheses": 0}, "tracker.settled_hypotheses"),
    ]
    for edit, msg in bad:
        with pytest.raises(ScenarioError, match=msg):
            s.replace(tracker={**mht_, **edit})


def _settled_state():
    """A K-slot state after the settled scan (scans > S: all but the K₂ heaviest empty)."""
    means, covs, args = _scene()
    hyp = mht.init(jnp.asarray(means), jnp.asarray(covs), K)
    upd = jax.jit(lambda h: mht.update_bank(h, *args, branch=1, settle=(1, K2)))
    return upd(upd(hyp))  # scan 0 branches, scan 1 is settled


def test_settled_time_update_gives_the_live_hypotheses_the_full_one():
    """Once settled (``scans > S``), :func:`mht.predict` and :func:`mht_settle.live_only`
    work on the K₂ live slots only: those get what the K-slot time update and the K-slot
    altitude prior give them, to round-off (float64, 1e-12: the same operations, which XLA
    vectorises differently for a batch of K₂ than of K, and the prior's renormalisation
    sums K₂ terms instead of K with K − K₂ zeros); the empty slots keep their stale banks
    and stay empty. Before (``scans <= S``) every slot is predicted."""
    from mjx_radar.env import mht_ops

    with jax.enable_x64(True):
        hyp = _settled_state()
        assert int(hyp.scans) == 2
        live = np.isfinite(np.asarray(hyp.logw))
        assert live.sum() == K2
        a6 = jnp.eye(6).at[:3, 3:].set(0.025 * jnp.eye(3))
        q6 = 0.1 * jnp.eye(6)
        full, few = mht.predict(hyp, a6, q6), mht.predict(hyp, a6, q6, (1, K2))
        prior = functools.partial(mht_ops.altitude_prior, h0=60.0, var=1600.0)
        full_a = prior(hyp)
        few_a = mht_settle.live_only(hyp, (1, K2), prior)
        early = mht.predict(hyp, a6, q6, (2, K2))  # scans = 2 <= S = 2: the K-slot update
    np.testing.assert_allclose(np.asarray(few.means)[live], full.means[live], rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.asarray(few.covs)[live], full.covs[live], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(np.asarray(few.means)[~live], np.asarray(hyp.means)[~live])
    assert not np.array_equal(np.asarray(full.means)[~live], np.asarray(hyp.means)[~live])
    np.testing.assert_array_equal(np.asarray(few.logw), np.asarray(hyp.logw))
    np.testing.assert_allclose(np.asarray(few_a.logw), np.asarray(full_a.logw), atol=1e-12)
    np.testing.assert_allclose(np.asarray(few_a.means)[live], full_a.means[live], atol=1e-12)
    np.testing.assert_allclose(np.asarray(few_a.covs)[live], full_a.covs[live], atol=1e-12)
    assert not np.isfinite(np.asarray(few_a.logw)[~live]).any()
    for a, b in zip(early[:2], full[:2], strict=True):  # every slot predicted
        np.testing.assert_allclose(np.asarray(a), np.asarray(b), rtol=0, atol=1e-12)


def test_mht_fallback_keeps_the_loops_scan_counter():
    """A non-finite update falls back to the prediction for the banks and weights, but
    the scan counter is the update's (the loop's step in every trial: what lets the step
    program hand it to the vmapped loop unbatched, engine/program_trace.py)."""
    import mjx_radar
    from mjx_radar.env import mht_ops
    from mjx_radar.task.task import build

    s = mjx_radar.load_scenario("clutter_3r4t").replace(
        tracker={"association": "mht", "hypotheses": 4, "branch_scans": 1}
    )
    ops = mht_ops.mht_bank(*build(s))
    post = mht.HypState(jnp.full((4, 4, 6), jnp.nan), jnp.zeros((4, 4, 6, 6)), jnp.zeros(4), 7)
    pred = mht.HypState(jnp.ones((4, 4, 6)), jnp.eye(6) * jnp.ones((4, 4, 1, 1)), jnp.zeros(4), 6)
    out = ops.keep(jnp.asarray(True), jnp.asarray(False), post, pred, pred)
    np.testing.assert_array_equal(np.asarray(out.means), np.asarray(pred.means))
    assert int(out.scans) == 7
