"""A sweep of bundled scenarios x 3 methods completes in one process (issue 36), with at
most ``$MJX_RADAR_LIVE_PROGRAMS`` compiled programs alive (scripts/sweep_bundled.py)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.slow
def test_sweep_of_three_scenarios_and_three_methods_completes(tmp_path):
    out = tmp_path / "rows.json"
    env = os.environ | {"MJX_RADAR_LIVE_PROGRAMS": "2", "PYTHONPATH": str(ROOT)}
    cmd = [sys.executable, str(ROOT / "scripts" / "sweep_bundled.py"),
           "--scenarios", "smoke,clutter_3r4t,waypoints_3r4t", "--steps", "4",
           "--no-cache", "--json", str(out)]  # fmt: skip
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=tmp_path)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    rows = json.loads(out.read_text())
    assert [(r["scenario"], r["method"]) for r in rows] == [
        (s, m)
        for s in ("smoke", "clutter_3r4t", "waypoints_3r4t")
        for m in ("stationary", "ddr-sfim", "ddr-pfim")
    ]
    assert all(r["finite"] and r["steps"] == 4 for r in rows)
    assert max(r["live_programs"] for r in rows) == 2  # 9 programs compiled, 2 kept
    assert "9 of 9 cases completed" in proc.stdout
