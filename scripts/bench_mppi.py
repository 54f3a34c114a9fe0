"""Time one MPPI control call at paper settings (issue 15).

3 radars / 4 targets, 200 samples, 5 iterations, horizon 15, MJX rollouts
(``--rollouts analytic`` for the closed-form kinematics). For every method and
rollout unroll asked for, prints the compile time and the per-call times after
warm-up; the last line per combination is ``mppi_call_s=<median>``.

    python scripts/bench_mppi.py [--scenario paper_3r4t] [--methods ddr-sfim,ddr-pfim]
        [--unroll 1,15] [--calls 20] [--matmul-precision pinned|default]
        [--planner-precision LEVEL]

``--unroll`` sets how many horizon steps one loop iteration of the MJX rollout holds
(``plant.ROLLOUT_UNROLL``, default 1). ``--matmul-precision default`` un-pins every dot
(JAX's default: TF32 on Ampere+ GPUs, as before issue 26), ``--planner-precision``
relaxes only the MPPI sampling and rollouts (:data:`mjx_radar.precision.PLANNER`):
the cost of the pin (docs/scaling.md, "Precision on GPUs").
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import jax
import jax.numpy as jnp
import numpy as np

from mjx_radar import precision
from mjx_radar.control import mppi
from mjx_radar.io.scenario import load_scenario
from mjx_radar.physics import plant as physics
from mjx_radar.simulation.placement import initial_conditions
from mjx_radar.simulation.streams import trial_streams
from mjx_radar.task.planner import make_planner
from mjx_radar.task.task import build


def bench(s, method: str, calls: int) -> float:
    n = s.n_radars
    task, params = build(s, method)
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
    compile_s = time.perf_counter() - t0
    times = []
    for i in range(calls):
        t0 = time.perf_counter()
        _, u = jax.block_until_ready(control(*args_, u, jax.random.PRNGKey(i + 1)))
        times.append(time.perf_counter() - t0)
    t = np.array(times)
    unroll = physics.ROLLOUT_UNROLL
    print(
        f"{s.name} {method} rollouts={s.mpc.rollout} unroll={unroll} samples={s.mppi.samples} "
        f"iterations={s.mppi.iterations} horizon={s.mpc.horizon} {precision.describe()} "
        f"on {jax.devices()[0].device_kind}: "
        f"compile+first {compile_s:.1f} s; min {t.min() * 1e3:.2f} ms, median "
        f"{np.median(t) * 1e3:.2f} ms, max {t.max() * 1e3:.2f} ms over {len(t)} calls"
    )
    print(f"mppi_call_s={np.median(t):.4f}", flush=True)
    return float(np.median(t))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="paper_3r4t")
    ap.add_argument("--methods", "--method", default="ddr-sfim")
    ap.add_argument("--rollouts", choices=("mjx", "analytic"), default="mjx")
    ap.add_argument("--unroll", default="1", help="comma list of rollout unrolls")
    ap.add_argument("--calls", type=int, default=20)
    ap.add_argument("--matmul-precision", choices=("pinned", "default"), default="pinned")
    ap.add_argument("--planner-precision", default=None, help="e.g. high, default")
    args = ap.parse_args()
    if args.matmul_precision == "default":
        precision.ESTIMATION = precision.PLANNER = "default"
    if args.planner_precision:
        precision.PLANNER = args.planner_precision
    s = load_scenario(args.scenario)
    s = dataclasses.replace(s, mpc=dataclasses.replace(s.mpc, rollout=args.rollouts))
    for unroll in args.unroll.split(","):
        physics.ROLLOUT_UNROLL = int(unroll)
        for method in args.methods.split(","):
            bench(s, method, args.calls)


if __name__ == "__main__":
    main()
