"""The offline HTML viewer (``mjx-radar view``, ``Run.view``) on synthetic run directories.

The run directories are written by :func:`mjx_radar.rundir.writer.write_run` from
synthetic arrays of the right schema (no closed loop is compiled), for the bundled
``smoke`` scenario and, for the sizes, ``paper_3r4t`` (600 steps).
"""

from __future__ import annotations

import importlib
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

import mjx_radar
from mjx_radar.api.run_case import run_header
from mjx_radar.errors import InputError
from mjx_radar.rundir.results import METRIC_COLUMNS
from mjx_radar.rundir.writer import write_run
from mjx_radar.viz.view import viewer, viewer_budget
from mjx_radar.viz.view.viewer_traces import LAYERS

cli_main = importlib.import_module("mjx_radar.cli.main")
CHROMIUM = Path("/usr/bin/chromium")


def synthetic_run(out, scenario, trials=1, steps=None, seed=0, var=4.0, radar_z=None) -> Path:
    """A run directory of synthetic arrays (schema of rundir.results) for ``scenario``
    (position and velocity variances ``var``; radar z 1 m, or ``radar_z(xy [..., 2])``);
    the count metrics are random integers, ``targets_present`` the scenario's presence."""
    s = scenario
    rng = np.random.default_rng(seed)
    steps = steps or s.timing.steps
    every = s.timing.control_every
    c, n, m = steps // every, s.n_radars, s.n_targets
    h, k_s = s.mpc.horizon, min(32, s.mppi.samples)
    t = s.timing.dt_filter * np.arange(1, steps + 1)
    init = np.asarray(s.target_init, np.float32)
    target = init[None, None] + np.zeros((trials, steps, m, 6), np.float32)
    target[..., :3] += init[None, None, :, 3:] * t[None, :, None, None]
    target[..., 0] += 5.0 * np.arange(trials)[:, None, None]
    mean = (target + rng.normal(0, 1, target.shape)).reshape(trials, steps, 6 * m)
    cov = np.full((trials, steps, 6 * m), var, np.float32)
    radar = np.zeros((trials, steps, n, 6), np.float32)
    radar[..., 0] = 100.0 * np.arange(n) - 50.0 + 0.5 * t[None, :, None]
    radar[..., 1] = -80.0 + 0.2 * t[None, :, None] + 3.0 * np.arange(trials)[:, None, None]
    radar[..., 2] = 1.0 if radar_z is None else radar_z(radar[..., :2])
    base = radar[:, ::every, None, None, :, :2]  # [T, C, 1, 1, N, 2]
    steps_h = np.arange(1, h + 1)[None, None, None, :, None, None]
    sample_xy = (base + steps_h * rng.normal(0, 1, (trials, c, k_s, 1, n, 2))).astype(np.float32)
    res = {name: rng.uniform(1, 5, (trials, steps)) for name in METRIC_COLUMNS}
    for name in ("visible_pairs", "detections", "false_alarms"):
        res[name] = rng.integers(0, n * m, (trials, steps))
    res["targets_present"] = np.tile(_present(s, t).sum(-1), (trials, 1))
    res.update(
        lost=np.zeros((trials, steps)),
        diverged=np.zeros((trials, steps)),
        target=target,
        mean=mean.astype(np.float32),
        cov_diag=cov,
        radar=radar,
        control=np.zeros((trials, c, n, 2), np.float32),
        plan_xy=sample_xy[:, :, 0],
        sample_xy=sample_xy,
        sample_weight=rng.uniform(0, 1, (trials, c, k_s)).astype(np.float32),
        sample_cost=np.zeros((trials, c, k_s), np.float32),
        wall_s=1.0,
        compile_s=0.0,
        sim_s=1.0,
        control_hz=10.0,
    )
    head, toml = run_header(s), s.to_toml()
    return write_run(out, head, "ddr-sfim", s.seed, np.arange(trials), steps, res, toml=toml)


def _present(s, t) -> np.ndarray:
    """``[K, M]`` bool: target m present at time t[k] (``appear <= t < leave``, the spec)."""
    here = np.ones((len(t), s.n_targets), bool)
    for tm in s.target_motion:
        here[:, tm.target] = (tm.appear <= t) & (t < tm.leave)
    return here


@pytest.fixture(scope="module")
def smoke2(tmp_path_factory):
    """A two-trial smoke run directory."""
    out = tmp_path_factory.mktemp("view") / "smoke2"
    return synthetic_run(out, mjx_radar.load_scenario("smoke"), trials=2)


