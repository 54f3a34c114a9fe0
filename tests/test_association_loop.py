"""The ``jpda`` and ``gnn`` trackers in the closed loop (issue 35; maths: test_jpda.py)."""

import numpy as np
import pytest

from mjx_radar.engine import runner
from mjx_radar.engine.run_spec import run_spec

STEPS = 40
TRIALS = np.arange(3)
DET = {"model": "fixed", "fixed_pd": 0.9, "clutter_range_max": 500.0, "clutter_density": 0.002}


@pytest.mark.slow  # three closed-loop programs (~1-2 min each on a busy CPU)
def test_joint_association_in_the_closed_loop(tiny):
    """One drone: JPDA is its PDA (float32 round-off of a differently fused program over 40
    steps); GNN with the tiny scenario's two drones in clutter: finite, never diverged."""
    base = tiny.replace(filter={"structure": "per-target"}, detection=DET)
    one = base.replace(targets=base.target_init[:1])
    pda = runner.run_trials(run_spec(one), "stationary", 3, TRIALS, STEPS)
    jpda = runner.run_trials(run_spec(one.replace(tracker={"association": "jpda"})),
                             "stationary", 3, TRIALS, STEPS)  # fmt: skip
    np.testing.assert_allclose(jpda["rmse_pos"], pda["rmse_pos"], rtol=1e-3, atol=1e-3)
    if base.n_targets > 1:
        gnn = runner.run_trials(run_spec(base.replace(tracker={"association": "gnn"})),
                                "stationary", 3, TRIALS, STEPS)  # fmt: skip
        assert np.all(np.isfinite(gnn["rmse_pos"])) and not gnn["diverged"].any()
        assert gnn["false_alarms"].sum() > 0
