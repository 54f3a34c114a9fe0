"""Live view of a run while it simulates (``mjx-radar run --view``, ``simulate(view=True)``).

A :class:`LiveView` is a small HTTP server (standard library ``http.server`` in a
daemon thread, bound to ``127.0.0.1`` only) and the runner's per-segment callback
(:func:`mjx_radar.engine.runner.run_trials`'s ``on_segment``). Between two
segments of control periods the runner hands the segment's records, already on the
host, to :meth:`LiveView.update`, which only keeps references (no copy, no host round
trip inside the compiled loop); the server thread turns the latest state into JSON
when a browser asks for it, once per segment and trial. :func:`live_periods` shortens
the segments where needed so the view updates at least once per simulated second.

Routes (:mod:`mjx_radar.viz.live_view.live_http`): ``/`` the page
(:mod:`mjx_radar.viz.live_view.live_page`),
``/plotly.min.js``, ``/figure.json`` the initial figure (built from the run's
:class:`~mjx_radar.viz.scene.Scene` before the run), ``/state.json?trial=J&since=SEQ``
the layers at the latest step of trial position J
(only ``{"seq": SEQ, "ends": [...]}`` if nothing new), ``&step=K`` at filter step K (every
segment is kept: :mod:`mjx_radar.viz.live_view.live_state`). After the run, :meth:`LiveView.linger`
keeps serving until Ctrl-C or for a number of seconds.
"""

from __future__ import annotations

import json
import math
import sys
import threading
from http.server import ThreadingHTTPServer

import numpy as np

from mjx_radar.errors import InputError
from mjx_radar.viz.live_view import live_page
from mjx_radar.viz.live_view.live_http import handler, plotly_js
from mjx_radar.viz.live_view.live_state import Records, grow_box, paths_box, trial_at
from mjx_radar.viz.view.viewer_counts import count_columns

DEFAULT_PORT = 8765
SAMPLES = 16  # MPPI samples drawn per state (the highest weights)


def live_periods(timing, steps: int, default: int, every_s: float = 1.0) -> int:
    """Control periods per segment for a live view: ``<= default``, ``<= every_s`` simulated
    seconds, and a divisor of the run's control periods (the runner's contract);
    ``timing``: the run's clocks (:class:`~mjx_radar.scenario.schema.Timing`)."""
    total = steps // timing.control_every
    limit = max(1, math.floor(every_s / timing.dt_control + 1e-9))
    for p in range(max(1, min(default, limit)), 0, -1):
        if total % p == 0:
            return p
    return 1


def start(
    scene, trials, steps: int, port: int | None = None, name: str = "--view-port"
) -> LiveView:
    """A :class:`LiveView` of a :class:`~mjx_radar.viz.scene.Scene` serving now; prints
    ``live view: URL`` on stderr."""
    live = LiveView(scene, trials, steps, port, name=name)
    print(f"live view: {live.url}  (updates once per segment)", file=sys.stderr, flush=True)
    return live


