"""Environment throughput with the planner out of the loop (issue 34; docs/learning.md).

    python benchmarks/bench_env.py paper_3r4t --batch 4096 --periods 50 [--adapter] [--json F]

``jit(vmap(reset))`` over ``--batch`` trial keys, then one jitted ``lax.scan`` of
``--periods`` control periods of ``vmap(env.step)`` driven by random actions within the
limits (no planner). Reports the compile time and the warm median over ``--repeats`` of
batched environment steps per second (control periods) and filter steps per second
(x ``control_every``: tracker predict, plant, measurements, update, metrics).
``--adapter`` times the brax adapter's step instead (features, keep-out penalty: what
PPO steps), ``--batches`` several batch sizes in one process. ``--planners
mppi,policy:DIR`` times one control call of each planner instead (ms, vmapped over
``--batch`` trials): the compute per control call of MPPI vs a policy.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time

import jax
import jax.numpy as jnp


def bench(scenario: str, batch: int, periods: int, repeats: int, adapter: bool) -> dict:
    from mjx_radar.env import make
    from mjx_radar.learning import features

    env = make(scenario)
    keys = jax.vmap(lambda t: env.trial_key(0, t))(jnp.arange(batch))
    if adapter:
        from mjx_radar.learning import brax_env

        benv = brax_env.BraxRadarEnv(env)
        reset, step, size = benv.reset, benv.step, env.action_size

        def act(k):
            return jax.random.uniform(k, (batch, size), minval=-1.0, maxval=1.0)
    else:
        reset, step = env.reset, env.step

        def act(k):
            a = jax.random.uniform(k, (batch, env.action_size), minval=-1.0, maxval=1.0)
            return jax.vmap(lambda x: features.action_to_control(env, x))(a)

    v_step = jax.vmap(step)

    @jax.jit
    def run(states, key):
        def body(s, k):
            s = v_step(s, act(k))
            return s, s.reward.mean()

        s, r = jax.lax.scan(body, states, jax.random.split(key, periods))
        return s.reward, r

    states = jax.jit(jax.vmap(reset))(keys)
    jax.block_until_ready(states)
    t0 = time.perf_counter()
    jax.block_until_ready(run(states, jax.random.PRNGKey(0)))
    first = time.perf_counter() - t0
    times = []
    for i in range(repeats):
        t0 = time.perf_counter()
        jax.block_until_ready(run(states, jax.random.PRNGKey(i + 1)))
        times.append(time.perf_counter() - t0)
    med = statistics.median(times)
    every = env.every
    return {
        "scenario": scenario,
        "device": str(jax.devices()[0].device_kind),
        "batch": batch,
        "periods": periods,
        "control_every": every,
        "adapter": adapter,
        "compile_and_first_s": round(first, 3),
        "median_s": round(med, 4),
        "env_steps_per_s": batch * periods / med,
        "filter_steps_per_s": batch * periods * every / med,
    }


def bench_planner(scenario: str, name: str, batch: int, repeats: int) -> dict:
    """Median wall time of one control call of planner ``name`` (``vmap`` over ``batch``
    trials' observations at t = 0, jitted; the planner's carry from ``init``)."""
    from mjx_radar import precision
    from mjx_radar.env import make
    from mjx_radar.planners import PLANNERS

    env = make(scenario)
    planner = PLANNERS.get(name)(env)
    keys = jax.vmap(lambda t: env.trial_key(0, t))(jnp.arange(batch))
    obs = jax.jit(jax.vmap(env.reset))(keys).obs
    carry = jax.tree.map(lambda x: jnp.broadcast_to(x, (batch, *jnp.shape(x))), planner.init())
    plan = jax.jit(precision.pinned(jax.vmap(planner.plan)))
    t0 = time.perf_counter()
    jax.block_until_ready(plan(carry, obs, keys))
    first = time.perf_counter() - t0
    times = []
    for i in range(repeats):
        k = jax.vmap(lambda t, i=i: env.trial_key(i + 1, t))(jnp.arange(batch))
        t0 = time.perf_counter()
        jax.block_until_ready(plan(carry, obs, k))
        times.append(time.perf_counter() - t0)
    return {
        "scenario": scenario,
        "device": str(jax.devices()[0].device_kind),
        "planner": name,
        "batch": batch,
        "compile_and_first_s": round(first, 3),
        "ms_per_call": 1e3 * statistics.median(times),
    }


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("scenario", nargs="?", default="paper_3r4t")
    p.add_argument("--batch", type=int, default=4096)
    p.add_argument("--batches", default=None, help="comma-separated batch sizes")
    p.add_argument("--periods", type=int, default=50, help="control periods per timed scan")
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--adapter", action="store_true", help="time the brax adapter's step")
    p.add_argument("--json", default=None, help="append the results to this JSON-lines file")
    p.add_argument(
        "--planners",
        default=None,
        help="instead: ms per control call of these planners (e.g. mppi,policy:DIR), "
        "vmapped over --batch trials",
    )
    args = p.parse_args()
    if args.planners:
        for name in args.planners.split(","):
            r = bench_planner(args.scenario, name, args.batch, args.repeats)
            print(
                f"{r['scenario']} planner {name} batch {r['batch']} ({r['device']}): "
                f"{r['ms_per_call']:.3f} ms per control call (compile+first "
                f"{r['compile_and_first_s']} s)",
                flush=True,
            )
            if args.json:
                with open(args.json, "a") as f:
                    f.write(json.dumps(r) + "\n")
        return
    sizes = [int(b) for b in args.batches.split(",")] if args.batches else [args.batch]
    for b in sizes:
        r = bench(args.scenario, b, args.periods, args.repeats, args.adapter)
        print(
            f"{r['scenario']} batch {b} ({r['device']}, adapter={r['adapter']}): "
            f"{r['env_steps_per_s']:.3g} env steps/s, {r['filter_steps_per_s']:.3g} filter "
            f"steps/s (median {r['median_s']} s per {args.periods} periods; compile+first "
            f"{r['compile_and_first_s']} s)",
            flush=True,
        )
        if args.json:
            with open(args.json, "a") as f:
                f.write(json.dumps(r) + "\n")


if __name__ == "__main__":
    main()
