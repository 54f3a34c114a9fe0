"""The track table's JPDA associator (``association = "jpda"``, ``marginals = "lbp"``)
against the exact JPDA of the per-target bank and the per-track PDA, and its options."""

import functools

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from _table_scene import PER_TARGET, table_scene

from mjx_radar.errors import ScenarioError
from mjx_radar.estimation.data_association import jpda
from mjx_radar.estimation.data_association import pda as pda_mod
from mjx_radar.estimation.tracks import track_update
from mjx_radar.scenario.reader import load_scenario

MANAGED_JPDA = {"management": "managed", "association": "jpda", "marginals": "lbp"}


@functools.cache
def _associator(kind: str):
    """The jitted associator of ``_task()``'s table (one compilation per kind)."""
    _, args = table_scene(12.0)
    if kind == "jpda":
        return jax.jit(track_update.jpda_associator(*args, iterations=50))
    return jax.jit(track_update.pda_associator(*args, exclusive=False))


def _exact_jpda(scene, args):
    """The per-target bank's exact JPDA (every joint event enumerated), radar after
    radar, on the live slots with the associator's Pd."""
    means, covs, on, zs, valid, radar = scene
    model, noise, ccr, det_model, dp, density, gate, pg, _ = args
    pd = track_update._pd(det_model, dp, means, on, radar)  # [K, N]
    rule = jpda.rule("exact", candidates=zs.shape[1])
    for i in range(radar.shape[0]):
        h, r = pda_mod.radar_model(model, noise, ccr, radar, i)
        (means, covs), _ = jpda.joint_update(
            means, covs, zs[i], valid[i], h, r, pd[:, i], density, gate, pg, rule
        )
    return means, covs


def test_shared_return_equals_the_exact_jpda():
    """Tracks A and B 12 m apart both gate the drone's return at every radar: a tree
    (A - return - B), where loopy BP's fixed point is the exact marginal, so the
    associator equals the enumerated JPDA; the empty slot keeps its prediction."""
    scene, args = table_scene(12.0)
    m, c, nll = _associator("jpda")(*scene)
    m_ref, c_ref = jax.jit(lambda: _exact_jpda(scene, args))()
    # float32 over four sequential radar updates of 400 m^2 priors: a few ulp of 60 m
    np.testing.assert_allclose(np.asarray(m[:2]), np.asarray(m_ref[:2]), rtol=0, atol=5e-5)
    np.testing.assert_allclose(np.asarray(c[:2]), np.asarray(c_ref[:2]), rtol=2e-4, atol=2e-3)
    np.testing.assert_array_equal(np.asarray(m[2]), np.asarray(scene[0][2]))
    nll = np.asarray(nll)
    assert np.isfinite(nll[:2, :, 0]).all() and not np.isfinite(nll[2]).any()
    assert not np.isfinite(nll[:, :, 1]).any()  # the far return is in no gate


def test_separate_tracks_equal_the_per_track_pda():
    """Tracks 300 m apart share no gated return: JPDA is each track's own PDA."""
    scene, args = table_scene(300.0)
    m, c, _ = _associator("jpda")(*scene)
    m_p, c_p, _ = _associator("pda")(*scene)
    np.testing.assert_allclose(np.asarray(m), np.asarray(m_p), rtol=0, atol=1e-4)
    np.testing.assert_allclose(np.asarray(c), np.asarray(c_p), rtol=1e-5, atol=1e-4)


def test_jpda_shares_where_pda_double_counts():
    """With the shared return, the per-track PDA pulls the second track onto the drone
    as if the return were its own; the JPDA moves it less (the return is mostly A's)."""
    scene, args = table_scene(12.0)
    m, _, _ = _associator("jpda")(*scene)
    m_p, _, _ = _associator("pda")(*scene)
    moved = lambda x: float(jnp.linalg.norm(x[1, :3] - scene[0][1, :3]))  # noqa: E731
    assert moved(m) < moved(m_p)


def test_options():
    raid = load_scenario("raid_4r8t")
    s = raid.replace(tracker=MANAGED_JPDA, filter=PER_TARGET)
    assert (s.tracker.association, s.tracker.marginals) == ("jpda", "lbp")
    with pytest.raises(ScenarioError, match=r'tracker.marginals = "exact": the managed'):
        raid.replace(tracker={**MANAGED_JPDA, "marginals": "exact"}, filter=PER_TARGET)
