"""The five methods on one scenario, common random numbers, one table.

    python examples/compare_methods.py [--small]

Trial i is the same world (drones, noise) for every method, so the per-trial
differences are paired. All methods share one compiled program.
"""

import pandas as pd
from _common import parse, small

import mjx_radar

args = parse(__doc__.splitlines()[0], "compare_methods")
scenario = small(mjx_radar.load_scenario("smoke" if args.small else "paper_3r4t"), args)
trials, steps = (2, 16) if args.small else (16, None)

frames = [
    mjx_radar.simulate(scenario, m, trials=trials, steps=steps, seed=0, progress=False).metrics
    for m in mjx_radar.METHODS
]
metrics = pd.concat(frames, ignore_index=True)
per_trial = metrics.groupby(["method", "trial"], observed=True).agg(
    rmse=("rmse_pos", "mean"), crlb=("crlb_pos", "mean"), lost=("lost", "max")
)
table = per_trial.groupby("method", observed=True).agg(
    rmse_median=("rmse", "median"),
    rmse_mean=("rmse", "mean"),
    pcrlb=("crlb", "mean"),
    lost_trials=("lost", "sum"),
)
stationary = table.loc["stationary", "rmse_median"]
table["vs_stationary_%"] = 100.0 * (1.0 - table["rmse_median"] / stationary)
print(table.round(3).to_string())
table.to_csv(args.out / "methods.csv")
print(f"wrote {args.out / 'methods.csv'}")
