"""Hard edges of ``render`` / ``snapshot``: damaged run directories, unwritable outputs,
obstacle footprints from the world SDF (boxes, rotated boxes, cylinders, meshes)."""

from __future__ import annotations

import importlib
import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from mjx_radar.errors import InputError
from mjx_radar.viz import overlays
from mjx_radar.viz.run_dir import load_run, load_trial
from mjx_radar.world.obstacles import footprint_sdf

cli_main = importlib.import_module("mjx_radar.cli.main")
ROOT = Path(__file__).resolve().parents[1]
STEPS = 8
TRIALS = 2  # the program of test_closed_loop's and the examples' analytic runs


@pytest.fixture(scope="module")
def cli():
    """The ``mjx-radar`` entry module (``cli.main([...])`` returns the exit code)."""
    return cli_main


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory, cli):
    out = tmp_path_factory.mktemp("edges") / "run"
    argv = [
        "run",
        str(ROOT / "scenarios" / "smoke.toml"),
        "--steps",
        str(STEPS),
        "--rollouts",
        "analytic",
        "--trials",
        str(TRIALS),
        "--out",
        str(out),
    ]
    assert cli.main(argv) == 0
    return out


def _copy(run_dir: Path, dst: Path) -> Path:
    shutil.copytree(run_dir, dst)
    return dst


def _npz_without(d: Path, key: str, **replace) -> None:
    with np.load(d / "trajectories.npz") as z:
        arrays = {k: z[k] for k in z.files if k != key}
    np.savez(d / "trajectories.npz", **(arrays | replace))


def _json_edit(d: Path, **changes) -> None:
    meta = json.loads((d / "run.json").read_text())
    for k, v in changes.items():
        if v is None:
            meta.pop(k)
        else:
            meta[k] = v
    (d / "run.json").write_text(json.dumps(meta))


def _flip_middle(d: Path) -> None:
    p = d / "trajectories.npz"
    b = bytearray(p.read_bytes())
    mid = len(b) // 2
    b[mid : mid + 64] = bytes(x ^ 0xFF for x in b[mid : mid + 64])
    p.write_bytes(bytes(b))


NO_SOURCE = {"scenario_file": "/nope.toml", "source_scenario": "/nope.toml"}
DAMAGE = {  # name -> (damage(d), text the error line must hold)
    "missing_dir": (lambda d: shutil.rmtree(d), "no such directory"),
    "no_run_json": (lambda d: (d / "run.json").unlink(), "run.json"),
    "no_npz": (lambda d: (d / "trajectories.npz").unlink(), "trajectories.npz"),
    "garbage_npz": (
        lambda d: (d / "trajectories.npz").write_bytes(b"not a zip" * 50),
        "trajectories.npz",
    ),
    "truncated_npz": (
        lambda d: (d / "trajectories.npz").write_bytes(
            (d / "trajectories.npz").read_bytes()[:-200]
        ),
        "trajectories.npz",
    ),
    "corrupt_member": (_flip_middle, "trajectories.npz"),
    "npz_missing_key": (lambda d: _npz_without(d, "radar"), "'radar'"),
    "npz_bad_shape": (
        lambda d: _npz_without(d, "radar", radar=np.zeros((TRIALS, STEPS, 2, 5))),
        "'radar'",
    ),
    "garbage_json": (lambda d: (d / "run.json").write_text("{not json"), "run.json"),
    "json_list": (lambda d: (d / "run.json").write_text("[1, 2]"), "run.json"),
    "json_missing_key": (lambda d: _json_edit(d, r2t=None), "'r2t'"),
    "json_bad_value": (lambda d: _json_edit(d, dt_filter="fast"), "'dt_filter'"),
    "no_scenario": (
        lambda d: ((d / "scenario.toml").unlink(), _json_edit(d, **NO_SOURCE)),
        "scenario.toml",
    ),
    "bad_scenario": (
        lambda d: (
            (d / "scenario.toml").write_text("n_radars = 'x'\n"),
            _json_edit(d, **NO_SOURCE),
        ),
        "scenario.toml",
    ),
}


@pytest.mark.parametrize("damage", list(DAMAGE))
@pytest.mark.parametrize("command", ["render", "snapshot"])
def test_damaged_run_dir_one_line_exit_2(run_dir, tmp_path, capsys, cli, damage, command):
    d = _copy(run_dir, tmp_path / "copy")
    fn, needle = DAMAGE[damage]
    fn(d)
    out = tmp_path / ("out.mp4" if command == "render" else "out.png")
    argv = [command, str(d), "--out", str(out)] + (["--step", "1"] if command == "snapshot" else [])
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    assert needle in lines[0], lines[0]
    assert not out.exists() and not list(tmp_path.glob(".out*"))