class LiveView:
    """The live server of one run; call :meth:`update` after each segment, :meth:`close` at the end.

    Args:
        scene: the run's :class:`~mjx_radar.viz.scene.Scene`
            (:func:`~mjx_radar.viz.scene.scene_of` of its scenario).
        trials: ``[T]`` trial indices of the batch (the page's trial menu).
        steps: filter steps K of the run.
        port: TCP port on 127.0.0.1 (``None``: :data:`DEFAULT_PORT`; 0: any free port;
            :attr:`url` tells which).
        samples: MPPI samples drawn per state.
        name: the option's name in error messages.

    Raises:
        InputError: a bad port, or one that cannot be bound (in use, or not allowed).
    """

    def __init__(
        self,
        scene,
        trials,
        steps: int,
        port: int | None = None,
        samples: int = SAMPLES,
        name: str = "--view-port",
    ):
        port = DEFAULT_PORT if port is None else port
        if (
            isinstance(port, bool)
            or not isinstance(port, int | np.integer)
            or not (0 <= port <= 65535)
        ):
            raise InputError(f"{name} = {port!r}: must be an integer in [0, 65535]")
        self.scene, self.trials, self.steps = scene, list(trials), steps
        self.samples = samples
        self._lock = threading.Lock()
        self._records = Records()  # every segment's records (references), from the start
        self._seq, self._finished, self._figure, self._box = 0, False, None, None
        self._cache: dict = {}
        self.page_bytes = live_page.page(scene.name, self.trials).encode()
        self._build_figure()  # before the run: the simulation never waits for it
        plotly_js()  # read once, now
        try:
            self._server = ThreadingHTTPServer(("127.0.0.1", int(port)), handler(self))
        except OSError as err:
            raise InputError(
                f"{name} = {port}: cannot serve on 127.0.0.1:{port} "
                f"({err.strerror or err}); pass another port, or 0 for any free one"
            ) from None
        self._server.daemon_threads = True
        self.port = self._server.server_address[1]
        self._thread = threading.Thread(
            target=self._server.serve_forever, name="live-view", daemon=True
        )
        self._thread.start()

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.port}/"

    def update(self, done: int, records) -> None:
        """The runner's ``on_segment``: keeps the segment's records (``(StepRecord,
        ControlRecord)`` of numpy arrays ``[T, ...]``); ``done`` filter steps so far."""
        with self._lock:
            self._records.add(done, records)
            self._seq += 1

    def runner_options(self) -> dict:
        """``periods`` and ``on_segment`` for :func:`~mjx_radar.engine.runner.run_trials`
        (shortened from the runner's own segments, read from the scene's clocks)."""
        from mjx_radar.engine.runner import segment_periods

        default = segment_periods(self.scene, self.steps)
        return {
            "periods": live_periods(self.scene.timing, self.steps, default),
            "on_segment": self.update,
        }

    def linger(self, seconds: float | None = None) -> None:
        """At the end of the run: marks it finished, serves the whole run for ``seconds``
        (``None``: until Ctrl-C; 0: not at all; Ctrl-C ends it early, a line on stderr
        says so), then stops the server. Any page opened meanwhile replays the run."""
        self.finish()
        if seconds is None or seconds > 0:
            until = "until Ctrl-C" if seconds is None else f"for {seconds:g} s (Ctrl-C: stop)"
            print(f"live view: the run stays at {self.url} {until}", file=sys.stderr, flush=True)
            try:
                threading.Event().wait(seconds)
            except KeyboardInterrupt:
                pass
        self.close()

    def finish(self) -> None:
        """Marks the run as ended (the page says so); the server keeps answering."""
        with self._lock:
            self._finished = True
            self._seq += 1

    def close(self) -> None:
        """Stops the server (the page then says the run has ended)."""
        self._server.shutdown()
        self._server.server_close()
        self._thread.join(5.0)

    # -- the server thread's side ------------------------------------------------------

    def _snapshot(self):
        with self._lock:
            return self._records.arrays(), list(self._records.ends), self._seq, self._finished

    def _build_figure(self) -> None:
        """The figure before any data: the ground extent holds the drones' paths and the
        radars' placement square (or fixed starts) with their R2T discs."""
        s = self.scene
        lo, hi, ztop = paths_box(s, self.steps)
        w = s.half_width
        radars = (
            np.asarray(s.radar_init, float)[:, :2] if s.radar_init else np.array([[-w, -w], [w, w]])
        )
        lo = np.minimum(lo, (radars - s.r2t).min(0))
        hi = np.maximum(hi, (radars + s.r2t).max(0))
        title = f"{s.name}: live ({len(self.trials)} trial(s), {self.steps} steps)"
        self._cols = count_columns(s, None, self.steps * s.timing.dt_filter)
        fig, self._anim, self._metrics = live_page.figure_json(s, lo, hi, ztop, title, self._cols)
        d = json.loads(fig)
        d["ready"] = True
        self._figure = json.dumps(d).encode()

    def figure_bytes(self) -> bytes:
        return self._figure

    def state_bytes(self, j: int, since: int, step: int | None = None) -> bytes:
        """``/state.json``: trial position ``j`` at filter step ``step`` (1-based, clamped to
        the steps received; ``None``: the latest, only ``{"seq": ...}`` if ``since`` is
        the newest segment already)."""
        got, ends, seq, finished = self._snapshot()
        if got is None or (step is None and since == seq):
            return json.dumps({"seq": seq if got is not None else -1, "ends": ends}).encode()
        upto = ends[-1] if step is None else min(max(int(step), 1), ends[-1])
        key = (seq, j, upto)
        if key not in self._cache:
            a, c = got
            tr = trial_at(self.scene, a, c, j, upto)
            self._box = grow_box(self._box or paths_box(self.scene, self.steps), tr)
            dt = self.scene.timing.dt_filter
            curves = (
                dt * np.arange(1, upto + 1),
                a["rmse_pos"][j, :upto],
                a["crlb_pos"][j, :upto],
                {col: a[col][j, :upto] for col in self._cols},
            )
            body = live_page.state_json(
                tr,
                c["plan_xy"][j],
                self.samples,
                curves,
                (seq, ends),
                self.steps,
                finished,
                (self._anim, self._metrics),
                self._box,
            )
            self._cache = {key: body.encode()}  # only the newest is asked for again
        return self._cache[key]
