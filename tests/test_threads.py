"""Compile threads (``engine.threads``): a process that ends while XLA compiles in one of
them exits cleanly, and the ``mjx-radar`` command does not wait for a program it no
longer needs."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

# Lowered in the main thread, so the compile thread is inside XLA's C++ at once (about
# 3 s of XLA on 2 cores: 60 sorts, each its own loop) when the interpreter ends.
_ENDS_WHILE_COMPILING = """
import jax, jax.numpy as jnp
from mjx_radar.engine.threads import Started, busy

def f(x):
    for i in range(60):
        x = jnp.cumsum(jnp.sort(x * (i + 1)), axis=0)[::-1]
    return x

lowered = jax.jit(f).lower(jnp.ones(64))
Started(lowered.compile)
print("busy", busy(), flush=True)
"""


def test_process_ending_while_xla_compiles_exits_cleanly():
    """A daemon compile thread inside XLA aborted the interpreter's exit ("terminate
    called ...", exit 134, every time); a compile thread is waited for instead."""
    env = {**os.environ, "JAX_PLATFORMS": "cpu"}
    proc = subprocess.run(
        [sys.executable, "-c", _ENDS_WHILE_COMPILING],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "busy True" in proc.stdout
    assert "terminate called" not in proc.stderr


def _refused(tmp_path, command: list[str]):
    """``mjx-radar COMMAND cramped.toml ...`` (smoke with a box too small for its radars):
    ``(process, cache directory, out)``, the process checked for one line and exit 2."""
    text = (REPO / "scenarios" / "smoke.toml").read_text()
    head, _, tail = text.partition("\n[")
    bad = tmp_path / "cramped.toml"
    bad.write_text(f"{head}\nplacement_half_width = 20.0\n[{tail}")
    cache, out = tmp_path / "cache", tmp_path / "out"
    env = {**os.environ, "MJX_RADAR_CACHE_DIR": str(cache), "JAX_PLATFORMS": "cpu"}
    proc = subprocess.run(
        [sys.executable, "-m", "mjx_radar", command[0], str(bad), "--out", str(out)] + command[1:],
        capture_output=True,
        text=True,
        env=env,
        cwd=REPO,
        timeout=300,
    )
    err = proc.stderr.strip().splitlines()
    assert proc.returncode == 2, proc.stderr[-2000:]
    assert err[-1].startswith("error: placement_half_width = 20.0: cannot place")
    assert "Traceback" not in proc.stderr and "terminate called" not in proc.stderr
    assert not out.exists()
    return proc, cache / "programs"


def test_refused_run_exits_2_in_one_line_and_keeps_its_program(tmp_path):
    """Radars that cannot be placed are refused by the run's own initial conditions
    before the first step (exit 2, one line, no run directory); the program compiled for
    it stays in the cache (the box is a runtime number: the corrected scenario loads it)."""
    _, programs = _refused(tmp_path, ["run", "--method", "stationary", "--steps", "8"])
    assert len(list(programs.glob("exe-*.bin"))) == 1  # the loop's
    assert not list(programs.glob("place-*.bin"))  # no program of its own for the check


def test_refused_study_leaves_without_compiling_its_program(tmp_path):
    """A study checks placement for every shape before its first round, while its
    programs compile in the background; refused, the command exits without waiting for
    them: no executable written."""
    command = ["study", "--methods", "stationary", "--trials", "1", "--steps", "8"]
    _, programs = _refused(tmp_path, command)
    assert list(programs.glob("loop-*.lock"))  # its program had started
    assert not list(programs.glob("exe-*.bin"))  # and was left unfinished
