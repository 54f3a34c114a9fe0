"""``mjx-radar snapshot RUN_DIR --step K``: the CLI of :func:`mjx_radar.viz.snapshot.snapshot`."""

from __future__ import annotations

import argparse
from pathlib import Path

from mjx_radar.cli.args import positive_int
from mjx_radar.viz.snapshot import snapshot


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("run_dir", type=Path, help="a complete run directory (mjx-radar run --out)")
    p.add_argument("--step", type=int, required=True, help="filter step K in [1, steps]")
    p.add_argument("--trial", type=int, default=0, help="trial index (default 0)")
    p.add_argument("--out", type=Path, default=None, help="image (RUN_DIR/snapshot_stepK.png)")
    p.add_argument("--grid", type=positive_int("--grid", 1000), default=120, help="heat-map grid")


def main(args) -> int:
    path = snapshot(args.run_dir, args.step, args.trial, args.out, args.grid)
    print(f"wrote {path}")
    return 0
