"""The stages of the viewer's figure (:func:`mjx_radar.viz.view.viewer.build_figure`).

Each stage adds one part to a plotly figure: :func:`scene_box` (the drawn extent of the
trials and the vehicles' roads), :func:`add_scene` (static layers, the animated layers at
the first frame, the current-step markers), :func:`add_trial` (one trial's metric
curves, its frames and its slider) and :func:`figure_layout` (title, menus, axes).
Host-side numpy and plotly only.
"""

from __future__ import annotations

import numpy as np

from mjx_radar.errors import InputError
from mjx_radar.viz.run_dir import RunDir
from mjx_radar.viz.view import viewer_counts as counts
from mjx_radar.viz.view.viewer_controls import menus, slider
from mjx_radar.viz.view.viewer_legend import legend_per_layer, sample_legend
from mjx_radar.viz.view.viewer_traces import frame_traces
from mjx_radar.viz.view.viewer_world import aspect

RMSE_RGB, CRLB_RGB = "rgb(0,90,200)", "rgb(220,0,0)"


def check_options(max_frames, samples) -> None:
    """One-line ``InputError`` for a bad ``max_frames`` (>= 1) or ``samples`` (>= 0)."""
    if isinstance(max_frames, bool) or not isinstance(max_frames, int) or max_frames < 1:
        raise InputError(f"--max-frames = {max_frames!r}: must be an integer >= 1")
    if samples is not None and (
        isinstance(samples, bool) or not isinstance(samples, int) or samples < 0
    ):
        raise InputError(f"--samples = {samples!r}: must be an integer >= 0")


def metrics_table(rd: RunDir):
    """The run's ``metrics.parquet`` columns the viewer draws (``InputError`` if damaged)."""
    import pandas as pd

    path = rd.path / "metrics.parquet"
    if not path.is_file():
        raise InputError(
            f"RUN_DIR = {str(rd.path)!r}: not a complete run directory (no metrics.parquet)"
        )
    try:
        wanted = ["trial", "step", "time_s", "rmse_pos", "crlb_pos"]
        table = pd.read_parquet(path)
        return table[wanted + [c for c, *_ in counts.COUNTS if c in table]]
    except Exception as err:  # pyarrow raises many types for a damaged file
        first = str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__
        raise InputError(f"{path}: damaged metrics file ({first})") from None