def test_damage_raises_input_error_from_load_run(run_dir, tmp_path):
    for name, (fn, needle) in DAMAGE.items():
        d = _copy(run_dir, tmp_path / name)
        fn(d)
        with pytest.raises(InputError, match=None) as info:
            load_run(d)
        assert needle in str(info.value), (name, str(info.value))


def test_scenario_falls_back_to_scenario_file(run_dir, tmp_path):
    d = _copy(run_dir, tmp_path / "copy")
    (d / "scenario.toml").unlink()
    run = load_run(d)  # run.json's source_scenario is the bundled smoke.toml
    assert run.scenario.name == "smoke" and run.trials == TRIALS
    assert load_trial(run).steps == STEPS


@pytest.mark.parametrize("command", ["render", "snapshot"])
@pytest.mark.parametrize("where", ["under_a_file", "proc", "is_dir"])
def test_unwritable_out_fails_before_drawing(run_dir, tmp_path, capsys, cli, command, where):
    import mjx_radar.viz.render as render
    import mjx_radar.viz.snapshot as snapshot

    ext = ".mp4" if command == "render" else ".png"
    (tmp_path / "file").write_text("")
    (tmp_path / f"dir{ext}").mkdir()
    out = {
        "under_a_file": tmp_path / "file" / f"x{ext}",
        "proc": Path(f"/proc/mjx_radar_no/x{ext}"),
        "is_dir": tmp_path / f"dir{ext}",
    }[where]

    def boom(*a, **k):
        raise AssertionError("drawing started before the output was checked")

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(render, "_render_frames", boom)
        mp.setattr(snapshot, "snapshot_figure", boom)
        argv = [command, str(run_dir), "--out", str(out)]
        assert cli.main(argv + (["--step", "1"] if command == "snapshot" else [])) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--out" in err[0], err


# --- obstacle footprints ---------------------------------------------------------------

MESH = ROOT / "scenarios" / "meshes" / "hex_tower.obj"


def _obstacle_run(run_dir: Path, d: Path) -> tuple[Path, dict]:
    """A copy of the run whose scenario.toml holds a box, a rotated box, a cylinder and a
    mesh (copied into DIR/meshes, path relative to DIR), placed inside the figure and
    away from the radars' paths."""
    d = _copy(run_dir, d)
    (d / "meshes").mkdir()
    shutil.copy(MESH, d / "meshes" / "hex_tower.obj")
    tr = load_trial(d)
    lo, hi = tr.bounds()
    radar_xy = tr.radar[..., :2].reshape(-1, 2)
    cands = [lo + (hi - lo) * np.array([u, v]) for u in np.linspace(0.15, 0.85, 6)
             for v in np.linspace(0.15, 0.85, 6)]  # fmt: skip
    far = sorted(cands, key=lambda p: -np.min(np.linalg.norm(radar_xy - p, axis=1)))
    picks = []
    for p in far:  # 4 well separated spots, far from every radar position
        if all(np.linalg.norm(p - q) > 0.2 * np.max(hi - lo) for q in picks):
            picks.append(p)
        if len(picks) == 4:
            break
    (b, r, c, m) = [tuple(round(float(x), 2) for x in p) for p in picks]
    radars = ", ".join(f"[{x:.3f}, {y:.3f}, {th:.3f}]" for x, y, _, th, *_ in tr.radar[0])
    text = (ROOT / "scenarios" / "smoke.toml").read_text()
    text = text.replace("[timing]", f"radars = [{radars}]\n\n[timing]", 1)
    text += f"""
[[obstacles]]
kind = "box"
pos = [{b[0]}, {b[1]}, 10.0]
size = [30.0, 30.0, 10.0]
[[obstacles]]
kind = "box"
pos = [{r[0]}, {r[1]}, 10.0]
size = [40.0, 10.0, 10.0]
yaw = 0.7
[[obstacles]]
kind = "cylinder"
pos = [{c[0]}, {c[1]}, 10.0]
size = [25.0, 10.0]
[[obstacles]]
kind = "mesh"
path = "meshes/hex_tower.obj"
pos = [{m[0]}, {m[1]}, 0.0]
"""
    (d / "scenario.toml").write_text(text)
    return d, dict(box=b, rotated=r, cylinder=c, mesh=m)


@pytest.fixture(scope="module")
def obstacle_run(run_dir, tmp_path_factory):
    return _obstacle_run(run_dir, tmp_path_factory.mktemp("obs") / "run")