def _anim(fig, name: str) -> int:
    return [t.name for t in fig.data].index(name)


def test_frames_hold_the_run_arrays(smoke2):
    rd = viewer.load_run(smoke2)
    fig, info = viewer.build_figure(rd, max_frames=30, samples=5)
    ks = viewer_budget.frame_steps(rd.arrays["radar"].shape[1], 30)
    assert info.frames == len(ks) <= 30 and ks[-1] == rd.arrays["radar"].shape[1] - 1
    assert info.trials == (0, 1) and len(fig.frames) == 2 * len(ks)
    i_radar, i_drone = _anim(fig, "radars"), _anim(fig, "drones (truth)")
    names = {f.name: f for f in fig.frames}
    for t in (0, 1):
        for i, k in enumerate(ks):
            f = names[f"t{t}:{i}"]
            traces = dict(zip(f.traces, f.data, strict=True))
            for idx, key in ((i_radar, "radar"), (i_drone, "target")):
                got = np.column_stack([traces[idx].x, traces[idx].y, traces[idx].z])
                want = rd.arrays[key][t, k, :, :3]
                np.testing.assert_allclose(got, want, rtol=1e-6, atol=1e-4)
            samples = traces[_anim(fig, "MPPI samples")]
            assert np.isfinite(np.asarray(samples.x, float)).sum() == 5 * 2 * 8  # S * N * H
    np.testing.assert_allclose(  # the figure opens at the first frame of trial 0
        fig.data[i_radar].x, rd.arrays["radar"][0, ks[0], :, 0], rtol=1e-6
    )
    assert {t.name for t in fig.data} >= {name for name, _ in LAYERS}
    menu = [m for m in fig.layout.updatemenus if m.name == "trial"][0]
    assert [b.label for b in menu.buttons] == ["trial 0", "trial 1"]
    assert len(fig.layout.sliders) == 2 and [s.visible for s in fig.layout.sliders] == [True, False]
    assert "80 of 80 steps" not in fig.layout.title.text and "5 of 32" in fig.layout.title.text


def test_html_is_self_contained(smoke2, tmp_path):
    info = viewer.view(smoke2, tmp_path / "v.html", trial=[1], max_frames=20)
    html = info.path.read_text()
    assert info.trials == (1,) and info.bytes == info.path.stat().st_size < 15e6
    scripts = re.findall(r"<script[^>]*>(.*?)</script>", html, re.S | re.I)
    markup = re.sub(r"(<script[^>]*>).*?(</script>)", r"\1\2", html, flags=re.S | re.I)
    assert not re.search(r"<script[^>]*\bsrc\s*=", html, re.I)  # nothing loaded by URL
    assert not re.search(r"\b(?:src|href)\s*=", markup, re.I)  # no link, image, style sheet
    library = [s for s in scripts if "plotly.js v" in s[:2000]]
    assert len(library) == 1 and len(library[0]) > 2e6  # plotly.js inline
    ours = [s for s in scripts if "Plotly.newPlot" in s]  # the figure and the trial menu
    assert len(ours) == 1 and "http" not in ours[0]
    assert html.count("<script") >= 2 and "plotly_buttonclicked" in html


@pytest.mark.parametrize(
    "kwargs, text",
    [({"trial": 2}, "--trial = 2"), ({"trial": [0, -1]}, "--trial = -1"),
     ({"max_frames": 0}, "--max-frames"), ({"samples": -1}, "--samples")],
)  # fmt: skip
def test_bad_options(smoke2, tmp_path, kwargs, text):
    with pytest.raises(InputError, match=re.escape(text)):
        viewer.view(smoke2, tmp_path / "v.html", **kwargs)
    assert not (tmp_path / "v.html").exists()


