"""The page and the JSON documents of the live view (:mod:`mjx_radar.viz.live`).

The page (:data:`PAGE`) loads plotly.js from the live server itself (``/plotly.min.js``,
the copy inside the installed ``plotly`` package: no CDN, works offline), fetches the
figure once (``/figure.json``: :func:`figure_json`) and then polls ``/state.json``
(:func:`state_json`) every 250 ms; a new state replaces the data of the animated layers
of :data:`mjx_radar.viz.viewer_traces.LAYERS` and of the metrics curves in one
``Plotly.react`` (one redraw; ``uirevision`` keeps the camera and the legend's layer
toggles as the user left them).

The layers are those of the offline viewer (:func:`~mjx_radar.viz.viewer_traces.frame_traces`)
at the latest filter step received: radars with trails and R2T rings, drones, estimates
with 2-sigma axes, the acting MPPI samples and plan, lines of sight, fixed sites (and the
static terrain and waypoint routes); right, RMSE and PCRLB of the selected trial so far,
and below them the counts of :mod:`mjx_radar.viz.viewer_counts` where the scenario has
detection on or targets that appear / leave.
"""

from __future__ import annotations

import json

import numpy as np

from mjx_radar.viz import viewer_counts as counts
from mjx_radar.viz.viewer_traces import (
    fixed_sites,
    frame_traces,
    layer_styles,
    legend_per_layer,
    sample_legend,
    static_traces,
)
from mjx_radar.viz.viewer_world import aspect

PAGE = """<!DOCTYPE html>
<html><head><meta charset="utf-8"><title>mjx-radar live: {name}</title>
<link rel="icon" href="data:,">
<script src="plotly.min.js"></script>
<style>body {{font-family: sans-serif; margin: 6px}} #status {{margin-left: 1em}}</style>
</head><body>
<label>trial <select id="trial">{options}</select></label><span id="status">waiting for the
first segment (compiling)...</span>
<div id="plot" style="height: 92vh"></div>
<script>
var gd = document.getElementById('plot'), statusEl = document.getElementById('status');
var seq = -1, trial = 0, ranges = null;
window.liveState = {{seq: -1, step: 0, finished: false, ended: false}};
document.getElementById('trial').onchange = function (e) {{
  trial = Number(e.target.value); seq = -1;
}};
function sleep(ms) {{ return new Promise(function (r) {{ setTimeout(r, ms); }}); }}
function apply(s) {{  // one Plotly.react: one redraw of the scene per state
  var d = gd.data, lay = gd.layout;
  s.anim.forEach(function (i, n) {{
    d[i] = Object.assign({{}}, d[i], {{x: s.layers[n].x, y: s.layers[n].y, z: s.layers[n].z}});
  }});
  var w = s.anim[6];
  d[w] = Object.assign({{}}, d[w], {{line: Object.assign({{}}, d[w].line, {{color: s.sample_w}})}});
  var xs = [s.time, s.time, [s.t, s.t]], ys = [s.rmse, s.crlb, s.now];
  s.counts.forEach(function (c) {{ xs.push(s.time); ys.push(c); }});
  if (s.counts.length) {{
    xs.push(s.counts.map(function () {{ return s.t; }})); ys.push(s.counts_now);
  }}
  s.metrics.forEach(function (i, n) {{
    d[i] = Object.assign({{}}, d[i], {{x: xs[n], y: ys[n]}});
  }});
  var r = JSON.stringify(s.ranges);
  if (r !== ranges) {{
    ranges = r;
    d[0] = Object.assign({{}}, d[0], {{x: s.ground[0], y: s.ground[1], z: s.ground[2]}});
    var sc = Object.assign({{}}, lay.scene);
    ['xaxis', 'yaxis', 'zaxis'].forEach(function (a, n) {{
      sc[a] = Object.assign({{}}, sc[a], {{range: s.ranges[n]}});
    }});
    lay = Object.assign({{}}, lay, {{scene: sc}});
  }}
  return Plotly.react(gd, d.slice(), lay);
}}
async function run() {{
  for (;;) {{
    try {{
      var f = await (await fetch('figure.json')).json();
      if (f.ready) {{
        await Plotly.newPlot(gd, f.data, f.layout, {{displaylogo: false}});
        break;
      }}
    }} catch (e) {{ statusEl.textContent = 'no server: the run has ended'; return; }}
    await sleep(500);
  }}
  for (;;) {{
    var s;
    try {{
      s = await (await fetch('state.json?trial=' + trial + '&since=' + seq)).json();
    }} catch (e) {{
      statusEl.textContent = 'the run has ended and its server stopped: this is its last state';
      window.liveState.ended = true;
      return;
    }}
    if (s.seq !== seq && s.layers) {{
      await apply(s);
      seq = s.seq;
      window.liveState = {{seq: s.seq, step: s.step, finished: s.finished, ended: false,
                          trial: trial}};
      statusEl.textContent = 'step ' + s.step + ' of ' + s.steps + ' (t = ' + s.t.toFixed(2) +
        ' s)' + (s.finished ? ': run finished' : '');
    }}
    await sleep(250);
  }}
}}
run();
</script></body></html>
"""


def _num(a) -> list:
    """A float array as a JSON-ready list, NaN (plotly's gaps) as ``null``, 4 decimals."""
    a = np.round(np.asarray(a, np.float64).ravel(), 4)
    return np.where(np.isnan(a), None, a).tolist()


def page(name: str, trials) -> str:
    """The live page: a trial selector over ``trials`` (their indices), the plot, the poller."""
    options = "".join(f'<option value="{j}">{int(t)}</option>' for j, t in enumerate(trials))
    return PAGE.format(name=name, options=options)


