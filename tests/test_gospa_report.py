"""GOSPA / OSPA / continuity in the study summary, the report and Run.summary (issue 35)."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from mjx_radar.api.run import Run
from mjx_radar.rundir import results
from mjx_radar.study import metrics, report

T, K = 3, 5


def _frame(method="ddr-sfim", seed=0, with_sets=True):
    rng = np.random.default_rng(seed)
    cols = {name: rng.uniform(1.0, 5.0, (T, K)) for name in results.METRIC_COLUMNS}
    cols["lost"] = np.zeros((T, K))
    cols["label_switches"] = rng.integers(0, 3, (T, K)).astype(float)
    cols["broken_tracks"] = rng.integers(0, 2, (T, K)).astype(float)
    frame = results.metrics_frame("s", method, np.arange(T), 0.025 * np.arange(1, K + 1), cols)
    if not with_sets:
        frame = frame.drop(columns=list(results.SET_COLUMNS))
    return frame, cols


def test_summary_means_and_per_trial_counts():
    frame, cols = _frame()
    table = metrics.summary(metrics.per_step(frame), frame)
    row = table.iloc[0]
    for c in metrics.SET_VALUES:
        assert row[f"mean_{c}"] == pytest.approx(cols[c].mean(), rel=1e-12)
    for c in metrics.EVENTS:  # the mean over trials of each trial's total
        assert row[f"{c}_per_trial"] == pytest.approx(cols[c].sum(1).mean(), rel=1e-12)


def test_older_studies_have_nan_and_no_table(tmp_path):
    frame, _ = _frame(with_sets=False)
    table = metrics.summary(metrics.per_step(frame), frame)
    assert table[["mean_gospa", "broken_tracks_per_trial"]].isna().all().all()
    assert report._set_table(table, {}, "s") == []


def test_report_shows_the_table_with_c_and_p(tmp_path):
    frame = pd.concat([_frame("stationary", 1)[0], _frame("ddr-sfim", 2)[0]], ignore_index=True)
    frame.to_parquet(tmp_path / "metrics.parquet")
    meta = {"scenarios": ["s"], "trials": T, "seed": {"s": 0}, "steps": {"s": K}}
    meta |= {"devices": "cpu", "wall_s": 1.0, "command": "test"}
    meta["gospa"] = {"s": {"cutoff": 50.0, "order": 1.0}}
    (tmp_path / "study.json").write_text(json.dumps(meta))
    text = report.write_report(tmp_path).read_text()
    assert "Multi-target metrics (c = 50 m, p = 1)" in text
    table = pd.read_csv(tmp_path / "summary.csv")
    rows = [x for x in text.splitlines() if x.startswith("| ddr-sfim | ")]
    assert len(rows) == 2  # the RMSE table's row and the multi-target one
    assert rows[1].startswith(f"| ddr-sfim | {table.loc[1, 'mean_gospa']:.3f} | ")


def test_run_summary(tmp_path):
    frame, cols = _frame()
    scenario = type("S", (), {"name": "s"})()
    run = Run(scenario, "ddr-sfim", 0, np.arange(T), K, frame, {}, {})
    out = run.summary()
    assert out["gospa"] == pytest.approx(cols["gospa"].mean())
    assert out["label_switches"] == int(cols["label_switches"].sum())
    old = Run(scenario, "m", 0, np.arange(T), K, _frame(with_sets=False)[0], {}, {})
    assert np.isnan(old.summary()["ospa"])


def test_run_options_override_the_scenario_and_are_checked(capsys):
    import mjx_radar.cli.main as cli
    from mjx_radar.api import run_case
    from mjx_radar.io.checks import ScenarioError

    req = run_case.request("smoke", gospa_cutoff=20.0, gospa_order=2.0)
    assert (req.scenario.metrics.gospa_cutoff, req.scenario.metrics.gospa_order) == (20.0, 2.0)
    assert run_case.request("smoke").scenario.metrics.gospa_cutoff == 50.0
    with pytest.raises(ScenarioError, match=r"^gospa_order = 0.5: must be a number in \[1.0"):
        run_case.request("smoke", gospa_order=0.5)
    assert cli.main(["run", "smoke", "--gospa-cutoff", "-3"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.endswith("--gospa-cutoff = -3.0: must be a number in (0.0, 100000.0]"), err
    assert "\n" not in err
