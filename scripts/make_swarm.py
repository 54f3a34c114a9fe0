"""Generate a swarm scenario: N radars tracking M drones spread over the map (issue 15).

Usage::

    python scripts/make_swarm.py --radars 8 --targets 8 --seed 0
    python scripts/make_swarm.py --radars 32 --targets 32 --seed 0 --out /tmp/s.toml

writes ``scenarios/swarm_{N}r{M}t.toml`` (or ``--out``). The bundled files were made with::

    for n in 8 16 32; do python scripts/make_swarm.py --radars $n --targets $n --seed 0; done

Layout (seeded with ``numpy.random.default_rng(seed)``, deterministic: the same
arguments give the same file bytes):

* placement box ``[-w, w]²`` with ``w = 400·sqrt(max(M, 8)/8)`` m unless ``--half-width``
  (400 m, the paper's box, up to 8 drones; the area grows with M so the drones' keep-out
  discs (R2T = 125 m, 3-D) leave room for the radars);
* drone positions uniform (in area) in the disc of radius ``0.6·w`` about the origin
  (well inside the box), altitude uniform in [40, 80] m;
* speed uniform in [10, 25] m/s, heading uniform in [-π, π), vz = 0;
* more than 16 drones: ``[filter] structure = "per-target"`` (M independent 6-D CKFs),
  whose memory and time grow linearly in M; the joint CKF's planner expectations grow
  as M² (swarm_32r32t: ~10 GB a trial on the CPU, 7 GB on a GPU).

The radars are not fixed: each trial places them by the simulator's rejection rule
(``mjx_radar.env.placement``), so the file sets ``n_radars`` and
``placement_half_width`` only. Check a file with
``python -m mjx_radar validate scenarios/swarm_32r32t.toml``. Everything else takes the
SPEC defaults (paper MPPI 200 × 5, horizon 15, 600 steps of 25 ms).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
#: more drones than this: the per-target filter bank (memory and time linear in M)
JOINT_MAX_TARGETS = 16


def default_half_width(n_targets: int) -> float:
    """``400·sqrt(max(M, 8)/8)`` rounded up to 10 m."""
    return 10.0 * math.ceil(40.0 * math.sqrt(max(n_targets, 8) / 8.0))


def swarm_targets(n_targets: int, half_width: float, seed: int) -> np.ndarray:
    """``[M, 6]`` initial drone states (x y z vx vy vz), rounded to 0.01."""
    rng = np.random.default_rng(seed)
    r = 0.6 * half_width * np.sqrt(rng.uniform(0.0, 1.0, n_targets))
    phi = rng.uniform(-np.pi, np.pi, n_targets)
    z = rng.uniform(40.0, 80.0, n_targets)
    speed = rng.uniform(10.0, 25.0, n_targets)
    heading = rng.uniform(-np.pi, np.pi, n_targets)
    rows = np.stack(
        [
            r * np.cos(phi),
            r * np.sin(phi),
            z,
            speed * np.cos(heading),
            speed * np.sin(heading),
            np.zeros(n_targets),
        ],
        axis=-1,
    )
    return np.round(rows, 2) + 0.0  # + 0.0 turns -0.0 into 0.0


def swarm_toml(n_radars: int, n_targets: int, seed: int, half_width: float | None = None) -> str:
    """The scenario file text."""
    w = default_half_width(n_targets) if half_width is None else float(half_width)
    name = f"swarm_{n_radars}r{n_targets}t"
    rows = swarm_targets(n_targets, w, seed)
    cmd = f"python scripts/make_swarm.py --radars {n_radars} --targets {n_targets} --seed {seed}"
    if half_width is not None:
        cmd += f" --half-width {w:g}"
    lines = [
        f"# Swarm scenario: {n_radars} radars, {n_targets} drones spread over the map with",
        "# random headings (issue 15). Generated, do not edit by hand:",
        f"#   {cmd}",
        "# Radars are placed per trial by the rejection rule (no `radars`); everything",
        "# not listed takes the SPEC defaults (see mjx_radar/scenario/schema.py).",
        f'name = "{name}"',
        f'description = "{n_radars} radars, {n_targets} drones, random headings; {cmd}"',
        f"n_radars = {n_radars}",
        f"seed = {seed}",
        f"placement_half_width = {w:.1f}",
        "targets = [",
        *(f"  [{', '.join(f'{v:.2f}' for v in row)}]," for row in rows),
        "]",
        "",
        "[timing]",
        "dt_filter = 0.025",
        "dt_control = 0.1",
        "steps = 600",
        "",
    ]
    if n_targets > JOINT_MAX_TARGETS:
        lines += [
            "# The per-target CKF bank (M filters of 6-D): with the joint CKF (one filter of",
            "# 6M dimensions) the planner's expectations hold 12M cubature points of M",
            "# targets each, memory and time quadratic in M (32 drones: ~10 GB a trial);",
            "# the bank's 12 points per target make them linear (docs/scaling.md).",
            "[filter]",
            'structure = "per-target"',
            "",
        ]
    return "\n".join(lines)


def _count(name: str, hi: int, lo: int = 1):
    def parse(text: str) -> int:
        try:
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} must be an integer, got {text!r}") from None
        if not lo <= v <= hi:
            raise argparse.ArgumentTypeError(f"{name} must be in [{lo}, {hi}], got {v}")
        return v

    return parse


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--radars", type=_count("--radars", 1000), required=True)
    p.add_argument("--targets", type=_count("--targets", 1000), required=True)
    p.add_argument("--seed", type=_count("--seed", 2**31 - 1, 0), default=0)
    p.add_argument("--half-width", type=float, default=None, help="placement box half width [m]")
    p.add_argument("--out", type=Path, default=None, help="default scenarios/swarm_NrMt.toml")
    args = p.parse_args(argv)
    if args.half_width is not None and not (math.isfinite(args.half_width) and args.half_width > 0):
        print(f"--half-width must be finite and > 0 m, got {args.half_width}", file=sys.stderr)
        return 2
    out = args.out or ROOT / "scenarios" / f"swarm_{args.radars}r{args.targets}t.toml"
    text = swarm_toml(args.radars, args.targets, args.seed, args.half_width)
    out.write_text(text)
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
