"""One compilation per program across processes (issue 37): the per-program lock.

Another process (here a subprocess; in the suite the other pytest worker, in a study
another shard) compiles a program into the session's caches while this process asks
for the same program: this one waits on the program's lock, then loads the other's
executables instead of compiling a second time.
"""

from __future__ import annotations

import fcntl
import json
import subprocess
import sys
import time
from pathlib import Path

import jax
import pytest

from mjx_radar.engine import compile_cache, programs
from mjx_radar.engine.run_spec import run_spec
from mjx_radar.task.params import shape_key

ROOT = Path(__file__).resolve().parents[1]
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
from mjx_radar.engine.run_spec import run_spec
progs, _ = compile_programs(run_spec(tiny), 3, 1, False, None, "none", "hold")
from tests.test_program_lock import outputs_digest
print(json.dumps(COMPILE_LOG[-1] | {"digest": outputs_digest(tiny, progs)}))
"""


def outputs_digest(scenario, progs) -> str:
    """SHA-256 of every output of ``init`` on trials 0..2 and of one ``step`` after it."""
    import hashlib

    import jax.numpy as jnp
    import numpy as np

    from mjx_radar.task.method import parse_method
    from mjx_radar.task.params import task_params

    params = jax.tree.leaves(task_params(scenario, parse_method("stationary"), 0))
    p = [jax.device_put(x, progs.replicated) for x in params]
    *carry, ok = progs.init(jax.device_put(jnp.arange(3), progs.trial_sharding), *p)
    h = hashlib.sha256()
    for x in [*carry, ok]:
        h.update(np.asarray(x).tobytes())
    for x in progs.step(*p, *carry):  # (donates the carry)
        h.update(np.asarray(x).tobytes())
    return h.hexdigest()


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


@pytest.fixture
def no_plugins(monkeypatch):
    """No registered plug-in, as in the other process (a fresh interpreter): a plug-in that
    another test file left registered in this worker would enter the program's key here
    (``engine.programs._variant``) and not there, and the two would not share a lock."""
    from mjx_radar import registry

    kinds = ("PLANNERS", "TRACKERS", "ASSOCIATORS", "COST_TERMS", "SENSORS")
    for kind in kinds:
        monkeypatch.setattr(getattr(registry, kind), "_user", {})


def test_second_process_waits_then_loads_the_first_ones_program(tiny, no_plugins):
    mesh = programs.device_mesh(jax.local_devices()[:1])
    key = programs._key(shape_key(tiny), 1, False, 3, mesh, "none", "hold", False)
    lock = compile_cache.program_dir() / f"loop-{key}-d{mesh.devices.flat[0].id}.lock"
    other = subprocess.Popen(
        [sys.executable, "-c", OTHER], stdout=subprocess.PIPE, text=True, cwd=ROOT
    )
    try:
        deadline = time.monotonic() + 120
        while not _locked(lock):  # the other process holds the program's lock: tracing
            assert other.poll() is None, "the other process ended without taking the lock"
            assert time.monotonic() < deadline, "the other process never took the lock"
            time.sleep(0.05)
        n = len(programs.COMPILE_LOG)
        progs, _ = programs.compile_programs(run_spec(tiny), 3, 1, False, None, "none", "hold")
        first = json.loads(other.communicate(timeout=300)[0].strip().splitlines()[-1])
    finally:
        other.kill()
    mine = programs.COMPILE_LOG[n]
    assert first["source"] == "traced" and first["key"] == mine["key"] == key[:12]
    # XLA compiled it there (not JAX's persistent cache): its executables were written,
    # and this process loads them without lowering (engine.executable_cache)
    assert mine["source"] == "executable cache" and progs.source == "executable cache"
    assert outputs_digest(tiny, progs) == first["digest"]  # the same numbers, bit for bit
    # it waited for the other's trace and compilation, then XLA's cache answered
    assert mine["lock_wait_s"] > 0.5 * first["xla_compile_s"], (mine, first)
    assert mine["xla_compile_s"] < 0.5 * first["xla_compile_s"], (mine, first)
