"""Robust study statistics: HDI, lost-track rates, kept means, paired reductions, the report."""

import json

import numpy as np
import pandas as pd
import pytest

from mjx_radar.errors import InputError
from mjx_radar.study import metrics as sm
from mjx_radar.study.report import write_report
from mjx_radar.task.method import METHODS, parse_method


def test_hdi_of_a_known_distribution():
    # 90% HDI of a standard normal is +-1.6449 (symmetric unimodal: equal-tailed)
    x = np.random.default_rng(0).normal(size=200_000)
    np.testing.assert_allclose(sm.hdi(x), [-1.6449, 1.6449], atol=0.02)
    # exponential(1): the HDI starts at 0 and ends at -ln(0.1) = 2.3026
    e = np.random.default_rng(1).exponential(size=200_000)
    np.testing.assert_allclose(sm.hdi(e), [0.0, 2.3026], atol=0.03)


def test_lost_counts_and_kept_mean():
    lost = np.zeros((4, 5), bool)
    lost[1, 2] = True  # trial 1: one step
    lost[3, 1:] = True  # trial 3: four steps
    c = sm.lost_counts(lost)
    assert c == {"trials": 4, "trials_lost": 2, "trial_rate": 0.5, "step_rate": 5 / 20}
    values = np.arange(20.0).reshape(4, 5)
    np.testing.assert_array_equal(sm.kept_mean(values, lost.any(1)), values[[0, 2]].mean(0))
    assert np.isnan(sm.kept_mean(values, np.ones(4, bool))).all()


def test_lost_counts_by_cell_equal_each_cells_table():
    """One grouping of a long table gives each cell's :func:`lost_counts` of its [T, K]
    table exactly, whatever the row order (float 0/1 ``lost``, as the metrics files)."""
    rng = np.random.default_rng(3)
    tables, rows = {}, []
    for sc, meth, t, k, p in (("a", "ddr-sfim", 7, 5, 0.2), ("a", "stationary", 7, 5, 0.0),
                              ("b", "ddr-sfim", 3, 9, 0.5)):  # fmt: skip
        lost = rng.random((t, k)) < p
        tables[f"{sc}/{meth}"] = sm.lost_counts(lost)
        trial, step = np.meshgrid(np.arange(t), np.arange(1, k + 1), indexing="ij")
        cols = {"trial": trial.ravel(), "step": step.ravel(), "lost": lost.ravel().astype(float)}
        rows.append(pd.DataFrame({"scenario": sc, "method": meth, **cols}))
    frame = pd.concat(rows, ignore_index=True).sample(frac=1.0, random_state=0)
    frame[["scenario", "method"]] = frame[["scenario", "method"]].astype("category")
    got = sm.lost_counts_by_cell(frame)
    assert got == tables and list(got) == sorted(tables)
    assert got["a/stationary"]["trials_lost"] == 0 and got["b/ddr-sfim"]["trials"] == 3


def _frame(lost_col=True):
    """2 steps x 10 trials; ccr-sfim loses trials 0 and 1 (1e6 m), ddr-sfim loses trial 9."""
    trials = np.arange(10)
    rows = []
    for method, v, lost in (
        ("stationary", 10.0 + 0 * trials, []),
        ("ddr-sfim", trials + 1.0, [9]),
        ("ccr-sfim", np.where(trials < 2, 1e6, 2.0 * (trials + 1)), [0, 1]),
    ):
        for step in (1, 2):
            f = pd.DataFrame({"scenario": "x", "method": method, "trial": trials, "step": step,
                              "time_s": 0.025 * step, "rmse_pos": v, "rmse_state": 2 * v,
                              "crlb_pos": 1.0})  # fmt: skip
            if lost_col:
                f["lost"] = np.isin(trials, lost).astype(float) * (step == 2)  # lost at step 2
            rows.append(f)
    return pd.concat(rows, ignore_index=True)


