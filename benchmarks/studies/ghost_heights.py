"""Where a tracker's trials become unmatched: the track errors split into horizontal and height.

Runs one tracker variant of ``compare_trackers.py`` (``mjx_radar.simulate``, common random
numbers: trial i is the same world as in the study) for the given trials and, for each,
finds the first step at which some drone has no track within the GOSPA cutoff
(``gospa_missed > 0``). At that step (the last step for a trial that stays matched) the
tracks are assigned to the drones label-free (the order of least total position error,
over the M! orders) and the worst-placed drone's horizontal and vertical errors, the
filter's height standard deviation for that track, and the closest two drones' distance
are reported, with the lowest track height (a negative one is a track below ground)::

    python benchmarks/studies/ghost_heights.py --variant mht-jpda-1024-settle200to64-gate4-assoc10
        --trials 171,199,39 [--scenario clutter_3r4t] [--method ddr-sfim] [--steps 600]
        [--result ID]
"""

from __future__ import annotations

import argparse
import itertools
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from compare_trackers import known_variant, variant  # noqa: E402

import mjx_radar  # noqa: E402

COLUMNS = [
    "trial",
    "first unmatched step",
    "closest drones [m]",
    "worst drone: horizontal error [m]",
    "worst drone: height error [m]",
    "its track's height std [m]",
    "lowest track height [m]",
    "worst drone's error at the last step [m]",
]


def _assign(est, true):
    """The track order (over the M! orders) of least total position error."""
    m = true.shape[0]
    return min(
        itertools.permutations(range(m)),
        key=lambda p: sum(np.linalg.norm(est[p[t]] - true[t]) for t in range(m)),
    )


def row(trial, first, target, mean, cov_diag):
    """One trial's figures (``target [S, M, 6]``, ``mean``/``cov_diag`` ``[S, 6M]``)."""
    m = target.shape[1]
    k = (first if first else target.shape[0]) - 1
    est, var = mean[k].reshape(m, 6), cov_diag[k].reshape(m, 6)
    true = target[k]
    p = _assign(est[:, :3], true[:, :3])
    err = np.array([est[p[t], :3] - true[t, :3] for t in range(m)])
    worst = int(np.argmax(np.linalg.norm(err, axis=1)))
    sep = min(
        np.linalg.norm(true[a, :3] - true[b, :3]) for a, b in itertools.combinations(range(m), 2)
    )
    last = mean[-1].reshape(m, 6)[:, :3]
    q = _assign(last, target[-1, :, :3])
    final = max(np.linalg.norm(last[q[t]] - target[-1, t, :3]) for t in range(m))
    return [
        int(trial),
        int(first),
        round(float(sep), 1),
        round(float(np.linalg.norm(err[worst, :2])), 1),
        round(float(err[worst, 2]), 1),
        round(float(np.sqrt(var[p[worst], 2])), 2),
        round(float(est[:, 2].min()), 1),
        round(float(final), 1),
    ]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--variant", required=True)
    ap.add_argument("--trials", required=True, help="comma-separated trial indices")
    ap.add_argument("--scenario", default="clutter_3r4t")
    ap.add_argument("--method", default="ddr-sfim")
    ap.add_argument("--steps", type=int, default=600)
    ap.add_argument("--result", default=None, help="write benchmarks/results/ID.json")
    args = ap.parse_args(argv)
    if not known_variant(args.variant):
        ap.error(f"--variant: unknown {args.variant!r} (compare_trackers.py's variants)")
    trials = [int(t) for t in args.trials.split(",")]
    s = variant(mjx_radar.load_scenario(args.scenario), args.variant)
    run = mjx_radar.simulate(s, args.method, trials=trials, steps=args.steps, progress=False)
    a, met = run.arrays, run.metrics
    rows = []
    for i, t in enumerate(trials):
        g = met[met["trial"] == t]
        bad = g[g["gospa_missed"] > 0]["step"]
        first = int(bad.min()) if len(bad) else 0
        rows.append(row(t, first, a["target"][i], a["mean"][i], a["cov_diag"][i]))
    for r in rows:
        print(" | ".join(map(str, r)))
    if args.result:
        import jax
        from results import write_result

        dev = jax.devices()[0]
        hardware = dev.device_kind if dev.platform == "gpu" else "CPU"
        command = "python benchmarks/studies/ghost_heights.py " + " ".join(argv or sys.argv[1:])
        title = f"Where {args.variant} loses drones in {args.scenario} ({args.method})"
        print("wrote", write_result(args.result, title, command, hardware, COLUMNS, rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
