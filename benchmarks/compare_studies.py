"""Compares two studies value by value (device-count and chunk-size independence).

Joins ``metrics.parquet`` of both on (scenario, method, trial, step) and prints, per
metric column, how many values differ (exact comparison; NaN equals NaN) and the largest
absolute difference; last line ``differing_values=<total>``. Exit 1 if the studies hold
different trials or any value differs. Usage::

    python benchmarks/compare_studies.py STUDY_A STUDY_B
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd

from mjx_radar.rundir.results import METRIC_COLUMNS

KEYS = ["scenario", "method", "trial", "step"]


def main(a: Path, b: Path) -> int:
    fa, fb = (pd.read_parquet(p / "metrics.parquet") for p in (a, b))
    for f in (fa, fb):
        for k in ("scenario", "method"):
            f[k] = f[k].astype(str)
    fa, fb = (f.sort_values(KEYS).reset_index(drop=True) for f in (fa, fb))
    if not fa[KEYS].equals(fb[KEYS]):
        print(f"different trials or steps: {len(fa)} vs {len(fb)} rows")
        return 1
    total = 0
    for col in METRIC_COLUMNS:
        x, y = fa[col].to_numpy(), fb[col].to_numpy()
        same = (x == y) | (pd.isna(x) & pd.isna(y))
        diff = int((~same).sum())
        total += diff
        gap = np.nanmax(np.abs(x.astype(float) - y.astype(float))) if diff else 0.0
        print(f"{col}: {diff} of {len(x)} differ, max |diff| {gap:.3g}")
    print(f"differing_values={total}")
    return int(total > 0)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    sys.exit(main(Path(sys.argv[1]), Path(sys.argv[2])))
