"""``mjx-radar render``: offscreen MuJoCo video (MP4 or GIF) of a saved trial.

Each frame copies the saved radar and drone states of one filter step into an
``MjData`` (``mj_kinematics``), lets :class:`mujoco.Renderer` build the scene, then
appends user geoms within ``scene.maxgeom`` (most important first): radar and
drone markers, CKF estimates with 2-sigma ellipsoids, R2T / R2R rings, radar
trails (last 25 control steps) and the MPPI samples coloured by weight. The
OpenGL backend (EGL or OSMesa) is chosen by :mod:`mjx_radar.viz.gl`. :class:`Trial`
and :func:`load_trial` are shared with :mod:`mjx_radar.viz.snapshot`.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
import time
from pathlib import Path

import numpy as np

from mjx_radar.cli.args import positive_int
from mjx_radar.errors import InputError

CAMERAS = ("top", "chase", "free")
TRAIL_CONTROL_STEPS = 25
RADAR_RGB = np.array([[0.0, 0.45, 1.0], [1.0, 0.5, 0.0], [0.0, 0.7, 0.25], [0.8, 0.0, 0.8]])
TARGET_RGB = np.array([[0.85, 0.05, 0.05], [0.55, 0.0, 0.35], [0.35, 0.2, 0.0], [0.1, 0.1, 0.1]])


@dataclasses.dataclass(frozen=True)
class Trial:
    """One trial of a run directory (numpy arrays; K filter steps, C control steps)."""

    meta: dict
    scenario: object  # mjx_radar.config.Scenario
    target: np.ndarray  # [K, M, 6] true drone states
    mean: np.ndarray  # [K, M, 3] CKF position estimates
    sigma: np.ndarray  # [K, M, 3] CKF position standard deviations
    radar: np.ndarray  # [K, N, 6] radar states [x, y, z, theta, v, omega]
    sample_xy: np.ndarray  # [C, S, H, N, 2] MPPI sampled radar paths
    sample_weight: np.ndarray  # [C, S]
    every: int  # filter steps per control step
    dt: float  # filter step [s]

    @property
    def steps(self) -> int:
        return self.radar.shape[0]

    def control_index(self, k: int) -> int:
        """The control step whose plan was acting at filter step ``k``."""
        return min(k // self.every, self.sample_xy.shape[0] - 1)

    def trail(self, k: int) -> np.ndarray:
        """``[L, N, 3]`` radar positions at steps k, k - every, ... (last 25 control steps)."""
        ks = np.arange(k, max(k - TRAIL_CONTROL_STEPS * self.every, 0) - 1, -self.every)
        return self.radar[ks[ks >= 0], :, :3]

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper xy corners of the drone paths and the radars' R2T discs."""
        radar, r2t = self.radar[..., :2].reshape(-1, 2), self.meta["r2t"]
        xy = np.concatenate([radar - r2t, radar + r2t, self.target[..., :2].reshape(-1, 2)])
        return xy.min(0), xy.max(0)


def load_trial(run_dir, trial: int = 0) -> Trial:
    """Loads one trial of a complete run directory; raises ``InputError`` on bad input."""
    from mjx_radar.io import results
    from mjx_radar.io.scenario import ScenarioError, load_scenario

    run_dir = Path(run_dir)
    if not (run_dir / "run.json").is_file() or not (run_dir / "trajectories.npz").is_file():
        raise InputError(f"RUN_DIR = {str(run_dir)!r}: not a complete run directory (no run.json)")
    meta, a = results.read_run(run_dir)
    n_trials = a["radar"].shape[0]
    if not 0 <= trial < n_trials:
        raise InputError(f"--trial = {trial}: must be in [0, {n_trials - 1}]")
    try:
        scenario = load_scenario(run_dir / "scenario.toml")
    except ScenarioError:  # e.g. mesh paths relative to the original scenario file
        scenario = load_scenario(meta["scenario_file"])
    m = a["target"].shape[2]
    every = int(round(meta["dt_control"] / meta["dt_filter"]))
    return Trial(
        meta=meta,
        scenario=scenario,
        target=a["target"][trial],
        mean=a["mean"][trial].reshape(-1, m, 6)[..., :3],
        sigma=np.sqrt(np.maximum(a["cov_diag"][trial].reshape(-1, m, 6)[..., :3], 0.0)),
        radar=a["radar"][trial],
        sample_xy=a["sample_xy"][trial],
        sample_weight=a["sample_weight"][trial],
        every=every,
        dt=float(meta["dt_filter"]),
    )