def curves(metrics, trial_id: int, steps: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(time, rmse, crlb)`` of one trial, ``steps`` rows (``InputError`` otherwise)."""
    rows = metrics[metrics["trial"] == trial_id].sort_values("step")
    if len(rows) != steps:
        raise InputError(
            f"metrics.parquet: trial {trial_id} has {len(rows)} rows, "
            f"expected {steps}; damaged metrics file"
        )
    return (
        rows["time_s"].to_numpy(np.float32),
        rows["rmse_pos"].to_numpy(np.float32),
        rows["crlb_pos"].to_numpy(np.float32),
    )


def scene_box(trs, vehicles) -> tuple[np.ndarray, np.ndarray, float]:
    """``(lo, hi, ztop)``: the trials' extent and the ``vehicles``' roads, the top of z."""
    boxes = np.array([tr.bounds() for tr in trs])
    lo, hi = boxes[:, 0].min(0), boxes[:, 1].max(0)
    for car in vehicles:  # the vehicles' roads in the scene too
        lo, hi = np.minimum(lo, np.min(car.path, 0)), np.maximum(hi, np.max(car.path, 0))
    zs = np.concatenate([tr.target[..., 2].reshape(-1) for tr in trs])
    zs = zs[np.isfinite(zs)]  # NaN truth (a diverged trial) sets no range
    return lo, hi, max(float(zs.max()) * 1.15 if zs.size else 1.0, 1.0)


def add_scene(fig, layers, tr0, k0, samples, box, cols):
    """Static layers, the animated layers at ``tr0``'s step ``k0`` and the markers.

    Args:
        fig: the figure (traces added).
        layers: ``(static, styles)``: a function ``(lo, hi) -> static traces`` and the
            animated layers' styles (:func:`~mjx_radar.viz.view.viewer_traces.layer_styles`).
        tr0: the first trial shown; ``k0`` its first frame's step.
        samples: MPPI samples per frame.
        box: :func:`scene_box`'s ``(lo, hi, ztop)``.
        cols: the count columns drawn (:mod:`~mjx_radar.viz.view.viewer_counts`).

    Returns:
        ``(first, anim, zrange)``: the first animated trace's index, the indices every
        frame updates, ``(zlow, ztop)`` with the terrain surface counted.
    """

    lo, hi, ztop = box
    zlow = 0.0
    static, styles = layers
    for trace in static(lo, hi):
        fig.add_trace(trace)
        if trace["type"] == "surface":
            ztop, zlow = max(ztop, 1.1 * float(trace["z"].max())), float(trace["z"].min())
    first = len(fig.data)
    n, m = tr0.radar.shape[1], tr0.target.shape[1]
    for style, data in zip(
        styles,
        frame_traces(tr0, k0, samples, None, np.ones((n, m), bool)),
        strict=True,
    ):
        fig.add_trace(style | {k: v for k, v in data.items() if k != "line"})
    fig.add_trace(sample_legend(lo))
    anim = [*range(first, len(fig.data) - 1), len(fig.data)]  # the layers and the metrics marker
    fig.add_trace(counts.step_marker(), row=1, col=2)
    if cols:
        anim.append(len(fig.data))
        fig.add_trace(counts.cursor_trace(), row=2, col=2)
    return first, anim, (zlow, ztop)


def add_trial(fig, j: int, tr, trial_id: int, view: dict) -> tuple[list, list, dict]:
    """Trial ``j``'s metric curves (shown for the first), frames and slider.

    Args:
        fig: the figure (traces added).
        j: the trial's position in the figure.
        tr: the :class:`~mjx_radar.viz.run_dir.Trial`.
        trial_id: its id in the run.
        view: ``metrics``, ``cols`` (count columns), ``ks`` (frame steps), ``samples``,
            ``plan`` (its ``[C, H, N, 2]`` plans or None), ``anim``, ``visibility``
            (``(radar, target, time) -> [F, N, M]`` lines of sight).

    Returns:
        ``(metric trace indices, frames, slider)``.
    """
    import plotly.graph_objects as go

    ks, cols = view["ks"], view["cols"]
    time, rmse, crlb = curves(view["metrics"], trial_id, tr.steps)
    idx = [len(fig.data), len(fig.data) + 1]
    for name, y, colour in (("RMSE", rmse, RMSE_RGB), ("PCRLB", crlb, CRLB_RGB)):
        line = go.Scatter(
            x=time,
            y=y,
            mode="lines",
            name=f"{name} (trial {trial_id})",
            legendgroup="metrics",
            visible=j == 0,
            line={"color": colour},
        )
        fig.add_trace(line, row=1, col=2)
    count = counts.curves(view["metrics"], trial_id, cols)
    for c, trace in zip(cols, counts.count_traces(cols), strict=True):
        idx.append(len(fig.data))
        fig.add_trace(trace.update(x=time, y=count[c], visible=j == 0), row=2, col=2)
    vis = view["visibility"](tr.radar[ks, :, :3], tr.target[ks, :, :3], (ks + 1) * tr.dt)
    frames = []
    for i, k in enumerate(ks):
        data = frame_traces(tr, k, view["samples"], view["plan"], vis[i])
        data.append(dict(type="scatter", x=[time[k]] * 2, y=[rmse[k], crlb[k]]))
        if cols:
            y = [float(count[c][k]) for c in cols]
            data.append(dict(type="scatter", x=[time[k]] * len(cols), y=y))
        frames.append(go.Frame(data=data, traces=view["anim"], name=f"t{j}:{i}", group=f"trial{j}"))
    return idx, frames, slider(j, time[ks], j == 0)


def figure_layout(fig, title: str, box, zrange, controls: tuple, cols) -> None:
    """Title, trial menu, sliders, legend, the scene's axes and the metric panels."""
    (lo, hi, _), (zlow, ztop) = box, zrange
    trials, ids, metric_idx, sliders = controls
    pad = 0.05 * float(max(hi - lo))
    span = np.maximum(hi - lo + 2 * pad, 1.0)
    fig.update_layout(
        title={"text": title, "font": {"size": 13}},
        template="plotly_white",
        margin={"l": 10, "r": 10, "t": 70, "b": 10},
        updatemenus=menus(trials, ids, metric_idx),
        sliders=sliders,
        legend=legend_per_layer(fig),
        scene={
            "xaxis": {"range": [lo[0] - pad, hi[0] + pad], "title": {"text": "x [m]"}},
            "yaxis": {"range": [lo[1] - pad, hi[1] + pad], "title": {"text": "y [m]"}},
            "zaxis": {"range": [min(zlow, 0.0), ztop], "title": {"text": "z [m]"}},
            **aspect(span),
        },
        **counts.layout(bool(cols)),
    )
