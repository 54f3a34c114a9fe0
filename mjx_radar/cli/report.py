"""``mjx-radar report DIR``: the command line of :mod:`mjx_radar.study.report`."""

from __future__ import annotations

import argparse
from pathlib import Path


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Adds the positional ``DIR`` (a finished ``mjx-radar study`` directory)."""
    p.add_argument("dir", type=Path, metavar="DIR", help="study directory (mjx-radar study)")


def main(args) -> int:
    """Writes summary.csv, report.md and the figures; InputError (exit 2) for a bad DIR."""
    from mjx_radar.study.report import write_report

    print(f"report: {write_report(args.dir)}")
    return 0