def frame_steps(steps: int, frames: int | None) -> np.ndarray:
    """Filter steps (0-based) shown: all, or ``frames`` evenly spaced ones."""
    if frames is None:
        return np.arange(steps)
    if not 1 <= frames <= steps:
        raise InputError(f"--frames = {frames}: must be in [1, {steps}]")
    return np.unique(np.round(np.linspace(0, steps - 1, frames)).astype(int))


def scene_model(tr: Trial, camera: str = "top", aspect: float = 4 / 3):
    """The MuJoCo scene of the trial, its view extent set to the trial's area.

    The ``top`` camera is orthographic: the free camera's ``fovy`` is then the view
    height [m] (MuJoCo's convention), set here to fit the trial's area.
    """
    from mjx_radar.physics.scene import build_scene

    model, index = build_scene(tr.radar.shape[1], tr.target.shape[1], tr.dt, tr.scenario.obstacles)
    lo, hi = tr.bounds()
    model.stat.extent = max(float(np.max(hi - lo)), 100.0)  # sets near/far clipping
    model.stat.center[:] = [*(0.5 * (lo + hi)), 0.0]
    model.vis.headlight.ambient[:] = 0.35
    if camera == "top":
        model.vis.global_.orthographic = 1
        model.vis.global_.fovy = 1.05 * max(hi[1] - lo[1], (hi[0] - lo[0]) / aspect)
    return model, index


def set_state(model, data, index, tr: Trial, k: int) -> None:
    """Copies the saved radar and drone poses of step ``k`` into ``data``."""
    import mujoco

    data.qpos[index.radar_qpos.reshape(-1)] = tr.radar[k][:, [0, 1, 3]].reshape(-1)
    data.qpos[index.drone_qpos.reshape(-1)] = tr.target[k, :, :3].reshape(-1)
    mujoco.mj_kinematics(model, data)


def frame_camera(tr: Trial, k: int, kind: str, aspect: float, fovy: float = 45.0):
    """The ``MjvCamera`` of frame ``k``: ``top``, ``chase`` or ``free``."""
    import mujoco

    lo, hi = tr.bounds()
    tan = np.tan(np.deg2rad(fovy) / 2)
    cam = mujoco.MjvCamera()
    cam.type = mujoco.mjtCamera.mjCAMERA_FREE
    cam.lookat[:] = [*(0.5 * (lo + hi)), 0.0]
    if kind == "top":  # orthographic (see scene_model), +x right and +y up in the image
        cam.orthographic, cam.azimuth, cam.elevation = 1, 90.0, -90.0
        cam.distance = float(np.max(hi - lo)) + float(tr.target[..., 2].max())
        return cam
    if kind == "chase":  # behind the drones' mean velocity, close enough to see them all
        cam.lookat[:] = tr.target[k, :, :3].mean(0)
        spread = np.max(np.linalg.norm(tr.target[k, :, :2] - cam.lookat[:2], axis=1))
        vx, vy = tr.target[k, :, 3:5].mean(0)
        cam.azimuth, cam.elevation = float(np.degrees(np.arctan2(vy, vx))), -25.0
        cam.distance = 1.5 * (spread + 40.0) / tan
        return cam
    half = 0.5 * (hi - lo) * 1.1
    cam.distance = 0.9 * max(half[1], half[0] / aspect) / tan
    cam.azimuth, cam.elevation = 45.0 + 90.0 * k / max(tr.steps - 1, 1), -35.0
    return cam


