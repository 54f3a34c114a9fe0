"""The options of ``mjx-radar run`` (those of :func:`mjx_radar.simulate`, and the terminal's)."""

from __future__ import annotations

import argparse
from pathlib import Path

from mjx_radar.cli.args import linger, method_name, port, positive_int, seed
from mjx_radar.task.method import METHODS


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Adds the options of ``mjx-radar run`` to ``p`` (in ``--help`` order)."""
    add_run_arguments(p)
    add_output_arguments(p)


def add_run_arguments(p: argparse.ArgumentParser) -> None:
    """What to run: scenario, method, planner, plug-ins, seed, steps, trials, out, rollouts."""
    p.add_argument("scenario", help="scenario TOML file (or bundled name, e.g. smoke)")
    p.add_argument(
        "--method",
        type=method_name,
        default="ddr-sfim",
        metavar="METHOD",
        help=f"one of {', '.join(METHODS)} (any case; default ddr-sfim)",
    )
    p.add_argument(
        "--planner",
        default=None,
        metavar="NAME",
        help="a registered planner moving the radars instead of the method's own: mppi, "
        "ps, cem, grad, hybrid, hold, policy:DIR (a trained policy, docs/learning.md), or "
        "one a --plugin file registers (docs/extending.md)",
    )
    p.add_argument(
        "--plugin",
        action="append",
        default=[],
        metavar="FILE",
        help="a Python file run first, e.g. one that registers a planner or a cost term "
        "(repeatable)",
    )
    p.add_argument("--seed", type=seed, default=None, help="base seed (default: scenario's)")
    p.add_argument(
        "--steps",
        type=positive_int("--steps"),
        default=None,
        help="filter steps (default: scenario's)",
    )
    p.add_argument(
        "--trials",
        type=positive_int("--trials", 100_000),
        default=1,
        help="Monte Carlo trials, run as one vmapped batch (default 1)",
    )
    p.add_argument("--out", type=Path, default=None, help="output dir (default runs/NAME_METHOD)")
    p.add_argument(
        "--rollouts",
        choices=("mjx", "analytic"),
        default=None,
        help="planner rollouts: MJX physics (scenario default) or closed-form kinematics",
    )


def add_output_arguments(p: argparse.ArgumentParser) -> None:
    """Association, what to record and show, metrics settings, overwrite, verbosity."""
    p.add_argument(
        "--association",
        default=None,
        metavar="NAME",
        help="association of cluttered scans: pda, jpda, gnn, mht or one registered from a "
        "--plugin file (the scenario's [tracker] association; its other options in the TOML "
        "file, docs/tracking.md)",
    )
    p.add_argument(
        "--masks",
        action="store_true",
        help="also record each radar-drone pair's line of sight and detection per step "
        "(trajectories.npz: visible, detected [T,K,N,M])",
    )
    p.add_argument("--video", action="store_true", help="render trial 0 to DIR/video.mp4")
    p.add_argument(
        "--view",
        action="store_true",
        help="live 3-D view in a web browser while it simulates (URL printed; docs/viewer.md)",
    )
    p.add_argument(
        "--view-port",
        type=port,
        default=None,
        metavar="PORT",
        help="port of the live view on 127.0.0.1 (default 8765, 0: any free port; implies --view)",
    )
    p.add_argument(
        "--view-linger",
        type=linger,
        default=None,
        metavar="SECONDS",
        help="after the run, keep the live view this long (default: until Ctrl-C; 0: stop)",
    )
    for name, what in (("cutoff", "cutoff c [m]"), ("order", "order p")):
        p.add_argument(
            f"--gospa-{name}",
            type=float,
            default=None,
            metavar="X",
            help=f"GOSPA / OSPA {what} (default: the scenario's [metrics] gospa_{name})",
        )
    p.add_argument("--force", action="store_true", help="overwrite a complete run in --out")
    p.add_argument(
        "--verbose",
        "-v",
        action="store_true",
        help="also print the final-step RMSE, control rate, GOSPA / OSPA and track continuity",
    )
    p.add_argument(
        "--keep-diverged",
        action="store_true",
        help="exit 0 (with a warning) even if some trials' filters diverged",
    )
