"""``mjx-radar render RUN_DIR``: the command line of :func:`mjx_radar.viz.render.render_run`."""

from __future__ import annotations

import argparse
import os
from pathlib import Path

from mjx_radar.cli.args import positive_int
from mjx_radar.viz.render import CAMERAS, RenderOptions, render_run


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("run_dir", type=Path, help="a complete run directory (mjx-radar run --out)")
    p.add_argument("--trial", type=int, default=0, help="trial index (default 0)")
    p.add_argument("--out", type=Path, default=None, help=".mp4 or .gif (RUN_DIR/video.mp4)")
    p.add_argument("--fps", type=positive_int("--fps", 240), default=None, help="default real time")
    p.add_argument("--camera", choices=CAMERAS, default="top", help="default top")
    p.add_argument("--width", type=positive_int("--width", 4096), default=640, help="default 640")
    p.add_argument("--height", type=positive_int("--height", 4096), default=480, help="default 480")
    p.add_argument("--frames", type=positive_int("--frames"), default=None, help="subsample")
    p.add_argument("--gl", choices=("egl", "osmesa"), default=None, help="OpenGL backend")


def main(args) -> int:
    out = args.out or args.run_dir / "video.mp4"
    opts = RenderOptions(
        fps=args.fps,
        camera=args.camera,
        width=args.width,
        height=args.height,
        frames=args.frames,
        backend=args.gl,
    )
    info = render_run(args.run_dir, args.trial, out, opts)
    print(
        f"wrote {out}: {info['frames']} frames {args.width}x{args.height}, {args.camera} camera, "
        f"{info['fps']:.3g} fps; rendered at {info['render_fps']:.1f} frames/s "
        f"({os.environ.get('MUJOCO_GL', 'default')} GL)"
    )
    return 0
