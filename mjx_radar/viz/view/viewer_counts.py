"""The viewer's counts panel: detections, visible pairs, false alarms, targets present vs time.

Shown below the RMSE / PCRLB panel (offline HTML, :mod:`mjx_radar.viz.view.viewer`, and live
view, :mod:`mjx_radar.viz.live_view.live_page`) only when there is something to count:

- ``detections``, ``visible_pairs``, ``false_alarms`` (``metrics.parquet`` columns of the
  same names, docs/detection.md) when the run has detection on: a Pd model that draws
  (``[detection]`` ``detects``) or clutter (``clutter``);
- ``targets_present`` when it varies over the run (``[[target_motion]]`` appear / leave).

The curves are the metrics' own values (integers per filter step), a linear y axis.
"""

from __future__ import annotations

import numpy as np

#: (metrics column, legend name, colour)
COUNTS = (
    ("detections", "detections", "rgb(0,150,70)"),
    ("visible_pairs", "visible pairs", "rgb(110,110,110)"),
    ("false_alarms", "false alarms", "rgb(200,0,160)"),
    ("targets_present", "targets present", "rgb(40,40,200)"),
)


def presence_varies(target_motion, duration: float) -> bool:
    """Whether some target appears after 0 or leaves before ``duration`` [s]
    (``target_motion``: the ``[[target_motion]]`` tables)."""
    return any(tm.appear > 0.0 or tm.leave < duration for tm in target_motion)


def count_columns(scene, metrics=None, duration: float | None = None) -> tuple[str, ...]:
    """The columns of :data:`COUNTS` the panel shows.

    Args:
        scene: the run's :class:`~mjx_radar.viz.scene.Scene` (detection on, presence).
        metrics: ``metrics.parquet`` as a DataFrame (offline: ``targets_present`` is shown
            iff it takes more than one value), or ``None`` (live: iff
            :func:`presence_varies` over ``duration``).
        duration: the run's simulated time [s] (live only).
    """
    cols = [c for c, *_ in COUNTS[:3]] if scene.detection_on else []
    if metrics is not None:
        if "targets_present" in metrics and metrics["targets_present"].nunique() > 1:
            cols.append("targets_present")
    elif presence_varies(scene.target_motion, float("inf") if duration is None else duration):
        cols.append("targets_present")
    return tuple(cols)


def count_traces(cols, row: int = 2, col: int = 2) -> list:
    """Empty ``go.Scatter`` line traces of ``cols`` (legend group "counts")."""
    import plotly.graph_objects as go

    style = {c: (name, colour) for c, name, colour in COUNTS}
    return [
        go.Scatter(
            x=[],
            y=[],
            mode="lines",
            name=style[c][0],
            legendgroup="counts",
            line={"color": style[c][1], "width": 1.5, "shape": "hv"},
        )
        for c in cols
    ]


def step_marker():
    """The current-step marker of the RMSE / PCRLB panel (the offline and the live view)."""
    import plotly.graph_objects as go

    return go.Scatter(
        x=[],
        y=[],
        mode="markers",
        name="current step",
        legendgroup="metrics",
        marker={"size": 9, "color": "black"},
    )


def cursor_trace():
    """The current-step marker of the counts panel (one point per shown column)."""
    import plotly.graph_objects as go

    return go.Scatter(
        x=[],
        y=[],
        mode="markers",
        name="current step (counts)",
        legendgroup="counts",
        showlegend=False,
        marker={"size": 7, "color": "black"},
    )


def curves(metrics, trial_id: int, cols) -> dict[str, np.ndarray]:
    """``column -> [K]`` float32 values of one trial, ordered by step."""
    rows = metrics[metrics["trial"] == trial_id].sort_values("step")
    return {c: rows[c].to_numpy(np.float32) for c in cols}


def layout(has_counts: bool) -> dict:
    """The right column's axes: RMSE / PCRLB (log) above the counts (linear) if any."""
    top = {"title": {"text": "position [m]"}, "type": "log"}
    if not has_counts:
        return {"xaxis": {"title": {"text": "time [s]"}}, "yaxis": top}
    return {
        "xaxis": {"matches": "x2"},
        "yaxis": top,
        "xaxis2": {"title": {"text": "time [s]"}},
        "yaxis2": {"title": {"text": "count"}, "rangemode": "tozero"},
    }


def subplots(has_counts: bool):
    """``make_subplots`` of the viewer: the scene left; right one or two xy panels."""
    from plotly.subplots import make_subplots

    if not has_counts:
        return make_subplots(
            rows=1,
            cols=2,
            column_widths=[0.7, 0.3],
            horizontal_spacing=0.06,
            specs=[[{"type": "scene"}, {"type": "xy"}]],
        )
    return make_subplots(
        rows=2,
        cols=2,
        column_widths=[0.7, 0.3],
        horizontal_spacing=0.06,
        vertical_spacing=0.1,
        row_heights=[0.6, 0.4],
        specs=[[{"type": "scene", "rowspan": 2}, {"type": "xy"}], [None, {"type": "xy"}]],
    )
