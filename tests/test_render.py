"""``mjx-radar render`` / ``snapshot``: offscreen video, heat map and bad input (CPU)."""

from __future__ import annotations

import importlib
from pathlib import Path

import numpy as np
import pytest

from mjx_radar.estimation.information import fisher
from mjx_radar.viz import gl
from mjx_radar.viz.overlays import RADAR_RGB
from mjx_radar.viz.render import frame_camera, scene_model, set_state
from mjx_radar.viz.run_dir import load_trial

cli_main = importlib.import_module("mjx_radar.cli.main")
pytestmark = pytest.mark.filterwarnings("ignore:os.fork:RuntimeWarning")  # ffmpeg subprocess
STEPS = 20
SIZE = (320, 240)  # width, height
SMOKE = Path(__file__).resolve().parents[1] / "scenarios" / "smoke.toml"


def _gl_backend() -> str | None:
    """The first of MUJOCO_GL / auto / osmesa / egl that can create a context."""
    import os

    import mujoco

    model = mujoco.MjModel.from_xml_string("<mujoco><worldbody/></mujoco>")
    for backend in dict.fromkeys([os.environ.get("MUJOCO_GL"), gl.auto_backend(), "osmesa", "egl"]):
        if backend not in gl.BACKENDS:
            continue
        try:
            gl.make_renderer(model, 64, 64, backend).close()
            return backend
        except Exception:  # noqa: BLE001 - any failure means "not usable here"
            continue
    return None


@pytest.fixture(scope="module")
def cli():
    """The ``mjx-radar`` entry module (``cli.main([...])`` returns the exit code)."""
    return cli_main


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory, cli):
    out = tmp_path_factory.mktemp("render") / "run"
    argv = ["run", str(SMOKE), "--steps", str(STEPS), "--out", str(out)]
    # 2 trials: the program of test_closed_loop's, test_viz_edges' and the examples'
    # analytic runs (a trial's numbers do not depend on its batch mates); trial 0 is drawn
    assert cli.main([*argv, "--rollouts", "analytic", "--trials", "2"]) == 0
    return out


@pytest.fixture(scope="module")
def video(run_dir, cli):
    import imageio.v2 as imageio

    backend = _gl_backend()
    if backend is None:
        pytest.skip("neither OSMesa nor EGL can create an OpenGL context (apt install libosmesa6)")
    path = run_dir / "top.mp4"
    argv = ["render", str(run_dir), "--out", str(path), "--gl", backend]
    assert cli.main([*argv, "--width", str(SIZE[0]), "--height", str(SIZE[1])]) == 0
    with imageio.get_reader(path) as reader:
        return np.stack([np.asarray(f) for f in reader])


def test_video_decodes_with_expected_frames(video):
    assert video.shape == (STEPS, SIZE[1], SIZE[0], 3)
    assert all(f.std() > 5 for f in video), "blank frame"
    diffs = [
        np.abs(a.astype(int) - b.astype(int)).mean()
        for a, b in zip(video[:-1], video[1:], strict=True)
    ]
    assert min(diffs) > 0 and np.abs(video[-1].astype(int) - video[0]).mean() > 0.1


def _marker_centroid(frame, rgb, near, radius=25):
    """Centroid (col, row) of saturated pixels of the marker's hue within ``radius`` px.

    Lighting brightens the marker, so pixels are matched by their strongest and
    weakest channel (the ground is a light grey, the lines thin and blended).
    """
    rows, cols = np.mgrid[: frame.shape[0], : frame.shape[1]]
    window = (np.abs(cols - near[0]) < radius) & (np.abs(rows - near[1]) < radius)
    hue = (frame.argmax(-1) == np.argmax(rgb)) & (frame.argmin(-1) == np.argmin(rgb))
    sel = window & hue & (frame.max(-1) > 180) & (frame.min(-1) < 70)
    assert sel.sum() >= 10, "radar marker not found near its projected position"
    return np.array([cols[sel].mean(), rows[sel].mean()])


