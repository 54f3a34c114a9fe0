"""``mjx-radar validate`` and ``mjx-radar run``."""

from __future__ import annotations

import argparse
import shutil
import sys
from pathlib import Path

import numpy as np

from mjx_radar.cli.args import check_placement, load_with_overrides, positive_int, seed
from mjx_radar.errors import InputError
from mjx_radar.io.scenario import load_scenario, resolve_path
from mjx_radar.task.method import METHODS


def add_validate_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("scenario", help="scenario TOML file (or bundled name, e.g. smoke)")


def validate_main(args) -> int:
    s = load_scenario(args.scenario)
    check_placement(s, s.seed, 1)
    print(
        f"ok: {s.name}: {s.n_radars} radars, {s.n_targets} targets, {s.timing.steps} steps "
        f"of {s.timing.dt_filter} s, control every {s.timing.dt_control} s, "
        f"{len(s.obstacles)} obstacles"
    )
    return 0


def add_run_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("scenario", help="scenario TOML file (or bundled name, e.g. smoke)")
    p.add_argument("--method", default="ddr-sfim", choices=list(METHODS), help="default ddr-sfim")
    p.add_argument("--seed", type=seed, default=None, help="base seed (default: scenario's)")
    p.add_argument("--steps", type=positive_int("--steps"), default=None, help="filter steps")
    p.add_argument("--trials", type=positive_int("--trials", 100_000), default=1)
    p.add_argument("--out", type=Path, default=None, help="output dir (default runs/NAME_METHOD)")
    p.add_argument(
        "--rollouts",
        choices=("mjx", "analytic"),
        default=None,
        help="planner rollouts: MJX physics (scenario default) or closed-form kinematics",
    )
    p.add_argument("--video", action="store_true", help="render trial 0 to DIR/video.mp4")
    p.add_argument("--force", action="store_true", help="overwrite a complete run in --out")


def prepare(args, default_out: str):
    """Loads the scenario with the command-line overrides and checks the output dir."""
    s, steps = load_with_overrides(args.scenario, getattr(args, "rollouts", None), args.steps)
    seed = s.seed if args.seed is None else args.seed
    out = args.out or Path("runs") / default_out.format(name=s.name)
    if (out / "run.json").exists() and not getattr(args, "force", False):
        raise InputError(f"--out = {str(out)!r}: holds a complete run; pass --force or another dir")
    return s, steps, seed, out


def run_main(args) -> int:
    from tqdm import tqdm

    from mjx_radar.estimation.sensing import noise_constant
    from mjx_radar.io import results
    from mjx_radar.simulation import runner

    s, steps, seed, out = prepare(args, "{name}_" + args.method)
    check_placement(s, seed, args.trials)
    trials = np.arange(args.trials)
    print(
        f"{s.name}: {args.method}, {args.trials} trial(s) x {steps} steps, seed {seed}, "
        f"{s.mpc.rollout} rollouts (first call compiles)",
        file=sys.stderr,
    )
    with tqdm(total=steps, unit="step", desc="closed loop", file=sys.stderr) as bar:
        res = runner.run_trials(
            s, args.method, seed, trials, steps, progress=bar.update,
            phase=lambda p: bar.set_description_str(p),
        )  # fmt: skip
    dt = s.timing.dt_filter
    time_s = dt * np.arange(1, steps + 1)
    frame = results.metrics_frame(s.name, args.method, trials, time_s, res)
    control_hz = res["control_hz"]
    out.mkdir(parents=True, exist_ok=True)
    (out / "run.json").unlink(missing_ok=True)  # an overwritten run is incomplete until the end
    results.write_parquet(out / "metrics.parquet", frame)
    traj = {k: res[k] for k in ("target", "mean", "cov_diag", "radar", "control", "plan_xy")}
    traj |= {k: res[k] for k in ("sample_xy", "sample_weight", "sample_cost")}
    results.write_npz(out / "trajectories.npz", traj | {"time_s": time_s})
    src = resolve_path(args.scenario)
    results.atomic_write(out / "scenario.toml", lambda tmp: shutil.copyfile(src, tmp))
    meta = {
        "scenario": s.name,
        "scenario_file": str(src),
        "method": args.method,
        "seed": seed,
        "trials": args.trials,
        "steps": steps,
        "dt_filter": dt,
        "dt_control": s.timing.dt_control,
        "n_radars": s.n_radars,
        "n_targets": s.n_targets,
        "r2t": s.mpc.r2t,
        "r2r": s.mpc.r2r,
        "rollout": s.mpc.rollout,
        "noise_constant": noise_constant(s.radar_eq, s.n_targets),
        "wall_s": res["wall_s"],
        "compile_s": res["compile_s"],
        "precision": args.precision,
        "sim_s": res["sim_s"],
        "control_hz": control_hz,
    }
    results.write_json(out / "run.json", meta)
    rmse = float(np.mean(res["rmse_pos"]))
    print(
        f"mean position RMSE {rmse:.3f} m (final step {np.mean(res['rmse_pos'][:, -1]):.3f} m), "
        f"PCRLB {np.mean(res['crlb_pos']):.3f} m; control rate {control_hz:.1f} Hz for the "
        f"batch of {args.trials} (real time: {1 / s.timing.dt_control:g} Hz), "
        f"compile {res['compile_s']:.1f} s, simulation {res['sim_s']:.1f} s; results in {out}"
    )
    if args.video:
        from mjx_radar.viz import render

        render.render_run(out, trial=0, out_path=out / "video.mp4")
    return 0
