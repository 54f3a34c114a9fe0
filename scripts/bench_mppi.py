"""Time one MPPI control call at paper settings (issue 4).

3 radars / 4 targets, 200 samples, 5 iterations, horizon 15, DDR-SFIM, MJX
rollouts (``--rollouts analytic`` for the closed-form kinematics). Prints the
compile time, the per-call times after warm-up and, last, ``mppi_call_s=<median>``.

    python scripts/bench_mppi.py [--scenario paper_3r4t] [--method ddr-sfim] [--calls 20]
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import jax
import jax.numpy as jnp
import numpy as np

from mjx_radar.control import mppi
from mjx_radar.io.scenario import load_scenario
from mjx_radar.simulation.placement import initial_conditions
from mjx_radar.simulation.streams import trial_streams
from mjx_radar.task.planner import make_planner
from mjx_radar.task.task import build


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="paper_3r4t")
    ap.add_argument("--method", default="ddr-sfim")
    ap.add_argument("--rollouts", choices=("mjx", "analytic"), default="mjx")
    ap.add_argument("--calls", type=int, default=20)
    args = ap.parse_args()
    s = load_scenario(args.scenario)
    s = dataclasses.replace(s, mpc=dataclasses.replace(s.mpc, rollout=args.rollouts))
    n = s.n_radars
    task, params = build(s, args.method)
    init = initial_conditions(task.scenario, params, trial_streams(params.seed, 0))
    plan = make_planner(task)

    @jax.jit
    def control(radar_state, mean, cov, u, key):
        res, _ = plan(radar_state, mean, cov, u, key, params)
        return res.mean[0], mppi.shift(res.mean)

    u = jnp.zeros((s.mpc.horizon, 2 * n))
    args_ = (init.radar_state, init.mean, init.cov)
    t0 = time.perf_counter()
    jax.block_until_ready(control(*args_, u, jax.random.PRNGKey(0)))
    print(
        f"device={jax.devices()[0].device_kind} compile+first_call_s={time.perf_counter() - t0:.2f}"
    )
    times = []
    for i in range(args.calls):
        t0 = time.perf_counter()
        _, u = jax.block_until_ready(control(*args_, u, jax.random.PRNGKey(i + 1)))
        times.append(time.perf_counter() - t0)
    t = np.array(times)
    print(
        f"{s.name} {args.method} rollouts={args.rollouts} samples={s.mppi.samples} "
        f"iterations={s.mppi.iterations} horizon={s.mpc.horizon}: "
        f"min {t.min():.4f} s, median {np.median(t):.4f} s, max {t.max():.4f} s over {len(t)} calls"
    )
    print(f"mppi_call_s={np.median(t):.4f}")


if __name__ == "__main__":
    main()