def test_per_step_and_summary_by_hand():
    frame = _frame()
    steps = sm.per_step(frame)
    t = sm.summary(steps, frame).set_index("method")
    ccr = steps[steps.method == "ccr-sfim"]
    np.testing.assert_array_equal(ccr.lost_frac, [0.0, 0.2])
    np.testing.assert_array_equal(ccr.ever_lost_frac, [0.0, 0.2])
    assert t.loc["ccr-sfim", "lost_trial_rate"] == 0.2
    assert t.loc["ccr-sfim", "lost_step_rate"] == pytest.approx(0.1)
    assert t.loc["stationary", "lost_trial_rate"] == 0.0
    # medians: stationary 10, ddr 5.5, ccr median of {6, 8, ..., 20, 1e6, 1e6} = (14 + 16) / 2
    np.testing.assert_allclose(t["median_rmse_pos"], [10.0, 5.5, 15.0])
    # kept means: ddr trials 0..8 -> 5; ccr trials 2..9 -> 2 * 6.5 = 13
    np.testing.assert_allclose(t["kept_rmse_pos"], [10.0, 5.0, 13.0])
    ddr = t.loc["ddr-sfim"]
    assert ddr.red_median_vs_stationary == pytest.approx(45.0)
    assert ddr.red_median_vs_ccr == pytest.approx(100 * (1 - 5.5 / 15))
    # paired kept vs CCR: trials 2..8 kept by both: ddr mean 6, ccr mean 12 -> 50%
    assert ddr.red_kept_vs_ccr == pytest.approx(50.0) and ddr.n_kept_vs_ccr == 7
    # vs stationary: trials 0..8: ddr 5, stationary 10 -> 50%
    assert ddr.red_kept_vs_stationary == pytest.approx(50.0) and ddr.n_kept_vs_stationary == 9
    # the plain mean is dominated by the two lost CCR trials: a meaningless ~100%
    assert ddr.red_mean_vs_ccr > 99.9
    assert np.isnan(t.loc["ccr-sfim", "red_median_vs_ccr"])


def test_without_lost_column():
    frame = _frame(lost_col=False)
    t = sm.summary(sm.per_step(frame), frame).set_index("method")
    assert t[["kept_rmse_pos", "lost_trial_rate", "lost_step_rate"]].isna().all().all()
    assert np.isnan(t.loc["ddr-sfim", "red_kept_vs_ccr"])
    assert t.loc["ddr-sfim", "red_median_vs_ccr"] == pytest.approx(100 * (1 - 5.5 / 15))


def test_rms_vs_bound_columns():
    frame = _frame()
    steps = sm.per_step(frame)
    st = steps[steps.method == "ddr-sfim"]
    np.testing.assert_allclose(st.rms_pos, np.sqrt(np.mean((np.arange(10) + 1.0) ** 2)))
    np.testing.assert_allclose(st.crlb_rms, 1.0)


def test_method_lookup():
    assert parse_method("ddr-pfim").info == "pfim" and parse_method("ddr-pfim").plans
    assert not METHODS["stationary"].plans
    assert sm.baselines("ddr-pfim") == {"stationary": "stationary", "ccr": "ccr-pfim"}
    assert sm.baselines("ccr-sfim") == {} and sm.baselines("unknown") == {}
    with pytest.raises(ValueError, match="stationary, ccr-sfim"):
        parse_method("ddr")


@pytest.mark.parametrize("lost_col", [True, False])
def test_report_on_synthetic_study(tmp_path, lost_col):
    with pytest.raises(InputError, match="DIR"):
        write_report(tmp_path)
    _frame(lost_col).to_parquet(tmp_path / "metrics.parquet", index=False)
    meta = {"scenarios": ["x"], "trials": 10, "seed": {"x": 0}, "steps": {"x": 2},
            "devices": "cpu", "wall_s": 1.0, "command": "synthetic"}  # fmt: skip
    (tmp_path / "study.json").write_text(json.dumps(meta))
    md = write_report(tmp_path).read_text()
    assert "red. median" in md and "kept by *both*" in md and "38–74%" in md
    row = next(line for line in md.splitlines() if line.startswith("| ddr-sfim |"))
    cells = [c.strip() for c in row.strip("|").split("|")]
    assert cells[2] == "5.500"  # median
    if lost_col:
        assert cells[4] == "5.000" and cells[5] == "10.0%" and cells[-2] == "+50.0%"
        assert "predates" not in md
    else:
        assert cells[4] == "–" and cells[5] == "–" and "predates" in md
    for name in ("x_rmse.png", "x_rmse_mppi.png", "x_ecdf.png"):
        assert (tmp_path / "figures" / name).read_bytes()[:4] == b"\x89PNG"
    csv = pd.read_csv(tmp_path / "summary.csv")
    assert "red_kept_vs_ccr" in csv.columns and len(csv) == 3
