"""Time one MPPI control call at paper settings (issue 15).

3 radars / 4 targets, 200 samples, 5 iterations, horizon 15, MJX rollouts
(``--rollouts analytic`` for the closed-form kinematics). For every method and
rollout unroll asked for, prints the compile time and the per-call times after
warm-up; the last line per combination is ``mppi_call_s=<median>``.

    python benchmarks/bench_mppi.py [--scenario paper_3r4t] [--methods ddr-sfim,ddr-pfim]
        [--unroll 1,15] [--calls 20] [--step fused,mjx] [--batch B]
        [--matmul-precision pinned|default] [--planner-precision LEVEL] [--gc on|off|freeze]

``--batch B`` times B independent calls vmapped together (a study chunk's throughput).

``--step`` picks the physics step of the MJX rollouts: ``fused`` (the default, one
fused expression built from the compiled model, :mod:`mjx_radar.physics.fused_step`)
or ``mjx`` (MJX's kinematics / transmission / actuation / solve stages).
``--unroll`` sets how many horizon steps one loop iteration of the rollout holds
(``rollout.ROLLOUT_UNROLL``, default 1). ``--matmul-precision default`` un-pins every dot
(JAX's default: TF32 on Ampere+ GPUs, as before issue 26), ``--planner-precision``
relaxes only the MPPI sampling and rollouts (:data:`mjx_radar.precision.PLANNER`):
the cost of the pin (docs/scaling.md, "Precision on GPUs").
"""

from __future__ import annotations

import argparse
import dataclasses
import gc
import time

import jax
import jax.numpy as jnp
import numpy as np

from mjx_radar import precision
from mjx_radar.control import mppi
from mjx_radar.env.placement import initial_conditions, layout_of
from mjx_radar.env.streams import trial_streams
from mjx_radar.physics import plant as plant_module
from mjx_radar.physics import rollout as physics
from mjx_radar.scenario.reader import load_scenario
from mjx_radar.task import task as task_module
from mjx_radar.task.planner import make_planner
from mjx_radar.task.task import build


def bench(s, method: str, calls: int, batch: int = 0) -> float:
    n = s.n_radars
    task, params = build(s, method)
    init = initial_conditions(layout_of(task), params, trial_streams(params.seed, 0))
    plan = make_planner(task)

    def one(radar_state, mean, cov, u, key):
        res, _ = plan(radar_state, mean, cov, u, key, params)
        return res.mean[0], mppi.shift(res.mean)

    # batch > 0: that many independent calls vmapped (a study chunk's throughput)
    control = jax.jit(jax.vmap(one, (None, None, None, 0, 0)) if batch else one)
    u = jnp.zeros((s.mpc.horizon, 2 * n))

    def keys(i):
        return jax.random.split(jax.random.PRNGKey(i), batch) if batch else jax.random.PRNGKey(i)

    u = jnp.zeros((batch, *u.shape)) if batch else u
    args_ = (init.radar_state, init.mean, init.cov)
    t0 = time.perf_counter()
    jax.block_until_ready(control(*args_, u, keys(0)))
    compile_s = time.perf_counter() - t0
    if PROFILE_DIR:  # a perfetto trace of 3 calls (kernel names and durations)
        with jax.profiler.trace(f"{PROFILE_DIR}/{method}", create_perfetto_trace=True):
            for i in range(3):
                _, u = jax.block_until_ready(control(*args_, u, keys(i + 1000)))
    times, gc_in_call = [], []
    collections: list[float] = []  # seconds of each garbage collection (gc.callbacks)
    started = [0.0]

    def on_gc(phase, info):
        if phase == "start":
            started[0] = time.perf_counter()
        else:
            collections.append(time.perf_counter() - started[0])

    if GC == "freeze":  # everything alive now (JAX, the program) never scanned again
        gc.collect()
        gc.freeze()
    elif GC == "off":
        gc.disable()
    gc.callbacks.append(on_gc)
    for i in range(calls):
        n_before = len(collections)
        t0 = time.perf_counter()
        _, u = jax.block_until_ready(control(*args_, u, keys(i + 1)))
        times.append(time.perf_counter() - t0)
        gc_in_call.append(sum(collections[n_before:]))
    gc.callbacks.remove(on_gc)
    gc.enable()
    gc.unfreeze()
    t = np.array(times)
    slow = np.argsort(t)[::-1][:3]
    worst = ", ".join(f"#{j}: {t[j] * 1e3:.2f} ms (gc {gc_in_call[j] * 1e3:.2f} ms)" for j in slow)
    print(
        f"gc={GC}: {len(collections)} collections during the calls, "
        f"{sum(collections) * 1e3:.1f} ms in all; slowest calls {worst}"
    )
    unroll = physics.ROLLOUT_UNROLL
    print(
        f"{s.name} {method} rollouts={s.mpc.rollout} step={_step_kind()} unroll={unroll} "
        f"samples={s.mppi.samples} batch={batch or 1} "
        f"iterations={s.mppi.iterations} horizon={s.mpc.horizon} {precision.describe()} "
        f"on {jax.devices()[0].device_kind}: "
        f"compile+first {compile_s:.1f} s; min {t.min() * 1e3:.2f} ms, median "
        f"{np.median(t) * 1e3:.2f} ms, max {t.max() * 1e3:.2f} ms over {len(t)} calls"
    )
    print(f"mppi_call_s={np.median(t):.4f}", flush=True)
    return float(np.median(t))


