"""``mjx-radar render``: offscreen MuJoCo video (MP4 or GIF) of a saved trial.

Each frame copies the saved radar and drone states of one filter step into an
``MjData`` (``mj_kinematics``), lets :class:`mujoco.Renderer` build the scene, then
appends the step's overlays (:mod:`mjx_radar.viz.overlays`: radar and drone
markers, CKF estimates with 2-sigma ellipsoids, R2T / R2R rings, radar trails and
the MPPI samples coloured by weight) within ``scene.maxgeom``. The OpenGL backend
(EGL or OSMesa) is chosen by :mod:`mjx_radar.viz.gl`. The video is encoded to a
temporary file and renamed into place (:mod:`mjx_radar.io.atomic`).
"""

from __future__ import annotations

import dataclasses
import sys
import time
from pathlib import Path

import numpy as np

from mjx_radar.errors import InputError
from mjx_radar.io.atomic import atomic_write, check_writable
from mjx_radar.viz.overlays import draw_mujoco, step_overlay
from mjx_radar.viz.run_dir import Trial, load_trial

CAMERAS = ("top", "chase", "free")
FORMATS = (".mp4", ".gif")


@dataclasses.dataclass(frozen=True)
class RenderOptions:
    """How a trial is rendered.

    Attributes:
        fps: playback rate; ``None``: real time (frames per simulated second).
        camera: ``top`` (fixed, straight down, orthographic), ``chase`` (follows
            the drones) or ``free`` (oblique, orbiting the whole scene).
        width: image width [px], even, in [16, 4096].
        height: image height [px], even, in [16, 4096].
        frames: number of evenly spaced frames; ``None``: one per filter step.
        backend: ``egl`` or ``osmesa``; ``None``: ``MUJOCO_GL`` or automatic.
        progress: show a tqdm progress bar on stderr.
    """

    fps: float | None = None
    camera: str = "top"
    width: int = 640
    height: int = 480
    frames: int | None = None
    backend: str | None = None
    progress: bool = True

    def check(self) -> None:
        """Raises ``InputError`` (one line naming the option) on a bad value."""
        if self.camera not in CAMERAS:
            raise InputError(f"--camera = {self.camera!r}: must be one of {', '.join(CAMERAS)}")
        for name, value in (("--width", self.width), ("--height", self.height)):
            if not (16 <= value <= 4096 and value % 2 == 0):
                raise InputError(f"{name} = {value}: must be even and in [16, 4096]")
        if self.fps is not None and not 0 < self.fps <= 240:
            raise InputError(f"--fps = {self.fps}: must be in (0, 240]")

    @property
    def aspect(self) -> float:
        return self.width / self.height


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

    sc = tr.scene  # over terrain (the hfield ground) radars get a z joint to stand on it
    model, index = build_scene(
        tr.radar.shape[1],
        tr.target.shape[1],
        tr.dt,
        sc.obstacles.shapes,
        terrain=sc.ground.config,
        radar_z_joint=sc.ground.present,
        moving=sc.moving.vehicles,
    )
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
    ground = tr.scene.ground
    if ground.present:  # the radars' z joints: body origin on the ground (z - antenna)
        for i in range(tr.radar.shape[1]):
            adr = model.jnt_qposadr[model.joint(f"radar{i}/z").id]
            data.qpos[adr] = tr.radar[k, i, 2] - ground.antenna_height
    if tr.scene.moving.present:  # the vehicles at the step's time (k + 1) dt
        from mjx_radar.physics.moving_bodies import mocap_ids, mocap_pose
        from mjx_radar.world.moving import moving_params, pose

        mov = tr.scene.moving.vehicles
        xyz, quat = mocap_pose(mov, *pose(moving_params(mov, np.float32), (k + 1) * tr.dt))
        ids = mocap_ids(model, len(mov))
        data.mocap_pos[ids], data.mocap_quat[ids] = np.asarray(xyz), np.asarray(quat)
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


def _writer_args(out_path: Path, fps: float) -> dict:
    if out_path.suffix.lower() == ".gif":
        return dict(format="GIF", duration=1000.0 / fps, loop=0)
    return dict(format="FFMPEG", fps=fps, codec="libx264", macro_block_size=2)


def _render_frames(tr: Trial, ks: np.ndarray, opts: RenderOptions, append) -> None:
    """Renders the frames of steps ``ks`` and passes each ``[H, W, 3]`` image to ``append``."""
    import mujoco
    from tqdm import tqdm

    from mjx_radar.viz import gl

    model, index = scene_model(tr, opts.camera, opts.aspect)
    data, option = mujoco.MjData(model), mujoco.MjvOption()
    lo, hi = tr.bounds()
    scale = 0.012 * max(float(np.max(hi - lo)), 100.0)
    renderer = gl.make_renderer(model, opts.width, opts.height, opts.backend)
    try:
        renderer.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = 0
        bar = tqdm(ks, unit="frame", desc="render", file=sys.stderr, disable=not opts.progress)
        for k in bar:
            set_state(model, data, index, tr, k)
            cam = frame_camera(tr, k, opts.camera, opts.aspect)
            renderer.update_scene(data, camera=cam, scene_option=option)
            draw_mujoco(renderer.scene, step_overlay(tr, k), scale)
            append(renderer.render())
    finally:
        renderer.close()


def render_run(
    run_dir, trial: int = 0, out_path=None, options: RenderOptions | None = None
) -> dict:
    """Renders one saved trial to an MP4 (H.264) or GIF file, chosen by extension.

    Args:
        run_dir: a complete run directory.
        trial: trial index in ``[0, T)``.
        out_path: ``.mp4`` or ``.gif`` file; default ``run_dir/video.mp4``.
        options: :class:`RenderOptions`; default ``RenderOptions()``.

    Returns:
        ``{"frames", "fps", "render_s", "render_fps"}`` (time includes encoding).

    Raises:
        InputError: bad run directory, trial, option, extension or an unwritable
            ``out_path`` (all checked before the first frame).
    """
    import imageio.v2 as imageio

    opts = options or RenderOptions()
    out_path = Path(out_path) if out_path is not None else Path(run_dir) / "video.mp4"
    if out_path.suffix.lower() not in FORMATS:
        raise InputError(f"--out = {str(out_path)!r}: extension must be .mp4 or .gif")
    opts.check()
    tr = load_trial(run_dir, trial)
    ks = frame_steps(tr.steps, opts.frames)
    fps = float(opts.fps or max(len(ks) / (tr.steps * tr.dt), 0.5))
    check_writable(out_path, "--out")

    def write(tmp: str) -> None:
        with imageio.get_writer(tmp, mode="I", **_writer_args(out_path, fps)) as writer:
            _render_frames(tr, ks, opts, writer.append_data)

    t0 = time.perf_counter()
    atomic_write(out_path, write, keep_suffix=True)
    elapsed = time.perf_counter() - t0
    return dict(frames=len(ks), fps=fps, render_s=elapsed, render_fps=len(ks) / elapsed)
