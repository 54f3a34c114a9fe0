"""How the closed loop's cost grows with the swarm size N = M (issue 15).

Three measurements, each printed as a table and written to ``OUT/scaling.csv``
(rows ``kind,size,variant,samples,value,unit``) with a plot ``OUT/scaling.png``:

* ``loop``: wall time per control step of the closed loop (MPPI + 4 filter steps) for
  N = M in ``--sizes``, one jitted batch of ``--trials`` trials, ``--steps`` filter
  steps, measured by the public runner after its first (compiling) segment; the
  scenarios are ``scripts/make_swarm.py`` layouts (identical to the bundled
  ``scenarios/swarm_*`` files for 8, 16, 32). Real-time factor = dt_control / time.
  On a GPU the peak device memory after each size is reported too (``memory`` rows;
  cumulative over the sizes run so far in the process, so run one size for a clean figure).
* ``filter``: one CKF predict + DDR range update of M targets by N = M radars,
  joint (``ckf`` on the stacked 6M state) vs the per-target bank
  (``filter_bank``, state kept as ``[M, 6]``, ``[M, 6, 6]``); jit, warm, median of
  ``--calls`` calls, for ``--filter-sizes``.
* ``quality``: MPPI quality vs samples for N = M = ``--quality-size``: the objective of
  the optimised plan at the first control step (mean over ``--trials`` initial
  conditions and keys) and the closed loop's position RMSE (mean over trials and the
  last half of ``--steps``) for each of ``--samples``.

Usage (CPU numbers in docs/scaling.md)::

    JAX_PLATFORMS=cpu python benchmarks/bench_scaling.py --sizes 3 8 --steps 40 --trials 1 \\
        --rollouts analytic --samples 50 100 200 --out runs/scaling_cpu

``--skip loop filter quality`` leaves parts out.
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import sys
import tomllib
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

from mjx_radar.engine import runner
from mjx_radar.env import placement
from mjx_radar.env.streams import trial_streams
from mjx_radar.estimation.filters import ckf, filter_bank
from mjx_radar.estimation.sensor import sensing
from mjx_radar.physics import motion
from mjx_radar.scenario.reader import scenario_from_dict
from mjx_radar.scenario.schema import RadarEquation
from mjx_radar.task import objective
from mjx_radar.task.planner import make_planner
from mjx_radar.task.task import build

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))  # make_swarm
from bench_timing import median_seconds  # noqa: E402
from make_swarm import swarm_toml  # noqa: E402

from mjx_radar.engine.run_spec import run_spec


def swarm(n: int, rollouts: str, samples: int | None = None, structure: str = "joint"):
    """The N = M swarm scenario of make_swarm (seed 0) with the given rollouts / samples."""
    s = scenario_from_dict(tomllib.loads(swarm_toml(n, n, 0)))
    mppi = s.mppi if samples is None else dataclasses.replace(s.mppi, samples=samples)
    filt = dataclasses.replace(s.filter, structure=structure)
    mpc = dataclasses.replace(s.mpc, rollout=rollouts)
    return dataclasses.replace(s, mpc=mpc, mppi=mppi, filter=filt)


def run_loop(scenario, method: str, trials: int, steps: int) -> dict:
    """The one call of the public runner (its signature may change: keep it here)."""
    return runner.run_trials(
        run_spec(scenario), method, scenario.seed, np.arange(trials), steps, full=False
    )


def loop_step_s(scenario, method: str, trials: int, steps: int) -> float:
    """Wall seconds per control step of the batch, excluding the compiling segment."""
    return 1.0 / run_loop(scenario, method, trials, steps)["control_hz"]


def filter_times(m: int, calls: int) -> dict:
    """Seconds of one predict + DDR update, joint vs bank, for M targets and N = M radars."""
    rng = np.random.default_rng(m)
    truth = np.c_[rng.uniform(-300, 300, (m, 2)), rng.uniform(40, 80, m), np.zeros((m, 3))]
    radars = jnp.asarray(np.c_[rng.uniform(-400, 400, (m, 2)), np.zeros(m)], jnp.float32)
    c = sensing.noise_constant(RadarEquation(), m)
    z = sensing.sample_ranges(jax.random.PRNGKey(0), radars, jnp.asarray(truth[:, :3]), c)
    mean = jnp.asarray(truth.reshape(-1) + rng.normal(0, 5, 6 * m), jnp.float32)
    cov = 50.0 * jnp.eye(6 * m)
    a, q = motion.cv_transition(0.025, m), motion.cv_process_noise(0.025, 10.0, m)
    a6, q6 = motion.cv_transition(0.025, 1), motion.cv_process_noise(0.025, 10.0, 1)

    @jax.jit
    def joint(mean, cov, z, radars):
        mean, cov = ckf.predict(mean, cov, lambda x: a @ x, q)
        r = lambda zh: sensing.ddr_noise_cov(zh, c)  # noqa: E731
        return ckf.update(mean, cov, z, sensing.range_model(radars), r)

    @jax.jit
    def bank(means, covs, z, radars):
        means, covs = filter_bank.predict_bank(means, covs, a6, q6)
        zb = z.reshape(m, m, 1)
        r = filter_bank.ddr_R(c)
        return filter_bank.update_bank(means, covs, zb, radars, filter_bank.range_pair, r)

    @jax.jit
    def bank_joint_io(mean, cov, z, radars):
        mean, cov = filter_bank.predict_joint(mean, cov, a6, q6)
        return filter_bank.update_ranges(mean, cov, z, radars, filter_bank.ddr_R(c))

    means, covs = filter_bank.joint_to_bank(mean, cov)
    return {
        "joint": median_seconds(joint, mean, cov, z, radars, calls=calls),
        "bank": median_seconds(bank, means, covs, z, radars, calls=calls),
        "bank+conversions": median_seconds(bank_joint_io, mean, cov, z, radars, calls=calls),
    }


def plan_quality(scenario, method: str, trials: int) -> float:
    """Mean objective of the MPPI plan at the first control step over trials' initial states."""
    task, params = build(scenario, method)
    plan = make_planner(task)
    cost_fn = objective.make_objective(task)
    u0 = jnp.zeros((scenario.mpc.horizon, 2 * scenario.n_radars))

    def one(t):
        st = trial_streams(params.seed, t)
        init = placement.initial_conditions(placement.layout_of(task), params, st)
        res, _ = plan(init.radar_state, init.mean, init.cov, u0, st.planner, params)
        ctx = objective.plan_context(task, init.radar_state, init.mean, init.cov)
        return cost_fn(res.mean, ctx, params)[0]

    return float(jnp.mean(jax.jit(jax.vmap(one))(jnp.arange(trials))))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[3, 8, 16, 32], help="N = M")
    ap.add_argument("--filter-sizes", type=int, nargs="+", default=[4, 8, 16, 32])
    ap.add_argument("--samples", type=int, nargs="+", default=[50, 100, 200, 400, 800])
    ap.add_argument("--quality-size", type=int, default=8, help="N = M of the samples curve")
    ap.add_argument("--steps", type=int, default=40, help="filter steps per trial")
    ap.add_argument("--trials", type=int, default=1)
    ap.add_argument("--calls", type=int, default=20, help="filter timing: calls per median")
    ap.add_argument("--method", default="ddr-sfim")
    ap.add_argument("--rollouts", choices=("mjx", "analytic"), default="mjx")
    ap.add_argument("--structure", choices=("joint", "per-target"), default="joint")
    ap.add_argument("--skip", nargs="*", default=[], choices=("loop", "filter", "quality"))
    ap.add_argument("--out", type=Path, default=Path("runs/scaling"))
    args = ap.parse_args(argv)
    for name in ("sizes", "filter_sizes", "samples"):
        if min(getattr(args, name)) < 1:
            print(f"--{name.replace('_', '-')} must be integers >= 1", file=sys.stderr)
            return 2
    if args.steps < 8 or args.steps % 4 or args.trials < 1 or args.calls < 1:
        print("--steps must be a multiple of 4 >= 8; --trials, --calls >= 1", file=sys.stderr)
        return 2
    args.out.mkdir(parents=True, exist_ok=True)
    dev = jax.devices()[0].device_kind
    rows = []  # (kind, size, variant, samples, value, unit)
    print(f"device={dev} method={args.method} rollouts={args.rollouts}")
    if "loop" not in args.skip:
        for n in args.sizes:
            s = swarm(n, args.rollouts, structure=args.structure)
            dt = loop_step_s(s, args.method, args.trials, args.steps)
            rows.append(("loop", n, f"{args.trials} trials", s.mppi.samples, dt, "s/control step"))
            rt = s.timing.dt_control / dt
            peak = _peak_bytes()
            mem = "" if peak is None else f", peak device memory {peak / 2**30:.2f} GiB"
            if peak is not None:
                rows.append(("memory", n, f"{args.trials} trials", s.mppi.samples, peak, "bytes"))
            print(f"loop N=M={n:3d} N*M={n * n:5d}: {dt * 1e3:9.1f} ms/control step, "
                  f"{rt:.3f}x RT{mem}")  # fmt: skip
    if "filter" not in args.skip:
        for m in args.filter_sizes:
            for variant, dt in filter_times(m, args.calls).items():
                rows.append(("filter", m, variant, 0, dt, "s/predict+update"))
                print(f"filter N=M={m:3d} {variant:17s}: {dt * 1e3:9.3f} ms")
    if "quality" not in args.skip:
        for S in args.samples:
            s = swarm(args.quality_size, args.rollouts, S, args.structure)
            j = plan_quality(s, args.method, max(args.trials, 4))
            res = run_loop(s, args.method, args.trials, args.steps)["rmse_pos"]
            rmse = float(np.mean(res[:, res.shape[1] // 2 :]))
            rows += [("quality", args.quality_size, "objective", S, j, "cost")]
            rows += [("quality", args.quality_size, "rmse_pos", S, rmse, "m")]
            print(f"quality N=M={args.quality_size} samples={S:4d}: J={j:.4g} rmse={rmse:.3f} m")
    with open(args.out / "scaling.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["kind", "size", "variant", "samples", "value", "unit", "device"])
        w.writerows([(*r, dev) for r in rows])
    _plot(rows, args.out / "scaling.png", dev)
    print(f"wrote {args.out / 'scaling.csv'} and {args.out / 'scaling.png'}")
    return 0


def _peak_bytes() -> int | None:
    """Peak memory in use on the first device so far (None where unreported, e.g. CPU)."""
    stats = jax.local_devices()[0].memory_stats() or {}
    return stats.get("peak_bytes_in_use")


def _plot(rows, path: Path, dev: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.2))
    for kind, v in sorted({(r[0], r[2]) for r in rows if r[0] in ("loop", "filter")}):
        pts = sorted((r[1] ** 2, r[4]) for r in rows if r[0] == kind and r[2] == v)
        ax1.loglog(*np.array(pts).T, "o-" if kind == "loop" else "s--", label=f"{kind}: {v}")
    ax1.set(xlabel="N·M", ylabel="wall time [s]", title=f"cost vs N·M ({dev})")
    ax1.grid(True, which="both", alpha=0.3)
    if ax1.lines:
        ax1.legend(fontsize=8)
    for v, ax in (("objective", ax2), ("rmse_pos", ax2.twinx())):
        pts = sorted((r[3], r[4]) for r in rows if r[0] == "quality" and r[2] == v)
        if pts:
            ax.semilogx(*np.array(pts).T, "o-" if v == "objective" else "s--", label=v)
            ax.set_ylabel(v)
    ax2.set(xlabel="MPPI samples", title="MPPI quality vs samples")
    ax2.grid(True, alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


if __name__ == "__main__":
    sys.exit(main())
