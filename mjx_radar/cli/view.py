"""``mjx-radar view RUN_DIR``: the command line of :func:`mjx_radar.viz.view.viewer.view`."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from mjx_radar.cli.args import positive_int
from mjx_radar.viz.view.viewer import view
from mjx_radar.viz.view.viewer_budget import MAX_FRAMES


def _trials(text: str) -> list[int]:
    try:
        ids = [int(t) for t in text.split(",") if t.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"--trial = {text!r}: must be trial indices separated by commas"
        ) from None
    if not ids:
        raise argparse.ArgumentTypeError("--trial: empty list")
    return ids


def _samples(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--samples = {text!r}: must be an integer") from None
    if not 0 <= value <= 1000:
        raise argparse.ArgumentTypeError(f"--samples = {value}: must be in [0, 1000]")
    return value


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("run_dir", type=Path, help="a complete run directory (mjx-radar run --out)")
    p.add_argument("--out", type=Path, default=None, help="HTML file (RUN_DIR/view.html)")
    p.add_argument(
        "--trial",
        type=_trials,
        default=None,
        help="trial indices, e.g. 0 or 0,3 (default: the first ones that keep the "
        "file under about 14 MB, at most 8)",
    )
    p.add_argument(
        "--max-frames",
        type=positive_int("--max-frames", 100_000),
        default=MAX_FRAMES,
        help=f"frames per trial: every k-th filter step (default {MAX_FRAMES})",
    )
    p.add_argument(
        "--samples",
        type=_samples,
        default=None,
        help="MPPI samples per frame, the highest weights (default up to 32, "
        "fewer if the file would exceed about 14 MB)",
    )


def main(args) -> int:
    t0 = time.perf_counter()
    info = view(args.run_dir, args.out, args.trial, args.max_frames, args.samples)
    print(
        f"wrote {info.path} ({info.bytes / 1e6:.1f} MB, {time.perf_counter() - t0:.1f} s): "
        f"trials {', '.join(map(str, info.trials))}; shown: {info.dropped()}"
    )
    return 0
