"""Shared test fixtures."""

from __future__ import annotations

import dataclasses
import os
import signal
import subprocess
import time
from pathlib import Path

import pytest

from mjx_radar.scenario.reader import load_scenario


@pytest.fixture
def sigkill_once_written():
    """``kill(proc, path, timeout_s)``: SIGKILL a running study as soon as ``path`` (its
    first chunk file) exists; fails if the process ends first or the timeout passes."""

    def kill(proc: subprocess.Popen, path: Path, timeout_s: float) -> None:
        deadline = time.monotonic() + timeout_s
        try:
            while not path.exists():
                assert proc.poll() is None, f"the process ended before {path.name}"
                assert time.monotonic() < deadline, f"no {path.name} after {timeout_s} s"
                time.sleep(0.02)
            os.kill(proc.pid, signal.SIGKILL)
        finally:
            proc.kill()
            proc.wait()

    return kill


@pytest.fixture(scope="module")
def tiny():
    """smoke shrunk to the cheapest program: horizon 3, 32 samples x 1 iteration, analytic
    rollouts (programs and runner tests)."""
    s = load_scenario("smoke")
    return dataclasses.replace(
        s,
        name="tiny",
        mpc=dataclasses.replace(s.mpc, horizon=3, rollout="analytic"),
        mppi=dataclasses.replace(s.mppi, samples=32, iterations=1),
    )
