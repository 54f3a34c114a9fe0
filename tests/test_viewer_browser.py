"""The viewers in a real headless Chromium driven by Playwright (DevTools protocol).

Playwright's own browser download is not used: it drives the system's
``/usr/bin/chromium`` (Debian package ``chromium``; ``.ci/run`` installs it). Skipped,
with the reason, where either is missing.

- The offline HTML (``mjx-radar view --out``): the time slider is clicked, the scene's
  data read back from plotly (``_fullData``) must equal the run's arrays at that frame's
  step, and the screenshot must show the radars', drones' and 2-sigma axes' colours at
  the pixels where plotly's own camera (model, view and projection matrices and data
  scale, read back from the page) projects the run's positions; then the trial menu is
  clicked and the same checks hold for the other trial. Every request the page makes is
  logged through a route: only the file itself may be loaded.
- The live page (``run --view``): fed two segments of synthetic records, it redraws
  the drones where the records put them; it loads nothing but its own server's URLs.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import mjx_radar
from mjx_radar.viz.overlays import RADAR_RGB, TARGET_RGB
from mjx_radar.viz.view import viewer, viewer_budget

CHROMIUM = Path("/usr/bin/chromium")
pytestmark = pytest.mark.skipif(
    not CHROMIUM.exists(), reason="no /usr/bin/chromium (Debian package chromium): the "
    "headless-browser checks of the viewers are skipped")  # fmt: skip
sync_api = pytest.importorskip("playwright.sync_api", reason="playwright is not installed "
                               "(pip install -e .[test])")  # fmt: skip
sys.path.insert(0, str(Path(__file__).parent))
from test_viewer import synthetic_run  # noqa: E402

FRAMES = 10
AXIS_RGB = (200, 160, 0)  # "2-sigma axes" (viewer_traces.layer_styles)
HIDE = ("radar trails", "R2T rings", "MPPI samples", "plan", "lines of sight")

STATE_JS = """() => {
  var g = document.querySelector('.js-plotly-plot'), sc = g._fullLayout.scene._scene;
  var c = sc.glplot.cameraParams, r = sc.glplot.canvas.getBoundingClientRect();
  return {model: Array.from(c.model), view: Array.from(c.view), proj: Array.from(c.projection),
          scale: Array.from(sc.dataScale), box: [r.left, r.top, r.width, r.height],
          ranges: ['xaxis', 'yaxis', 'zaxis'].map(function (a) {
            return g._fullLayout.scene[a].range; }),
          active: g._fullLayout.sliders.map(function (s) { return s.active; }),
          shown: g._fullLayout.sliders.map(function (s) { return s.visible; }),
          data: g._fullData.map(function (d) { return {name: d.name,
            xyz: d.z ? [Array.from(d.x), Array.from(d.y), Array.from(d.z)] : null}; })};
}"""


@pytest.fixture(scope="module")
def browser():
    with sync_api.sync_playwright() as p:
        b = p.chromium.launch(executable_path=str(CHROMIUM), args=["--no-sandbox"])
        yield b
        b.close()


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    """Two trials of smoke with 2-sigma = 40 m (axes long enough to find on screen)."""
    out = tmp_path_factory.mktemp("browser") / "smoke2"
    return synthetic_run(out, mjx_radar.load_scenario("smoke"), trials=2, var=400.0)


def project(state: dict, points: np.ndarray) -> np.ndarray:
    """``[P, 2]`` CSS pixels of ``[P, 3]`` data points, as plotly's gl3d scene projects them
    (column-major 4x4 matrices: clip = P V M [s * p, 1])."""
    mat = {k: np.array(state[k]).reshape(4, 4) for k in ("model", "view", "proj")}
    v = np.column_stack([np.asarray(points) * state["scale"], np.ones(len(points))])
    c = v @ mat["model"] @ mat["view"] @ mat["proj"]
    left, top, w, h = state["box"]
    return np.column_stack([left + (0.5 + 0.5 * c[:, 0] / c[:, 3]) * w,
                            top + (0.5 - 0.5 * c[:, 1] / c[:, 3]) * h])  # fmt: skip


def colour_near(rgb: np.ndarray, xy, colour, r: int = 3, tol: int = 60) -> int:
    """Pixels within ``r`` of ``xy`` whose colour is within ``tol`` (L1) of ``colour``."""
    x, y = (int(round(v)) for v in xy)
    patch = rgb[max(y - r, 0) : y + r + 1, max(x - r, 0) : x + r + 1].astype(int)
    return int((np.abs(patch - np.asarray(colour)).sum(-1) < tol).sum())


def check_scene(page, rd, trial: int, ks) -> None:
    """The scene at the active frame of ``trial``: data and pixels as the run says."""
    import imageio.v3 as iio

    state = page.evaluate(STATE_JS)
    assert state["shown"] == [t == trial for t in range(2)]
    k = int(ks[state["active"][trial]])
    data = {d["name"]: d["xyz"] for d in state["data"]}
    radar = rd.arrays["radar"][trial, k, :, :3]
    drone = rd.arrays["target"][trial, k, :, :3]
    mean = rd.arrays["mean"][trial, k].reshape(-1, 6)[:, :3]
    sigma = np.sqrt(rd.arrays["cov_diag"][trial, k].reshape(-1, 6)[:, :3])
    np.testing.assert_allclose(np.array(data["radars"]).T, radar, atol=1e-3)
    np.testing.assert_allclose(np.array(data["drones (truth)"]).T, drone, atol=1e-3)
    np.testing.assert_allclose(np.array(data["estimates"]).T, mean, atol=1e-3)
    axes = np.array(data["2-sigma axes"]).T.reshape(-1, 3, 3)[:, :2]  # [M * 3, end, xyz]
    np.testing.assert_allclose(
        axes[0], mean[0] + [[-2 * sigma[0, 0], 0, 0], [2 * sigma[0, 0], 0, 0]], atol=1e-2
    )
    rgb = page.screenshot(type="png")
    rgb = iio.imread(rgb)[..., :3]
    for i, xy in enumerate(project(state, radar)):
        colour = np.round(255 * np.asarray(RADAR_RGB[i % len(RADAR_RGB)])).astype(int)
        assert colour_near(rgb, xy, colour) >= 3, f"radar {i} not drawn at {xy}"
    for j, xy in enumerate(project(state, drone)):
        colour = np.round(255 * np.asarray(TARGET_RGB[j % len(TARGET_RGB)])).astype(int)
        assert colour_near(rgb, xy, colour) >= 3, f"drone {j} not drawn at {xy}"
    lo, hi = np.array(state["ranges"]).T
    checked = 0
    for j in range(len(mean)):  # the x and y axes, 60 % out from the estimate
        for a in range(2):
            for sign in (-1, 1):
                p = mean[j].copy()
                p[a] += sign * 0.6 * 2 * sigma[j, a]
                if np.any(p < lo) or np.any(p > hi):
                    continue  # plotly clips lines at the scene's box
                xy = project(state, p[None])[0]
                assert colour_near(rgb, xy, AXIS_RGB, r=2) >= 2, f"no 2-sigma axis at {xy}"
                checked += 1
    assert checked >= 5


def test_offline_html_slider_and_trial_menu(browser, run_dir, tmp_path):
    rd = viewer.load_run(run_dir)
    html = viewer.view(rd, tmp_path / "v.html", max_frames=FRAMES, samples=4).path
    ks = viewer_budget.frame_steps(rd.arrays["radar"].shape[1], FRAMES)
    page = browser.new_page(viewport={"width": 1200, "height": 800})
    page.set_default_timeout(15_000)
    requests = []

    def route(r):
        requests.append(r.request.url)
        r.continue_() if r.request.url.startswith("file:") else r.abort()

    page.route("**/*", route)
    page.on("request", lambda r: requests.append(r.url))
    page.goto(html.resolve().as_uri())
    page.wait_for_function(
        "() => { var g = document.querySelector('.js-plotly-plot');"
        " return g && g._fullLayout && g._fullLayout.scene._scene; }"
    )
    page.evaluate(
        "(h) => Plotly.restyle(document.querySelector('.js-plotly-plot'), "
        "{visible: false}, document.querySelector('.js-plotly-plot').data"
        ".map((d, i) => h.includes(d.name) ? i : -1).filter(i => i >= 0))",
        list(HIDE),
    )

    def click_slider(trial: int, i: int) -> None:
        rail = page.locator(".slider-rail-rect").bounding_box()  # only the visible one is drawn
        # plotly insets the steps by the grip's half width (10 px) on both ends
        x = rail["x"] + 10 + (rail["width"] - 20) * i / (FRAMES - 1)
        page.mouse.click(x, rail["y"] + rail["height"] / 2)
        page.wait_for_function(
            f"() => document.querySelector('.js-plotly-plot')"
            f"._fullLayout.sliders[{trial}].active === {i}"
        )
        page.wait_for_timeout(300)  # the frame's redraw

    assert page.evaluate(STATE_JS)["active"][0] == 0
    click_slider(0, 6)
    check_scene(page, rd, 0, ks)
    page.locator("g.updatemenu-header-group", has_text="trial 0").click()
    page.locator("g.updatemenu-dropdown-button", has_text="trial 1").click()
    page.wait_for_function(
        "() => document.querySelector('.js-plotly-plot')._fullLayout.sliders[1].visible"
    )
    page.wait_for_timeout(300)
    check_scene(page, rd, 1, ks)  # the other trial, at its first frame
    click_slider(1, 8)
    check_scene(page, rd, 1, ks)
    page.close()
    assert requests and set(requests) == {html.resolve().as_uri()}, requests


def _records(seg: int, t: int = 2, p: int = 4, m: int = 2, n: int = 2, h: int = 8, s: int = 8):
    """Synthetic ``(StepRecord, ControlRecord)`` of segment ``seg`` (numpy, ``[T, ...]``):
    drone j at x = k + 30 j, radar i at x = -50 + 60 i + k / 4 (k: filter step)."""
    from mjx_radar.env.records import StepRecord
    from mjx_radar.planners.records import plan_record

    k = seg * p + np.arange(1, p + 1, dtype=np.float32)[None, :, None]
    target = np.zeros((t, p, m, 6), np.float32)
    target[..., 0], target[..., 2] = k + 30.0 * np.arange(m), 50.0
    radar = np.zeros((t, p, n, 6), np.float32)
    radar[..., 0], radar[..., 2] = -50.0 + 60.0 * np.arange(n) + k / 4, 1.0
    zero = np.zeros((t, p), np.float32)
    steps = StepRecord(**{f: zero for f in StepRecord._fields} | dict(
        target=target, mean=target.reshape(t, p, 6 * m),
        cov_diag=np.full((t, p, 6 * m), 4.0, np.float32), radar=radar, rmse_pos=zero + 2.0,
        crlb_pos=zero + 1.0))  # fmt: skip
    rng = np.random.default_rng(seg)
    controls = plan_record(np.zeros((t, 1, n, 2), np.float32),
                             np.zeros((t, 1, h, n, 2), np.float32),
                             rng.normal(0, 5, (t, 1, s, h, n, 2)).astype(np.float32),
                             rng.uniform(0, 1, (t, 1, s)).astype(np.float32),
                             np.zeros((t, 1, s), np.float32))  # fmt: skip
    return steps, controls


def test_live_page_redraws_the_scene(browser):
    from mjx_radar.viz.live_view.live import LiveView
    from mjx_radar.viz.scene import scene_of

    view = LiveView(scene_of(mjx_radar.load_scenario("smoke")), [0, 5], 80, port=0)
    page = browser.new_page(viewport={"width": 1200, "height": 800})
    page.set_default_timeout(15_000)
    requests, errors = [], []
    page.on("request", lambda r: requests.append(r.url))
    page.on("pageerror", lambda e: errors.append(str(e)))
    try:
        page.goto(view.url)
        page.wait_for_timeout(600)  # the page waits for the first segment
        assert page.evaluate("window.liveState.seq") == -1
        for seg in range(2):
            view.update(4 * (seg + 1), _records(seg))
            page.wait_for_function(f"() => window.liveState.step === {4 * (seg + 1)}")
            state = page.evaluate(STATE_JS)
            data = {d["name"]: d["xyz"] for d in state["data"]}
            k = 4 * (seg + 1)  # the latest step received
            np.testing.assert_allclose(np.array(data["drones (truth)"])[0], [k, k + 30])
            np.testing.assert_allclose(np.array(data["radars"])[0], [-50 + k / 4, 10 + k / 4])
        assert "step 8 of 80" in page.text_content("#status")
        page.select_option("#trial", "1")  # trial 5: the same synthetic data, read again
        page.wait_for_function("() => window.liveState.trial === 1")
        view.linger(0)  # the run ends, the server stops: the page says so, keeps its state
        page.wait_for_function("() => window.liveState.ended")
        assert "ended" in page.text_content("#status")
    finally:
        page.close()
        view.close()
    assert not errors, errors
    assert requests and all(u.startswith(view.url) for u in requests), requests


def test_terrain_surface_renders(browser, tmp_path):
    """hills_4r4t: plotly's own scene data of the "terrain" surface equals the height grid at
    the drawn nodes, and its pixels (every other layer hidden) are drawn where plotly's
    camera projects interior nodes, in colours of the surface, not the white background."""
    import imageio.v3 as iio

    from mjx_radar.viz.view.viewer_world import terrain_nodes

    s = mjx_radar.load_scenario("hills_4r4t")
    rd = viewer.load_run(synthetic_run(tmp_path / "hills", s, steps=40))
    html = viewer.view(rd, tmp_path / "h.html", max_frames=4, samples=0).path
    page = browser.new_page(viewport={"width": 1200, "height": 800})
    page.set_default_timeout(15_000)
    try:
        page.goto(html.resolve().as_uri())
        page.wait_for_function(
            "() => { var g = document.querySelector('.js-plotly-plot');"
            " return g && g._fullLayout && g._fullLayout.scene._scene; }"
        )
        page.evaluate(
            "() => { var g = document.querySelector('.js-plotly-plot');"
            " return Plotly.restyle(g, {visible: false}, g.data.map((d, i) => "
            "d.type === 'surface' ? -1 : i).filter(i => i >= 0)); }"
        )
        page.wait_for_timeout(500)
        state = page.evaluate(STATE_JS)
        shot = iio.imread(page.screenshot(type="png"))[..., :3].astype(int)
    finally:
        page.close()
    surf = [d for d in state["data"] if d["name"] == "terrain"]
    assert len(surf) == 1
    xs, ys, h, _ = terrain_nodes(s.terrain, *viewer.load_trial(rd, 0).bounds())
    x, y, z = (np.array(a, float) for a in surf[0]["xyz"])
    np.testing.assert_allclose(x, xs, atol=1e-3)
    np.testing.assert_allclose(y, ys, atol=1e-3)
    np.testing.assert_allclose(z, h, atol=1e-3)
    i, j = np.meshgrid(np.arange(1, len(ys) - 1), np.arange(1, len(xs) - 1), indexing="ij")
    nodes = np.column_stack([xs[j.ravel()], ys[i.ravel()], h[i, j].ravel()])
    lo, hi = np.array(state["ranges"]).T
    nodes = nodes[np.all((nodes[:, :2] > lo[:2] + 5) & (nodes[:, :2] < hi[:2] - 5), 1)]
    assert len(nodes) >= 50  # inside the axis ranges (plotly clips the surface there)
    px = np.round(project(state, nodes)).astype(int)
    drawn = (np.abs(shot[px[:, 1], px[:, 0]] - 255).sum(-1) > 60).sum()  # not the background
    assert drawn >= 0.95 * len(nodes), (drawn, len(nodes))  # (a node may lie on a silhouette)
