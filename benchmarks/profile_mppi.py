"""Times the pieces of one MPPI iteration (rollouts, cost terms, information) on one device.

Usage: ``python benchmarks/profile_mppi.py [--scenario paper_3r4t] [--method ddr-sfim]``
(200 samples, the scenario's horizon; jit, median of 10 calls).
"""

from __future__ import annotations

import argparse

import jax
from bench_timing import median_seconds  # scripts/, on the path when run

from mjx_radar.env.placement import initial_conditions, layout_of
from mjx_radar.env.streams import trial_streams
from mjx_radar.scenario.reader import load_scenario
from mjx_radar.task import objective
from mjx_radar.task.costs import Horizon, information, radar_radar, radar_target
from mjx_radar.task.task import build


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="paper_3r4t")
    ap.add_argument("--method", default="ddr-sfim")
    args = ap.parse_args()
    s = load_scenario(args.scenario)
    task, params = build(s, args.method)
    init = initial_conditions(layout_of(task), params, trial_streams(params.seed, 0))
    ctx = objective.plan_context(task, init.radar_state, init.mean, init.cov)
    cost = objective.make_objective(task)
    h, n, samples = s.mpc.horizon, s.n_radars, s.mppi.samples
    u = jax.random.normal(jax.random.PRNGKey(0), (samples, h, 2 * n))
    roll = jax.jit(jax.vmap(lambda uu: task.rollout(init.radar_state, uu.reshape(h, n, 2))))
    traj = roll(u)

    def horizon(tr):
        return Horizon(u[0].reshape(h, n, 2), tr, ctx.target_points, ctx.info0)

    def terms(tr):
        hz = horizon(tr)
        return sum(f(hz, task, params).sum() for f in (information, radar_radar, radar_target))

    info = jax.jit(jax.vmap(lambda tr: information(horizon(tr), task, params).sum()))
    full = jax.jit(jax.vmap(lambda uu: cost(uu, ctx, params)[0]))
    print(
        f"{s.name} {args.method}, one MPPI iteration of {samples} samples on "
        f"{jax.devices()[0].device_kind}: rollout {1e3 * median_seconds(roll, u):.1f} ms, "
        f"cost terms {1e3 * median_seconds(jax.jit(jax.vmap(terms)), traj):.1f} ms "
        f"(information {1e3 * median_seconds(info, traj):.1f} ms), "
        f"rollout + cost {1e3 * median_seconds(full, u):.1f} ms"
    )


if __name__ == "__main__":
    main()
