"""One compilation per program across processes (issue 37): the per-program lock.

Another process (here a subprocess; in the suite the other pytest worker, in a study
another shard) compiles a program into the session's caches while this process asks
for the same program: this one waits on the program's lock, then loads the other's
export and XLA's executable instead of compiling a second time.
"""

from __future__ import annotations

import fcntl
import json
import subprocess
import sys
import time

import jax

from mjx_radar.engine import compile_cache, programs
from mjx_radar.task.params import shape_key

# conftest's ``tiny`` at batch 3: a program no other test compiles, so the other process
# is the first to trace it
OTHER = """
import dataclasses, json
from mjx_radar.engine import compile_cache
compile_cache.enable()
from mjx_radar.engine.programs import COMPILE_LOG, compile_programs
from mjx_radar.scenario.reader import load_scenario
s = load_scenario("smoke")
tiny = dataclasses.replace(s, name="tiny",
    mpc=dataclasses.replace(s.mpc, horizon=3, rollout="analytic"),
    mppi=dataclasses.replace(s.mppi, samples=32, iterations=1))
compile_programs(tiny, 3, 1, False, None, "none", "hold")
print(json.dumps(COMPILE_LOG[-1]))
"""


def _locked(path) -> bool:
    """True while another open file description holds an exclusive lock on ``path``."""
    if not path.exists():
        return False
    with open(path, "ab") as f:
        try:
            fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            return True
        fcntl.flock(f, fcntl.LOCK_UN)
        return False


def test_second_process_waits_then_loads_the_first_ones_program(tiny):
    mesh = programs.device_mesh(jax.local_devices()[:1])
    key = programs._key(shape_key(tiny), 1, False, 3, mesh, "none", "hold", False)
    lock = compile_cache.program_dir() / f"loop-{key}-d{mesh.devices.flat[0].id}.lock"
    other = subprocess.Popen([sys.executable, "-c", OTHER], stdout=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 120
        while not _locked(lock):  # the other process holds the program's lock: tracing
            assert other.poll() is None, "the other process ended without taking the lock"
            assert time.monotonic() < deadline, "the other process never took the lock"
            time.sleep(0.05)
        n = len(programs.COMPILE_LOG)
        progs, _ = programs.compile_programs(tiny, 3, 1, False, None, "none", "hold")
        first = json.loads(other.communicate(timeout=300)[0].strip().splitlines()[-1])
    finally:
        other.kill()
    mine = programs.COMPILE_LOG[n]
    assert first["source"] == "traced" and first["key"] == mine["key"] == key[:12]
    assert mine["source"] == "export cache" and progs.source == "export cache"
    # it waited for the other's trace and compilation, then XLA's cache answered
    assert mine["lock_wait_s"] > 0.5 * first["xla_compile_s"], (mine, first)
    assert mine["xla_compile_s"] < 0.5 * first["xla_compile_s"], (mine, first)