def test_snapshot_footprints_equal_world_sdf(obstacle_run):
    import matplotlib.pyplot as plt

    from mjx_radar.viz.snapshot import snapshot_figure

    d, where = obstacle_run
    tr = load_trial(d)
    kinds = [o.kind for o in tr.scene.obstacles.shapes]
    assert kinds == ["box", "box", "cylinder", "mesh"]  # DIR/scenario.toml, not smoke.toml
    assert Path(tr.scene.obstacles.shapes[3].path) == (d / "meshes" / "hex_tower.obj").resolve()
    fig = snapshot_figure(tr, STEPS - 1, grid=8)
    try:
        (img,) = [im for im in fig.axes[0].images if im.get_gid() == "obstacles"]
        mask = ~np.ma.getmaskarray(img.get_array())
        x0, x1, y0, y1 = img.get_extent()
    finally:
        plt.close(fig)
    ny, nx = mask.shape
    dx, dy = (x1 - x0) / nx, (y1 - y0) / ny
    gx, gy = np.meshgrid(x0 + dx * (np.arange(nx) + 0.5), y0 + dy * (np.arange(ny) + 0.5))
    pts = np.stack([gx, gy], -1)
    sdf = np.min([footprint_sdf(o, pts) for o in tr.scene.obstacles.shapes], axis=0)
    np.testing.assert_array_equal(mask, sdf <= 0)  # cell centres: exactly the SDF footprint
    for name, obs in zip(
        ("box", "rotated", "cylinder", "mesh"), tr.scene.obstacles.shapes, strict=True
    ):
        filled = mask & (footprint_sdf(obs, pts) <= 0)
        assert filled.sum() > 20, name  # each obstacle drawn, not just one
    # A box corner: inside the box, outside the circle of its half-size (the old drawing).
    box = tr.scene.obstacles.shapes[0]
    corner = np.asarray(box.pos[:2]) + 0.9 * np.asarray(box.size[:2])
    j, i = int((corner[0] - x0) // dx), int((corner[1] - y0) // dy)
    centre = np.array([gx[i, j], gy[i, j]])
    assert np.linalg.norm(centre - box.pos[:2]) > box.size[0]  # the circle misses it
    assert mask[i, j]


def test_snapshot_and_render_with_obstacles(obstacle_run, cli, capsys):
    d, _ = obstacle_run
    assert cli.main(["snapshot", str(d), "--step", "2", "--grid", "16"]) == 0
    assert (d / "snapshot_step2.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    argv = ["render", str(d), "--frames", "2", "--width", "64", "--height", "48"]
    code = cli.main([*argv, "--out", str(d / "v.gif"), "--camera", "free"])
    if code != 0 and "OpenGL" in capsys.readouterr().err:
        pytest.skip("no OpenGL context here")
    assert code == 0 and (d / "v.gif").stat().st_size > 0
    assert not list(d.glob(".*part*"))


def test_step_overlay_orders_samples_by_weight(run_dir):
    tr = load_trial(run_dir)
    k = STEPS - 1
    ov = overlays.step_overlay(tr, k)
    c = tr.control_index(k)
    assert np.all(np.diff(ov.weight) >= 0) and ov.weight[-1] == pytest.approx(1.0)
    (j,) = np.flatnonzero(np.all(tr.sample_xy[c] == ov.samples[-1], axis=(1, 2, 3)))[:1]
    assert tr.sample_weight[c, j] == tr.sample_weight[c].max()  # the best sample drawn last
    assert sorted(map(bytes, ov.samples)) == sorted(map(bytes, tr.sample_xy[c]))  # a permutation
    assert ov.trail.shape[1:] == (tr.radar.shape[1], 3)
    np.testing.assert_array_equal(ov.trail[0], tr.radar[k, :, :3])
    assert ov.r2t == tr.meta["r2t"] and ov.radar_rgb.shape == (tr.radar.shape[1], 3)


def test_matplotlib_overlay_draws_every_marker(run_dir):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tr = load_trial(run_dir)
    ov = overlays.step_overlay(tr, 3)
    fig, ax = plt.subplots()
    try:
        lines = overlays.draw_matplotlib(ax, ov)
        n, m = tr.radar.shape[1], tr.target.shape[1]
        assert len(lines.get_segments()) == len(ov.weight) * n
        assert len(ax.patches) == 2 * n + m  # R2T + R2R rings, 2-sigma ellipses
        assert len(ax.lines) == 2 * n + 2 * m  # trails, radar markers, drones, estimates
    finally:
        plt.close(fig)


def test_view_of_a_run_whose_truth_and_radars_hold_nan(run_dir, tmp_path, cli):
    """A diverged run's NaN positions draw as gaps; the scene's ranges come from the finite
    values (plotly refused a NaN axis range: a ValueError traceback)."""
    import warnings

    d = _copy(run_dir, tmp_path / "nan")
    with np.load(d / "trajectories.npz") as z:
        target, radar = z["target"].astype(float), z["radar"].astype(float)
    target[0] = np.nan
    radar[0, 3:] = np.nan
    _npz_without(d, "target", target=target)
    _npz_without(d, "radar", radar=radar)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        assert cli.main(["view", str(d), "--out", str(tmp_path / "v.html")]) == 0
    assert (tmp_path / "v.html").stat().st_size > 0
