"""Keep-out statistics of planners: how close the radars come to the drones and each other.

    python benchmarks/studies/keepout_stats.py paper_3r4t --planners mppi,policy:DIR,stationary \
        --trials 200 [--json F]

Runs ``simulate`` once per planner (``mppi`` and ``stationary`` are the scenario's
DDR-SFIM MPPI and stationary methods; any other name is a planner of the DDR-SFIM method,
e.g. ``policy:DIR``), common random numbers across planners, and reports from the true
positions (``run.trajectories``: ``radar_states`` x y z, ``truth`` x y z):

* ``median_rmse``, ``mean_rmse``: over trials of each trial's time-mean position RMSE;
* ``r2t_pair_fraction``: the fraction of (step, radar, drone) triples closer than the
  scenario's ``mpc.r2t`` (3-D distance, as the MPC's keep-out term measures it);
  ``r2t_step_fraction``: of steps with at least one such pair;
* ``median_min_r2t_m`` / ``median_min_horizontal_m``: the median over trials of the
  closest radar-drone approach (3-D / horizontal);
* ``r2r_step_fraction``: of steps with two radars closer than ``mpc.r2r`` (horizontal).

A learned policy whose reward weighs the keep-outs less than MPPI's objective does
(``train_policy.py --penalty-scale``) can buy accuracy by breaking them: compare both
columns (docs/learning.md).
"""

from __future__ import annotations

import argparse
import json
import sys

import numpy as np


def keepout_of(radar, truth, rmse, r2t: float, r2r: float) -> dict:
    """The statistics above from arrays.

    Args:
        radar: ``[T, K, N, 3]`` radar positions (x, y, z).
        truth: ``[T, K, M, 3]`` true drone positions.
        rmse: ``[T]`` each trial's time-mean position RMSE.
        r2t: the radar-drone keep-out radius (3-D).
        r2r: the radar-radar keep-out radius (horizontal).
    """
    radar, truth, rmse = np.asarray(radar), np.asarray(truth), np.asarray(rmse)
    gap = radar[:, :, :, None, :] - truth[:, :, None, :, :]  # [T, K, N, M, 3]
    d3 = np.linalg.norm(gap, axis=-1)
    dh = np.linalg.norm(gap[..., :2], axis=-1)
    n = radar.shape[2]
    rr = np.linalg.norm(radar[:, :, :, None, :2] - radar[:, :, None, :, :2], axis=-1)
    rr = rr + np.where(np.eye(n, dtype=bool), np.inf, 0.0)
    inside = d3 < r2t
    return {
        "trials": int(len(rmse)),
        "median_rmse": float(np.median(rmse)),
        "mean_rmse": float(np.mean(rmse)),
        "r2t_pair_fraction": float(inside.mean()),
        "r2t_step_fraction": float(inside.any(axis=(2, 3)).mean()),
        "median_min_r2t_m": float(np.median(d3.min(axis=(1, 2, 3)))),
        "median_min_horizontal_m": float(np.median(dh.min(axis=(1, 2, 3)))),
        "r2r_step_fraction": float((rr < r2r).any(axis=(2, 3)).mean()),
    }


def keepout_stats(scenario, planner: str, trials: int) -> dict:
    """The statistics above for one planner (``mppi``, ``stationary`` or a planner name)."""
    import mjx_radar
    from mjx_radar.scenario.reader import load_scenario

    sc = load_scenario(scenario) if isinstance(scenario, str) else scenario
    method = "stationary" if planner == "stationary" else "ddr-sfim"
    other = None if planner in ("stationary", "mppi") else planner
    run = mjx_radar.simulate(sc, method=method, planner=other, trials=trials, progress=False)
    ds = run.trajectories
    radar = ds.radar_states.sel(radar_state=["x", "y", "z"])  # [T, K, N, 3]
    truth = ds.truth.sel(state=["x", "y", "z"])  # [T, K, M, 3]
    rmse = run.metrics.groupby("trial")["rmse_pos"].mean()
    return {"planner": planner, **keepout_of(radar, truth, rmse, sc.mpc.r2t, sc.mpc.r2r)}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("scenario", help="a bundled scenario name or TOML file")
    p.add_argument("--planners", default="mppi,stationary", help="comma-separated names")
    p.add_argument("--trials", type=int, default=64)
    p.add_argument("--json", default=None, help="write the results to this JSON file")
    args = p.parse_args(argv)
    from mjx_radar.io.checks import ScenarioError

    if args.trials < 1:
        print(f"error: --trials = {args.trials}: must be >= 1", file=sys.stderr)
        return 2
    out = {}
    try:
        for name in args.planners.split(","):
            out[name] = keepout_stats(args.scenario, name, args.trials)
            print(json.dumps(out[name]), flush=True)
    except ScenarioError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    if args.json:
        with open(args.json, "w") as f:
            json.dump(out, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
