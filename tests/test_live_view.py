"""The live view (``mjx-radar run --view``, ``simulate(view=True)``), headless.

A tiny closed loop (``tiny`` fixture: 2 radars, 2 drones, 40 filter steps in 10
segments) runs with the view's per-segment callback; the test reads the server's JSON
while the runner is between two segments (from inside the callback, so the reads are
during the run by construction) and checks that the scene advanced and equals the
run's own arrays at the step the server reports.
"""

from __future__ import annotations

import json
import re
import threading
import time
import urllib.error
import urllib.request

import numpy as np
import pytest

import mjx_radar
from mjx_radar.engine import runner
from mjx_radar.engine.run_spec import run_spec
from mjx_radar.errors import InputError
from mjx_radar.viz.live_view import live as live_mod
from mjx_radar.viz.scene import scene_of
from mjx_radar.viz.view.viewer_traces import LAYERS

STEPS = 40  # 10 control periods of 4 filter steps; one period per segment
TRIALS = [0, 3]


def get(url: str) -> tuple[bytes, str]:
    with urllib.request.urlopen(url, timeout=10) as r:
        return r.read(), r.headers["Content-Type"]


def get_json(url: str) -> dict:
    return json.loads(get(url)[0])


def layer(state: dict, name: str) -> np.ndarray:
    """``[P, 3]`` points of a layer (``null`` -> NaN)."""
    i = [n for n, _ in LAYERS].index(name)
    d = state["layers"][i]
    return np.array([d["x"], d["y"], d["z"]], dtype=float).T


@pytest.fixture(scope="module")
def live_run(tiny):
    """A 2-trial run with the view; states read from the server after segments 3 and 7."""
    view = live_mod.LiveView(scene_of(tiny), TRIALS, STEPS, port=0)
    reads: dict = {}

    def hook(done, records):
        view.update(done, records)
        if done // tiny.timing.control_every in (3, 7):
            fig = get_json(view.url + "figure.json")
            reads[done] = (fig, get_json(view.url + "state.json?trial=1"))

    opts = view.runner_options()
    assert opts["periods"] == 1  # smoke's default: one period (0.1 s) per segment
    res = runner.run_trials(run_spec(tiny), "ddr-sfim", 0, TRIALS, STEPS, periods=opts["periods"],
                            on_segment=hook)  # fmt: skip
    yield view, reads, res
    view.close()


def test_scene_advances_between_two_reads(live_run, tiny):
    view, reads, res = live_run
    (k1, (fig, s1)), (k2, (_, s2)) = sorted(reads.items())
    assert fig["ready"] and (k1, k2) == (12, 28)
    assert (s1["step"], s2["step"]) == (k1, k2) and s2["seq"] > s1["seq"]
    assert not s1["finished"] and s1["steps"] == STEPS
    np.testing.assert_allclose([s1["t"], s2["t"]], np.array([k1, k2]) * tiny.timing.dt_filter)
    for s, k in ((s1, k1), (s2, k2)):  # trial position 1 (index 3) at the latest step
        np.testing.assert_allclose(layer(s, "drones (truth)"), res["target"][1, k - 1, :, :3],
                                   atol=1e-3)  # fmt: skip
        np.testing.assert_allclose(layer(s, "radars"), res["radar"][1, k - 1, :, :3], atol=1e-3)
        m = tiny.n_targets
        np.testing.assert_allclose(
            layer(s, "estimates"), res["mean"][1, k - 1].reshape(m, 6)[:, :3], atol=1e-3
        )
        np.testing.assert_allclose(s["rmse"], res["rmse_pos"][1, :k], rtol=1e-4, atol=1e-4)
        # 2-sigma axes: the x segment of drone 0 spans mean_x -/+ 2 sqrt(P_xx)
        axes = layer(s, "2-sigma axes")
        sx = 2 * np.sqrt(res["cov_diag"][1, k - 1, 0])
        np.testing.assert_allclose(axes[:2, 0], res["mean"][1, k - 1, 0] + [-sx, sx], atol=2e-3)
    assert not np.allclose(layer(s1, "drones (truth)"), layer(s2, "drones (truth)"))
    assert not np.allclose(layer(s1, "radars"), layer(s2, "radars"))
    anim = s1["anim"]
    assert [fig["data"][i]["name"] for i in anim] == [n for n, _ in LAYERS]


