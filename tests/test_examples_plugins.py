"""The examples that register a plug-in from the script (a planner, an associator) run
in small mode and write what they promise (the other examples: tests/test_examples.py;
``run_example``: tests/conftest.py)."""

from __future__ import annotations


def test_custom_planner(tmp_path, run_example):
    """A planner of the user's own, registered from the script, runs like MPPI (issue 32)."""
    out = run_example("custom_planner", tmp_path / "o")
    lines = (tmp_path / "o" / "custom_planner.txt").read_text().splitlines()
    assert [line.split(":")[0].strip() for line in lines] == ["mppi", "best-of-k"], out
    rmse = [float(line.split("RMSE ")[1].split(" m")[0]) for line in lines]
    assert all(0 < r < 100 for r in rmse) and rmse[0] != rmse[1]


def test_custom_associator(tmp_path, run_example):
    """An associator of the user's own (examples/_auction.py), registered from the script,
    runs as ``[tracker] association`` on a cluttered scenario (1 trial, 16 steps; --small
    keeps the radars stationary: the associator's closed loop without a planner to compile,
    the planned one is the script's default)."""
    out = run_example("custom_associator", tmp_path / "o")
    lines = (tmp_path / "o" / "custom_associator.txt").read_text().splitlines()
    assert [line.split(":")[0].strip() for line in lines] == ["pda", "auction"], out
    rmse = [float(line.split("RMSE ")[1].split(" m")[0]) for line in lines]
    assert all(0 < r < 100 for r in rmse) and rmse[0] != rmse[1]
