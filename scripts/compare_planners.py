"""Which planner wins per millisecond: a study of every planner at several compute budgets.

For each scenario, one resumable study (``mjx_radar.run_study``: its programs compile
concurrently) of ``METHOD+PLANNER`` for every planner and budget on common random
numbers (same seeds, same trials: only the planner differs). The budget B is rollouts
per control call, the same for all: the sampling planners (mppi, ps, cem, cmaes,
sep-cmaes) run ``mppi.iterations`` rounds of ``B / iterations`` samples; ``grad`` takes
``B / 3`` gradient steps (one step: a forward and a reverse pass, about three
rollouts); ``hybrid`` samples half the budget and polishes with ``B / 6`` steps. Writes
``DIR/planners.csv``: per scenario, budget and planner the paper's time-averaged
median position RMSE and 90 % HDI upper end (``study.summary()``), the per-trial mean
RMSE's median with its 90 % HDI (as arviz 0.x), and the lost-trial rate::

    python scripts/compare_planners.py --out DIR [--scenarios paper_3r4t,hills_4r4t]
        [--planners mppi,ps,cem,grad,hybrid,cmaes] [--budgets 1000,300,100]
        [--trials 500,200] [--method ddr-sfim] [--steps N] [--chunk 500]

``--trials`` gives one count per scenario (or one for all). The ms per control call
comes from ``benchmarks/bench_planners.py`` (one call timed alone); ``benchmarks/plot_planners.py``
draws the Pareto figure from both files. docs/planners.md says what was run and found.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import pandas as pd


def budget_variant(scenario, rollouts: int):
    """``scenario`` at a budget of ``rollouts`` rollout-equivalents per control call."""
    it = scenario.mppi.iterations
    return scenario.replace(
        name=f"{scenario.name}_b{rollouts}",
        mppi={"samples": max(4, round(rollouts / it))},
        planner={
            "gradient_steps": max(1, round(rollouts / 3)),
            "polish_steps": max(1, round(rollouts / 6)),
        },
    )


def per_trial(metrics: pd.DataFrame) -> pd.DataFrame:
    """Median and 90 % HDI of the per-trial time-mean position RMSE, and lost trials."""
    from mjx_radar.study.metrics import hdi

    trial = metrics.groupby(["scenario", "method", "trial"]).agg(
        rmse=("rmse_pos", "mean"), lost=("lost", "max")
    )
    rows = []
    for (sc, m), g in trial.groupby(level=[0, 1]):
        lo, hi = hdi(g["rmse"].to_numpy(), 0.9)
        rows.append(
            {
                "scenario": sc,
                "method": m,
                "trial_rmse_median": float(np.median(g["rmse"])),
                "trial_rmse_hdi_lo": float(lo),
                "trial_rmse_hdi_hi": float(hi),
                "lost_trials": int(g["lost"].sum()),
                "trials": len(g),
            }
        )
    return pd.DataFrame(rows)


def main(argv=None) -> int:
    import mjx_radar

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, required=True)
    p.add_argument("--scenarios", default="paper_3r4t")
    p.add_argument("--planners", default="mppi,ps,cem,grad,hybrid,cmaes")
    p.add_argument("--budgets", default="1000,300,100")
    p.add_argument("--method", default="ddr-sfim")
    p.add_argument("--trials", default="500")
    p.add_argument("--steps", type=int, default=None)
    p.add_argument("--chunk", type=int, default=500)
    args = p.parse_args(argv)
    names = args.scenarios.split(",")
    trials = [int(t) for t in args.trials.split(",")]
    trials = trials * len(names) if len(trials) == 1 else trials
    frames = []
    for name, n in zip(names, trials, strict=True):
        base = mjx_radar.load_scenario(name)
        variants = [budget_variant(base, int(b)) for b in args.budgets.split(",")]
        out = args.out / name
        study = mjx_radar.run_study(
            variants,
            methods=[args.method],
            planners=args.planners.split(","),
            trials=n,
            chunk=min(args.chunk, n),
            out=out,
            steps=args.steps,
            resume=(out / "study.json").exists(),
            progress=False,
        )
        summ = study.summary()[
            ["scenario", "method", "median_rmse_pos", "hdi_hi_pos", "lost_trial_rate"]
        ]
        frame = summ.merge(per_trial(study.metrics), on=["scenario", "method"])
        frame.insert(0, "base", name)
        frame.insert(2, "rollouts", frame["scenario"].str.rsplit("_b", n=1).str[1].astype(int))
        frame.insert(3, "planner", frame["method"].str.partition("+")[2].replace("", "mppi"))
        frames.append(frame)
        pd.concat(frames).to_csv(args.out / "planners.csv", index=False)  # after each scenario
        print(frame.to_string(index=False), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
