"""The README's examples run as written (cheap ones at small size)."""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
README = (REPO / "README.md").read_text()
ENV = {**os.environ, "JAX_PLATFORMS": "cpu", "PYTHONPATH": str(REPO)}


def _blocks(lang: str) -> list[str]:
    return re.findall(rf"```{lang}\n(.*?)```", README, re.S)


def _commands() -> list[list[str]]:
    """Every ``mjx-radar ...`` command of the bash blocks (continuations joined)."""
    cmds = []
    for block in _blocks("bash"):
        for line in block.replace("\\\n", " ").splitlines():
            for part in re.split(r"&&|;", line.split("#")[0]):
                words = shlex.split(part)
                if words[:1] == ["mjx-radar"]:
                    cmds.append(words[1:])
    return cmds


def test_python_api_block_runs():
    (code,) = _blocks("python")
    proc = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=REPO, env=ENV, timeout=300
    )
    assert proc.returncode == 0, proc.stderr
    # The block's last line prints the shapes its comment promises.
    promised = code.strip().splitlines()[-1].split("#")[1].strip()
    assert proc.stdout.strip().splitlines()[-1] == promised


def test_scenarios_named_in_examples_validate(capsys, monkeypatch):
    """In one process (``mjx-radar validate``'s own entry point; the console script's
    exit codes are tested in test_cli and test_fuzz_validate)."""
    from mjx_radar.cli.main import main

    monkeypatch.chdir(REPO)
    names = sorted({w for cmd in _commands() for w in cmd if w.endswith(".toml")})
    assert "scenarios/smoke.toml" in names and len(names) >= 3
    for name in names:
        assert main(["validate", name]) == 0, (name, capsys.readouterr().err)
        assert capsys.readouterr().out.startswith("ok: ")


def test_video_example_works_after_quick_start():
    # The quick start writes runs/smoke; a later `run --out runs/smoke` needs --force.
    runs = [c for c in _commands() if c[:1] == ["run"]]
    first_out = runs[0][runs[0].index("--out") + 1]
    for cmd in runs[1:]:
        if "--out" in cmd and cmd[cmd.index("--out") + 1] == first_out:
            assert "--force" in cmd, cmd


@pytest.mark.slow
def test_quick_start_run_small(tmp_path):
    cmd = next(c for c in _commands() if c[:1] == ["run"])
    cmd = [w if w != "runs/smoke" else str(tmp_path / "smoke") for w in cmd]
    proc = subprocess.run(
        [sys.executable, "-m", "mjx_radar", *cmd, "--steps", "8", "--rollouts", "analytic"],
        capture_output=True,
        text=True,
        cwd=REPO,
        env=ENV,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "smoke" / "run.json").exists()
