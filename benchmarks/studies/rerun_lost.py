"""Reruns the trials a study lost, changed one way, and says which of them then keep track.

For every scenario x method of a finished study (``mjx-radar study``), the trials that
ever lost track are rerun with the same seed and trial indices (common random numbers)
through ``mjx_radar.simulate``, with one change:

* ``--precision float64``: the whole closed loop in x64 (is the loss a float32 artefact?);
* ``--ground-prior``: ``[filter] ground_prior = true`` (are mirror locks avoided?).

Each lost trial is classed by its cause in the study: *diverged* (the filter became
non-finite / not positive definite at some step) or *lost* otherwise (mirror lock or
an error beyond max(5 sigma, 50 m): docs/statistics.md). Prints one table and writes
``OUT.csv`` (one row per rerun trial). Usage::

    python benchmarks/studies/rerun_lost.py STUDY_DIR --precision float64 \\
        --methods ccr-sfim,ccr-pfim \\
        --out runs/lost_f64
    python benchmarks/studies/rerun_lost.py STUDY_DIR --ground-prior --methods ddr-sfim \\
        --out runs/gp
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import pandas as pd


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("study", type=Path)
    p.add_argument("--precision", choices=("float32", "float64"), default="float32")
    p.add_argument("--ground-prior", action="store_true")
    p.add_argument("--methods", default=None, help="comma-separated (default: all in the study)")
    p.add_argument("--max-trials", type=int, default=64, help="per scenario x method")
    p.add_argument("--out", type=Path, required=True, help="CSV path stem")
    args = p.parse_args()
    if args.precision == "float64":
        import jax

        jax.config.update("jax_enable_x64", True)
    import json

    import mjx_radar

    meta = json.loads((args.study / "study.json").read_text())
    frame = pd.read_parquet(args.study / "metrics.parquet")
    methods = args.methods.split(",") if args.methods else meta["methods"]
    rows = []
    for name in meta["scenarios"]:
        s = mjx_radar.load_scenario(args.study / "scenarios" / f"{name}.toml")
        if args.ground_prior:
            s = s.replace(filter={"ground_prior": True})
        steps, seed = meta["steps"][name], meta["seed"][name]
        for method in methods:
            g = frame[(frame["scenario"] == name) & (frame["method"] == method)]
            per = g.groupby("trial").agg(lost=("lost", "max"), diverged=("diverged", "max"),
                                         rmse=("rmse_pos", "mean"))  # fmt: skip
            lost = per[per["lost"] > 0].head(args.max_trials)
            if lost.empty:
                continue
            run = mjx_radar.simulate(s, method, trials=lost.index.to_numpy(), steps=steps,
                                     seed=seed, progress=False)  # fmt: skip
            again = run.metrics.groupby("trial").agg(
                lost=("lost", "max"), diverged=("diverged", "max"), rmse=("rmse_pos", "mean")
            )
            for t, before in lost.iterrows():
                rows.append({"scenario": name, "method": method, "trial": int(t),
                             "cause": "diverged" if before["diverged"] else "lost",
                             "rmse_study": before["rmse"], "lost_rerun": bool(again.loc[t, "lost"]),
                             "diverged_rerun": bool(again.loc[t, "diverged"]),
                             "rmse_rerun": again.loc[t, "rmse"]})  # fmt: skip
            args.out.parent.mkdir(parents=True, exist_ok=True)  # after each group: partial
            pd.DataFrame(rows).to_csv(args.out.with_suffix(".csv"), index=False)
            print(
                f"{name} {method}: {len(lost)} lost trials rerun, "
                f"{int(again['lost'].gt(0).sum())} lost again",
                flush=True,
            )
    table = pd.DataFrame(rows)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    table.to_csv(args.out.with_suffix(".csv"), index=False)
    change = f"precision {args.precision}" + (", ground prior" if args.ground_prior else "")
    print(f"rerun of lost trials with {change}:")
    if table.empty:
        print("no lost trials")
        return 0
    summary = table.groupby(["scenario", "method", "cause"]).agg(
        trials=("trial", "size"), still_lost=("lost_rerun", "sum"),
        diverged_rerun=("diverged_rerun", "sum"), rmse_study=("rmse_study", "median"),
        rmse_rerun=("rmse_rerun", "median"))  # fmt: skip
    print(summary.to_string())
    return 0


if __name__ == "__main__":
    sys.exit(main())
