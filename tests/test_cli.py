"""Command-line contract (SPEC §11): bad input -> exit 2, one line on stderr, no files."""

import subprocess
import sys
from pathlib import Path

import pytest

from mjx_radar.cli.main import main

GOOD = """
name = "t"
n_radars = 2
targets = [[0, 0, 55, 20, 10, 0]]
[timing]
steps = 8
"""

BAD_FILES = {
    "missing_field": ('name = "t"\nn_radars = 2\n', "targets"),
    "wrong_type": (GOOD.replace("n_radars = 2", 'n_radars = "two"'), "n_radars"),
    "negative_dt": (GOOD + "dt_filter = -0.025\n", "timing.dt_filter"),
    "zero_dt_control": (GOOD + "dt_control = 0\n", "timing.dt_control"),
    "not_multiple": (GOOD + "dt_control = 0.03\n", "integer multiple"),
    "steps_not_multiple": (GOOD.replace("steps = 8", "steps = 7"), "timing.steps"),
    "zero_radars": (GOOD.replace("n_radars = 2", "n_radars = 0"), "n_radars"),
    "no_targets": (GOOD.replace("targets = [[0, 0, 55, 20, 10, 0]]", "targets = []"), "targets"),
    "short_target_row": (GOOD.replace("20, 10, 0]]", "20]]"), "targets[0]"),
    "malformed_syntax": (GOOD + "[mpc\nhorizon = 3\n", "malformed TOML"),
    "unknown_field": (GOOD + "colour = 3\n", "colour"),
    "unknown_table_field": (GOOD + "[mppi]\nsample = 10\n", "mppi.sample"),
    "bad_weighting": (GOOD + "[mppi]\nweighting = 'max'\n", "mppi.weighting"),
    "negative_power": (GOOD + "[radar_equation]\npower_tx = -1.0\n", "radar_equation.power_tx"),
    "gamma_out_of_range": (GOOD + "[mpc]\ngamma = 1.5\n", "mpc.gamma"),
    "nan_value": (GOOD + "sigma_w2 = nan\n", "sigma_w2"),
    "cannot_place": (GOOD + "placement_half_width = 20.0\n", "placement_half_width"),
    "bad_obstacle": (GOOD + "[[obstacles]]\nkind = 'pyramid'\n", "obstacles[0].kind"),
    "bad_radar_rows": (GOOD + "radars = [[0, 0, 0]]\n", "radars"),
}

BAD_ARGS = {
    "unknown_method": (["--method", "greedy"], "--method"),
    "zero_trials": (["--trials", "0"], "--trials"),
    "negative_steps": (["--steps", "-4"], "--steps"),
    "steps_not_multiple": (["--steps", "6"], "--steps"),
    "bad_seed": (["--seed", "x"], "--seed"),
    "unknown_option": (["--colour", "red"], "unrecognized"),
    "bad_association": (["--association", "pmbm"], "--association: tracker.association"),
    "association_no_clutter": (["--association", "jpda"], "needs clutter"),
}


def _check_exit2(capsys, argv, needle, out: Path):
    code = main(argv)
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert len(err.splitlines()) == 1, err
    assert needle in err, err
    assert "Traceback" not in err
    assert not out.exists() or not any(out.iterdir())


@pytest.mark.parametrize("case", sorted(BAD_FILES))
def test_bad_scenario_files_exit_2(tmp_path, capsys, case):
    text, needle = BAD_FILES[case]
    # Put lines that must land in [timing] right after that table header.
    if "dt_" in text and "[timing]" in text and text.startswith(GOOD):
        extra = text[len(GOOD) :]
        text = GOOD.replace("[timing]\n", "[timing]\n" + extra)
    path = tmp_path / "s.toml"
    path.write_text(text)
    out = tmp_path / "out"
    _check_exit2(capsys, ["validate", str(path)], needle, out)
    _check_exit2(capsys, ["run", str(path), "--out", str(out)], needle, out)


