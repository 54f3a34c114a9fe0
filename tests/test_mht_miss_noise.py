"""The MHT's miss noise (``[tracker] miss_noise``, docs/tracking.md): in a soft scan each
target's position covariance gains ``q P_D β_0 u uᵀ``, u the unit line of sight from the
radar to the target's predicted position.

Reference: with one hypothesis the soft scan is the exact JPDA bank
(``jpda.joint_update``, ``tests/test_mht_soft.py``), which gives each target's β_0; the
line of sight is computed in numpy from the radar's and the prediction's positions. The
soft scan with q must be the soft scan without it plus that term, means unchanged
(float64, 1e-12).
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.stats import chi2

from mjx_radar.estimation.data_association import jpda, mht, pda
from mjx_radar.io.checks import ScenarioError

PG, Q = 0.99, 0.7


def test_soft_scan_adds_q_pd_beta0_along_the_line_of_sight():
    from mjx_radar.estimation.sensor.measurement import RangeModel
    from mjx_radar.estimation.sensor.noise import NoiseParams

    rng = np.random.default_rng(3)
    radars = np.array([[300.0, 40.0, 0.0], [-50.0, 260.0, 0.0]])
    truth = np.array([[0.0, -150, 50, 5, 2, 0], [8.0, 3, 55, 4, 3, 0], [3.0, 9, 48, 6, 1, 0]])
    means = truth + rng.normal(0, [2, 2, 2, 1, 1, 1], truth.shape)
    covs = np.stack([np.diag([6.0, 5.0, 7.0, 2.0, 2.0, 2.0])] * 3)
    d = np.linalg.norm(truth[1:, :3] - radars[0], axis=-1)  # target 0 unseen: β_0 = 1
    z = np.concatenate([2 * d + rng.normal(0, 1.2, 2), [2 * d[0] + 9.0]])[:, None]
    pd = np.array([0.95, 0.8, 0.7])
    with jax.enable_x64(True):
        one = jnp.float64(1.0)
        noise = NoiseParams(one, jnp.float64(1.5), one, one)
        h, R = pda.radar_model(RangeModel(), noise, True, jnp.asarray(radars), 0)
        args = (jnp.asarray(z), jnp.ones(len(z), bool), h, R, jnp.asarray(pd)[None])
        tail = (jnp.float64(0.02), jnp.float64(chi2.ppf(PG, 1)), jnp.float64(PG), 3)
        hyp = mht.init(jnp.asarray(means), jnp.asarray(covs), 1)
        soft = jax.jit(lambda hy, q: mht.soft_update(hy, *args, *tail, miss=q), static_argnums=1)
        plain, grown = soft(hyp, 0.0), soft(hyp, Q)
        at_radar = jnp.concatenate([jnp.asarray(radars[0]), jnp.ones(3)])  # no line of sight
        same = jax.jit(lambda x, P: pda.miss_inflation(x, P, h, 1.0, Q))(at_radar, covs[0])
        rule = jpda.rule("exact", 3)
        _, (beta0, _) = jax.jit(
            lambda m, c: jpda.joint_update(m, c, *args[:4], args[4][0], *tail[:3], rule)
        )(jnp.asarray(means), jnp.asarray(covs))
    np.testing.assert_array_equal(np.asarray(same), covs[0])  # finite, untouched
    beta0 = np.asarray(beta0)
    assert beta0[0] == pytest.approx(1.0, abs=1e-9) and 0 < beta0[1] < 0.5
    u = means[:, :3] - radars[0]
    u /= np.linalg.norm(u, axis=-1, keepdims=True)
    want = np.asarray(plain.covs[0]).copy()
    want[:, :3, :3] += Q * (pd * beta0)[:, None, None] * u[:, :, None] * u[:, None, :]
    np.testing.assert_allclose(np.asarray(grown.covs[0]), want, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(np.asarray(grown.means), np.asarray(plain.means))
    np.testing.assert_array_equal(np.asarray(grown.logw), np.asarray(plain.logw))
    # the unseen target's range variance along u grew by Q P_D
    grew = u[0] @ (np.asarray(grown.covs[0, 0]) - np.asarray(plain.covs[0, 0]))[:3, :3] @ u[0]
    assert grew == pytest.approx(Q * pd[0], rel=1e-12)


def test_miss_noise_off_by_default_and_refused_in_one_line():
    import mjx_radar

    s = mjx_radar.load_scenario("clutter_3r4t")
    assert s.tracker.miss_noise == 0.0
    s.replace(tracker={"association": "mht", "branch_scans": 1, "miss_noise": 0.5})
    with pytest.raises(ScenarioError, match=r"tracker.miss_noise = 0.5: needs tracker.branch"):
        s.replace(tracker={"association": "mht", "miss_noise": 0.5})
    with pytest.raises(ScenarioError, match="tracker.miss_noise"):
        s.replace(tracker={"association": "mht", "branch_scans": 1, "miss_noise": -1.0})
