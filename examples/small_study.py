"""A small Monte Carlo study with its report (``mjx-radar study`` + ``report``).

    python examples/small_study.py [--small]

Resumable: run it again after an interruption and it continues where it stopped
(``resume=True``); a finished study is simply loaded.
"""

from _common import parse

import mjx_radar

args = parse(__doc__.splitlines()[0], "small_study")
scenarios = ["smoke"] if args.small else ["paper_3r4t", "paper_6r3t"]
methods = ["stationary", "ddr-sfim"] if args.small else ["stationary", "ccr-sfim", "ddr-sfim"]
trials, chunk, steps = (4, 2, 16) if args.small else (64, 32, None)

study = mjx_radar.run_study(
    scenarios,
    methods=methods,
    trials=trials,
    chunk=chunk,
    steps=steps,
    out=args.out / "study",
    resume=True,
    rollouts="analytic" if args.small else None,
)
table = study.summary()  # one row per scenario and method, as in report.md
print(table[["scenario", "method", "median_rmse_pos", "lost_trial_rate"]].to_string(index=False))
report = study.report()  # summary.csv, report.md and figures in the study directory
print(f"wrote {report}")