class _Geoms:
    """Appends user geoms to an ``MjvScene`` until ``scene.maxgeom`` is reached."""

    def __init__(self, scene, scale: float):
        import mujoco

        self.mj, self.scene, self.scale = mujoco, scene, scale
        self.eye = np.eye(3).reshape(-1)

    def add(self, gtype, size, pos, rgba, emission=0.3) -> bool:
        s = self.scene
        if s.ngeom >= s.maxgeom:
            return False
        g = s.geoms[s.ngeom]
        size, pos = np.asarray(size, np.float64), np.asarray(pos, np.float64)
        self.mj.mjv_initGeom(g, gtype, size, pos, self.eye, np.asarray(rgba, np.float32))
        g.emission = emission
        s.ngeom += 1
        return True

    def line(self, a, b, rgba, width=2.0) -> bool:
        line = self.mj.mjtGeom.mjGEOM_LINE
        if not self.add(line, np.zeros(3), np.zeros(3), rgba):
            return False
        a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
        self.mj.mjv_connector(self.scene.geoms[self.scene.ngeom - 1], line, width, a, b)
        return True

    def polyline(self, pts, rgba, width=2.0) -> bool:
        return all(self.line(p, q, rgba, width) for p, q in zip(pts[:-1], pts[1:], strict=True))

    def ring(self, center, radius, rgba, n=40) -> bool:
        t = np.linspace(0, 2 * np.pi, n + 1)
        pts = np.stack([center[0] + radius * np.cos(t), center[1] + radius * np.sin(t)], -1)
        return self.polyline(np.column_stack([pts, np.full(n + 1, 0.5)]), rgba, 1.5)


def add_overlays(scene, tr: Trial, k: int) -> None:
    """Appends the markers, estimates, rings, trails and MPPI samples of step ``k``."""
    import mujoco

    gt = mujoco.mjtGeom
    lo, hi = tr.bounds()
    g = _Geoms(scene, scale=0.012 * max(float(np.max(hi - lo)), 100.0))
    s = g.scale
    radars, r2t, r2r = tr.radar[k], tr.meta["r2t"], tr.meta["r2r"]
    for n, (x, y, *_rest) in enumerate(radars):
        rgb = RADAR_RGB[n % len(RADAR_RGB)]
        g.add(gt.mjGEOM_CYLINDER, [s, 0.3 * s, 0], [x, y, 0.3 * s + 5.0], [*rgb, 1.0], emission=0.6)
    for m, rgb in enumerate(TARGET_RGB[np.arange(tr.target.shape[1]) % len(TARGET_RGB)]):
        g.add(gt.mjGEOM_SPHERE, [0.7 * s] * 3, tr.target[k, m, :3], [*rgb, 1.0])
        g.add(gt.mjGEOM_SPHERE, [0.35 * s] * 3, tr.mean[k, m], [1.0, 1.0, 1.0, 1.0])
        size = np.maximum(2.0 * tr.sigma[k, m], 0.05 * s)  # 2-sigma semi-axes
        g.add(gt.mjGEOM_ELLIPSOID, size, tr.mean[k, m], [1.0, 1.0, 0.4, 0.35])
    for x, y, *_rest in radars:
        g.ring((x, y), r2t, [0.9, 0.1, 0.1, 0.8])
        g.ring((x, y), r2r, [0.1, 0.1, 0.1, 0.9])
    trail = tr.trail(k)
    for n in range(radars.shape[0]):
        pts = np.column_stack([trail[:, n, :2], np.full(len(trail), 1.0)])
        g.polyline(pts, [*RADAR_RGB[n % len(RADAR_RGB)], 0.6], 3.0)
    c = tr.control_index(k)
    w = tr.sample_weight[c] / max(float(tr.sample_weight[c].max()), 1e-12)
    for j in np.argsort(w):  # lowest weight first, the best drawn on top
        rgba = [0.3 + 0.7 * w[j], 0.3 - 0.2 * w[j], 0.6 - 0.6 * w[j], 0.25 + 0.7 * w[j]]
        for n in range(radars.shape[0]):
            xy = tr.sample_xy[c, j, :, n]
            if not g.polyline(np.column_stack([xy, np.full(len(xy), 0.7)]), rgba, 1.0):
                return


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
    opts = {k: getattr(args, k) for k in ("fps", "camera", "width", "height", "frames")}
    info = render_run(args.run_dir, args.trial, out, backend=args.gl, **opts)
    print(
        f"wrote {out}: {info['frames']} frames {args.width}x{args.height}, {args.camera} camera, "
        f"{info['fps']:.3g} fps; rendered at {info['render_fps']:.1f} frames/s "
        f"({os.environ.get('MUJOCO_GL', 'default')} GL)"
    )
    return 0


