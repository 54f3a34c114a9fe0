"""Compact digest of a study for analysis elsewhere: per trial and per step summaries.

Writes ``OUT/trials.csv`` (scenario, method, trial, mean rmse_pos, mean rmse_pos over the
last half, ever lost, lost steps, diverged steps) and ``OUT/steps.csv`` (scenario, method,
step, mean / median / RMS RMSE, RMS PCRLB, trials lost) and ``OUT/columns.csv`` (scenario,
method: the mean over trials and steps of every numeric metric column, e.g. detections,
false alarms, visible pairs, targets present). Usage::

    python benchmarks/studies/study_digest.py STUDY_DIR OUT_DIR
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd


def main(study: Path, out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    f = pd.read_parquet(study / "metrics.parquet")
    half = f["step"] > f["step"].max() / 2
    g = f.groupby(["scenario", "method", "trial"], observed=True)
    trials = pd.DataFrame(
        {
            "rmse_mean": g["rmse_pos"].mean(),
            "rmse_late": f[half]
            .groupby(["scenario", "method", "trial"], observed=True)["rmse_pos"]
            .mean(),
            "ever_lost": g["lost"].max(),
            "lost_steps": g["lost"].sum(),
            "diverged_steps": g["diverged"].sum(),
        }
    ).reset_index()
    trials.to_csv(out / "trials.csv", index=False)
    s = f.groupby(["scenario", "method", "step"], observed=True)
    steps = pd.DataFrame(
        {
            "mean": s["rmse_pos"].mean(),
            "median": s["rmse_pos"].median(),
            "rms": np.sqrt(s["rmse_pos"].apply(lambda x: np.mean(x**2))),
            "crlb_rms": np.sqrt(s["crlb_pos"].apply(lambda x: np.mean(x**2))),
            "lost": s["lost"].sum(),
        }
    ).reset_index()
    steps.to_csv(out / "steps.csv", index=False)
    numeric = [
        c for c in f.columns if c not in ("trial", "step") and pd.api.types.is_numeric_dtype(f[c])
    ]
    f.groupby(["scenario", "method"], observed=True)[numeric].mean().reset_index().to_csv(
        out / "columns.csv", index=False
    )


if __name__ == "__main__":
    main(Path(sys.argv[1]), Path(sys.argv[2]))