def test_any_step_from_the_start(live_run, tiny):
    """``/state.json?step=K``: the state at any step received, from the run's start (what the
    page replays when it is opened late); K is clamped to the steps received."""
    view, reads, res = live_run
    every = tiny.timing.control_every
    first = get_json(view.url + "state.json?trial=1&step=0")
    assert first["step"] == 1 and first["ends"] == list(range(every, STEPS + 1, every))
    for k in (1, 12, every * 3 + 1, STEPS):
        s = get_json(view.url + f"state.json?trial=1&step={k}")
        assert s["step"] == k and len(s["rmse"]) == k
        np.testing.assert_allclose(layer(s, "drones (truth)"), res["target"][1, k - 1, :, :3],
                                   atol=1e-3)  # fmt: skip
        np.testing.assert_allclose(layer(s, "radars"), res["radar"][1, k - 1, :, :3], atol=1e-3)
    k12 = get_json(view.url + "state.json?trial=1&step=12")
    assert k12["layers"] == reads[12][1]["layers"]  # the same as when it was the latest
    assert get_json(view.url + "state.json?trial=1&step=99999")["step"] == STEPS


def test_page_is_served_offline(live_run):
    view, _, _ = live_run
    page, kind = get(view.url)
    html = page.decode()
    assert kind.startswith("text/html") and "plotly.min.js" in html
    assert not re.search(r"https?://", html), "the page references an external URL"
    assert not re.search(r"\bsrc\s*=\s*[\"']?(?://|https?:)", html)
    js, kind = get(view.url + "plotly.min.js")
    assert kind == "application/javascript" and len(js) > 2e6 and b"plotly.js v" in js[:2000]
    assert html.count('<option value="') == len(TRIALS)
    seq = get_json(view.url + "state.json?trial=0")["seq"]
    news = get_json(view.url + f"state.json?trial=0&since={seq}")
    assert news["seq"] == seq and "layers" not in news  # no news
    for bad in ("state.json?trial=2", "state.json?trial=x", "state.json?step=x", "nope"):
        with pytest.raises(urllib.error.HTTPError):
            get(view.url + bad)


def test_segments_of_at_most_a_simulated_second(tiny):
    paper = mjx_radar.load_scenario("paper_3r4t")  # dt_control 0.1 s
    assert live_mod.live_periods(paper.timing, 600, 6) == 6  # 0.6 s: kept
    assert live_mod.live_periods(paper.timing, 6000, 30) == 10  # 3 s -> 1 s (divides 600)
    assert live_mod.live_periods(paper.timing, 392, 14) == 7  # 98 periods: 1.4 s -> 0.7 s


def test_port_errors(tiny):
    view = live_mod.LiveView(scene_of(tiny), [0], STEPS, port=0)
    try:
        with pytest.raises(InputError, match=rf"--view-port = {view.port}: cannot serve"):
            live_mod.LiveView(scene_of(tiny), [0], STEPS, port=view.port)
    finally:
        view.close()
    with pytest.raises(urllib.error.URLError):
        get(view.url)  # closed: nothing answers
    with pytest.raises(InputError, match=r"view_port = 70000: must be an integer in \[0, 65535\]"):
        live_mod.LiveView(scene_of(tiny), [0], STEPS, port=70000, name="view_port")


