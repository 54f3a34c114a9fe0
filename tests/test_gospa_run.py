"""GOSPA / OSPA / continuity columns of a run (issue 35): the runner's host computation.

Checks (a tiny stationary run, 2 trials x 16 steps, target 1 appearing at 0.2 s):

* the metrics-only program (studies) and the full one (runs) give the same columns,
  and they equal :func:`mjx_radar.estimation.tracks.gospa.set_metrics` of the run's own arrays;
* with p = 2 and a cutoff far beyond every error, ``GOSPA² = min_π Σ d²`` can only
  undercut the loop's ``n · rmse_pos²`` (n targets present, the identity assignment),
  and equals it wherever the identity is optimal;
* the missed part counts exactly the absent-then-appearing target as nothing (an absent
  target is no truth, its track no estimate).
"""

from __future__ import annotations

import numpy as np
import pytest

from mjx_radar.engine import runner
from mjx_radar.engine.run_spec import run_spec
from mjx_radar.estimation.tracks.gospa import set_metrics
from mjx_radar.rundir import results
from mjx_radar.scenario.schema import TargetMotion

pytestmark = pytest.mark.slow  # two programs compiled on the CPU (~90 s)

STEPS, TRIALS = 16, np.arange(2)


@pytest.fixture(scope="module")
def runs(tiny):
    s = tiny.replace(
        target_motion=(TargetMotion(target=1, appear=0.2),),
        metrics={"gospa_cutoff": 1e5, "gospa_order": 2.0},
    )
    full = runner.run_trials(run_spec(s), "stationary", 0, TRIALS, STEPS, full=True)
    lean = runner.run_trials(run_spec(s), "stationary", 0, TRIALS, STEPS, full=False)
    return s, full, lean


def test_metrics_only_and_full_runs_agree(runs):
    _, full, lean = runs
    for k in results.METRIC_COLUMNS:
        np.testing.assert_array_equal(lean[k], full[k], err_msg=k)
        assert lean[k].shape == (len(TRIALS), STEPS), k
    assert not set(lean) & {"truth_pos", "track_pos", "track_exists"}


def test_columns_are_the_set_metrics_of_the_arrays(runs):
    s, full, _ = runs
    m = s.n_targets
    here = full["present"]
    assert here.shape == (len(TRIALS), STEPS, m)
    np.testing.assert_array_equal(here.sum(-1), full["targets_present"])
    assert not here[:, :7, 1].any() and here[:, 8:, 1].all()  # appears at 0.2 s = step 8
    track = full["mean"].reshape(len(TRIALS), STEPS, m, 6)[..., :3]
    ref = set_metrics(full["target"][..., :3], here, track, here, 1e5, 2.0)
    np.testing.assert_allclose(full["gospa"], ref.gospa, rtol=1e-12)
    np.testing.assert_allclose(full["ospa"], ref.ospa, rtol=1e-12)
    loc = full["gospa_localisation"]
    np.testing.assert_allclose(loc, full["gospa"] ** 2, rtol=1e-9)  # nothing beyond c
    assert (full["gospa_missed"] == 0).all() and (full["gospa_false"] == 0).all()
    # GOSPA^2 = min over assignments <= the identity's n rmse^2 (float32 loop: 1e-5)
    n_rmse2 = full["targets_present"] * full["rmse_pos"].astype(np.float64) ** 2
    assert np.all(loc <= n_rmse2 * (1 + 1e-5) + 1e-6)
    ident = (ref.assignment == np.where(here, np.arange(m), -1)).all(-1)
    assert ident.mean() > 0.5
    np.testing.assert_allclose(loc[ident], n_rmse2[ident], rtol=1e-5)


def test_small_cutoff_counts_missed_and_false(runs, tiny):
    s, full, _ = runs
    track = full["mean"].reshape(len(TRIALS), STEPS, s.n_targets, 6)[..., :3]
    err = np.linalg.norm(track - full["target"][..., :3], axis=-1)
    here = full["present"]
    c = float(np.median(err[here]))  # about half of the pairs beyond c
    sets = {"truth_pos": full["target"][..., :3], "present": here}
    cols = results.set_columns(sets | {"track_pos": track, "track_exists": here}, c, 1.0)
    beyond = (here & (err >= c)).sum(-1)  # identity-assigned pairs beyond c (2 targets)
    assert cols["gospa_missed"].sum() > 0
    np.testing.assert_array_less(cols["gospa_missed"] - 0.5 * c * beyond, 1e-9)
    np.testing.assert_allclose(cols["gospa_missed"], cols["gospa_false"])  # |X| = |Y|
