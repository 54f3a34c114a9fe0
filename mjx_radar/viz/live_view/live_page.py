"""The page and the JSON documents of the live view (:mod:`mjx_radar.viz.live_view.live`).

The page (:data:`PAGE`) loads plotly.js from the live server itself (``/plotly.min.js``,
the copy inside the installed ``plotly`` package: no CDN, works offline), fetches the
figure once (``/figure.json``: :func:`figure_json`) and then polls ``/state.json``
(:func:`state_json`) every 250 ms; a new state replaces the data of the animated layers
of :data:`mjx_radar.viz.view.viewer_traces.LAYERS` and of the metrics curves in one
``Plotly.react`` (one redraw; ``uirevision`` keeps the camera and the legend's layer
toggles as the user left them).

The layers are those of the offline viewer (:func:`~mjx_radar.viz.view.viewer_traces.frame_traces`)
at the latest filter step received: radars with trails and R2T rings, drones, estimates
with 2-sigma axes, the acting MPPI samples and plan, lines of sight, fixed sites (and the
static terrain and waypoint routes); right, RMSE and PCRLB of the selected trial so far,
and below them the counts of :mod:`mjx_radar.viz.view.viewer_counts` where the run has
detection on or targets that appear / leave.
"""

from __future__ import annotations

import json

import numpy as np

from mjx_radar.viz.live_view.live_html import PAGE
from mjx_radar.viz.view import viewer_counts as counts
from mjx_radar.viz.view.viewer_legend import hide_blocked_entry, legend_per_layer, sample_legend
from mjx_radar.viz.view.viewer_traces import frame_traces, layer_styles, static_traces
from mjx_radar.viz.view.viewer_world import aspect


def _num(a) -> list:
    """A float array as a JSON-ready list, NaN (plotly's gaps) as ``null``, 4 decimals."""
    a = np.round(np.asarray(a, np.float64).ravel(), 4)
    return np.where(np.isnan(a), None, a).tolist()


def page(name: str, trials) -> str:
    """The live page: a trial selector over ``trials`` (their indices), the plot, the poller."""
    options = "".join(f'<option value="{j}">{int(t)}</option>' for j, t in enumerate(trials))
    return PAGE.format(name=name, options=options)


def figure_json(scene, lo, hi, ztop: float, title: str, cols=()) -> tuple[str, list, list]:
    """The live figure before any data; ``(json, layer indices, metrics indices)``.

    Built from the scene alone (before the simulation starts, so it costs the run
    nothing): the layers of :data:`~mjx_radar.viz.view.viewer_traces.LAYERS` are empty until
    the first ``/state.json``.

    Args:
        scene: the run's :class:`~mjx_radar.viz.scene.Scene` (radar and drone counts,
            fixed sites, world components, routes).
        lo, hi: ``[2]`` xy corners of the ground extent.
        ztop: top of the z axis [m].
        title: figure title.
        cols: the counts panel's metrics (:func:`~mjx_radar.viz.view.viewer_counts.count_columns`).
    """
    import plotly.graph_objects as go

    fig = counts.subplots(bool(cols))
    for trace in static_traces(scene, lo, hi):
        fig.add_trace(trace)
    first = len(fig.data)
    fixed = np.array(scene.fixed, bool)
    for style in layer_styles(scene.n_radars, scene.n_targets, fixed, scene.moving.present):
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
    fig.add_trace(counts.step_marker(), row=1, col=2)
    metrics = list(range(len(fig.data) - 3, len(fig.data)))
    if cols:
        for trace in [*counts.count_traces(cols), counts.cursor_trace()]:
            metrics.append(len(fig.data))
            fig.add_trace(trace, row=2, col=2)
    hide_blocked_entry(fig, scene.occluded)
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


def state_json(tr, plan_xy, samples: int, curves, seq, steps: int, finished: bool, idx, box) -> str:
    """``/state.json``: the layers at the last step of ``tr`` and the metrics up to it.

    Args:
        tr: :class:`~mjx_radar.viz.run_dir.Trial` of the steps shown (1 .. K).
        plan_xy: ``[C, H, N, 2]`` the plans received.
        samples: MPPI samples drawn (the highest weights).
        curves: ``(time [K], rmse [K], crlb [K], {count column: [K]})`` up to the step.
        seq: ``(segments received, [the steps at their ends])``; steps: the run's filter
            steps; finished: the run ended.
        idx: ``(layer trace indices, metrics trace indices)``.
        box: ``(lo, hi, ztop)`` of the scene ranges.
    """
    k = tr.steps - 1
    layers = frame_traces(tr, k, samples, plan_xy)
    time, rmse, crlb, count = curves
    out = {
        "seq": seq[0],
        "ends": seq[1],
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
        "anim": idx[0],
        "metrics": idx[1],
        "ranges": ranges(*box),
        "ground": _ground(*box[:2]),
    }
    return json.dumps(out)
