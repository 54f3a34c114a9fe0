"""Headless Chromium (Playwright, the system's ``/usr/bin/chromium``): blocked lines of sight,
vehicles and a console free of warnings in the offline viewer; the live page replaying a
run from its start when opened after the run ended (skipped without either, see
``tests/test_viewer_browser.py``)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import mjx_radar
from mjx_radar.viz.view import viewer, viewer_budget

CHROMIUM = Path("/usr/bin/chromium")
pytestmark = pytest.mark.skipif(not CHROMIUM.exists(), reason="no /usr/bin/chromium")
sync_api = pytest.importorskip("playwright.sync_api", reason="playwright is not installed")
sys.path.insert(0, str(Path(__file__).parent))
from test_viewer import synthetic_run  # noqa: E402
from test_viewer_browser import STATE_JS, _records, colour_near, project  # noqa: E402

BLOCKED_RGB, VISIBLE_RGB, VEHICLE_RGB = (215, 0, 0), (20, 20, 20), (170, 60, 20)
WALL = dict(kind="box", pos=(-20.0, -40.0, 20.0), size=(40.0, 2.0, 20.0))
# browser-side messages of the headless renderer and of the screenshot's read-back
HARMLESS = ("[.WebGL", "Canvas2D:")


@pytest.fixture(scope="module")
def browser():
    with sync_api.sync_playwright() as p:
        b = p.chromium.launch(executable_path=str(CHROMIUM), args=["--no-sandbox"])
        yield b
        b.close()


def _console(page) -> list:
    msgs: list = []
    page.on("console", lambda m: msgs.append((m.type, m.text)))
    page.on("pageerror", lambda e: msgs.append(("pageerror", str(e))))
    return msgs


def _warnings(msgs) -> list:
    return [m for m in msgs if m[0] != "log" and not m[1].startswith(HARMLESS)]


def _wall_blocks(a, b) -> np.ndarray:
    """Independent slab test: segments ``a -> b`` ``[P, 3]`` through the axis-aligned WALL."""
    lo = np.array(WALL["pos"]) - WALL["size"]
    hi = np.array(WALL["pos"]) + WALL["size"]
    e = b - a
    with np.errstate(divide="ignore", invalid="ignore"):
        t0, t1 = (lo - a) / e, (hi - a) / e
    tmin = np.maximum(np.minimum(t0, t1).max(1), 0.0)
    tmax = np.minimum(np.maximum(t0, t1).min(1), 1.0)
    return tmin < tmax


def _scenario():
    from mjx_radar.scenario.schema import MovingObstacle, Obstacle

    car = MovingObstacle(kind="box", size=(2.5, 1.0), height=2.5,
                         path=((-100.0, 20.0), (100.0, 20.0)), speed=8.0)  # fmt: skip
    s = mjx_radar.load_scenario("smoke")
    starts = ((-300.0, -300.0, 0.0), (300.0, -300.0, 0.0))  # checks only: synthetic paths
    return s.replace(radar_init=starts, obstacles=(Obstacle(**WALL),), moving_obstacles=(car,))


def test_blocked_lines_vehicles_no_warnings(browser, tmp_path):
    """smoke with a wall that hides radar 0 from both drones and a car driving y = 20: the
    frame's "blocked lines of sight" are the pairs an independent slab test blocks, dashed
    red on screen; the others solid dark; the car a box at its closed-form place; the
    console has no warning (plotly's "Invalid color specifier" included)."""
    import imageio.v3 as iio

    s = _scenario()
    rd = viewer.load_run(synthetic_run(tmp_path / "wall", s, steps=40))
    html = viewer.view(rd, tmp_path / "w.html", max_frames=4, samples=2).path
    page = browser.new_page(viewport={"width": 1400, "height": 900})
    page.set_default_timeout(20_000)
    msgs = _console(page)
    try:
        page.goto(html.resolve().as_uri())
        page.wait_for_function(
            "() => { var g = document.querySelector('.js-plotly-plot');"
            " return g && g._fullLayout && g._fullLayout.scene._scene; }"
        )
        keep = ["lines of sight", "blocked lines of sight", "vehicles"]
        page.evaluate(
            "(h) => { var g = document.querySelector('.js-plotly-plot');"
            " return Plotly.restyle(g, {visible: false}, g.data.map((d, i) => "
            "h.includes(d.name) || d.type !== 'scatter3d' ? -1 : i).filter(i => i >= 0)); }",
            keep,
        )
        page.wait_for_timeout(500)
        state = page.evaluate(STATE_JS)
        shot = iio.imread(page.screenshot(type="png"))[..., :3].astype(int)
    finally:
        page.close()
    assert not _warnings(msgs), msgs
    k = int(viewer_budget.frame_steps(40, 4)[0])  # the figure opens at the first frame
    radar, drone = rd.arrays["radar"][0, k, :, :3], rd.arrays["target"][0, k, :, :3]
    a, b = np.repeat(radar, 2, 0), np.tile(drone, (2, 1))
    blocked = _wall_blocks(a, b)
    assert blocked.tolist() == [True, True, False, False]  # the wall hides radar 0 only
    data = {d["name"]: d["xyz"] for d in state["data"]}
    for name, want, colour in (("blocked lines of sight", blocked, BLOCKED_RGB),
                               ("lines of sight", ~blocked, VISIBLE_RGB)):  # fmt: skip
        seg = np.array(data[name], float).T.reshape(-1, 3, 3)[:, :2]  # [P, end, xyz]
        np.testing.assert_allclose(seg[:, 0], a[want], atol=1e-3)
        np.testing.assert_allclose(seg[:, 1], b[want], atol=1e-3)
        for p, q in zip(a[want], b[want], strict=True):  # drawn in their colour along them
            pts = p + np.linspace(0.15, 0.85, 15)[:, None] * (q - p)
            hits = sum(colour_near(shot, xy, colour, r=2) > 0 for xy in project(state, pts))
            assert hits >= 8, (name, hits)  # a dashed line: most of them
    car = np.array(data["vehicles"], float).T
    car = car[np.isfinite(car).all(1)]
    x = -100.0 + 8.0 * (k + 1) * rd.scenario.timing.dt_filter
    np.testing.assert_allclose(car.min(0), [x - 2.5, 19.0, 0.0], atol=1e-3)
    np.testing.assert_allclose(car.max(0), [x + 2.5, 21.0, 2.5], atol=1e-3)
    top = np.array([[x, 21.0, 2.5], [x, 19.0, 2.5]])  # the long top edges' middles
    assert all(colour_near(shot, xy, VEHICLE_RGB, r=3) > 0 for xy in project(state, top))


def test_live_page_opened_after_the_run_replays_it(browser):
    """A warm-cache run ends before the page opens: the page (the server lingering) shows
    the run from step 1, segment by segment, to the last step, then "live"; the slider
    goes back to step 8; no console warning."""
    from mjx_radar.viz.live_view.live import LiveView
    from mjx_radar.viz.scene import scene_of

    view = LiveView(scene_of(mjx_radar.load_scenario("smoke")), [0, 5], 80, port=0)
    for seg in range(5):
        view.update(4 * (seg + 1), _records(seg))
    view.finish()  # the run is over; linger() would wait here, the server answering
    page = browser.new_page(viewport={"width": 1200, "height": 800})
    page.set_default_timeout(20_000)
    msgs = _console(page)
    try:
        page.goto(view.url)
        page.wait_for_function("() => window.liveState.mode === 'live'")
        live = page.evaluate("window.liveState")
        assert live["shown"] == [1, 4, 8, 12, 16, 20] and live["finished"]
        assert "run finished" in page.text_content("#status")
        page.eval_on_selector("#step", "(e) => { e.value = 8; e.oninput(); }")
        page.wait_for_function("() => window.liveState.step === 8")
        assert not page.is_checked("#live")
        data = {d["name"]: d["xyz"] for d in page.evaluate(STATE_JS)["data"]}
        np.testing.assert_allclose(np.array(data["drones (truth)"])[0], [8, 38])
        np.testing.assert_allclose(np.array(data["radars"])[0], [-50 + 8 / 4, 10 + 8 / 4])
    finally:
        page.close()
        view.close()
    assert not _warnings(msgs), msgs
