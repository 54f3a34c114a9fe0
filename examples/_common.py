"""Shared command line of the examples: ``--small`` (what CI runs) and ``--out``."""

import argparse
import os
from pathlib import Path


def parse(description: str, name: str) -> argparse.Namespace:
    """``--small`` (or ``MJX_RADAR_SMALL=1``): a tiny, fast version; ``--out`` folder.

    The small versions plan with closed-form (analytic) rollouts instead of MJX: the
    same objective, a program that compiles in about half the time (what CI runs).
    """
    p = argparse.ArgumentParser(description=description)
    p.add_argument("--small", action="store_true", help="tiny version (CI)")
    p.add_argument("--out", type=Path, default=Path("out") / "examples" / name)
    args = p.parse_args()
    args.small = args.small or os.environ.get("MJX_RADAR_SMALL") == "1"
    args.out.mkdir(parents=True, exist_ok=True)
    return args


def small(scenario, args):
    """``scenario`` for ``--small``: analytic planner rollouts (compiles faster)."""
    return scenario.replace(mpc={"rollout": "analytic"}) if args.small else scenario
