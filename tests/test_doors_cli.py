"""The command-line and API doors: conflicting options, the many-process flags, names
in any case, a single string where a list is expected, each refused (or read) in one line
with nothing left at the output path."""

from __future__ import annotations

import os

import pytest

import mjx_radar
from mjx_radar import ScenarioError
from mjx_radar.api.run_case import request
from mjx_radar.cli import main as cli_main


def _run(argv, capsys):
    code = cli_main.main(argv)
    err = capsys.readouterr().err.strip().splitlines()
    return code, err


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--planner", "policy"], "planner 'policy': give policy:DIR"),
        (["--method", "ddr-sfim+cem", "--planner", "ps"], "'ps' conflicts with the method"),
        (["--planner", "nope"], "planner: 'nope' is not one of"),
    ],
)
def test_run_refuses_in_one_line(tmp_path, capsys, extra, message):
    out = tmp_path / "run"
    code, err = _run(["run", "smoke", "--steps", "4", "--out", str(out), *extra], capsys)
    assert code == 2 and len(err) == 1 and message in err[0], err
    assert not out.exists()


def test_the_same_planner_twice_is_no_conflict():
    assert request("smoke", method="ddr-sfim+cem", planner="CEM").method.name == "ddr-sfim+cem"


def test_names_are_case_insensitive():
    assert request("smoke", method="DDR-SFIM", planner="Cem").method.planner == "cem"
    s = request("clutter_3r4t", association="JPDA").scenario
    assert s.tracker.association == "jpda"


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--coordinator", "h:1"], "--coordinator: only with --distributed"),
        (["--num-processes", "2"], "--num-processes: only with --distributed"),
        (["--process-id", "0"], "--process-id: only with --distributed"),
        (["--distributed", "--num-processes", "2", "--process-id", "2"], "must be in [0, 1]"),
        (["--distributed", "--process-id", "1"], "give --num-processes too"),
        (["--distributed", "--num-processes", "0"], "--num-processes = 0"),
        (["--distributed", "--coordinator", "nohostport"], "must be HOST:PORT"),
        (["--distributed", "--shard", "0/2"], "--shard and --distributed: choose one"),
        (["--planners", ""], "--planners = '': give one or more planner names"),
        (["--planners", " , "], "give one or more planner names"),
        (["--planners", "policy"], "give policy:DIR"),
        (["--methods", "stationary", "--planners", "cem"], "no method of stationary plans"),
    ],
)
def test_study_flags(tmp_path, capsys, extra, message):
    out = tmp_path / "study"
    argv = ["study", "smoke", "--methods", "ddr-sfim", "--trials", "2", "--out", str(out)]
    code, err = _run([*argv, *extra], capsys)
    assert code == 2 and len(err) == 1 and message in err[0], err
    assert not out.exists()


def test_run_study_reads_one_string_as_one_name(tmp_path):
    out = tmp_path / "s"
    with pytest.raises(ScenarioError, match="planner: 'nope' is not one of"):
        mjx_radar.run_study("smoke", methods="ddr-sfim", planners="nope", out=out)
    with pytest.raises(ScenarioError, match="methods: 'nope' is not one of"):
        mjx_radar.run_study("smoke", methods="nope", out=out)
    with pytest.raises(ScenarioError, match="planners: empty list"):
        mjx_radar.run_study("smoke", methods="ddr-sfim", planners=[], out=out)
    assert not out.exists()


def test_managed_tracker_refuses_an_association_it_ignores():
    s = mjx_radar.load_scenario("clutter_3r4t")
    with pytest.raises(ScenarioError, match='tracker.association = "mht": the managed tracker'):
        s.replace(
            filter={"structure": "per-target"},
            tracker={"management": "managed", "association": "mht"},
        )


def test_a_plugin_folder_is_named_as_a_folder(tmp_path):
    from mjx_radar.api.run_case import load_plugins

    with pytest.raises(ScenarioError, match="a folder, not a Python file"):
        load_plugins([tmp_path])


def test_distributed_without_a_coordinator_is_one_line(tmp_path):
    """In a fresh process (JAX's distributed start must come first): our own line."""
    import subprocess
    import sys

    out = tmp_path / "study"
    cmd = [sys.executable, "-m", "mjx_radar", "study", "smoke", "--distributed"]
    cmd += ["--trials", "2", "--out", str(out)]
    env = {k: v for k, v in os.environ.items() if not k.startswith(("SLURM_", "JAX_COORD"))}
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300, env=env)
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 2 and len(lines) == 1, proc.stderr
    assert "--distributed: no coordinator given and no cluster found (give" in lines[0]
    assert not out.exists()