PROFILE_DIR = ""
#: the garbage collector during the timed calls: "on" (Python's default), "off", or
#: "freeze" (gc.freeze() after the warm-up: the objects alive then are never scanned)
GC = "on"


def _step_kind() -> str:
    return "fused" if plant_module.FUSED_STEP else "mjx-stages"


def _use_step(kind: str) -> None:
    """Builds later plants with the fused step or MJX's stages (clears the plant and
    task caches, which hold the plants)."""
    plant_module.FUSED_STEP = kind == "fused"
    for cached in (plant_module.planner_plant, plant_module.truth_plant,
                   task_module._make_task, task_module._task_of_kind):  # fmt: skip
        cached.cache_clear()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="paper_3r4t")
    ap.add_argument("--methods", "--method", default="ddr-sfim")
    ap.add_argument("--rollouts", choices=("mjx", "analytic"), default="mjx")
    ap.add_argument("--unroll", default="1", help="comma list of rollout unrolls")
    ap.add_argument("--calls", type=int, default=20)
    ap.add_argument("--batch", type=int, default=0, help="vmapped independent calls (0: one)")
    ap.add_argument("--profile", default="", help="write a perfetto trace of 3 calls here")
    ap.add_argument(
        "--step",
        default="fused",
        help="comma list of physics steps: fused (default), mjx (MJX's stages)",
    )
    ap.add_argument("--matmul-precision", choices=("pinned", "default"), default="pinned")
    ap.add_argument("--planner-precision", default=None, help="e.g. high, default")
    ap.add_argument(
        "--gc",
        choices=("on", "off", "freeze"),
        default="on",
        help="Python's garbage collector during the timed calls (off, or freeze the objects "
        "alive after the warm-up); each run reports the collections that fell into a call",
    )
    args = ap.parse_args()
    global GC
    GC = args.gc
    if args.matmul_precision == "default":
        precision.ESTIMATION = precision.PLANNER = "default"
    if args.planner_precision:
        precision.PLANNER = args.planner_precision
    global PROFILE_DIR
    PROFILE_DIR = args.profile
    s = load_scenario(args.scenario)
    s = dataclasses.replace(s, mpc=dataclasses.replace(s.mpc, rollout=args.rollouts))
    for kind in args.step.split(","):
        _use_step(kind)
        for unroll in args.unroll.split(","):
            physics.ROLLOUT_UNROLL = int(unroll)
            for method in args.methods.split(","):
                bench(s, method, args.calls, args.batch)


if __name__ == "__main__":
    main()
