"""Do the closed loop's numbers on the default backend (a GPU) match the CPU's? (issue 26)

Runs the same trials (scenario, methods, trials, steps, seed: common random numbers) on
the default backend and on the CPU backend of the same process, and prints per method
and metric the largest absolute and relative difference between the two, the mean of
each metric and the diverged / lost trial counts on each backend. Exit status 1 when a
difference exceeds the float32-noise thresholds below, 0 when none does, 2 on bad
arguments. Without a GPU both runs are on the CPU and agree exactly (the output says so).

    python benchmarks/check_precision.py [--scenario paper_3r4t] [--methods ccr-sfim,ddr-sfim]
        [--trials 8] [--steps 200] [--seed 0] [--tight-steps 20]
        [--matmul-precision pinned|default] [--planner-precision LEVEL]
        [--save FILE.npz] [--reference cpu|none|FILE.npz] [--perturb]

``--matmul-precision default`` un-pins every dot product (JAX's default: TF32 on Ampere
and later GPUs), i.e. the programs before issue 26: on such a GPU the check fails.
``--planner-precision`` relaxes only :data:`mjx_radar.precision.PLANNER` (MPPI sampling,
planner rollouts), to measure whether that is safe. ``--save`` writes the default
backend's metrics; ``--reference FILE.npz`` compares with such a saved run instead of the
CPU, ``--reference none`` only reports the default backend (large GPU batches, e.g. the
128 x 600 of issue 26, whose CPU run would take too long). ``--perturb`` scales the
initial covariance p0 of the default backend's run by ``1 + 2^-22`` (two float32 ulps; it
also moves the initial estimate by as much): a round-off-sized change that shows, on any
machine, what the closed loop makes of float32 noise (how the thresholds were chosen).

Thresholds (what float32 round-off can explain). Two float32 implementations of the same
program (CPU and GPU: other reduction orders, fused multiply-adds, transcendental
functions) differ by round-off, which the closed loop amplifies. ``--perturb`` measures
that amplification (paper_3r4t, 8 trials x 200 steps, CPU, docs/scaling.md): a 2-ulp
change of p0 moved the filter alone by up to 2e-4 (relative, all steps) and the planned
methods by up to 2e-3 in their first 40 steps. The thresholds are 10-100x those. On an
H100 the pinned programs stayed within 6e-4 of the CPU (filter alone, all steps; every
method's first 20 steps), TF32 (``--matmul-precision default``) missed by up to 0.38:

* ``stationary`` (always run first): the filter alone. With the radars parked there is no
  discrete choice to flip (round-off stays round-off, amplified), so rmse_pos, crlb_pos
  and nees must agree within :data:`FILTER_REL` (relative) over all steps, and lost /
  diverged exactly.
* every method, the first ``--tight-steps`` steps: within :data:`TIGHT_REL`. Later the
  planner's discrete choices (the elite set of MPPI's cross-entropy weights) flip on
  round-off and a trial's trajectory drifts apart as any chaotic system's would, so:
* every method, all steps: only the distribution: the mean over trials and steps of
  rmse_pos and crlb_pos within :data:`DIST_REL`, and the diverged-trial counts within
  ``max(1, DIVERGED_FRAC * trials)`` of each other.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import sys
import time

os.environ.setdefault("MJX_RADAR_EXPORT", "0")  # compile each backend's own trace

import jax  # noqa: E402
import numpy as np  # noqa: E402

from mjx_radar import precision  # noqa: E402
from mjx_radar.engine import runner  # noqa: E402
from mjx_radar.engine.run_spec import run_spec
from mjx_radar.scenario.reader import ScenarioError, load_scenario  # noqa: E402
from mjx_radar.task.method import parse_method  # noqa: E402

CONTINUOUS = ("rmse_pos", "crlb_pos", "nees")
FLAGS = ("lost", "diverged")
FILTER_REL = 2e-2  # stationary: all steps
TIGHT_REL = 2e-2  # planned methods: the first --tight-steps steps
DIST_REL = 0.10  # planned methods: mean over trials and steps
DIVERGED_FRAC = 0.05  # planned methods: diverged trials
LEVELS = ("highest", "float32", "high", "tensorfloat32", "default", "bfloat16")


def run(scenario, methods, trials, steps, seed, device) -> dict:
    """``{method: {metric: [T, K]}}`` and ``{method: sim_s}`` on one device."""
    mesh = runner.device_mesh([device])
    out, secs = {}, {}
    for method in methods:
        res = runner.run_trials(run_spec(scenario), method, seed, np.arange(trials), steps,
                                full=False, mesh=mesh)  # fmt: skip
        out[method] = {k: np.asarray(res[k], np.float64) for k in CONTINUOUS + FLAGS}
        secs[method] = (res["compile_s"], res["sim_s"])
        print(f"  {device.platform}:{device.id} {method}: compile {res['compile_s']:.1f} s, "
              f"closed loop {res['sim_s']:.2f} s", flush=True)  # fmt: skip
    return {"metrics": out, "seconds": secs}


def rel_diff(a, b):
    """Largest ``|a - b| / max(|a|, |b|)`` (0 where both are 0 or equal, inf at a NaN)."""
    if a.size == 0:
        return 0.0
    same = (a == b) | (np.isnan(a) & np.isnan(b))
    scale = np.maximum(np.abs(a), np.abs(b))
    r = np.where(same, 0.0, np.abs(a - b) / np.where(scale > 0, scale, 1.0))
    return float(np.nan_to_num(r, nan=np.inf).max())


def abs_diff(a, b):
    if a.size == 0:
        return 0.0
    same = (a == b) | (np.isnan(a) & np.isnan(b))
    return float(np.nan_to_num(np.where(same, 0.0, np.abs(a - b)), nan=np.inf).max())


def compare(method, dev, ref, tight, trials) -> list[str]:
    """Prints the comparison of one method; returns the failed checks."""
    fails = []
    window = slice(None) if method == "stationary" else slice(0, tight)
    limit = FILTER_REL if method == "stationary" else TIGHT_REL
    span = "all steps" if method == "stationary" else f"first {tight} steps"
    print(f"\n{method}: metric | max |diff| all steps | max rel diff all steps | "
          f"max rel diff {span} (limit {limit:g}) | mean dev / ref")  # fmt: skip
    for k in CONTINUOUS + FLAGS:
        a, b = dev[k], ref[k]
        r_win = rel_diff(a[:, window], b[:, window])
        ma, mb = np.nanmean(a), np.nanmean(b)
        print(f"  {k:9s} {abs_diff(a, b):12.4g} {rel_diff(a, b):12.4g} {r_win:12.4g}"
              f"   {ma:.6g} / {mb:.6g}")  # fmt: skip
        if k in FLAGS and r_win > 0:
            fails.append(f"{method}: {k} differs in the {span}")
        elif k in CONTINUOUS and r_win > limit:
            fails.append(f"{method}: {k} rel diff {r_win:.3g} > {limit:g} in the {span}")
        if k in ("rmse_pos", "crlb_pos") and method != "stationary":
            d = abs(ma - mb) / max(abs(ma), abs(mb), 1e-30)
            if d > DIST_REL:
                fails.append(f"{method}: mean {k} differs by {d:.1%} > {DIST_REL:.0%}")
    div = [int(np.any(x["diverged"] > 0, axis=1).sum()) for x in (dev, ref)]
    lost = [int(np.any(x["lost"] > 0, axis=1).sum()) for x in (dev, ref)]
    print(f"  trials diverged: {div[0]} (dev) vs {div[1]} (ref); lost track: {lost[0]} vs "
          f"{lost[1]} (of {trials})")  # fmt: skip
    allowed = max(1, math.floor(DIVERGED_FRAC * trials))
    if abs(div[0] - div[1]) > allowed:
        fails.append(f"{method}: diverged trials {div[0]} vs {div[1]} (allowed +-{allowed})")
    return fails


def save(path, meta, metrics) -> None:
    arrays = {f"{m}/{k}": v for m, d in metrics.items() for k, v in d.items()}
    np.savez_compressed(path, meta=np.asarray(repr(meta)), **arrays)


def load(path, meta, methods) -> dict:
    with np.load(path) as z:
        if str(z["meta"]) != repr(meta):
            raise SystemExit(f"--reference {path}: other settings {z['meta']} (want {meta})")
        return {m: {k: z[f"{m}/{k}"] for k in CONTINUOUS + FLAGS} for m in methods}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="paper_3r4t")
    ap.add_argument("--methods", default="ccr-sfim,ddr-sfim", help="comma list")
    ap.add_argument("--trials", type=int, default=8)
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--tight-steps", type=int, default=20)
    ap.add_argument("--matmul-precision", choices=("pinned", "default"), default="pinned")
    ap.add_argument("--planner-precision", choices=LEVELS, default=None)
    ap.add_argument("--save", default=None, help="write the default backend's metrics (.npz)")
    ap.add_argument("--reference", default="cpu", help="cpu | none | a --save file")
    ap.add_argument("--perturb", action="store_true", help="p0 * (1 + 2^-22) on the default")
    args = ap.parse_args()
    try:
        scenario = load_scenario(args.scenario)
        methods = ["stationary"] + [m for m in args.methods.split(",") if m != "stationary"]
        for m in methods:
            parse_method(m)
    except (ScenarioError, ValueError, KeyError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    if args.matmul_precision == "default":
        precision.ESTIMATION = precision.PLANNER = "default"
    if args.planner_precision:
        precision.PLANNER = args.planner_precision
    dev, cpu = jax.devices()[0], jax.devices("cpu")[0]
    x64 = bool(jax.config.jax_enable_x64)
    meta = (scenario.name, methods, args.trials, args.steps, args.seed)
    print(f"{scenario.name}: {', '.join(methods)}; {args.trials} trials x {args.steps} steps, "
          f"seed {args.seed}; {'float64' if x64 else 'float32'}; matmul precision "
          f"{precision.describe()}")  # fmt: skip
    t0 = time.perf_counter()
    print(f"default backend: {dev.platform} ({dev.device_kind})")
    dev_scenario = scenario
    if args.perturb:
        dev_scenario = dataclasses.replace(scenario, p0=scenario.p0 * (1 + 2.0**-22))
    got = run(dev_scenario, methods, args.trials, args.steps, args.seed, dev)
    if args.save:
        save(args.save, meta, got["metrics"])
    if args.reference == "none":
        for m in methods:
            x = got["metrics"][m]
            div, lost = (int(np.any(x[k] > 0, axis=1).sum()) for k in FLAGS)
            print(f"{m}: mean rmse_pos {np.nanmean(x['rmse_pos']):.4g} m, crlb_pos "
                  f"{np.nanmean(x['crlb_pos']):.4g} m, nees {np.nanmean(x['nees']):.4g}; "
                  f"{div} diverged, {lost} lost of {args.trials} trials")  # fmt: skip
        return 0
    if args.reference != "cpu":
        ref, ref_name = {"metrics": load(args.reference, meta, methods)}, args.reference
    else:
        print(f"reference: cpu ({cpu.device_kind})")
        ref, ref_name = run(scenario, methods, args.trials, args.steps, args.seed, cpu), "cpu"
    same = dev.platform == "cpu" and args.reference == "cpu" and not args.perturb
    note = ": no GPU here, so CPU vs CPU -- every difference must be 0" if same else ""
    print(f"\n{dev.platform} (dev) vs {ref_name} (ref){note}")
    fails = []
    for m in methods:
        fails += compare(m, got["metrics"][m], ref["metrics"][m], args.tight_steps, args.trials)
    if same and any(
        abs_diff(got["metrics"][m][k], ref["metrics"][m][k]) > 0
        for m in methods for k in CONTINUOUS + FLAGS
    ):  # fmt: skip
        fails.append("CPU vs CPU: the same program gave different numbers")
    print(f"\n{len(fails)} check(s) failed ({time.perf_counter() - t0:.0f} s)")
    for f in fails:
        print(f"  FAIL {f}")
    return 1 if fails else 0


if __name__ == "__main__":
    sys.exit(main())
