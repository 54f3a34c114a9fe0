"""Shared test fixtures."""

from __future__ import annotations

import os
import signal
import subprocess
import time
from pathlib import Path

import pytest


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