def render_run(
    run_dir,
    trial: int = 0,
    out_path=None,
    *,
    fps=None,
    camera: str = "top",
    width: int = 640,
    height: int = 480,
    frames: int | None = None,
    backend: str | None = None,
    progress: bool = True,
) -> dict:
    """Renders one saved trial to an MP4 (H.264) or GIF file, chosen by extension.

    Args:
        run_dir: a complete run directory.
        trial: trial index in ``[0, T)``.
        out_path: ``.mp4`` or ``.gif`` file; default ``run_dir/video.mp4``.
        fps: playback rate; default real time (frames per simulated second).
        camera: ``top`` (fixed, straight down), ``chase`` (follows the drones) or
            ``free`` (oblique, orbiting the whole scene).
        width: image width [px], even, >= 16.
        height: image height [px], even, >= 16.
        frames: number of evenly spaced frames; default one per filter step.
        backend: ``egl`` or ``osmesa``; default ``MUJOCO_GL`` or automatic.
        progress: show a tqdm progress bar on stderr.

    Returns:
        ``{"frames", "fps", "render_s", "render_fps"}`` (time includes encoding).

    Raises:
        InputError: bad run directory, trial, frame count, camera or extension.
    """
    import imageio.v2 as imageio
    import mujoco
    from tqdm import tqdm

    from mjx_radar.viz import gl

    run_dir = Path(run_dir)
    out_path = Path(out_path) if out_path is not None else run_dir / "video.mp4"
    if out_path.suffix.lower() not in (".mp4", ".gif"):
        raise InputError(f"--out = {str(out_path)!r}: extension must be .mp4 or .gif")
    if camera not in CAMERAS:
        raise InputError(f"--camera = {camera!r}: must be one of {', '.join(CAMERAS)}")
    for name, value in (("--width", width), ("--height", height)):
        if not (16 <= value <= 4096 and value % 2 == 0):
            raise InputError(f"{name} = {value}: must be even and in [16, 4096]")
    tr = load_trial(run_dir, trial)
    ks = frame_steps(tr.steps, frames)
    fps = float(fps or max(len(ks) / (tr.steps * tr.dt), 0.5))
    model, index = scene_model(tr, camera, width / height)
    data, option = mujoco.MjData(model), mujoco.MjvOption()
    out_path.parent.mkdir(parents=True, exist_ok=True)
    tmp = out_path.with_name(f".{out_path.stem}.partial{out_path.suffix}")
    if out_path.suffix.lower() == ".gif":
        writer_args = dict(format="GIF", duration=1000.0 / fps, loop=0)
    else:
        writer_args = dict(format="FFMPEG", fps=fps, codec="libx264", macro_block_size=2)
    renderer = gl.make_renderer(model, width, height, backend)
    t0 = time.perf_counter()
    try:
        renderer.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = 0
        with imageio.get_writer(tmp, mode="I", **writer_args) as writer:
            for k in tqdm(ks, unit="frame", desc="render", file=sys.stderr, disable=not progress):
                set_state(model, data, index, tr, k)
                cam = frame_camera(tr, k, camera, width / height)
                renderer.update_scene(data, camera=cam, scene_option=option)
                add_overlays(renderer.scene, tr, k)
                writer.append_data(renderer.render())
        os.replace(tmp, out_path)
    finally:
        renderer.close()
        tmp.unlink(missing_ok=True)
    elapsed = time.perf_counter() - t0
    return dict(frames=len(ks), fps=fps, render_s=elapsed, render_fps=len(ks) / elapsed)
