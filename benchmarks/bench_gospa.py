"""Host time of the GOSPA / OSPA / continuity columns (issue 35, docs/tracking_metrics.md).

Random sets of the sizes of a paper study and a swarm (500 trials x 600 steps each):
drones uniform in a 60 m box, tracks at Gaussian errors of the given size; prints the
wall time of :func:`mjx_radar.rundir.results.set_columns` (assignment, GOSPA, OSPA,
continuity) per case.

Usage: ``python benchmarks/bench_gospa.py [--trials 500] [--steps 600]``
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from mjx_radar.rundir.results import set_columns

CASES = ((4, 3.0), (4, 15.0), (32, 3.0))  # (drones = tracks, error sigma [m])


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--trials", type=int, default=500)
    p.add_argument("--steps", type=int, default=600)
    args = p.parse_args()
    rng = np.random.default_rng(0)
    for m, sigma in CASES:
        truth = rng.uniform(0.0, 60.0, (args.trials, args.steps, m, 3)).astype(np.float32)
        track = truth + rng.normal(0.0, sigma, truth.shape).astype(np.float32)
        here = np.ones(truth.shape[:-1], bool)
        sets = {"truth_pos": truth, "present": here, "track_pos": track, "track_exists": here}
        t0 = time.perf_counter()
        cols = set_columns(sets, 50.0, 1.0)
        wall = time.perf_counter() - t0
        print(
            f"{args.trials} x {args.steps} steps, {m} drones / {m} tracks, errors {sigma:g} m: "
            f"{wall:.2f} s (mean GOSPA {cols['gospa'].mean():.2f} m, "
            f"{cols['label_switches'].sum():.0f} label switches)",
            flush=True,
        )


if __name__ == "__main__":
    main()