def test_simulate_with_view(tiny, monkeypatch):
    """``simulate(view=True, linger=0)``: the server answers during the run and stops after
    it."""
    seen, urls = [], []
    start = live_mod.start

    def spy(*args, **kwargs):
        v = start(*args, **kwargs)
        urls.append(v.url)
        update = v.update

        def slow_update(done, records):  # read the server between segments
            update(done, records)
            seen.append(get_json(v.url + "state.json?trial=0")["seq"])

        v.update = slow_update
        return v

    monkeypatch.setattr(live_mod, "start", spy)
    run = mjx_radar.simulate(tiny, trials=TRIALS, steps=STEPS, view_port=0, progress=False,
                             linger=0)  # fmt: skip
    assert run.steps == STEPS and len(urls) == 1
    assert seen == list(range(1, STEPS // tiny.timing.control_every + 1))
    with pytest.raises(urllib.error.URLError):
        get(urls[0])


def test_linger_serves_the_whole_run_then_stops(tiny, monkeypatch, capsys):
    """``simulate(view=True, linger=S)``: after the run the server stays S seconds (a page
    opened then gets the whole run, from step 1 to the last, finished), then stops."""
    seen, views = {}, []
    start = live_mod.start

    def spy(*args, **kwargs):
        v = start(*args, **kwargs)
        views.append(v)
        linger = v.linger

        def read_then_linger(seconds=None):
            t = threading.Thread(target=linger, args=(seconds,))
            t.start()
            time.sleep(0.3)  # lingering now: a late client reads the run
            seen["last"] = get_json(v.url + "state.json?trial=0")
            seen["first"] = get_json(v.url + "state.json?trial=0&step=1")
            seen["alive"] = t.is_alive()
            t.join()

        v.linger = read_then_linger
        return v

    monkeypatch.setattr(live_mod, "start", spy)
    t0 = time.perf_counter()
    mjx_radar.simulate(tiny, trials=TRIALS, steps=STEPS, view_port=0, progress=False, linger=1.5)
    assert time.perf_counter() - t0 >= 1.5 and seen["alive"]
    assert seen["last"]["finished"] and seen["last"]["step"] == STEPS
    assert seen["first"]["step"] == 1 and seen["first"]["ends"][-1] == STEPS
    assert "stays at" in capsys.readouterr().err
    with pytest.raises(urllib.error.URLError):
        get(views[0].url)
    with pytest.raises(InputError, match="linger = -1"):
        mjx_radar.simulate(tiny, steps=STEPS, view=True, linger=-1)


def test_cli_busy_port_is_one_line_before_compiling(tmp_path, capsys):
    import importlib

    cli_main = importlib.import_module("mjx_radar.cli.main")
    busy = live_mod.LiveView(scene_of(mjx_radar.load_scenario("smoke")), [0], 80, port=0)
    try:
        code = cli_main.main(["run", "smoke", "--out", str(tmp_path / "r"), "--view-port",
                              str(busy.port)])  # fmt: skip
    finally:
        busy.close()
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and err[-1].startswith(f"error: --view-port = {busy.port}: cannot serve")
    assert not (tmp_path / "r").exists()  # the directory it made is removed
    assert cli_main.main(["run", "smoke", "--view-port", "-1"]) == 2


@pytest.mark.slow
def test_cli_run_with_view(tmp_path, capsys, monkeypatch):
    """``mjx-radar run smoke --view-port 0``: URL printed, segments fed to the view, the
    server stopped at the end (stdin is not a terminal under pytest), exit 0."""
    import importlib

    cli_main = importlib.import_module("mjx_radar.cli.main")
    views = []
    start = live_mod.start
    monkeypatch.setattr(live_mod, "start", lambda *a, **k: views.append(start(*a, **k))
                        or views[-1])  # fmt: skip
    out = tmp_path / "r"
    assert cli_main.main(["run", "smoke", "--steps", "8", "--rollouts", "analytic", "--out",
                          str(out), "--view-port", "0", "--view-linger", "0"]) == 0  # fmt: skip
    err = capsys.readouterr().err
    assert f"live view: {views[0].url}" in err and (out / "run.json").is_file()
    assert views[0]._seq == 2 + 1 and views[0]._finished  # 2 segments, then finish()
    with pytest.raises(urllib.error.URLError):
        get(views[0].url)


def test_view_leaves_the_numbers_alone(live_run, tiny):
    """The view's callback changes nothing: a plain run of the same program (same
    segments: no compilation) gives identical arrays."""
    _, _, res = live_run
    plain = runner.run_trials(run_spec(tiny), "ddr-sfim", 0, TRIALS, STEPS)
    assert plain["compile_s"] == 0.0
    for k in ("target", "mean", "cov_diag", "radar", "rmse_pos", "crlb_pos", "sample_xy"):
        np.testing.assert_array_equal(plain[k], res[k], err_msg=k)


@pytest.mark.slow
def test_shorter_segments_give_the_same_numbers(live_run, tiny):
    """Where ``--view`` shortens the segments (runs longer than 20 simulated seconds), the
    run is the same: 1 period per segment (the view's) vs 5 (another program)."""
    _, _, res = live_run
    other = runner.run_trials(run_spec(tiny), "ddr-sfim", 0, TRIALS, STEPS, periods=5)
    for k in ("target", "mean", "cov_diag", "radar", "rmse_pos", "crlb_pos", "sample_xy"):
        np.testing.assert_array_equal(other[k], res[k], err_msg=k)


def test_interactive_linger_serves_until_ctrl_c(tiny, capsys):
    import os
    import signal

    view = live_mod.LiveView(scene_of(tiny), [0], STEPS, port=0)
    timer = threading.Timer(1.0, os.kill, (os.getpid(), signal.SIGINT))

    def check_then_interrupt():  # still serving, finished, while linger waits
        try:
            seen.append(get_json(view.url + "state.json?trial=0")["seq"])
        finally:  # Ctrl-C whatever the check found: a failed check fails, never hangs
            timer.start()

    seen: list = []
    # Python's own Ctrl-C handler for this test: a library loaded by an earlier test in the
    # same worker process must not be able to turn the SIGINT into a hang
    old = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        threading.Timer(0.3, check_then_interrupt).start()
        view.linger()  # None: until Ctrl-C; returns on it
    finally:
        signal.signal(signal.SIGINT, old)
    assert seen == [-1]  # the server answered while linger waited (no segment was fed)
    assert "until Ctrl-C" in capsys.readouterr().err
    with pytest.raises(urllib.error.URLError):
        get(view.url)


def test_live_counts_panel_and_absent_drones():
    """clutter_3r4t with drone 1 leaving at 0.05 s: the live figure has the counts panel, a
    state's counts are the records' own, and the absent drone is not drawn (no closed loop:
    synthetic records, as the runner hands them over)."""
    from mjx_radar.env.records import StepRecord
    from mjx_radar.planners.records import plan_record

    s = mjx_radar.load_scenario("clutter_3r4t").replace(
        target_motion=[{"target": 1, "model": "cv", "leave": 0.05}]
    )
    t, p, n, m, h = 1, 8, 3, 4, 4
    rng = np.random.default_rng(0)
    count = {
        c: rng.integers(0, 12, (t, p)).astype(np.int32)
        for c in ("detections", "visible_pairs", "false_alarms", "targets_present")
    }
    zero = np.zeros((t, p), np.float32)
    target = rng.normal(0, 50, (t, p, m, 6)).astype(np.float32)
    steps = StepRecord(**{f: zero for f in StepRecord._fields} | count | dict(
        target=target, mean=target.reshape(t, p, 6 * m), radar=np.zeros((t, p, n, 6), np.float32),
        cov_diag=np.ones((t, p, 6 * m), np.float32)))  # fmt: skip
    controls = plan_record(
        np.zeros((t, 1, n, 2), np.float32),
        np.zeros((t, 1, h, n, 2), np.float32),
        np.zeros((t, 1, 2, h, n, 2), np.float32),
        np.ones((t, 1, 2), np.float32),
        np.zeros((t, 1, 2), np.float32),
    )
    view = live_mod.LiveView(scene_of(s), [0], 80, port=0)
    try:
        fig = get_json(view.url + "figure.json")
        view.update(p, (steps, controls))
        state = get_json(view.url + "state.json?trial=0")
    finally:
        view.close()
    names = [fig["data"][i].get("name") for i in state["metrics"]]
    assert names[3:] == ["detections", "visible pairs", "false alarms", "targets present",
                         "current step (counts)"]  # fmt: skip
    cols = ("detections", "visible_pairs", "false_alarms", "targets_present")
    np.testing.assert_array_equal(state["counts"], [count[c][0] for c in cols])
    assert state["counts_now"] == [int(count[c][0, -1]) for c in cols]
    drones = layer(state, "drones (truth)")  # t = 8 * 0.025 s = 0.2 s: drone 1 has left
    assert np.isnan(drones[1]).all() and np.isfinite(drones[[0, 2, 3]]).all()
    np.testing.assert_allclose(drones[[0, 2, 3]], target[0, -1, [0, 2, 3], :3], atol=1e-3)
