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

from mjx_radar.estimation.data_association import mht
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
