"""A video and a snapshot of a run (offscreen OpenGL: EGL on a GPU, else OSMesa).

    python examples/video_and_snapshot.py [--small]

The same as ``mjx-radar run ... --out DIR && mjx-radar render DIR && mjx-radar
snapshot DIR --step K``, from Python.
"""

from _common import parse, small

import mjx_radar

args = parse(__doc__.splitlines()[0], "video_and_snapshot")
scenario = small(mjx_radar.load_scenario("smoke" if args.small else "city_4r4t"), args)
steps = 16 if args.small else 400

run = mjx_radar.simulate(scenario, "ddr-sfim", trials=2, steps=steps, seed=0, progress=False)
run.save(args.out / "run", force=True)  # render and snapshot read the run directory
video = run.render(
    args.out / "run.gif" if args.small else args.out / "run.mp4",
    camera="top",
    width=320 if args.small else 640,
    height=240 if args.small else 480,
    frames=8 if args.small else None,
)
png = run.snapshot(
    step=steps // 2, path=args.out / "snapshot.png", grid=40 if args.small else 120
)  # step: filter step in [1, steps]
print(f"wrote {video} and {png}")