def figure_json(scenario, lo, hi, ztop: float, title: str, cols=()) -> tuple[str, list, list]:
    """The live figure before any data; ``(json, layer indices, metrics indices)``.

    Built from the scenario alone (before the simulation starts, so it costs the run
    nothing): the layers of :data:`~mjx_radar.viz.viewer_traces.LAYERS` are empty until
    the first ``/state.json``.

    Args:
        scenario: the scenario (radar and drone counts, obstacles).
        lo, hi: ``[2]`` xy corners of the ground extent.
        ztop: top of the z axis [m].
        title: figure title.
        cols: the counts panel's metrics (:func:`~mjx_radar.viz.viewer_counts.count_columns`).
    """
    import plotly.graph_objects as go

    fig = counts.subplots(bool(cols))
    for trace in static_traces(scenario, lo, hi):
        fig.add_trace(trace)
    first = len(fig.data)
    n = scenario.n_radars
    moving = bool(getattr(scenario, "moving_obstacles", ()))
    for style in layer_styles(n, len(scenario.target_init), fixed_sites(scenario, n), moving):
        fig.add_trace(style | {"x": [], "y": [], "z": []})
    anim = list(range(first, len(fig.data)))
    fig.add_trace(sample_legend(lo))
    for name, colour in (("RMSE", "rgb(0,90,200)"), ("PCRLB", "rgb(220,0,0)")):
        fig.add_trace(
            go.Scatter(
                x=[], y=[], mode="lines", name=name, legendgroup="metrics", line={"color": colour}
            ),
            row=1,
            col=2,
        )
    fig.add_trace(
        go.Scatter(
            x=[],
            y=[],
            mode="markers",
            name="current step",
            legendgroup="metrics",
            marker={"size": 9, "color": "black"},
        ),
        row=1,
        col=2,
    )
    metrics = list(range(len(fig.data) - 3, len(fig.data)))
    if cols:
        for trace in [*counts.count_traces(cols), counts.cursor_trace()]:
            metrics.append(len(fig.data))
            fig.add_trace(trace, row=2, col=2)
    fig.update_layout(
        title={"text": title, "font": {"size": 13}},
        template="plotly_white",
        margin={"l": 10, "r": 10, "t": 50, "b": 10},
        legend=legend_per_layer(fig),
        uirevision="live",
        scene=_scene(lo, hi, ztop),
        **counts.layout(bool(cols)),
    )
    return fig.to_json(), anim, metrics


def ranges(lo, hi, ztop: float) -> list[list[float]]:
    """Scene axis ranges: the xy box with a 5 % margin, z from 0 to ``ztop``."""
    pad = 0.05 * float(max(np.max(hi - lo), 1.0))
    return [
        [float(lo[0] - pad), float(hi[0] + pad)],
        [float(lo[1] - pad), float(hi[1] + pad)],
        [0.0, float(ztop)],
    ]


def _ground(lo, hi) -> list[list[float]]:
    """The ground extent's rectangle at z = 0 (trace 0 of the figure), as x, y, z lists."""
    x = [lo[0], hi[0], hi[0], lo[0], lo[0]]
    y = [lo[1], lo[1], hi[1], hi[1], lo[1]]
    return [[float(v) for v in x], [float(v) for v in y], [0.0] * 5]


def _scene(lo, hi, ztop: float) -> dict:
    r = ranges(lo, hi, ztop)
    return {
        "xaxis": {"range": r[0], "title": {"text": "x [m]"}},
        "yaxis": {"range": r[1], "title": {"text": "y [m]"}},
        "zaxis": {"range": r[2], "title": {"text": "z [m]"}},
        **aspect((r[0][1] - r[0][0], r[1][1] - r[1][0])),
    }


def state_json(
    tr,
    plan_xy,
    samples: int,
    curves,
    seq: int,
    steps: int,
    finished: bool,
    anim: list,
    metrics: list,
    box,
) -> str:
    """``/state.json``: the layers at the latest step of ``tr`` and the metrics so far.

    Args:
        tr: :class:`~mjx_radar.viz.run_dir.Trial` of the steps received (its
            ``sample_xy`` holds the acting control step only).
        plan_xy: ``[1, H, N, 2]`` the acting plan.
        samples: MPPI samples drawn (the highest weights).
        curves: ``(time [K], rmse [K], crlb [K], {count column: [K]})`` so far.
        seq: segments received; steps: the run's filter steps; finished: the run ended.
        anim, metrics: trace indices of the layers and of RMSE, PCRLB, marker.
        box: ``(lo, hi, ztop)`` of the scene ranges.
    """
    k = tr.steps - 1
    layers = frame_traces(tr, k, samples, plan_xy)
    time, rmse, crlb, count = curves
    out = {
        "seq": seq,
        "step": k + 1,
        "steps": steps,
        "finished": finished,
        "t": float(time[k]),
        "layers": [{c: _num(d[c]) for c in "xyz"} for d in layers],
        "sample_w": _num(layers[6]["line"]["color"]),
        "time": _num(time),
        "rmse": _num(rmse),
        "crlb": _num(crlb),
        "now": [_num(rmse[k : k + 1])[0], _num(crlb[k : k + 1])[0]],
        "counts": [_num(c) for c in count.values()],
        "counts_now": [_num(c[k : k + 1])[0] for c in count.values()],
        "anim": anim,
        "metrics": metrics,
        "ranges": ranges(*box),
        "ground": _ground(*box[:2]),
    }
    return json.dumps(out)
