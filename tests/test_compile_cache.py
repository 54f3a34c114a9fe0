"""A damaged persistent-cache entry: one line of ours, once per process (issue 26).

JAX warns with a two-line ``UserWarning`` (file, line and the ``warnings.warn(``
source line) for every program it cannot read from the cache, then recompiles;
``compile_cache.enable`` turns them into one line per process.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
ENV = {**os.environ, "JAX_PLATFORMS": "cpu", "PYTHONPATH": str(REPO)}
ENV.pop("MJX_RADAR_CACHE_DIR", None)
ENV.pop("JAX_COMPILATION_CACHE_DIR", None)
JIT = """
import sys
import jax, jax.numpy as jnp
from mjx_radar.engine import compile_cache
compile_cache.enable(sys.argv[1])
for k in range(3):  # three programs, three cache entries
    print(float(jax.jit(lambda x, k=k: jnp.sin(x) * (k + 1))(1.0)))
"""


def _corrupt(cache: Path) -> int:
    files = [p for p in cache.iterdir() if p.is_file()]
    for p in files:
        p.write_bytes(b"\x00garbage" * 17)
    return len(files)


def _unreadable_line(cache: Path) -> str:
    return (f"warning: compilation cache entry in {cache} unreadable; recompiling "
            f"(delete {cache} to clear it)")  # fmt: skip


def test_corrupt_entries_one_line(tmp_path):
    cache = tmp_path / "cache"
    first = subprocess.run([sys.executable, "-c", JIT, str(cache)], env=ENV,
                           capture_output=True, text=True, timeout=120)  # fmt: skip
    assert first.returncode == 0 and "warning" not in first.stderr.lower(), first.stderr
    assert _corrupt(cache) >= 3
    again = subprocess.run([sys.executable, "-c", JIT, str(cache)], env=ENV,
                           capture_output=True, text=True, timeout=120)  # fmt: skip
    assert again.returncode == 0 and again.stdout == first.stdout, again.stderr
    lines = [ln for ln in again.stderr.splitlines() if ln.strip()]
    assert lines == [_unreadable_line(cache)], again.stderr


def test_other_warnings_pass_through(tmp_path):
    code = (
        "import sys, warnings\nfrom mjx_radar.engine import compile_cache\n"
        "compile_cache.enable(sys.argv[1])\nwarnings.warn('something else', UserWarning)\n"
    )
    proc = subprocess.run([sys.executable, "-c", code, str(tmp_path / "c")], env=ENV,
                          capture_output=True, text=True, timeout=120)  # fmt: skip
    assert "UserWarning: something else" in proc.stderr, proc.stderr


@pytest.mark.slow  # a whole CLI run (suite time)
def test_run_with_a_corrupt_cache_warns_once(tmp_path):
    """``mjx-radar run --cache-dir D`` twice, D's entries overwritten with garbage between."""
    cache = tmp_path / "cache"
    cmd = [sys.executable, "-m", "mjx_radar", "run", "smoke", "--steps", "8", "--rollouts",
           "analytic", "--cache-dir", str(cache)]  # fmt: skip
    first = subprocess.run([*cmd, "--out", str(tmp_path / "a")], env=ENV, cwd=REPO,
                           capture_output=True, text=True, timeout=900)  # fmt: skip
    assert first.returncode == 0, first.stderr[-2000:]
    assert _corrupt(cache) > 0
    again = subprocess.run([*cmd, "--out", str(tmp_path / "b")], env=ENV, cwd=REPO,
                           capture_output=True, text=True, timeout=900)  # fmt: skip
    assert again.returncode == 0, again.stderr[-2000:]
    assert again.stderr.count(_unreadable_line(cache)) == 1, again.stderr
    assert "UserWarning" not in again.stderr and "warnings.warn" not in again.stderr
