"""Pd-aware planning vs Pd-blind planning vs stationary radars where detection limits bind.

Issue 35, part 5 (docs/detection.md). Runs two resumable studies on one scenario
(default the bundled ``faint_3r4t``: Swerling I detection within ~250 m, no clutter):

* ``OUT/pd_aware``: the scenario as it is (``[detection] planner = true``: the
  information costs use the expected FIM Pd·J) with ``stationary`` and ``ddr-sfim``;
* ``OUT/pd_blind``: the same scenario with ``planner = false`` (the paper's costs; same
  world, same random draws) with ``ddr-sfim``;

then prints, per arm: lost trials, mean and median position RMSE, mean GOSPA (and its
missed part), detections per step, and the paired difference of the per-trial mean
GOSPA and RMSE, Pd-aware minus Pd-blind (common random numbers: trial i sees the same
drones, noise and detection draws in both), with a 95% interval (mean ± 1.96 SE).
Everything is written to ``OUT/comparison.csv``. Killed at any point, the same command
resumes (each study resumes chunk by chunk; a finished study is read back).

Usage::

    python benchmarks/studies/compare_pd_planning.py --trials 8 --steps 200 --chunk 8 \\
        --out /tmp/pd  # CPU
    python benchmarks/studies/compare_pd_planning.py --trials 200 --chunk 200 \\
        --out runs/pd_planning  # GPU
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[2]


def parse(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scenario", default=str(ROOT / "scenarios" / "faint_3r4t.toml"))
    p.add_argument("--trials", type=int, default=200)
    p.add_argument("--steps", type=int, default=None, help="default: the scenario's")
    p.add_argument("--chunk", type=int, default=50, help="trials per device per call")
    p.add_argument("--out", type=Path, default=Path("runs/pd_planning"))
    p.add_argument("--rollouts", choices=("mjx", "analytic"), default=None)
    return p.parse_args(argv)


def arms(scenario) -> list[tuple[str, object, list[str]]]:
    """``(study folder, scenario, methods)`` of the two studies."""
    aware = scenario.replace(detection={"planner": True})
    blind = scenario.replace(name=f"{scenario.name}_pd_blind", detection={"planner": False})
    return [("pd_aware", aware, ["stationary", "ddr-sfim"]), ("pd_blind", blind, ["ddr-sfim"])]


def per_trial(frame: pd.DataFrame) -> pd.DataFrame:
    """One row per trial: mean GOSPA, mean RMSE, lost (any step), detections per step."""
    g = frame.groupby("trial")
    return pd.DataFrame(
        {
            "gospa": g["gospa"].mean(),
            "rmse": g["rmse_pos"].mean(),
            "lost": g["lost"].max() > 0,
            "detections": g["detections"].mean(),
        }
    )


def row(label: str, frame: pd.DataFrame) -> dict:
    """The headline numbers of one arm (definitions: docs/statistics.md)."""
    from mjx_radar.study import metrics

    summary = metrics.summary(metrics.per_step(frame), frame).iloc[0]
    t = per_trial(frame)
    return {
        "arm": label,
        "trials": len(t),
        "lost_trials": int(t["lost"].sum()),
        "mean_rmse_pos": float(summary["mean_rmse_pos"]),
        "median_rmse_pos": float(summary["median_rmse_pos"]),
        "mean_gospa": float(summary["mean_gospa"]),
        "mean_gospa_missed": float(summary["mean_gospa_missed"]),
        "detections_per_step": float(frame["detections"].mean()),
    }


def paired(a: pd.DataFrame, b: pd.DataFrame, column: str) -> tuple[float, float, float]:
    """Mean of the paired per-trial differences a − b and its 95% interval."""
    d = (per_trial(a)[column] - per_trial(b)[column]).dropna().to_numpy()
    if len(d) < 2:
        return float(d.mean()) if len(d) else float("nan"), float("nan"), float("nan")
    half = 1.96 * d.std(ddof=1) / np.sqrt(len(d))
    return float(d.mean()), float(d.mean() - half), float(d.mean() + half)


def show(rows: list[dict]) -> None:
    head = "| arm | trials | lost | mean RMSE [m] | median RMSE [m] | mean GOSPA [m] "
    head += "| GOSPA missed [m] | detections / step |"
    print(head + "\n|" + "---|" * 8, flush=True)
    for r in rows:
        print(
            f"| {r['arm']} | {r['trials']} | {r['lost_trials']} | {r['mean_rmse_pos']:.2f} "
            f"| {r['median_rmse_pos']:.2f} | {r['mean_gospa']:.2f} | "
            f"{r['mean_gospa_missed']:.2f} | {r['detections_per_step']:.2f} |",
            flush=True,
        )


def main(argv=None) -> int:
    import mjx_radar

    args = parse(argv)
    scenario = mjx_radar.load_scenario(args.scenario)
    rows, frames = [], {}
    for folder, s, methods in arms(scenario):
        out = args.out / folder
        print(f"== {folder}: {s.name}, {', '.join(methods)}, {args.trials} trials -> {out}")
        study = mjx_radar.run_study(
            s,
            methods=methods,
            trials=args.trials,
            chunk=min(args.chunk, args.trials),
            out=out,
            steps=args.steps,
            resume=True,
            rollouts=args.rollouts,
        )
        for method in methods:
            frame = study.metrics[study.metrics["method"].astype(str) == method]
            label = "stationary" if method == "stationary" else f"{method}, {folder}"
            frames[label] = frame
            rows.append(row(label, frame))
            show(rows[-1:])
    print(f"\n{scenario.name}, {args.trials} trials:", flush=True)
    show(rows)
    aware, blind = frames["ddr-sfim, pd_aware"], frames["ddr-sfim, pd_blind"]
    for column, unit in (("gospa", "m"), ("rmse", "m"), ("detections", "")):
        mean, lo, hi = paired(aware, blind, column)
        interval = f"95% interval {lo:+.3f} .. {hi:+.3f}"
        print(f"Pd-aware − Pd-blind, per-trial mean {column}: {mean:+.3f} {unit} ({interval})")
    pd.DataFrame(rows).to_csv(args.out / "comparison.csv", index=False)
    print(f"written: {args.out / 'comparison.csv'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