def project_points(tr, k: int, points, camera="top", width=640, height=480) -> np.ndarray:
    """``[P, 2]`` pixel (column, row) of world ``points[P, 3]`` in frame ``k`` (no GL needed).

    Uses the camera that ``mjv_updateScene`` builds for the frame, so it checks the
    renderer against MuJoCo's own camera, not against a re-derivation.
    """
    import mujoco

    model, index = scene_model(tr, camera, width / height)
    data = mujoco.MjData(model)
    set_state(model, data, index, tr, k)
    scene = mujoco.MjvScene(model, maxgeom=1000)
    cam = frame_camera(tr, k, camera, width / height)
    catmask = int(mujoco.mjtCatBit.mjCAT_ALL)
    mujoco.mjv_updateScene(model, data, mujoco.MjvOption(), None, cam, catmask, scene)
    glc = mujoco.mjv_averageCamera(scene.camera[0], scene.camera[1])
    forward, up = np.asarray(glc.forward), np.asarray(glc.up)
    v = np.asarray(points, np.float64) - np.asarray(glc.pos)
    scale = glc.frustum_near / (v @ forward) if not glc.orthographic else 1.0
    x, y = (v @ np.cross(forward, up)) * scale, (v @ up) * scale
    half_w = glc.frustum_width or 0.5 * (glc.frustum_top - glc.frustum_bottom) * width / height
    col = (x - glc.frustum_center + half_w) / (2 * half_w) * width
    row = (glc.frustum_top - y) / (glc.frustum_top - glc.frustum_bottom) * height
    return np.stack([col, row], axis=-1)


def test_radar_pixels_follow_radar_state(run_dir, video):
    tr = load_trial(run_dir, 0)
    n = int(np.argmax(np.linalg.norm(tr.radar[-1, :, :2] - tr.radar[0, :, :2], axis=1)))
    rgb = RADAR_RGB[n % len(RADAR_RGB)]
    found, expected = [], []
    for k in (0, STEPS - 1):
        px = project_points(tr, k, tr.radar[k, n : n + 1, :3], "top", *SIZE)[0]
        found.append(_marker_centroid(video[k], rgb, px))
        expected.append(px)
        assert np.linalg.norm(found[-1] - px) < 4.0, (k, found[-1], px)
    moved_px, moved_world = found[1] - found[0], tr.radar[-1, n, :2] - tr.radar[0, n, :2]
    if np.linalg.norm(expected[1] - expected[0]) > 2.0:  # image y points down
        assert moved_px @ np.array([moved_world[0], -moved_world[1]]) > 0


def test_gif_and_subsampled_frames(run_dir, video, cli):
    import imageio.v2 as imageio

    path = run_dir / "clip.gif"
    argv = ["render", str(run_dir), "--out", str(path), "--frames", "5", "--camera", "free"]
    assert cli.main([*argv, "--width", "96", "--height", "64"]) == 0
    frames = imageio.mimread(path)
    assert len(frames) == 5 and frames[0].shape[:2] == (64, 96)


def test_fim_heatmap_matches_direct_sfim(run_dir):
    from mjx_radar.viz.snapshot import fim_heatmap

    radars = np.array([[-100.0, 20.0, 0.0], [150.0, -40.0, 0.0], [30.0, 200.0, 0.0]])
    xs, ys, z, c = np.linspace(-300, 300, 7), np.linspace(-200, 250, 5), 60.0, 7.285e-10
    heat = fim_heatmap(radars, xs, ys, z, c)
    assert heat.shape == (5, 7) and np.all(np.isfinite(heat))
    for i, j in ((0, 0), (2, 3), (4, 6), (1, 5)):
        target = np.array([[xs[j], ys[i], z]])
        direct = float(fisher.logdet(fisher.sfim(radars, target, c))[0])
        assert heat[i, j] == pytest.approx(direct, rel=1e-4, abs=1e-4)


def test_snapshot_writes_png(run_dir, cli):
    path = run_dir / "snap.png"
    assert cli.main(["snapshot", str(run_dir), "--step", str(STEPS), "--out", str(path)]) == 0
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize(
    "argv, needle",
    [
        (["render", "{missing}", "--out", "{out}.mp4"], "RUN_DIR"),
        (["render", "{run}", "--trial", "3", "--out", "{out}.mp4"], "--trial"),
        (["render", "{run}", "--frames", "999", "--out", "{out}.mp4"], "--frames"),
        (["render", "{run}", "--out", "{out}.avi"], "--out"),
        (["snapshot", "{run}", "--step", "0", "--out", "{out}.png"], "--step"),
        (["snapshot", "{run}", "--step", str(STEPS + 1), "--out", "{out}.png"], "--step"),
        (["snapshot", "{missing}", "--step", "1", "--out", "{out}.png"], "RUN_DIR"),
    ],
)
def test_bad_input_exits_2_without_output(run_dir, tmp_path, capsys, cli, argv, needle):
    fill = dict(run=run_dir, missing=tmp_path / "nope", out=tmp_path / "result")
    assert cli.main([a.format(**fill) for a in argv]) == 2
    err = capsys.readouterr().err
    assert needle in err and "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert not list(tmp_path.glob("result*")) and not list(tmp_path.glob(".result*"))
