"""Compile a study's programs in worker processes, so that tracing runs in parallel too.

:func:`mjx_radar.engine.runner.precompile` compiles a study's programs (one per scenario
shape, program kind and planner) in threads. XLA's compilation releases the GIL and
overlaps, but tracing and lowering are Python and run one program at a time: with the
9 programs of the paper study that is seconds of tracing per program in a row. On a
host with cores to spare, :func:`warm` instead starts one ``python -m
mjx_radar.engine.compile_workers`` process per program (at most ``workers`` at once);
each traces, exports and compiles its program into the persistent caches (the export
cache, ``<cache>/programs``, and XLA's), and the study's process then loads every program
from them without tracing.

Nothing here changes a number: a worker compiles the program the study's own process
would (same scenario, shape, kind, planner, batch and segment length). The study's
process finds it under the same key (:func:`mjx_radar.engine.programs.program_key`),
which also holds x64, the precision pins and the registries; where anything differs
(a cost term, planner or tracker registered only in the calling process) the key
differs, the export is not found, and the study's process traces that program itself,
as before. A worker that fails costs nothing but its time.

Used only with the persistent cache on; by default on GPUs (XLA's CPU compiler already
uses every core, and a 2-core CPU gains nothing), with ``min(cores // 2, programs)``
workers; ``MJX_RADAR_COMPILE_WORKERS=N`` sets the count (0: threads only).
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import jax

from mjx_radar.engine import compile_cache


def default_workers(n_programs: int) -> int:
    """Worker processes for ``n_programs`` programs (module docstring)."""
    env = os.environ.get("MJX_RADAR_COMPILE_WORKERS")
    if env is not None:
        try:
            return max(0, min(int(env), n_programs))
        except ValueError:
            return 0
    if jax.default_backend() != "gpu" or n_programs < 2:
        return 0
    return max(0, min((os.cpu_count() or 1) // 2, n_programs))


def exported(scenario, kind: str, planner: str, batch: int, periods: int, full: bool) -> bool:
    """True if the program is in this process's export cache (no worker needed)."""
    from mjx_radar.engine.programs import device_mesh, program_key
    from mjx_radar.task.params import shape_key

    store = compile_cache.program_dir()
    if store is None:
        return False
    mesh = device_mesh(jax.local_devices()[:1])
    key = program_key(shape_key(scenario), periods, full, batch, mesh, kind, planner)
    return (store / f"loop-{key}.jaxexport").exists()


def _environment() -> dict:
    env = dict(os.environ)
    env["MJX_RADAR_CACHE_DIR"] = str(compile_cache.program_dir().parent)
    env["XLA_PYTHON_CLIENT_PREALLOCATE"] = "false"  # workers share the study's GPU
    if jax.default_backend() == "cpu":  # else inherited ("gpu" would also demand ROCm)
        env["JAX_PLATFORMS"] = "cpu"
    env["JAX_ENABLE_X64"] = "1" if jax.config.jax_enable_x64 else "0"
    matmul = jax.config.jax_default_matmul_precision
    if matmul:
        env["JAX_DEFAULT_MATMUL_PRECISION"] = str(matmul)
    env["MJX_RADAR_COMPILE_WORKERS"] = "0"
    return env


def warm(jobs, workers: int) -> int:
    """Compiles ``jobs`` into the persistent caches in worker processes.

    Args:
        jobs: ``(scenario, kind, planner, batch, periods, full)`` tuples, one program each.
        workers: processes at once (0: nothing is done).

    Returns:
        How many workers finished cleanly (the caller loads or traces every program
        either way).
    """
    if workers < 1 or not jobs or compile_cache.program_dir() is None:
        return 0
    t0 = time.perf_counter()
    env = _environment()
    ok = 0
    with tempfile.TemporaryDirectory(prefix="mjx_radar_compile_") as tmp:
        commands = []
        for i, (scenario, kind, planner, batch, periods, full) in enumerate(jobs):
            path = Path(tmp) / f"job{i}.toml"
            scenario.to_toml(path)
            args = [str(path), kind, planner, str(batch), str(periods), str(int(full))]
            commands.append([sys.executable, "-m", "mjx_radar.engine.compile_workers", *args])
        running: list = []
        failed: list[str] = []

        def finish(proc, log: Path, job) -> int:
            if proc.wait() == 0:
                return 1
            lines = log.read_text(errors="replace").strip().splitlines() or ["no output"]
            failed.append(f"{job[0].name} {job[1]}: {lines[-1][:200]}")
            return 0

        for i, cmd in enumerate(commands):
            while len(running) >= workers:
                ok += finish(*running.pop(0))
            log = Path(tmp) / f"job{i}.err"
            with log.open("w") as err:
                proc = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=err)
            running.append((proc, log, jobs[i]))
        for entry in running:
            ok += finish(*entry)
    for line in failed:  # the study's process compiles these itself
        print(f"compile: a worker failed ({line}); compiling it here", file=sys.stderr)
    print(
        f"compile: {ok} of {len(jobs)} program(s) traced and compiled in {workers} worker "
        f"process(es) in {time.perf_counter() - t0:.1f} s",
        file=sys.stderr,
    )
    return ok


def main(argv: list[str]) -> int:
    """Worker: ``SCENARIO.toml KIND PLANNER BATCH PERIODS FULL``; compiles one program."""
    from mjx_radar.engine.programs import compile_programs
    from mjx_radar.scenario.reader import load_scenario

    path, kind, planner, batch, periods, full = argv
    compile_cache.enable(os.environ["MJX_RADAR_CACHE_DIR"])
    scenario = load_scenario(path)
    full = bool(int(full))
    compile_programs(scenario, int(batch), int(periods), full, kind=kind, planner=planner)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
