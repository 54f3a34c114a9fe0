"""Every script in examples/ runs in small mode and writes what it promises.

The examples share the session's persistent compilation cache (tests/conftest.py), so
those of the same program shape compile once.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

REPO = Path(__file__).resolve().parent.parent
EXAMPLES = sorted(p.stem for p in (REPO / "examples").glob("*.py") if not p.stem.startswith("_"))


@pytest.fixture
def cache_dir(session_cache):
    return session_cache


def _run(name: str, out: Path, cache: Path) -> str:
    env = {**os.environ, "JAX_PLATFORMS": "cpu", "MJX_RADAR_CACHE_DIR": str(cache),
           "MPLBACKEND": "Agg", "PYTHONPATH": str(REPO)}  # fmt: skip
    proc = subprocess.run(
        [sys.executable, str(REPO / "examples" / f"{name}.py"), "--small", "--out", str(out)],
        capture_output=True, text=True, cwd=out.parent, env=env, timeout=900,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-3000:]
    return proc.stdout


def test_examples_are_listed_and_short():
    assert len(EXAMPLES) >= 5
    doc = (REPO / "docs" / "api.md").read_text()
    for name in EXAMPLES:
        text = (REPO / "examples" / f"{name}.py").read_text()
        assert len(text.splitlines()) <= 70, name
        assert "--small" in text and f"examples/{name}.py" in doc, name


@pytest.mark.slow  # CI keeps compare_methods, custom_cost, video_and_snapshot (suite time)
def test_sweep_r2t(tmp_path, cache_dir):
    _run("sweep_r2t", tmp_path / "o", cache_dir)
    table = pd.read_csv(tmp_path / "o" / "sweep_r2t.csv")
    assert list(table["r2t"]) == [75.0, 125.0, 200.0]
    assert (table["rmse_median"] > 0).all() and (table["rmse_median"] < 50).all()
    assert (tmp_path / "o" / "sweep_r2t.png").stat().st_size > 10_000


def test_compare_methods(tmp_path, cache_dir):
    _run("compare_methods", tmp_path / "o", cache_dir)
    table = pd.read_csv(tmp_path / "o" / "methods.csv", index_col=0)
    assert sorted(table.index) == sorted(["stationary", "ccr-sfim", "ccr-pfim", "ddr-sfim",
                                          "ddr-pfim"])  # fmt: skip
    assert table.loc["stationary", "vs_stationary_%"] == 0.0


def test_custom_cost(tmp_path, cache_dir):
    out = _run("custom_cost", tmp_path / "o", cache_dir)
    assert "without stay_home" in out and "with stay_home" in out


def test_custom_planner(tmp_path, cache_dir):
    """A planner of the user's own, registered from the script, runs like MPPI (issue 32)."""
    out = _run("custom_planner", tmp_path / "o", cache_dir)
    lines = (tmp_path / "o" / "custom_planner.txt").read_text().splitlines()
    assert [line.split(":")[0].strip() for line in lines] == ["mppi", "best-of-k"], out
    rmse = [float(line.split("RMSE ")[1].split(" m")[0]) for line in lines]
    assert all(0 < r < 100 for r in rmse) and rmse[0] != rmse[1]


def test_custom_associator(tmp_path, cache_dir):
    """An associator of the user's own (examples/_auction.py), registered from the script,
    runs as ``[tracker] association`` on a cluttered scenario (1 trial, 16 steps)."""
    out = _run("custom_associator", tmp_path / "o", cache_dir)
    lines = (tmp_path / "o" / "custom_associator.txt").read_text().splitlines()
    assert [line.split(":")[0].strip() for line in lines] == ["pda", "auction"], out
    rmse = [float(line.split("RMSE ")[1].split(" m")[0]) for line in lines]
    assert all(0 < r < 100 for r in rmse) and rmse[0] != rmse[1]


@pytest.mark.slow  # CI keeps compare_methods, custom_cost, video_and_snapshot (suite time)
def test_scenario_in_code(tmp_path, cache_dir):
    import mjx_radar

    _run("scenario_in_code", tmp_path / "o", cache_dir)
    s = mjx_radar.load_scenario(tmp_path / "o" / "two_blocks.toml")
    assert s.name == "two_blocks" and len(s.obstacles) == 2 and s.mpc.los
    run = mjx_radar.Run.load(tmp_path / "o" / "run")
    assert run.scenario == s and len(run.trials) == 2


def test_video_and_snapshot(tmp_path, cache_dir):
    _run("video_and_snapshot", tmp_path / "o", cache_dir)
    assert (tmp_path / "o" / "run.gif").read_bytes()[:6] in (b"GIF89a", b"GIF87a")
    assert (tmp_path / "o" / "snapshot.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.slow  # CI keeps compare_methods, custom_cost, video_and_snapshot (suite time)
def test_small_study(tmp_path, cache_dir):
    _run("small_study", tmp_path / "o", cache_dir)
    study = tmp_path / "o" / "study"
    assert (study / "study.json").exists() and (study / "report.md").exists()
    frame = pd.read_parquet(study / "metrics.parquet")
    assert sorted(frame["method"].astype(str).unique()) == ["ddr-sfim", "stationary"]
    assert frame["trial"].nunique() == 4
