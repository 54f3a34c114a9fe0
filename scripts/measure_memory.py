"""The memory estimate of ``engine/resources.py`` against XLA's own numbers (issue 26).

Compiles the segment program of a scenario (``engine.programs.compile_programs``,
nothing is run) and prints one JSON line per scenario: the estimate's device terms,
``compiled.memory_analysis()`` of the step program (temporaries, arguments, outputs,
donated aliases) and their ratio ``estimate / (temp + arg + out - alias)``::

    JAX_PLATFORMS=cpu python scripts/measure_memory.py scenarios/smoke.toml --rollouts analytic
    python scripts/measure_memory.py scenarios/swarm_32r32t.toml --structure per-target \\
        --trials 100 --metrics-only

``--metrics-only`` compiles the study's program (metrics, no trajectories); the default
is ``run``'s (full trajectories). The figures measured so far (CPU and H100) are the
tables of ``tests/test_resources.py``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def measure(path: str, trials: int, steps: int | None, structure, rollouts, full: bool) -> dict:
    """Estimate and XLA's memory analysis of one scenario's step program."""
    import jax

    from mjx_radar.engine import programs, resources, runner
    from mjx_radar.scenario.reader import load_with_overrides

    s, steps = load_with_overrides(path, rollouts, steps)
    if structure:
        s = dataclasses.replace(s, filter=dataclasses.replace(s.filter, structure=structure))
    t0 = time.perf_counter()
    progs, _ = programs.compile_programs(s, trials, runner.segment_periods(s, steps), full)
    ma = progs.step.memory_analysis()
    xla = {
        "temp": ma.temp_size_in_bytes,
        "arg": ma.argument_size_in_bytes,
        "out": ma.output_size_in_bytes,
        "alias": ma.alias_size_in_bytes,
    }
    peak = xla["temp"] + xla["arg"] + xla["out"] - xla["alias"]
    est = resources.device_terms(s, trials)
    return {
        "scenario": s.name,
        "structure": s.filter.structure,
        "rollout": s.mpc.rollout,
        "trials": trials,
        "full": full,
        "device": str(jax.devices()[0].device_kind),
        "estimate": est,
        "estimate_total": sum(est.values()),
        "xla": xla,
        "xla_peak": peak,
        "ratio": sum(est.values()) / peak,
        "compile_s": time.perf_counter() - t0,
    }


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("scenarios", nargs="+")
    p.add_argument("--trials", type=int, default=1, help="trials per device (default 1)")
    p.add_argument("--steps", type=int, default=8, help="filter steps (default 8)")
    p.add_argument("--structure", choices=("joint", "per-target"), default=None)
    p.add_argument("--rollouts", choices=("mjx", "analytic"), default=None)
    p.add_argument("--metrics-only", action="store_true", help="the study's program")
    a = p.parse_args()
    for path in a.scenarios:
        rec = measure(path, a.trials, a.steps, a.structure, a.rollouts, not a.metrics_only)
        print(json.dumps(rec), flush=True)


if __name__ == "__main__":
    main()