def test_cli(smoke2, tmp_path, capsys):
    run = tmp_path / "run"
    shutil.copytree(smoke2, run)
    assert cli_main.main(["view", str(run)]) == 0
    out = capsys.readouterr().out
    assert str(run / "view.html") in out and "shown:" in out and (run / "view.html").is_file()
    assert cli_main.main(["view", str(run), "--trial", "7"]) == 2
    assert cli_main.main(["view", str(tmp_path / "nope")]) == 2
    assert cli_main.main(["view", str(run), "--out", str(tmp_path / "v.png")]) == 2
    (run / "metrics.parquet").write_bytes(b"garbage")
    assert cli_main.main(["view", str(run)]) == 2
    (run / "trajectories.npz").unlink()
    assert cli_main.main(["view", str(run)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 5 and all(line.startswith("error: ") for line in err)


def test_run_view_saves_first(smoke2, tmp_path):
    run = mjx_radar.Run.load(smoke2)
    path = run.view(tmp_path / "r.html", trial=0, max_frames=10, samples=2)
    assert path == tmp_path / "r.html" and path.stat().st_size < 15e6


def test_paper_sized_run_fits_an_email(tmp_path):
    s = mjx_radar.load_scenario("paper_3r4t")
    d = synthetic_run(tmp_path / "paper", s, trials=3)
    info = viewer.view(d)
    assert info.frames == 150 and info.steps == 600 and info.bytes < 15e6
    assert "150 of 600 steps (every 4)" in info.dropped()


@pytest.mark.skipif(not CHROMIUM.exists(), reason="no /usr/bin/chromium (Debian package "
                    "chromium): the headless-browser check of the HTML is skipped")  # fmt: skip
def test_headless_browser_draws_the_scene(smoke2, tmp_path):
    import imageio.v3 as iio

    html = viewer.view(smoke2, tmp_path / "v.html", max_frames=10).path
    png = tmp_path / "shot.png"
    cmd = [str(CHROMIUM), "--headless", "--no-sandbox", "--disable-gpu",
           "--disable-background-networking", "--disable-component-update", "--no-first-run",
           f"--user-data-dir={tmp_path / 'profile'}", f"--screenshot={png}",
           "--window-size=1000,800", "--virtual-time-budget=5000",
           html.resolve().as_uri()]  # fmt: skip
    subprocess.run(cmd, capture_output=True, timeout=120, check=False)
    assert png.is_file(), "chromium wrote no screenshot"
    rgb = iio.imread(png)[..., :3].astype(int)
    assert rgb.std() > 5, "blank page"

    def near(colour, tol=40):
        return int((np.abs(rgb - np.array(colour)).sum(-1) < tol).sum())

    assert near((0, 115, 255)) > 10, "no radar-blue pixels"  # radar 0 marker and legend
    assert near((217, 13, 13)) + near((230, 25, 25)) > 10, "no drone / ring red pixels"


def test_zero_samples_draws_none(smoke2):
    """``--samples 0`` draws no MPPI sample (``argsort(w)[-0:]`` had kept them all)."""
    from mjx_radar.viz.view.viewer_traces import frame_traces

    tr = viewer.load_trial(viewer.load_run(smoke2), 0)
    assert frame_traces(tr, 10, 0, None)[6]["x"].size == 0
    assert np.isfinite(frame_traces(tr, 10, 3, None)[6]["x"]).sum() == 3 * 2 * 8  # S * N * H


def _frame(fig, name: str):
    """``{layer name: trace}`` of frame ``name``."""
    f = {f.name: f for f in fig.frames}[name]
    return {fig.data[i].name: d for i, d in zip(f.traces, f.data, strict=True)}


def _xyz(trace) -> np.ndarray:
    return np.column_stack([np.asarray(trace.x, float), np.asarray(trace.y, float),
                            np.asarray(trace.z, float)])  # fmt: skip


@pytest.fixture(scope="module")
def hills(tmp_path_factory):
    """hills_4r4t, 200 steps, radars on the ground (z = terrain + antenna height)."""
    from mjx_radar.world.terrain import height_np

    s = mjx_radar.load_scenario("hills_4r4t")
    z = lambda xy: height_np(s.terrain, xy.reshape(-1, 2)).reshape(xy.shape[:-1]) + 2.0  # noqa: E731
    return synthetic_run(tmp_path_factory.mktemp("view") / "hills", s, steps=200, radar_z=z)


def test_terrain_surface_is_the_height_grid(hills, tmp_path):
    """The surface's nodes are grid nodes of the PNG's heights (read here with imageio, not
    the simulator's reader) and the radars stand on it at their recorded z."""
    import imageio.v3 as iio

    from mjx_radar.viz.view.viewer_world import terrain_nodes

    rd = viewer.load_run(hills)
    t = rd.scenario.terrain
    png = iio.imread(Path(mjx_radar.__file__).parent.parent / "scenarios" / t.path)
    grid = t.height_scale * np.flipud(png.astype(float)) / np.iinfo(png.dtype).max  # row 0 south
    dx = t.extent_x / (grid.shape[1] - 1)
    for max_nodes, every in ((160, 1), (7, None)):
        lo, hi = load_trial_bounds(rd)
        xs, ys, h, stride = terrain_nodes(t, lo, hi, max_nodes)
        assert len(xs) <= max_nodes and len(ys) <= max_nodes
        assert every is None and stride > 1 or stride == every
        j = np.round((xs + t.extent_x / 2) / dx).astype(int)
        i = np.round((ys + t.extent_y / 2) / dx).astype(int)
        np.testing.assert_allclose(xs, -t.extent_x / 2 + j * dx, atol=1e-9)  # on nodes
        np.testing.assert_allclose(h, grid[np.ix_(i, j)], atol=1e-9)
        assert xs[0] <= lo[0] and xs[-1] >= hi[0] and ys[0] <= lo[1] and ys[-1] >= hi[1]
    fig, info = viewer.build_figure(rd, max_frames=10, samples=2)
    surf = [d for d in fig.data if d.type == "surface"]
    assert len(surf) == 1 and surf[0].name == "terrain" and "terrain" in info.dropped()
    xs, ys, h, _ = terrain_nodes(t, lo, hi)
    np.testing.assert_allclose(np.asarray(surf[0].z, float), h, rtol=1e-6, atol=1e-4)
    np.testing.assert_allclose(np.asarray(surf[0].x, float), xs, atol=1e-3)
    radar = _xyz(_frame(fig, "t0:9")["radars"])
    np.testing.assert_allclose(radar, rd.arrays["radar"][0, -1, :, :3], atol=1e-3)
    rings = _xyz(_frame(fig, "t0:9")["R2T rings"])  # draped: 0.5 m above the ground
    ok = np.isfinite(rings[:, 0])
    from mjx_radar.world.terrain import height_np

    np.testing.assert_allclose(rings[ok, 2], height_np(t, rings[ok, :2]) + 0.5, atol=1e-3)
    assert fig.layout.scene.zaxis.range[1] > h.max()


def load_trial_bounds(rd):
    return viewer.load_trial(rd, 0).bounds()


def test_fixed_sites_drawn_apart(tmp_path):
    s = mjx_radar.load_scenario("mixed_6r4t")
    rd = viewer.load_run(synthetic_run(tmp_path / "mixed", s, steps=80))
    fig, _ = viewer.build_figure(rd, max_frames=5, samples=2)
    fixed = np.array([0, 1])  # mobile = false in the scenario file
    for i, k in enumerate(viewer_budget.frame_steps(80, 5)):
        f = _frame(fig, f"t0:{i}")
        want = rd.arrays["radar"][0, k, :, :3]
        sites, mobile = _xyz(f["fixed sites"]), _xyz(f["radars"])
        np.testing.assert_allclose(sites[fixed], want[fixed], atol=1e-3)
        np.testing.assert_allclose(mobile[2:], want[2:], atol=1e-3)
        assert np.isnan(sites[2:]).all() and np.isnan(mobile[fixed]).all()
    traces = {d.name: d for d in fig.data}
    assert traces["fixed sites"].marker.symbol == "cross" != traces["radars"].marker.symbol
    assert traces["fixed sites"].showlegend is not False
    smoke_fig, _ = viewer.build_figure(
        viewer.load_run(
            synthetic_run(tmp_path / "smoke", mjx_radar.load_scenario("smoke"), steps=40)
        ),
        max_frames=3,
    )
    assert {d.name: d for d in smoke_fig.data}["fixed sites"].showlegend is False


def test_absent_drones_hidden_and_counts_panel(tmp_path):
    """raid_4r8t: drones 0-3 leave at 36 s, 4-7 appear at 15 s; each frame hides exactly the
    absent ones (truth, estimate, axes, lines of sight); the present count is plotted."""
    s = mjx_radar.load_scenario("raid_4r8t").replace(timing={"steps": 1600})
    d = synthetic_run(tmp_path / "raid", s, steps=1600)
    rd = viewer.load_run(d)
    fig, _ = viewer.build_figure(rd, max_frames=40, samples=0)
    ks = viewer_budget.frame_steps(1600, 40)
    t = s.timing.dt_filter * (ks + 1)
    here = _present(s, t)
    assert here.all(1).sum() < len(ks) and here[:, :4].any() and here[:, 4:].any()
    assert {tuple(h) for h in here} >= {(True,) * 4 + (False,) * 4, (True,) * 8,
                                        (False,) * 4 + (True,) * 4}  # fmt: skip
    for i, k in enumerate(ks):
        f = _frame(fig, f"t0:{i}")
        truth, est = _xyz(f["drones (truth)"]), _xyz(f["estimates"])
        np.testing.assert_array_equal(np.isfinite(truth).all(1), here[i])
        np.testing.assert_array_equal(np.isfinite(est).all(1), here[i])
        np.testing.assert_allclose(truth[here[i]], rd.arrays["target"][0, k, here[i], :3],
                                   atol=1e-3)  # fmt: skip
        los = _xyz(f["lines of sight"]).reshape(s.n_radars, s.n_targets, 3, 3)
        np.testing.assert_array_equal(
            np.isfinite(los[:, :, 1]).all(-1), np.broadcast_to(here[i], (s.n_radars, s.n_targets))
        )
        assert np.isfinite(_xyz(f["2-sigma axes"])).all(1).sum() == 3 * 2 * here[i].sum()
    import pandas as pd

    metrics = pd.read_parquet(d / "metrics.parquet")
    present = {t.name: t for t in fig.data}["targets present"]
    np.testing.assert_array_equal(present.y, metrics.sort_values("step")["targets_present"])
    assert "detections" not in {t.name for t in fig.data}  # detection off in raid


def test_detection_counts_equal_the_metrics(tmp_path):
    import pandas as pd

    s = mjx_radar.load_scenario("clutter_3r4t")
    d = synthetic_run(tmp_path / "clutter", s, trials=2, steps=120)
    metrics = pd.read_parquet(d / "metrics.parquet")
    fig, _ = viewer.build_figure(d, max_frames=12, samples=2)
    ks = viewer_budget.frame_steps(120, 12)
    names = ["detections", "visible pairs", "false alarms"]
    traces = [t for t in fig.data if t.type == "scatter" and t.name in [*names, "targets present"]]
    assert [t.name for t in traces] == names * 2  # per trial; no targets present (constant)
    for j in (0, 1):
        rows = metrics[metrics.trial == j].sort_values("step")
        for tr, col in zip(traces[3 * j:3 * j + 3], ("detections", "visible_pairs",
                                                       "false_alarms"), strict=True):  # fmt: skip
            np.testing.assert_array_equal(tr.y, rows[col].to_numpy(np.float32))
            np.testing.assert_allclose(tr.x, rows["time_s"], rtol=1e-6)
            assert tr.xaxis == "x2" and tr.yaxis == "y2" and tr.visible == (j == 0)
        for i, k in enumerate(ks):
            cursor = _frame(fig, f"t{j}:{i}")["current step (counts)"]
            np.testing.assert_array_equal(
                cursor.y, rows[["detections", "visible_pairs", "false_alarms"]].to_numpy()[k]
            )
    menu = [m for m in fig.layout.updatemenus if m.name == "trial"][0]
    shown = dict(zip(menu.buttons[1].args[1], menu.buttons[1].args[0]["visible"], strict=True))
    idx = [i for i, t in enumerate(fig.data) if t.name in names]
    assert [shown[i] for i in idx] == [False] * 3 + [True] * 3  # trial 1 shows its own
    assert (
        "xaxis2"
        not in viewer.build_figure(
            viewer.load_run(
                synthetic_run(tmp_path / "smoke", mjx_radar.load_scenario("smoke"), steps=40)
            ),
            max_frames=3,
        )[0].layout
    )


def test_waypoint_routes(tmp_path):
    s = mjx_radar.load_scenario("waypoints_3r4t")
    fig, _ = viewer.build_figure(synthetic_run(tmp_path / "wp", s, steps=80), max_frames=3)
    route = _xyz({t.name: t for t in fig.data}["waypoint routes"])
    pieces = np.split(route, np.flatnonzero(np.isnan(route[:, 0])) + 1)[:-1]
    assert len(pieces) == 4 and {t.name: t for t in fig.data}["waypoint routes"].line.dash == "dot"
    for tm, piece in zip(s.target_motion, pieces, strict=True):
        want = [s.target_init[tm.target][:3], *tm.waypoints, *tm.waypoints[:1] * tm.loop]
        np.testing.assert_allclose(piece[:-1], want, atol=1e-3)
