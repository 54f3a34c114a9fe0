"""Time one control call of every planner at several compute budgets (issue 33).

For each planner and budget (rollouts per control call = ``mppi.samples x
mppi.iterations`` for the sampling planners, gradient steps for grad and hybrid: the
budgets of ``scripts/compare_planners.py``), builds the environment of the scenario and method,
resets one trial, compiles ``jit(planner.plan)(carry, obs, key)`` ahead (every case at
once, in threads), then times ``--calls`` calls of each, one after the other, each waited
for, the carry fed back as in the closed loop. Prints one line per case and writes ``--csv``::

    python benchmarks/bench_planners.py [--scenario paper_3r4t] [--method ddr-sfim]
        [--planners mppi,ps,cem,grad,hybrid,cmaes] [--budgets 1000,300,100] [--calls 30]
        [--csv planner_calls.csv]

Times are wall clock on the default JAX device (``jax.devices()[0]``), so the same
command gives the H100's figures on a GPU machine and the CPU's on a CPU machine.
"""

from __future__ import annotations

import argparse
import csv
import sys
import time
from pathlib import Path

import jax
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
from compare_planners import budget_variant  # noqa: E402  (the same budgets)


def prepare(scenario, method: str, name: str, seed: int = 0):
    """``(compiled plan, carry, obs)`` of one planner's control call (compiled ahead)."""
    from mjx_radar.env import make
    from mjx_radar.planners import base

    env = make(scenario, method)
    planner = base.make(name, env)
    state = jax.jit(env.reset)(env.trial_key(seed, 0))
    carry = planner.init()
    key = jax.random.PRNGKey(0)
    t0 = time.perf_counter()
    plan = jax.jit(planner.plan).lower(carry, state.obs, key).compile()
    return plan, carry, state.obs, time.perf_counter() - t0


def time_planner(plan, carry, obs, calls: int) -> dict:
    """Per-call wall times [ms] of a compiled control call (first call excluded)."""
    action, carry = jax.block_until_ready(plan(carry, obs, jax.random.PRNGKey(0)))
    times = []
    for i in range(calls):
        key = jax.random.PRNGKey(i + 1)
        t0 = time.perf_counter()
        action, carry = jax.block_until_ready(plan(carry, obs, key))
        times.append(time.perf_counter() - t0)
    t = np.asarray(times)
    return {
        "min_ms": 1e3 * t.min(),
        "median_ms": 1e3 * float(np.median(t)),
        "max_ms": 1e3 * t.max(),
        "finite": bool(np.isfinite(np.asarray(action)).all()),
    }


def main(argv=None) -> int:
    import mjx_radar
    from mjx_radar.engine.threads import parallel

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scenario", default="paper_3r4t")
    p.add_argument("--method", default="ddr-sfim")
    p.add_argument("--planners", default="mppi,ps,cem,grad,hybrid,cmaes")
    p.add_argument("--budgets", default="1000,300,100")
    p.add_argument("--calls", type=int, default=30)
    p.add_argument("--csv", type=Path, default=None)
    args = p.parse_args(argv)
    base = mjx_radar.load_scenario(args.scenario)
    device = jax.devices()[0].device_kind
    cases = [
        (budget, name, budget_variant(base, budget))
        for budget in (int(b) for b in args.budgets.split(","))
        for name in args.planners.split(",")
    ]
    t0 = time.perf_counter()  # every case compiles at once (XLA compiles in C++ threads)
    ready = parallel([lambda s=s, n=n: prepare(s, args.method, n) for _, n, s in cases])
    print(f"compiled {len(cases)} control calls in {time.perf_counter() - t0:.1f} s", flush=True)
    rows = []
    for (budget, name, _), (plan, carry, obs, compile_s) in zip(cases, ready, strict=True):
        r = {"compile_s": compile_s, **time_planner(plan, carry, obs, args.calls)}
        row = {"scenario": args.scenario, "rollouts": budget, "planner": name, "device": device}
        rows.append({**row, **r})
        print(
            f"{args.scenario} {args.method}+{name} rollouts={budget} on {device}: "
            f"compile {compile_s:.1f} s (concurrent); min {r['min_ms']:.2f} ms, median "
            f"{r['median_ms']:.2f} ms, max {r['max_ms']:.2f} ms over {args.calls} calls",
            flush=True,
        )
        if args.csv:  # rewritten after every case: a killed run keeps what it measured
            args.csv.parent.mkdir(parents=True, exist_ok=True)
            with args.csv.open("w", newline="") as f:
                w = csv.DictWriter(f, fieldnames=list(rows[0]))
                w.writeheader()
                w.writerows(rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