@pytest.mark.parametrize("case", sorted(BAD_ARGS))
def test_bad_arguments_exit_2(tmp_path, capsys, case):
    path = tmp_path / "s.toml"
    path.write_text(GOOD)
    args, needle = BAD_ARGS[case]
    out = tmp_path / "out"
    _check_exit2(capsys, ["run", str(path), "--out", str(out), *args], needle, out)


def test_missing_file_exit_2(tmp_path, capsys):
    _check_exit2(capsys, ["run", str(tmp_path / "nope.toml")], "cannot read", tmp_path / "o")


def test_validate_bundled_scenarios(capsys):
    for name in ("smoke", "paper_3r4t", "paper_6r3t", "paper_4r4t"):
        assert main(["validate", f"scenarios/{name}.toml"]) == 0
        assert capsys.readouterr().out.startswith(f"ok: {name}")


def test_run_smoke_end_to_end(tmp_path, capsys):
    # A real subprocess: console entry point, files, summary line. Stationary radars: the
    # program of test_closed_loop's stationary run (smoke, analytic, 2 trials, one period
    # per segment), loaded from the session's caches when that ran first. Planned runs
    # through the CLI: test_run_with_a_plugin_planner below and tests/test_options_cli.py.
    out = tmp_path / "run"
    cmd = [sys.executable, "-m", "mjx_radar", "run", "scenarios/smoke.toml", "--steps", "16",
           "--trials", "2", "--rollouts", "analytic", "--method", "stationary",
           "--out", str(out)]  # fmt: skip
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert "mean position RMSE" in proc.stdout
    assert {p.name for p in out.iterdir()} == {
        "run.json",
        "metrics.parquet",
        "trajectories.npz",
        "scenario.toml",
    }
    import pandas as pd

    df = pd.read_parquet(out / "metrics.parquet")
    assert len(df) == 2 * 16
    assert {"scenario", "method", "trial", "step", "time_s", "rmse_pos", "rmse_state"} <= set(
        df.columns
    )
    # A complete run is not silently overwritten (refused before anything is compiled:
    # in this process).
    assert main(cmd[3:]) == 2 and "--force" in capsys.readouterr().err


def test_run_with_a_plugin_planner(tmp_path):
    """``mjx-radar run --plugin FILE --planner NAME`` runs a planner registered by a script;
    an unregistered name is one line and exit 2, before anything is compiled."""
    out = tmp_path / "run"
    # 2 trials: the program of examples/custom_planner.py --small (test_examples), compiled
    # once per session (tests/conftest.py)
    base = [sys.executable, "-m", "mjx_radar", "run", "scenarios/smoke.toml", "--steps", "8",
            "--trials", "2", "--rollouts", "analytic"]  # fmt: skip
    bad = subprocess.run([*base, "--planner", "best-of-k", "--out", str(out)],
                         capture_output=True, text=True, timeout=600)  # fmt: skip
    assert bad.returncode == 2 and "planner: 'best-of-k' is not one of mppi, hold" in bad.stderr
    assert bad.stderr.count("\n") == 1 and not out.exists()
    cmd = [*base, "--plugin", "examples/custom_planner.py", "--planner", "best-of-k",
           "--out", str(out)]  # fmt: skip
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    import json

    import pandas as pd

    meta = json.loads((out / "run.json").read_text())
    assert meta["method"] == "ddr-sfim+best-of-k" and meta["planner"] == "best-of-k"
    assert set(pd.read_parquet(out / "metrics.parquet")["method"]) == {"ddr-sfim+best-of-k"}


def test_public_python_interface():
    # SPEC §11: the top-level names users and outside checks rely on.
    import mjx_radar
    from mjx_radar import physics
    from mjx_radar.estimation.filters import ckf
    from mjx_radar.estimation.information import fisher
    from mjx_radar.estimation.sensor import sensing

    s = mjx_radar.load_scenario("scenarios/paper_3r4t.toml")
    assert isinstance(s, mjx_radar.Scenario) and s.n_radars == 3
    assert issubclass(mjx_radar.ScenarioError, ValueError)
    for fn in (sensing.noise_constant, fisher.sfim, fisher.sfim_ccr, fisher.pfim_step,
               ckf.predict, ckf.update, physics.rollout_radars):  # fmt: skip
        assert callable(fn)
