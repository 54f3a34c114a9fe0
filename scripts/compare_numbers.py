"""A refactor keeps the numbers: every bundled scenario x method from two source trees.

Runs ``mjx-radar run SCENARIO --method M --trials T --steps K --seed S`` with the package
of each tree (``PYTHONPATH=TREE``), several runs at a time, then compares the
``metrics.parquet`` files column by column (identical, or the largest relative
difference of each differing column)::

    python scripts/compare_numbers.py --base OLD_TREE --new . --out DIR [--jobs 8]
        [--trials 2] [--steps 40] [--seed 7] [--scenarios a,b] [--methods m,n]

Each tree keeps its own compilation cache (``DIR/TREE_NAME/.cache``); a run already in
``DIR`` is not run again. Exit 1 if any pair differs or a run failed.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor, as_completed
from pathlib import Path

import numpy as np
import pandas as pd

METHODS = ("stationary", "ccr-sfim", "ccr-pfim", "ddr-sfim", "ddr-pfim")


def run_one(tree: Path, out: Path, scenario: str, method: str, args) -> str:
    d = out / scenario / method
    if (d / "run.json").exists():
        return "kept"
    cmd = [sys.executable, "-m", "mjx_radar", "run", str(tree / "scenarios" / f"{scenario}.toml"),
           "--method", method, "--trials", str(args.trials), "--steps", str(args.steps),
           "--seed", str(args.seed), "--out", str(d), "--force", "--keep-diverged",
           "--cache-dir", str(out / ".cache")]  # fmt: skip
    path = os.pathsep.join([str(tree), os.environ.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    env = dict(os.environ, PYTHONPATH=path)
    p = subprocess.run(cmd, cwd=tree, env=env, capture_output=True, text=True)
    if p.returncode not in (0, 1):
        return f"failed ({p.returncode}): {p.stderr.strip().splitlines()[-1:]}"
    return "ran"


def compare(a: Path, b: Path) -> str:
    x, y = pd.read_parquet(a), pd.read_parquet(b)
    if list(x.columns) != list(y.columns) or len(x) != len(y):
        return "DIFF columns or rows"
    worst = []
    for c in x.columns:
        if x[c].dtype.kind in "fiub":
            u, v = x[c].to_numpy(float), y[c].to_numpy(float)
            if not np.array_equal(u, v, equal_nan=True):
                rel = np.nanmax(np.abs(u - v) / np.maximum(np.abs(u), 1e-12))
                worst.append(f"{c}:{rel:.1e}")
        elif not x[c].equals(y[c]):
            worst.append(c)
    return "identical" if not worst else "DIFF " + " ".join(worst)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--base", type=Path, required=True)
    p.add_argument("--new", type=Path, default=Path("."))
    p.add_argument("--out", type=Path, required=True)
    p.add_argument("--jobs", type=int, default=max(1, (os.cpu_count() or 2) // 2))
    p.add_argument("--trials", type=int, default=2)
    p.add_argument("--steps", type=int, default=40)
    p.add_argument("--seed", type=int, default=7)
    p.add_argument("--scenarios", default=None)
    p.add_argument("--methods", default=",".join(METHODS))
    args = p.parse_args(argv)
    names = args.scenarios.split(",") if args.scenarios else sorted(
        f.stem for f in (args.new / "scenarios").glob("*.toml"))  # fmt: skip
    methods = args.methods.split(",")
    trees = {"base": args.base.resolve(), "new": args.new.resolve()}
    bad = 0

    def pair(s_m):  # both trees' runs of one scenario and method, then their comparison
        s, m = s_m
        status = {k: run_one(t, args.out / k, s, m, args) for k, t in trees.items()}
        failed = [f"{k} {v}" for k, v in status.items() if v.startswith("failed")]
        if failed:
            return f"{s}/{m}: " + "; ".join(failed)
        fa, fb = (args.out / k / s / m / "metrics.parquet" for k in trees)
        return f"{s}/{m}: {compare(fa, fb)}"

    # the largest scenarios first (their compilations take longest), each line as soon as
    # its pair is done
    names.sort(key=lambda n: (not n.startswith("swarm"), n))
    with ThreadPoolExecutor(args.jobs) as pool:
        futures = [pool.submit(pair, (s, m)) for s in names for m in methods]
        for fut in as_completed(futures):
            line = fut.result()
            print(line, flush=True)
            bad += not line.endswith("identical")
    print(f"{bad} differ or failed")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
