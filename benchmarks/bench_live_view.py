"""Overhead of the live view (``mjx-radar run --view``) on the simulation (issue 25).

Runs the same compiled closed loop (one process, program compiled once before timing)
alternately without and with the live view, ``--repeats`` times each, and prints the
simulation time (``sim_s``: the segments, excluding compilation) of every run, the
medians and the overhead ``median(view) / median(plain) - 1``, and the same for this
process's CPU time (all its threads: XLA's, the runner's and the server's; steadier
than wall time on a shared machine; a browser's CPU is not in it). With the view, a client
polls the server as the page does: ``figure.json`` once, then ``state.json`` every
250 ms (``--client http``), or a real headless Chromium showing the page
(``--client chromium``, needs playwright and /usr/bin/chromium; its software WebGL
competes for the CPU). The segments are those of ``run --view`` (at most one simulated
second; :func:`mjx_radar.viz.live_view.live.live_periods`); without it, those of ``run``. Usage::

    python benchmarks/bench_live_view.py --scenario smoke --steps 400 --rollouts analytic
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import threading
import time
import urllib.request

from mjx_radar.engine.run_spec import run_spec


def poll(url: str, stop: threading.Event, counts: list, ready: threading.Event) -> None:
    urllib.request.urlopen(url + "figure.json", timeout=30).read()
    ready.set()
    seq = -1
    while not stop.is_set():
        with urllib.request.urlopen(f"{url}state.json?trial=0&since={seq}", timeout=30) as r:
            seq = json.loads(r.read())["seq"]
        counts.append(seq)
        stop.wait(0.25)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="smoke")
    ap.add_argument("--method", default="ddr-sfim")
    ap.add_argument("--steps", type=int, default=400)
    ap.add_argument("--trials", type=int, default=1)
    ap.add_argument("--rollouts", choices=("mjx", "analytic"), default=None)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--client", choices=("http", "chromium", "none"), default="http")
    args = ap.parse_args()

    from mjx_radar.engine import compile_cache, runner
    from mjx_radar.scenario.reader import load_with_overrides
    from mjx_radar.viz.live_view.live import LiveView
    from mjx_radar.viz.scene import scene_of

    compile_cache.enable()
    s, steps = load_with_overrides(args.scenario, args.rollouts, args.steps)
    trials = list(range(args.trials))
    scene = scene_of(s)
    probe = LiveView(scene, trials, steps, port=0)
    periods, default = probe.runner_options()["periods"], runner.segment_periods(s, steps)
    probe.close()
    first = runner.run_trials(run_spec(s), args.method, 0, trials, steps, periods=periods)
    runner.run_trials(run_spec(s), args.method, 0, trials, steps, periods=default)
    seconds = steps * s.timing.dt_filter
    print(f"{s.name} {args.method}: {args.trials} trial(s) x {steps} steps ({seconds:g} s "
          f"simulated), {steps // s.timing.control_every // periods} segments of "
          f"{periods * s.timing.dt_control:g} s with the view, {default * s.timing.dt_control:g} s "
          f"without; compile {first['compile_s']:.1f} s; "
          f"client {args.client}; {os.cpu_count()} CPUs")  # fmt: skip
    times: dict = {"plain": [], "view": []}
    cpus: dict = {"plain": [], "view": []}
    for rep in range(args.repeats):
        for mode in ("plain", "view"):
            opts, view, stop, counts, client = {"periods": default}, None, None, [], None
            if mode == "view":
                view = LiveView(scene, trials, steps, port=0)
                opts = view.runner_options()
                stop = threading.Event()
                ready = threading.Event()
                client = threading.Thread(target=_client, args=(args.client, view.url, stop,
                                                                counts, ready))  # fmt: skip
                client.start()
                ready.wait(120)  # the page has loaded and drawn its (empty) figure
            cpu = time.process_time()
            res = runner.run_trials(run_spec(s), args.method, 0, trials, steps, **opts)
            cpu = time.process_time() - cpu
            if view is not None:
                stop.set()
                client.join()
                view.linger(0)
            times[mode].append(res["sim_s"])
            cpus[mode].append(cpu)
            extra = f", {len(set(counts))} states read" if mode == "view" else ""
            print(f"  {rep}: {mode:5s} sim {res['sim_s']:.3f} s, process CPU {cpu:.3f} s{extra}",
                  flush=True)  # fmt: skip
    for what, d in (("sim wall", times), ("process CPU", cpus)):
        plain, view = statistics.median(d["plain"]), statistics.median(d["view"])
        print(
            f"median {what}: plain {plain:.3f} s, view {view:.3f} s: overhead "
            f"{100 * (view / plain - 1):+.1f} %"
        )
    print(f"load average {os.getloadavg()[0]:.1f}")


def _client(kind: str, url: str, stop: threading.Event, counts: list,
            ready: threading.Event) -> None:  # fmt: skip
    if kind == "http":
        poll(url, stop, counts, ready)
    elif kind == "chromium":
        from playwright.sync_api import sync_playwright

        with sync_playwright() as p:
            b = p.chromium.launch(executable_path="/usr/bin/chromium", args=["--no-sandbox"])
            page = b.new_page()
            page.goto(url)
            page.wait_for_function("() => document.getElementById('plot')._fullLayout")
            ready.set()
            while not stop.is_set():
                counts.append(page.evaluate("window.liveState.seq"))
                stop.wait(0.25)
            b.close()
    else:
        ready.set()


if __name__ == "__main__":
    main()
