"""The MHT's altitude prior (``[tracker] height_std`` with ``association = "mht"``,
:func:`mjx_radar.env.mht_ops.altitude_prior`) against a numpy reference.

Every hypothesis's every target takes the scalar Kalman update with the pseudo-measurement
``z = h₀`` of its height (variance σ_a²), and every hypothesis's weight is multiplied by
the pseudo-measurement's predictive likelihood ``Π_t N(h₀; x_z, P_zz + σ_a²)`` before the
weights are renormalised. The reference writes both out in float64 loops; the two differ
only in the order of their sums (1e-12).
"""

import jax
import numpy as np
import pytest

from mjx_radar.env.mht_ops import altitude_prior
from mjx_radar.estimation.data_association import mht
from mjx_radar.io.checks import ScenarioError


def _state(seed=0, k=5, m=3):
    rng = np.random.default_rng(seed)
    means = rng.normal(size=(k, m, 6)) * np.array([100, 100, 30, 5, 5, 2]) + [0, 0, 60, 0, 0, 0]
    a = rng.normal(size=(k, m, 6, 6))
    covs = a @ np.swapaxes(a, -1, -2) + 6 * np.eye(6)
    logw = np.log(rng.uniform(0.05, 1.0, k))
    logw[-1] = -np.inf  # an empty slot
    return means, covs, logw


def _reference(means, covs, logw, h0, var):
    k, m = means.shape[:2]
    out_m, out_c, ll = means.copy(), covs.copy(), np.zeros(k)
    for h in range(k):
        for t in range(m):
            p, x = covs[h, t], means[h, t]
            s = p[2, 2] + var
            gain = p[:, 2] / s
            out_m[h, t] = x + gain * (h0 - x[2])
            out_c[h, t] = p - np.outer(gain, gain) * s
            ll[h] += -0.5 * ((x[2] - h0) ** 2 / s + np.log(2 * np.pi * s))
    w = logw + ll
    live = np.isfinite(w)
    w[live] -= np.log(np.sum(np.exp(w[live] - w[live].max()))) + w[live].max()
    return out_m, out_c, w


@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("std", [10.0, 40.0, 150.0])
def test_altitude_prior_matches_numpy(seed, std):
    means, covs, logw = _state(seed)
    with jax.enable_x64(True):
        out = jax.jit(altitude_prior, static_argnums=(1, 2))(
            mht.HypState(means, covs, logw), 60.0, std**2
        )
    rm, rc, rw = _reference(means, covs, logw, 60.0, std**2)
    np.testing.assert_allclose(np.asarray(out.means), rm, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(np.asarray(out.covs), rc, rtol=1e-12, atol=1e-9)
    assert np.isneginf(np.asarray(out.logw)[-1])  # the empty slot stays empty
    np.testing.assert_allclose(np.asarray(out.logw)[:-1], rw[:-1], rtol=1e-12, atol=1e-12)


def test_a_height_ghost_loses_weight_by_the_likelihood_ratio():
    """Two hypotheses alike but one target 45 m lower: the weight ratio moves by exactly
    N(h0; 15, s) / N(h0; 60, s) and the heights move towards h0."""
    means, covs, _ = _state(4, k=2, m=2)
    means[1] = means[0]
    covs[1] = covs[0]
    means[0, 0, 2], means[1, 0, 2] = 60.0, 15.0
    logw = np.log([0.5, 0.5])
    var = 40.0**2
    with jax.enable_x64(True):
        out = altitude_prior(mht.HypState(means, covs, logw), 60.0, var)
    s = covs[0, 0, 2, 2] + var
    want = -0.5 * (45.0**2) / s  # log N(60; 15, s) - log N(60; 60, s)
    got = float(out.logw[1] - out.logw[0])
    assert got == pytest.approx(want, rel=1e-12)
    assert 15.0 < float(out.means[1, 0, 2]) < 60.0


def test_refused_in_one_line_where_nothing_reads_it():
    import mjx_radar

    s = mjx_radar.load_scenario("clutter_3r4t")
    s.replace(tracker={"association": "mht", "height_std": 40.0, "birth_height": 55.0})
    cases = [
        ({"association": "jpda", "height_std": 40.0}, "height_std = 40.0: read only with"),
        ({"association": "mht", "birth_height": 55.0}, "birth_height = 55.0: the MHT reads"),
    ]
    for edit, msg in cases:
        with pytest.raises(ScenarioError, match=msg) as e:
            s.replace(tracker=edit)
        assert "\n" not in str(e.value)


@pytest.mark.slow  # two closed-loop environment programs
def test_the_loop_applies_it():
    import jax.numpy as jnp

    import mjx_radar
    from mjx_radar.env import environment

    base = mjx_radar.load_scenario("clutter_3r4t")
    out = []
    for std in (0.0, 40.0):
        s = base.replace(tracker={"association": "mht", "hypotheses": 4, "height_std": std})
        env = environment.make(s)
        state = jax.jit(env.reset)(env.trial_key(env.params.seed, 0))
        state = jax.jit(env.step)(state, jnp.zeros((env.n_radars, 2)))
        out.append(np.asarray(state.loop.mean))
    assert np.max(np.abs(out[0] - out[1])) > 1e-3


def test_height_scans_limits_it_to_the_first_scans():
    """``height_scans = H``: the state after scan ``s`` (``hyp.scans = s``) takes the prior
    for ``s <= H`` (the same numbers as without the limit) and is unchanged for ``s > H``;
    without ``branch_scans`` (no scan counter) it is refused in one line."""
    import mjx_radar

    means, covs, logw = _state(5)
    with jax.enable_x64(True):
        for s, on in ((1, True), (200, True), (201, False)):
            hyp = mht.HypState(means, covs, logw, np.int32(s))
            out = jax.jit(altitude_prior, static_argnums=(1, 2, 3))(hyp, 60.0, 1600.0, 200)
            want = altitude_prior(hyp, 60.0, 1600.0) if on else hyp
            for a, b in zip(out[:3], want[:3], strict=True):  # jit against eager
                np.testing.assert_allclose(np.asarray(a), np.asarray(b), rtol=1e-12, atol=1e-12)
            assert on or np.array_equal(np.asarray(out.means), means)
    s = mjx_radar.load_scenario("clutter_3r4t")
    edit = {"association": "mht", "height_std": 40.0, "height_scans": 200}
    s.replace(tracker={**edit, "branch_scans": 2})  # accepted
    with pytest.raises(ScenarioError, match="height_scans = 200: the MHT limits") as e:
        s.replace(tracker=edit)
    assert "\n" not in str(e.value)
