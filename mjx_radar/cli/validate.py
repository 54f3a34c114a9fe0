"""``mjx-radar validate``: load and check a scenario file without running it."""

from __future__ import annotations

import argparse

from mjx_radar.cli.args import check_placement
from mjx_radar.scenario.reader import load_scenario


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("scenario", help="scenario TOML file (or bundled name, e.g. smoke)")


def main(args) -> int:
    s = load_scenario(args.scenario)
    if not s.radar_init:  # fixed starts are checked by the loader (scenario.plausibility)
        check_placement(s, s.seed, 1)
    print(
        f"ok: {s.name}: {s.n_radars} radars, {s.n_targets} targets, {s.timing.steps} steps "
        f"of {s.timing.dt_filter} s, control every {s.timing.dt_control} s, "
        f"{len(s.obstacles)} obstacles"
        + (f", {len(s.moving_obstacles)} moving obstacles" if s.moving_obstacles else "")
    )
    return 0
