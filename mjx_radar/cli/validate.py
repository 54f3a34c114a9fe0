"""``mjx-radar validate``: load and check a scenario file without running it."""

from __future__ import annotations

import argparse

from mjx_radar.cli.args import check_placement
from mjx_radar.scenario.reader import load_scenario
from mjx_radar.world.components import Ground


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("scenario", help="scenario TOML file (or bundled name, e.g. smoke)")


def main(args) -> int:
    s = load_scenario(args.scenario)
    if not s.radar_init:  # fixed starts are checked by the loader (scenario.plausibility)
        check_placement(s, s.seed, 1)
    print(
        f"ok: {s.name}: {s.n_radars} radars, {s.n_targets} targets, {s.timing.steps} steps "
        f"of {s.timing.dt_filter} s, control every {s.timing.dt_control} s; " + ", ".join(world(s))
    )
    return 0


def world(s) -> list[str]:
    """What the scenario adds to the paper's open flat world, in a few words each (or
    "flat open ground" when nothing)."""
    out = [f"{len(s.obstacles)} obstacles"] if s.obstacles else []
    if s.moving_obstacles:
        out.append(f"{len(s.moving_obstacles)} moving obstacles")
    ground = Ground(s.terrain)
    if ground.present:
        out.append(ground.summary)
    fixed = sum(not ov.mobile for ov in s.radar_override)
    if fixed:
        out.append(f"{fixed} fixed radar sites")
    d = s.detection
    if d.model != "perfect" or d.clutter:
        out.append(f"detection {d.model}" + (" with clutter" if d.clutter else ""))
    moves = sorted({tm.model for tm in s.target_motion if tm.model != "cv"})
    if moves:
        out.append("target motion " + "/".join(moves))
    return out or ["flat open ground, no obstacles"]
