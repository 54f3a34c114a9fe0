"""The training door: train_policy's settings, output folder and resume state, the
script's flags, and the planner policy:DIR, each mistake one line before anything runs."""

from __future__ import annotations

import dataclasses
import importlib.util
import json
from pathlib import Path

import pytest

from mjx_radar import ScenarioError
from mjx_radar.learning.config import PPOConfig, check_config
from mjx_radar.learning.train import read_state, train_policy

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def script():
    spec = importlib.util.spec_from_file_location("train_policy", ROOT / "scripts/train_policy.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.mark.parametrize(
    ("change", "steps", "message"),
    [
        ({}, 10**20, r"steps = 100000000000000000000: must be an integer in \[1, 1000000000000\]"),
        ({}, 2.5e5, "steps = 250000.0: must be an integer"),
        ({"learning_rate": -3e-4}, 100, "learning_rate = -0.0003: must be a finite number > 0"),
        ({"discounting": 1.5}, 100, r"discounting = 1.5: must be a finite number in \(0, 1\]"),
        ({"num_updates_per_batch": 0}, 100, "num_updates_per_batch = 0"),
        ({"entropy_cost": float("nan")}, 100, "entropy_cost = nan"),
        ({"policy_hidden": (0,)}, 100, "policy_hidden"),
    ],
)  # fmt: skip
def test_settings_out_of_range(change, steps, message):
    with pytest.raises(ScenarioError, match=message):
        check_config(dataclasses.replace(PPOConfig(), **change), steps)


def test_out_a_file_or_under_a_file(tmp_path):
    f = tmp_path / "policy.txt"
    f.write_text("x")
    with pytest.raises(ScenarioError, match="a file, not a folder"):
        train_policy("smoke", 100, f)
    with pytest.raises(ScenarioError, match="is not a folder"):
        train_policy("smoke", 100, f / "sub")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["policy.txt"]


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("", "is not a policy file .Expecting value"),
        ("[1]", "not a JSON object"),
        ('{"scenario": "smoke"}', "lacks method, config"),
    ],
)
def test_resume_from_a_damaged_policy_json(tmp_path, text, message):
    (tmp_path / "policy.json").write_text(text)
    with pytest.raises(ScenarioError, match=message):
        read_state(tmp_path)


def test_resume_from_a_checkpoint_that_is_gone(tmp_path):
    state = {
        "scenario": "smoke", "method": "ddr-sfim", "config": dataclasses.asdict(PPOConfig()),
        "steps_done": 10, "wall_s": 1.0, "chunks": 1, "checkpoint": "checkpoints/000000000010",
    }  # fmt: skip
    (tmp_path / "policy.json").write_text(json.dumps(state))
    with pytest.raises(ScenarioError, match="names checkpoint 'checkpoints/000000000010', which"):
        read_state(tmp_path)


def test_script_flags_one_line(script, tmp_path, capsys):
    out = tmp_path / "p"
    for argv, message in (
        (["--steps", "2e5", "--lr=-3e-4"], "--lr = -0.0003"),
        (["--steps", "1000", "--discounting", "1.5"], "--discounting = 1.5"),
        (["--steps", "1000", "--updates-per-batch", "0"], "--updates-per-batch = 0"),
        (["--steps", "2.5"], "'2.5' is not a whole number"),
        (["--steps", "1000", "--max-minutes", "-1"], "--max-minutes = -1: must be a number > 0"),
        (["--steps", "1000", "--max-minutes", "nan"], "--max-minutes = nan"),
    ):
        with pytest.raises(SystemExit) if "2.5" in argv else _no_raise() as caught:
            code = script.main(["smoke", *argv, "--out", str(out)])
        code = caught.value.code if caught else code
        err = capsys.readouterr().err.strip().splitlines()
        assert code == 2 and len(err) == 1 and message in err[0], err
        assert not out.exists()


class _no_raise:
    def __enter__(self):
        return None

    def __exit__(self, *exc):
        return False


@pytest.mark.parametrize(
    ("files", "message"),
    [
        (None, "no such folder"),
        ({}, "no policy.json"),
        ({"policy.json": ""}, "is not a policy file"),
        ({"policy.json": '{"checkpoint": "c"}'}, "lacks n_radars"),
    ],
)
def test_policy_dir(tmp_path, files, message):
    from mjx_radar.api.run_case import request

    d = tmp_path / "pol"
    if files is not None:
        d.mkdir()
        for name, text in files.items():
            (d / name).write_text(text)
    with pytest.raises(ScenarioError, match=f"planner policy:.*{message}"):
        request("smoke", planner=f"policy:{d}")


def test_policy_dir_checkpoint_missing(tmp_path):
    from mjx_radar.api.run_case import request

    state = {"checkpoint": "checkpoints/1", "n_radars": 2, "n_targets": 2, "config": {}}
    (tmp_path / "policy.json").write_text(json.dumps({**state, "observation_size": 1,
                                                      "action_size": 4}))  # fmt: skip
    with pytest.raises(ScenarioError, match="checkpoint 'checkpoints/1' is missing"):
        request("smoke", planner=f"policy:{tmp_path}")
