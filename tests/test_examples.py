"""Every script in examples/ runs in small mode and writes what it promises.

The examples share the session's persistent compilation cache (tests/conftest.py), so
those of the same program shape compile once. The two that register a plug-in from the
script: tests/test_examples_plugins.py (a file of their own, so that ``--dist loadfile``
spreads the examples over two workers).
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest

REPO = Path(__file__).resolve().parent.parent
EXAMPLES = sorted(p.stem for p in (REPO / "examples").glob("*.py") if not p.stem.startswith("_"))


def test_examples_are_listed_and_short():
    assert len(EXAMPLES) >= 5
    doc = (REPO / "docs" / "api.md").read_text()
    for name in EXAMPLES:
        text = (REPO / "examples" / f"{name}.py").read_text()
        assert len(text.splitlines()) <= 70, name
        assert "--small" in text and f"examples/{name}.py" in doc, name


@pytest.mark.slow  # CI keeps compare_methods, custom_cost, video_and_snapshot (suite time)
def test_sweep_r2t(tmp_path, run_example):
    run_example("sweep_r2t", tmp_path / "o")
    table = pd.read_csv(tmp_path / "o" / "sweep_r2t.csv")
    assert list(table["r2t"]) == [75.0, 125.0, 200.0]
    assert (table["rmse_median"] > 0).all() and (table["rmse_median"] < 50).all()
    assert (tmp_path / "o" / "sweep_r2t.png").stat().st_size > 10_000


def test_compare_methods(tmp_path, run_example):
    run_example("compare_methods", tmp_path / "o")
    table = pd.read_csv(tmp_path / "o" / "methods.csv", index_col=0)
    assert sorted(table.index) == sorted(["stationary", "ccr-sfim", "ccr-pfim", "ddr-sfim",
                                          "ddr-pfim"])  # fmt: skip
    assert table.loc["stationary", "vs_stationary_%"] == 0.0


def test_custom_cost(tmp_path, run_example):
    out = run_example("custom_cost", tmp_path / "o")
    assert "without stay_home" in out and "with stay_home" in out


@pytest.mark.slow  # CI keeps compare_methods, custom_cost, video_and_snapshot (suite time)
def test_scenario_in_code(tmp_path, run_example):
    import mjx_radar

    run_example("scenario_in_code", tmp_path / "o")
    s = mjx_radar.load_scenario(tmp_path / "o" / "two_blocks.toml")
    assert s.name == "two_blocks" and len(s.obstacles) == 2 and s.mpc.los
    run = mjx_radar.Run.load(tmp_path / "o" / "run")
    assert run.scenario == s and len(run.trials) == 2


def test_video_and_snapshot(tmp_path, run_example):
    run_example("video_and_snapshot", tmp_path / "o")
    assert (tmp_path / "o" / "run.gif").read_bytes()[:6] in (b"GIF89a", b"GIF87a")
    assert (tmp_path / "o" / "snapshot.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.slow  # CI keeps compare_methods, custom_cost, video_and_snapshot (suite time)
def test_small_study(tmp_path, run_example):
    run_example("small_study", tmp_path / "o")
    study = tmp_path / "o" / "study"
    assert (study / "study.json").exists() and (study / "report.md").exists()
    frame = pd.read_parquet(study / "metrics.parquet")
    assert sorted(frame["method"].astype(str).unique()) == ["ddr-sfim", "stationary"]
    assert frame["trial"].nunique() == 4


@pytest.mark.slow  # CI keeps compare_methods, custom_cost, video_and_snapshot (suite time)
def test_track_in_clutter(tmp_path, run_example):
    run_example("track_in_clutter", tmp_path / "o")
    table = pd.read_csv(tmp_path / "o" / "trackers.csv")
    assert list(table["tracker"]) == ["jpda", "mht"] and (table["trials"] == 2).all()
    assert table["unmatched_trials"].between(0, 2).all()
    assert (table["median_gospa_m"] > 0).all() and (table["median_gospa_m"] < 60).all()
