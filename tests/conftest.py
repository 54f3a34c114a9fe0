"""Shared test fixtures."""

from __future__ import annotations

import dataclasses
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

from mjx_radar.scenario.reader import load_scenario

_OWN_CACHE = "_MJX_RADAR_TEST_CACHE_OWNER"


def pytest_addoption(parser):
    parser.addoption(
        "--compile-profile",
        metavar="PATH",
        help="append one JSON line per test to PATH: its wall seconds, JAX's compile "
        "counts and seconds in the test's process, its compilations of >= 1 s by name and "
        "the closed-loop programs it compiled or loaded (benchmarks/bench_suite.py sums them)",
    )


def pytest_configure(config):
    """One compilation cache for the whole test session (suite time, issue 37).

    The first process (the xdist controller, or the only process with ``-n 0``) makes an
    empty folder and names it in ``$MJX_RADAR_CACHE_DIR``; the workers and every
    subprocess a test starts inherit it, and each test process turns XLA's persistent
    cache on there. A program that two test files (or an example script and a test)
    compile alike is compiled once per session instead of once per process. The cache
    only stores executables keyed by their HLO: the numbers are those of a fresh
    compilation. Tests that need a cold or private cache set their own folder or
    ``--no-cache``; the user's ``~/.cache`` is not touched.
    """
    if not hasattr(config, "workerinput") and _OWN_CACHE not in os.environ:
        os.environ["MJX_RADAR_CACHE_DIR"] = tempfile.mkdtemp(prefix="mjx_radar_test_cache_")
        os.environ[_OWN_CACHE] = str(os.getpid())
    if hasattr(config, "workerinput") or not config.getoption("numprocesses", None):
        from mjx_radar.engine import compile_cache

        compile_cache.enable(os.environ["MJX_RADAR_CACHE_DIR"])
    if config.getoption("compile_profile"):  # every test process (workers included)
        import jax.monitoring

        jax.monitoring.register_event_duration_secs_listener(_on_duration)


_COMPILES: dict = {}  # --compile-profile: this process's compile events during one test
_EVENTS = {  # jax.monitoring duration events -> (count key, seconds key)
    "/jax/core/compile/backend_compile_duration": ("xla_n", "xla_s"),
    "/jax/core/compile/jaxpr_trace_duration": ("trace_n", "trace_s"),
    "/jax/core/compile/jaxpr_to_mlir_module_duration": ("lower_n", "lower_s"),
}


def _on_duration(event: str, duration: float, fun_name: str = "?", **_) -> None:
    if event in _EVENTS:
        n, s = _EVENTS[event]
        _COMPILES[n] = _COMPILES.get(n, 0) + 1
        _COMPILES[s] = _COMPILES.get(s, 0.0) + duration
        if n == "xla_n" and duration >= 1.0:  # the long compilations, by function name
            _COMPILES.setdefault("xla_long", []).append([fun_name, round(duration, 2)])


def _program_log() -> list:
    """``engine.programs.COMPILE_LOG`` once a test imported it (empty before): the suite
    does not import the engine for tests that do not use it."""
    return getattr(sys.modules.get("mjx_radar.engine.programs"), "COMPILE_LOG", [])


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    """With ``--compile-profile``: the test's wall time (setup, call, teardown) and the XLA
    compilations, tracing and lowering it caused in this process (not in subprocesses)."""
    path = item.config.getoption("compile_profile")
    if not path:
        yield
        return
    _COMPILES.clear()
    n_log = len(_program_log())
    start, t0 = time.time(), time.perf_counter()
    yield
    worker = getattr(item.config, "workerinput", {}).get("workerid", "main")  # xdist's
    rec = {"worker": worker, "start": start}
    rec.update(_COMPILES)
    if len(_program_log()) > n_log:  # the closed-loop programs this test compiled or loaded
        rec["programs"] = _program_log()[n_log:]
    with open(path, "a") as f:
        f.write(json.dumps({"id": item.nodeid, "wall": time.perf_counter() - t0, **rec}) + "\n")


def pytest_unconfigure(config):
    if os.environ.get(_OWN_CACHE) == str(os.getpid()):
        shutil.rmtree(os.environ["MJX_RADAR_CACHE_DIR"], ignore_errors=True)


@pytest.fixture
def session_cache() -> Path:
    """The session's compilation cache folder (see :func:`pytest_configure`)."""
    return Path(os.environ["MJX_RADAR_CACHE_DIR"])


@pytest.fixture
def run_example(session_cache):
    """``run_example(name, out) -> stdout``: ``examples/<name>.py --small --out out`` in a
    subprocess on the CPU, with the session's compilation cache; fails on a non-zero exit
    (tests/test_examples.py, tests/test_examples_plugins.py)."""
    repo = Path(__file__).resolve().parent.parent

    def run(name: str, out: Path) -> str:
        env = {**os.environ, "JAX_PLATFORMS": "cpu", "MJX_RADAR_CACHE_DIR": str(session_cache),
               "MPLBACKEND": "Agg", "PYTHONPATH": str(repo)}  # fmt: skip
        proc = subprocess.run(
            [sys.executable, str(repo / "examples" / f"{name}.py"), "--small", "--out", str(out)],
            capture_output=True, text=True, cwd=out.parent, env=env, timeout=900,
        )  # fmt: skip
        assert proc.returncode == 0, proc.stderr[-3000:]
        return proc.stdout

    return run


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
