"""How a joint tracker loses a drone in ``clutter_3r4t``: two tracks exchange one radar's
returns (docs/tracking.md, "Range coincidences").

Replays the given trials of a tracker variant (``compare_trackers.py``'s names, with the
same draws: common random numbers by trial index) with DDR-SFIM and the full records, and
for each trial with an unmatched drone (no track within 50 m) looks at the step before:

* the two drones i, j whose tracks are farthest off (best assignment of tracks to drones);
* per radar n, each of the two tracks' range error ``|x̂ − p_n| − |x − p_n|`` and the
  drones' range gap ``g_n = r_ni − r_nj``: an exchange at radar n shows as errors
  ``−g_n`` and ``+g_n`` there and small errors at the other radars (three ranges fix a
  position, so the exchanged pair is a consistent pair of ghosts);
* the smallest ``|g_n|`` at that radar since the start, and its step: where the two
  drones' returns coincided.

::

    python benchmarks/studies/diagnose_swaps.py --variant jpda-p0 --trials 1,37,163 \
        --steps 600 [--result clutter_swaps_cpu]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from scipy.optimize import linear_sum_assignment

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

COLUMNS = [
    "variant",
    "trial",
    "first unmatched step",
    "drones",
    "radar",
    "range gap there [m]",
    "track range errors there [m]",
    "largest track range error at the other radars [m]",
    "smallest gap there before [m]",
    "at step",
]


def swap_row(target, mean, radar, first: int) -> list:
    """The row of one trial (``target [K, M, 6]``, ``mean [K, 6M]``, ``radar [K, N, 6]``)
    whose first unmatched step is ``first`` (1-based)."""
    k = first - 2  # the step before, 0-based
    m = target.shape[1]
    tgt, est, rad = target[k, :, :3], mean[k].reshape(m, 6)[:, :3], radar[k, :, :3]
    cost = np.linalg.norm(tgt[:, None] - est[None], axis=-1)
    rows, cols = linear_sum_assignment(cost)
    err = cost[rows, cols]
    i, j = (int(rows[x]) for x in np.argsort(err)[-2:][::-1])
    track = dict(zip(rows, cols, strict=True))
    rng = lambda p: np.linalg.norm(p[None] - rad, axis=-1)  # noqa: E731  [N]
    e_i, e_j = rng(est[track[i]]) - rng(tgt[i]), rng(est[track[j]]) - rng(tgt[j])
    n = int(np.argmax(np.abs(e_i) + np.abs(e_j)))
    others = [r for r in range(rad.shape[0]) if r != n]
    gaps = np.linalg.norm(target[: k + 1, i, None, :3] - radar[: k + 1, :, :3], axis=-1)
    gaps -= np.linalg.norm(target[: k + 1, j, None, :3] - radar[: k + 1, :, :3], axis=-1)
    low = int(np.argmin(np.abs(gaps[:, n])))
    return [
        f"drones {i}, {j}",
        n,
        round(float(gaps[k, n]), 1),
        f"{e_i[n]:+.1f}, {e_j[n]:+.1f}",
        round(float(max(np.abs(e_i[others]).max(), np.abs(e_j[others]).max())), 1),
        round(float(abs(gaps[low, n])), 2),
        low + 1,
    ]


def main(argv=None) -> int:
    from compare_trackers import known_variant, variant

    import mjx_radar

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--variant", default="jpda-p0")
    p.add_argument("--trials", default="1,37,163")
    p.add_argument("--steps", type=int, default=600)
    p.add_argument("--result", default=None, help="also write benchmarks/results/ID.json")
    args = p.parse_args(argv)
    if not known_variant(args.variant):
        p.error(f"--variant: unknown {args.variant!r} (compare_trackers.py's variants)")
    trials = [int(t) for t in args.trials.split(",")]
    s = variant(mjx_radar.load_scenario("clutter_3r4t"), args.variant)
    run = mjx_radar.simulate(s, "ddr-sfim", trials=trials, steps=args.steps)
    a, out = run.arrays, []
    for x, trial in enumerate(trials):
        g = run.metrics[run.metrics["trial"] == trial]
        missed = g[g["gospa_missed"] > 0]["step"]
        row = [args.variant, trial]
        if len(missed) == 0:
            row += [0, "none unmatched"] + ["–"] * 6
        else:
            first = int(missed.min())
            row += [first, *swap_row(a["target"][x], a["mean"][x], a["radar"][x], first)]
        out.append(row)
        print(" | ".join(str(c) for c in row), flush=True)
    if args.result:
        from results import write_result

        command = "python benchmarks/studies/diagnose_swaps.py " + " ".join(sys.argv[1:])
        notes = (
            "clutter_3r4t, ddr-sfim, seed 0; the step before the first unmatched step; range "
            "error: a track's range to the radar minus its drone's; gap: r_i - r_j at the radar."
        )
        title = f"Where {args.variant} loses a drone in clutter: one radar's returns exchanged"
        write_result(args.result, title, command, "2-core CPU", COLUMNS, out, notes)
    return 0


if __name__ == "__main__":
    sys.exit(main())
