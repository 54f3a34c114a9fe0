"""Median MPPI call time without obstacles, with the obstacle cost, and with ``mpc.los``.

Same settings as ``benchmarks/bench_mppi.py`` (the scenario's MPPI and MPC tables,
DDR-SFIM); "no obstacles" is the same scenario with its obstacles removed.
Numbers for the 2-core CPU are in docs/obstacles.md.

    python benchmarks/bench_obstacles.py [--scenario forest_4r4t] [--rollouts mjx] [--calls 15]
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import jax
import jax.numpy as jnp
import numpy as np

from mjx_radar.control import mppi
from mjx_radar.env.placement import initial_conditions, layout_of
from mjx_radar.env.streams import trial_streams
from mjx_radar.scenario.reader import load_scenario
from mjx_radar.task.planner import make_planner
from mjx_radar.task.task import build


def bench(s, calls: int, method: str = "ddr-sfim") -> tuple[float, float]:
    """(compile + first call, median call) seconds of one jitted MPPI control call."""
    n = s.n_radars
    task, params = build(s, method)
    init = initial_conditions(layout_of(task), params, trial_streams(params.seed, 0))
    plan = make_planner(task)

    @jax.jit
    def control(radar_state, mean, cov, u, key):
        res, _ = plan(radar_state, mean, cov, u, key, params)
        return res.mean[0], mppi.shift(res.mean)

    u = jnp.zeros((s.mpc.horizon, 2 * n))
    args = (init.radar_state, init.mean, init.cov)
    t0 = time.perf_counter()
    jax.block_until_ready(control(*args, u, jax.random.PRNGKey(0)))
    first = time.perf_counter() - t0
    times = []
    for i in range(calls):
        t0 = time.perf_counter()
        _, u = jax.block_until_ready(control(*args, u, jax.random.PRNGKey(i + 1)))
        times.append(time.perf_counter() - t0)
    return first, float(np.median(times))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="forest_4r4t")
    ap.add_argument("--rollouts", choices=("mjx", "analytic"), default="mjx")
    ap.add_argument("--calls", type=int, default=15)
    args = ap.parse_args()
    s = load_scenario(args.scenario)
    s = dataclasses.replace(s, mpc=dataclasses.replace(s.mpc, rollout=args.rollouts))
    variants = {
        "no obstacles": dataclasses.replace(s, obstacles=()),
        "obstacle cost": s,
        "obstacle cost + los": dataclasses.replace(s, mpc=dataclasses.replace(s.mpc, los=True)),
    }
    print(
        f"{s.name} ({len(s.obstacles)} obstacles), {args.rollouts} rollouts, "
        f"{jax.devices()[0].device_kind}, {s.mppi.samples} samples x {s.mppi.iterations} "
        f"iterations, H={s.mpc.horizon}"
    )
    for name, variant in variants.items():
        first, med = bench(variant, args.calls)
        print(f"  {name:22s} compile+first {first:6.2f} s   median call {1e3 * med:8.1f} ms")


if __name__ == "__main__":
    main()
