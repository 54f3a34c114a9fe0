"""The Pareto figure of the planner comparison: median RMSE vs milliseconds per control call.

Joins ``planners.csv`` (``scripts/compare_planners.py``: RMSE per scenario, budget and
planner) with one or more per-call timing files (``benchmarks/bench_planners.py --csv``,
e.g. one from the H100 and one from the 2-core CPU), draws one panel per scenario and
device (x: median ms per control call, log scale; y: median per-trial RMSE with its 90 %
HDI as error bars; one colour per planner, marker size by budget), marks the Pareto
front, and writes the joined table next to the figure::

    python benchmarks/plot_planners.py DIR/planners.csv CALLS.csv [CALLS2.csv ...] --out FIG.png
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import pandas as pd


def pareto(frame: pd.DataFrame, x: str, y: str) -> pd.Series:
    """True for the rows no other row beats on both ``x`` and ``y`` (lower is better)."""
    keep = []
    for _, r in frame.iterrows():
        dominated = ((frame[x] <= r[x]) & (frame[y] < r[y])) | (
            (frame[x] < r[x]) & (frame[y] <= r[y])
        )
        keep.append(not dominated.any())
    return pd.Series(keep, index=frame.index)


def main(argv=None) -> int:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("planners", type=Path)
    p.add_argument("calls", type=Path, nargs="+")
    p.add_argument("--out", type=Path, required=True)
    args = p.parse_args(argv)
    rmse = pd.read_csv(args.planners)
    calls = pd.concat([pd.read_csv(c) for c in args.calls]).rename(columns={"scenario": "base"})
    joined = rmse.merge(calls, on=["base", "rollouts", "planner"])
    if joined.empty:
        print("plot_planners: no (scenario, budget, planner) in both files", file=sys.stderr)
        return 2
    panels = joined.groupby(["base", "device"])
    fig, axes = plt.subplots(1, len(panels), figsize=(5.5 * len(panels), 4.2), squeeze=False)
    colours = {n: f"C{i}" for i, n in enumerate(sorted(joined["planner"].unique()))}
    for ax, ((base, device), g) in zip(axes[0], panels, strict=True):
        g = g.assign(front=pareto(g, "median_ms", "trial_rmse_median"))
        for name, h in g.groupby("planner"):
            yerr = [
                h["trial_rmse_median"] - h["trial_rmse_hdi_lo"],
                h["trial_rmse_hdi_hi"] - h["trial_rmse_median"],
            ]
            ax.errorbar(
                h["median_ms"],
                h["trial_rmse_median"],
                yerr=yerr,
                fmt="none",
                ecolor=colours[name],
                alpha=0.3,
            )
            ax.scatter(
                h["median_ms"],
                h["trial_rmse_median"],
                s=h["rollouts"] / 8 + 10,
                color=colours[name],
                label=name,
                edgecolor="k",
            )
        f = g[g["front"]].sort_values("median_ms")
        ax.plot(f["median_ms"], f["trial_rmse_median"], "k--", lw=1, label="Pareto front")
        ax.set_xscale("log")
        ax.set_xlabel(f"median ms per control call ({device})")
        ax.set_ylabel("median per-trial RMSE [m] (90% HDI)")
        ax.set_title(base)
        ax.legend(fontsize=7)
    fig.tight_layout()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=130)
    joined.to_csv(args.out.with_suffix(".csv"), index=False)
    print(f"wrote {args.out} and {args.out.with_suffix('.csv')}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
