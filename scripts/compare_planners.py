"""Which planner wins per millisecond: a study of every planner at several compute budgets.

For each scenario and each budget (rollouts per control call = ``mppi.samples x
mppi.iterations``, the iterations kept, the samples scaled), runs one resumable study
(``mjx_radar.run_study``) of ``METHOD+PLANNER`` for every planner on common random
numbers (one study per planner), then writes ``DIR/planners.csv``: median position RMSE
with its 90 % HDI upper end, the lost-trial rate and the simulation's wall time per
control call of a chunk (``chunk`` trials vmapped together)::

    python scripts/compare_planners.py --out DIR [--scenarios paper_3r4t,hills_4r4t]
        [--planners mppi,ps,cem,grad,hybrid] [--budgets 1000,300,100] [--trials 500]
        [--method ddr-sfim] [--steps N] [--chunk 250]

The per-call figure here is the batch's (a study chunk); ``scripts/bench_mppi.py`` times
one MPPI call alone. docs/planners.md says what was run and what it found.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import pandas as pd


def budget_variant(scenario, rollouts: int):
    """``scenario`` with ``mppi.samples`` set so that samples x iterations ~ ``rollouts``."""
    it = scenario.mppi.iterations
    samples = max(2, round(rollouts / it))
    name = f"{scenario.name}_b{rollouts}"
    return scenario.replace(name=name, mppi={"samples": samples})


def main(argv=None) -> int:
    import mjx_radar

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, required=True)
    p.add_argument("--scenarios", default="paper_3r4t")
    p.add_argument("--planners", default="mppi,ps,cem,grad,hybrid")
    p.add_argument("--budgets", default="1000,300,100")
    p.add_argument("--method", default="ddr-sfim")
    p.add_argument("--trials", type=int, default=500)
    p.add_argument("--steps", type=int, default=None)
    p.add_argument("--chunk", type=int, default=250)
    args = p.parse_args(argv)
    planners = args.planners.split(",")
    rows = []
    for name in args.scenarios.split(","):
        base = mjx_radar.load_scenario(name)
        for budget in (int(b) for b in args.budgets.split(",")):
            s = budget_variant(base, budget)
            steps = args.steps or s.timing.steps
            calls = (steps // s.timing.control_every) * math.ceil(args.trials / args.chunk)
            for planner in planners:  # one study each: its own simulation time
                out = args.out / s.name / planner
                study = mjx_radar.run_study(
                    s,
                    methods=[args.method],
                    planners=[planner],
                    trials=args.trials,
                    chunk=min(args.chunk, args.trials),
                    out=out,
                    steps=args.steps,
                    resume=(out / "study.json").exists(),
                    progress=False,
                )
                r = study.summary().iloc[0]
                meta = json.loads((out / "study.json").read_text())
                rows.append(
                    {
                        "scenario": name,
                        "rollouts": s.mppi.samples * s.mppi.iterations,
                        "planner": planner,
                        "median_rmse_pos": r["median_rmse_pos"],
                        "hdi_hi_pos": r["hdi_hi_pos"],
                        "lost_trial_rate": r["lost_trial_rate"],
                        "ms_per_call_of_batch": 1e3 * meta["sim_s"] / calls,
                    }
                )
    frame = pd.DataFrame(rows)
    args.out.mkdir(parents=True, exist_ok=True)
    frame.to_csv(args.out / "planners.csv", index=False)
    print(frame.to_string(index=False))
    return 0


if __name__ == "__main__":
    sys.exit(main())
