"""Stage programs or one program? Compile and run time of the closed loop split in two.

The runner compiles one ``step`` program per shape: a ``lax.scan`` over control periods,
each the MPPI plan then ``control_every`` filter steps. Issue 27 asked whether compiling
the two stages of a control period (the planner's ``plan``, the environment's
``transition``: :mod:`mjx_radar.loop.closed_loop`) as separate programs,
in parallel threads, driven by a host loop per control period, starts faster without
slowing the simulation by more than 10 %. This measures, for one scenario and program
kind, on a fresh compilation cache (one process per configuration, so no stage inherits
another's warm compiler)::

    trace     Python tracing + lowering of each program [s]
    ops       StableHLO operations of each lowered program
    compile   XLA compilation of plan, period, the whole step, and plan || period [s]
    run       wall time of the periods of one run, host-driven stages vs the step [s]

    python benchmarks/bench_stages.py [--scenario scenarios/paper_3r4t.toml] [--kind sfim]
        [--batch 1] [--periods 6] [--steps 600]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

PARTS = ("plan", "period", "step", "parallel")


def _build(scenario_path: str, kind: str, batch: int, periods: int):
    """Jitted ``plan``, ``period``, ``step``, ``init`` and their argument specs (single device)."""
    import jax
    import jax.numpy as jnp

    from mjx_radar import precision
    from mjx_radar.env.streams import streams_of
    from mjx_radar.loop import closed_loop
    from mjx_radar.scenario.reader import load_scenario
    from mjx_radar.task.method import parse_method
    from mjx_radar.task.params import shape_key, task_params
    from mjx_radar.task.task import make_task

    sc = load_scenario(scenario_path)
    task = make_task(shape_key(sc), kind)
    method = {"none": "stationary", "sfim": "ddr-sfim", "pfim": "ddr-pfim"}.get(kind, "ddr-sfim")
    params = task_params(sc, parse_method(method))
    one = jax.ShapeDtypeStruct((), jnp.int32)
    carry = jax.eval_shape(lambda t, p: closed_loop.init_carry(task, p, t)[0], one, params)
    carry = jax.tree.map(lambda x: jax.ShapeDtypeStruct((batch, *x.shape), x.dtype), carry)

    @precision.pinned
    def plan(p, c):  # the planner's call of one control period
        def one_trial(c):
            env, planner = closed_loop.make_env(task, p)
            info = c.state.info
            key = jax.random.fold_in(streams_of(info["key"]).planner, info["period"])
            u, pc = planner.plan(c.planner, c.state.obs, key)
            return u, pc, planner.record(pc, u)

        return jax.vmap(one_trial)(c)

    @precision.pinned
    def period(p, c, u, pc):  # the environment's control period under u
        def one_trial(c, u, pc):
            env, _ = closed_loop.make_env(task, p)
            state, srec = env.transition(c.state, u)
            return closed_loop.LoopCarry(state, pc), srec

        return jax.vmap(one_trial)(c, u, pc)

    def step(p, c):
        return jax.vmap(lambda c: closed_loop.advance(task, p, c, periods))(c)

    def init(trials, p):
        return jax.vmap(lambda t: closed_loop.init_carry(task, p, t)[0])(trials)

    u = jax.eval_shape(plan, params, carry)
    fns = {
        "plan": (jax.jit(plan), (params, carry)),
        "period": (jax.jit(period, donate_argnums=1), (params, carry, u[0], u[1])),
        "step": (jax.jit(step, donate_argnums=1), (params, carry)),
    }
    return fns, jax.jit(init), params, sc


def measure(scenario: str, kind: str, batch: int, periods: int, steps: int, part: str) -> dict:
    """One configuration in this process (its compilation cache is fresh)."""
    import jax
    import jax.numpy as jnp

    from mjx_radar.engine.threads import parallel

    fns, init, params, sc = _build(scenario, kind, batch, periods)
    out: dict = {}
    lowered = {}
    for name in ("plan", "period") if part == "parallel" else (part,):
        fn, args = fns[name]
        t0 = time.perf_counter()
        lowered[name] = fn.lower(*args)
        if part != "parallel":  # tracing and size: from the process of that program alone
            out[f"trace_{name}"] = time.perf_counter() - t0
            out[f"ops_{name}"] = lowered[name].as_text().count(" = stablehlo.")
    t0 = time.perf_counter()
    if part == "parallel":
        plan_c, period_c = parallel([lowered["plan"].compile, lowered["period"].compile])
    else:
        compiled = lowered[part].compile()
    out[f"compile_{part}"] = time.perf_counter() - t0
    if part not in ("parallel", "step"):
        return out
    trials = jnp.arange(batch, dtype=jnp.int32)
    total = steps // sc.timing.control_every
    carry = init(trials, params)
    jax.block_until_ready(carry)

    def staged(carry, j0, n):
        keep = []
        for _ in range(j0, j0 + n):
            u, pc, crec = plan_c(params, carry)
            carry, srec = period_c(params, carry, u, pc)
            keep.append((srec, crec))
        return carry, keep

    def whole(carry, j0, n):
        keep = []
        for _ in range(j0, j0 + n, periods):
            carry, *rec = compiled(params, carry)
            keep.append(rec)
        return carry, keep

    drive = staged if part == "parallel" else whole
    carry, keep = drive(carry, 0, periods)  # first call: allocation, not timed
    jax.block_until_ready((carry, keep))
    t0 = time.perf_counter()
    carry, keep = drive(carry, periods, total - periods)
    jax.block_until_ready((carry, keep))
    out["run_" + ("stages" if part == "parallel" else "step")] = time.perf_counter() - t0
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenario", default="scenarios/paper_3r4t.toml")
    ap.add_argument("--kind", default="sfim", help="program kind: none, sfim, pfim or all")
    ap.add_argument("--batch", type=int, default=1)
    ap.add_argument("--periods", type=int, default=6, help="control periods per step call")
    ap.add_argument("--steps", type=int, default=600, help="filter steps of the timed run")
    ap.add_argument("--part", choices=PARTS, help=argparse.SUPPRESS)  # one child process
    args = ap.parse_args(argv)
    conf = (args.scenario, args.kind, args.batch, args.periods, args.steps)
    if args.part:
        print(json.dumps(measure(*conf, args.part)))
        return 0
    res: dict = {}
    for part in PARTS:
        env = dict(os.environ, MJX_RADAR_CACHE_DIR=tempfile.mkdtemp(prefix="bench_stages_"))
        cmd = [sys.executable, __file__, "--part", part, "--scenario", args.scenario, "--kind",
               args.kind, "--batch", str(args.batch), "--periods", str(args.periods),
               "--steps", str(args.steps)]  # fmt: skip
        done = subprocess.run(cmd, capture_output=True, text=True, env=env)
        if done.returncode:
            print(done.stderr.strip().splitlines()[-1], file=sys.stderr)
            return 1
        res.update(json.loads(done.stdout.strip().splitlines()[-1]))
    import jax

    print(f"{args.scenario} kind={args.kind} batch={args.batch} on {jax.devices()[0].device_kind}")
    print(f"{'program':<10}{'ops':>8}{'trace s':>10}{'compile s':>11}")
    for name in ("plan", "period", "step"):
        print(f"{name:<10}{res[f'ops_{name}']:>8}{res[f'trace_{name}']:>10.2f}"
              f"{res[f'compile_{name}']:>11.2f}")  # fmt: skip
    print(f"{'plan||period':<18}{'':>10}{res['compile_parallel']:>11.2f}")
    sim = res["run_stages"] / res["run_step"] - 1.0
    print(f"run of {args.steps} steps: step program {res['run_step']:.2f} s, host-driven stages "
          f"{res['run_stages']:.2f} s ({sim:+.0%})")  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
