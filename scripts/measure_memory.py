"""The memory model (``engine/memory_model.py``) against XLA's figures and the device's peak.

For every scenario (default: every bundled one) and program kind (default: the three
kinds a run compiles, ``none`` for ``stationary``, ``sfim`` and ``pfim`` for the
planning methods) it compiles the segment program (nothing is run unless ``--peak``)
and writes one row: the model's prediction, ``compiled.memory_analysis()`` of the step
program (temporaries + arguments + outputs - donated aliases) and their ratio::

    JAX_PLATFORMS=cpu python scripts/measure_memory.py --trials 2 --json cpu.json
    python scripts/measure_memory.py smoke paper_3r4t --kinds sfim --trials 64

With ``--peak`` every case runs in a process of its own (``--jobs`` at once), runs one
segment after compiling and adds the device's ``peak_bytes_in_use``
(``jax.Device.memory_stats()``; ``None`` on the CPU, where the process's peak RSS is
given instead) and compares it with the model's device peak (``predicted_peak``: on a
GPU the runtime's floor added to a small program). The GPU tables (every bundled
scenario x kind at 64 trials, SFIM at 16, a study's program; one H200)::

    CUDA_VISIBLE_DEVICES=0 python scripts/measure_memory.py --peak --kinds sfim \\
        --trials 64 --jobs 5 --json gpu_sfim64.json
    ... --kinds none,pfim --trials 64 --jobs 6 --json gpu_nonepfim64.json
    ... --kinds sfim --trials 16 --jobs 5 --json gpu_sfim16.json
    ... --kinds sfim+pfim+none --metrics-only --trials 64 --jobs 5 --json gpu_study64.json
    python benchmarks/memory_gpu_result.py gpu_*.json   # the result files

``--kinds sfim+pfim+none --metrics-only`` is a study's program (every built-in method
of a shape in one program, metrics only). ``--structure`` and ``--rollouts`` override
the scenarios' own. Rows print as they finish; ``--json`` holds every row so far.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import resource
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from mjx_radar.engine.run_spec import program_size, run_spec

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

KINDS = "none,sfim,pfim"
METHOD_OF_KIND = {"none": "stationary", "sfim": "ddr-sfim", "pfim": "ddr-pfim"}


def measure(
    path: str,
    kind: str,
    trials: int,
    steps: int,
    structure=None,
    rollouts=None,
    full: bool = True,
    peak: bool = False,
) -> dict:
    """Prediction, XLA's memory analysis and (``peak``) the device peak of one program."""
    import jax

    from mjx_radar.engine import memory_model, programs, resources, runner
    from mjx_radar.scenario.reader import load_with_overrides

    s, steps = load_with_overrides(path, rollouts, steps)
    if structure:
        s = dataclasses.replace(s, filter=dataclasses.replace(s.filter, structure=structure))
    every = s.timing.control_every
    steps = max(every, steps // every * every)
    periods = runner.segment_periods(s, steps)
    t0 = time.perf_counter()
    progs, _ = programs.compile_programs(run_spec(s), trials, periods, full, kind=kind)
    compile_s = time.perf_counter() - t0
    ma = progs.step.memory_analysis()
    xla = {
        "temp": ma.temp_size_in_bytes,
        "arg": ma.argument_size_in_bytes,
        "out": ma.output_size_in_bytes,
        "alias": ma.alias_size_in_bytes,
    }
    xla_peak = xla["temp"] + xla["arg"] + xla["out"] - xla["alias"]
    dev = jax.local_devices()[0]
    est = resources.device_terms(program_size(s), trials, dev.platform, kind, full, periods * every)
    row = {
        "scenario": s.name,
        "kind": kind,
        "structure": s.filter.structure,
        "rollout": s.mpc.rollout,
        "trials": trials,
        "full": full,
        "device": str(dev.device_kind),
        "estimate": est,
        "predicted": sum(est.values()),
        "xla": xla,
        "xla_peak": xla_peak,
        "ratio": round(sum(est.values()) / xla_peak, 3),
        "compile_s": round(compile_s, 1),
    }
    if peak:
        method = METHOD_OF_KIND.get(kind, "ddr-sfim")
        program = None if kind in METHOD_OF_KIND else (kind, "mppi")
        t0 = time.perf_counter()
        runner.run_trials(
            run_spec(s), method, 0, list(range(trials)), periods * every, full, program=program
        )
        stats = dev.memory_stats() or {}
        row["device_peak"] = stats.get("peak_bytes_in_use")
        # the model's device peak: XLA's figure and, on a GPU, the runtime's floor
        row["predicted_peak"] = memory_model.device_peak(row["predicted"], dev.platform)
        if row["device_peak"]:
            row["peak_ratio"] = round(row["predicted_peak"] / row["device_peak"], 3)
        row["peak_rss"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
        row["run_s"] = round(time.perf_counter() - t0, 1)
    return row


def _in_subprocess(case: tuple, a) -> dict:
    """One case in a fresh process (its own device peak)."""
    path, kind = case
    cmd = [sys.executable, __file__, path, "--kinds", kind, "--trials", str(a.trials)]
    cmd += ["--steps", str(a.steps), "--one"]
    for opt in ("structure", "rollouts"):
        if getattr(a, opt):
            cmd += [f"--{opt}", getattr(a, opt)]
    if a.metrics_only:
        cmd.append("--metrics-only")
    env = {**os.environ, "XLA_PYTHON_CLIENT_PREALLOCATE": "false"}
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=ROOT)
    rows = [line for line in proc.stdout.splitlines() if line.startswith("{")]
    if proc.returncode or not rows:
        last = (proc.stderr.strip().splitlines() or ["no output"])[-1]
        return {"scenario": path, "kind": kind, "error": last[:300]}
    return json.loads(rows[-1])


def _keep(rows: list, row: dict, path: str | None) -> None:
    """Prints a row and rewrites the JSON file with every row so far (a run cut short
    keeps what it measured)."""
    rows.append(row)
    print(json.dumps(row), flush=True)
    if path:
        Path(path).write_text(json.dumps(rows, indent=1))


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("scenarios", nargs="*", help="files or bundled names (default: all bundled)")
    p.add_argument("--kinds", default=KINDS, help=f"program kinds, comma list ({KINDS})")
    p.add_argument("--trials", type=int, default=2, help="trials per device (default 2)")
    p.add_argument("--steps", type=int, default=8, help="filter steps (default 8)")
    p.add_argument("--structure", choices=("joint", "per-target"), default=None)
    p.add_argument("--rollouts", choices=("mjx", "analytic"), default=None)
    p.add_argument("--metrics-only", action="store_true", help="a study's program")
    p.add_argument("--peak", action="store_true", help="also run it: the device's peak")
    p.add_argument("--jobs", type=int, default=1, help="processes at once with --peak")
    p.add_argument("--json", default=None, help="write the rows to this JSON file")
    p.add_argument("--one", action="store_true", help=argparse.SUPPRESS)  # a --peak worker
    a = p.parse_args()
    from mjx_radar.scenario.reader import bundled_scenarios

    cases = [(s, k) for s in a.scenarios or bundled_scenarios() for k in a.kinds.split(",")]
    full = not a.metrics_only
    if a.one or not a.peak:
        rows = []
        for path, kind in cases:
            try:
                row = measure(path, kind, a.trials, a.steps, a.structure, a.rollouts, full, a.one)
            except Exception as err:  # noqa: BLE001 -- one row per case, the table goes on
                row = {"scenario": path, "kind": kind, "error": f"{type(err).__name__}: {err}"}
            _keep(rows, row, a.json)
    else:
        with ThreadPoolExecutor(max(1, a.jobs)) as pool:
            rows = []
            for row in pool.map(lambda c: _in_subprocess(c, a), cases):
                _keep(rows, row, a.json)
    if not a.one:
        for r in rows:
            if "error" in r:
                print(f"{r['scenario']:<16} {r['kind']:<15} FAILED {r['error']}", file=sys.stderr)
                continue
            dp = r.get("device_peak")
            peak = f" device peak {dp / 1e6:10.1f} MB ({r['peak_ratio']:.2f})" if dp else ""
            print(
                f"{r['scenario']:<16} {r['kind']:<15} predicted {r['predicted'] / 1e6:10.1f} MB"
                f"  XLA {r['xla_peak'] / 1e6:10.1f} MB  ratio {r['ratio']:.2f}{peak}",
                file=sys.stderr,
            )
    return 1 if any("error" in r for r in rows) else 0


if __name__ == "__main__":
    sys.exit(main())
