"""Compile workers (engine/compile_workers.py): a worker's program is the study's own.

A worker process traces and exports a program from the scenario written to TOML; the
study's process must then find it under its own key and load it without tracing. That
holds only if the TOML round trip keeps the scenario's shape, checked here for every
bundled scenario, and the loaded program is checked end to end in a subprocess.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from mjx_radar.engine import compile_workers
from mjx_radar.scenario.reader import bundled_scenarios, load_scenario
from mjx_radar.task.params import shape_key

REPO = Path(__file__).resolve().parent.parent
ENV = {**os.environ, "JAX_PLATFORMS": "cpu", "PYTHONPATH": str(REPO)}
for name in ("MJX_RADAR_CACHE_DIR", "JAX_COMPILATION_CACHE_DIR", "MJX_RADAR_COMPILE_WORKERS"):
    ENV.pop(name, None)

SCRIPT = """
import sys
from mjx_radar.engine import compile_cache, compile_workers, programs
from mjx_radar.engine.runner import segment_periods
from mjx_radar.scenario.reader import bundled_scenarios, load_scenario

compile_cache.enable(sys.argv[1])
s = load_scenario("smoke").replace(seed=3)
bad = (s, "no-such-kind", "mppi", 2, segment_periods(s, 8), False)  # a worker that fails
print("bad", compile_workers.warm([bad], 1), compile_workers.exported(*bad))
job = (s, "none", "mppi", 2, segment_periods(s, 8), False)
print("warmed", compile_workers.warm([job], 1), compile_workers.exported(*job))
programs.compile_programs(s, 2, segment_periods(s, 8), False, kind="none")
print("source", programs.COMPILE_LOG[-1]["source"])
"""


def test_worker_program_is_loaded_without_tracing(tmp_path):
    out = subprocess.run(
        [sys.executable, "-c", SCRIPT, str(tmp_path / "cache")],
        env=ENV,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert out.returncode == 0, out.stderr[-3000:]
    assert "bad 0 False" in out.stdout  # a failed worker: nothing exported, no error
    assert "warmed 1 True" in out.stdout
    assert "source export cache" in out.stdout  # loaded, not traced again


@pytest.mark.parametrize("name", bundled_scenarios())
def test_toml_round_trip_keeps_the_shape(name, tmp_path):
    s = load_scenario(name)
    path = tmp_path / f"{name}.toml"
    s.to_toml(path)
    assert shape_key(load_scenario(path)) == shape_key(s)


def test_worker_count(monkeypatch):
    monkeypatch.setenv("MJX_RADAR_COMPILE_WORKERS", "3")
    assert compile_workers.default_workers(2) == 2
    assert compile_workers.default_workers(9) == 3
    monkeypatch.setenv("MJX_RADAR_COMPILE_WORKERS", "junk")
    assert compile_workers.default_workers(9) == 0
    monkeypatch.delenv("MJX_RADAR_COMPILE_WORKERS")
    assert compile_workers.default_workers(9) == 0  # the CPU: threads only
