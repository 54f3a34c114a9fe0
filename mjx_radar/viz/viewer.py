"""``mjx-radar view``: one self-contained, offline HTML file to look inside a saved run.

A plotly figure (docs/viewer.md): left, a 3-D scene animated by frames with a time
slider and play / pause — ground extent and obstacle wireframes, radars with their
trails and R2T rings, true drones, CKF estimates with their 2-sigma axes, the kept
MPPI samples (at the radars' height, coloured by relative weight), the plan and
the radar-to-drone lines of sight (:mod:`mjx_radar.viz.viewer_traces`); right, the
position RMSE and the PCRLB of the selected trial against time with a marker at the
current step, and below it, where the run has them, the detection counts and the targets
present (:mod:`mjx_radar.viz.viewer_counts`). A dropdown selects the trial; each trial
has its own frames and slider (a few lines of JavaScript swap them:
:mod:`mjx_radar.viz.viewer_controls`). Each layer is one named trace, shown or
hidden from the legend. plotly.js is embedded: opening the file makes no request.

Steps are subsampled to at most ``max_frames`` frames per trial (every k-th filter
step, the last step always included) and at most ``samples`` MPPI samples (the
highest weights) per frame; a terrain surface is subsampled to at most 160 nodes per
side (:mod:`mjx_radar.viz.viewer_world`); the title says what was dropped.
"""

from __future__ import annotations

import dataclasses
import math
from html import escape
from pathlib import Path

import numpy as np

from mjx_radar.errors import InputError
from mjx_radar.io.atomic import atomic_write, check_writable
from mjx_radar.viz import viewer_counts as counts
from mjx_radar.viz.run_dir import RunDir, load_run, load_trial
from mjx_radar.viz.viewer_budget import MAX_FRAMES, ViewInfo, fit_budget, frame_steps, trial_list
from mjx_radar.viz.viewer_controls import TRIAL_JS, menus, slider
from mjx_radar.viz.viewer_legend import hide_blocked_entry, legend_per_layer, sample_legend
from mjx_radar.viz.viewer_los import visibility
from mjx_radar.viz.viewer_traces import (
    fixed_sites,
    frame_traces,
    layer_styles,
    static_traces,
)
from mjx_radar.viz.viewer_world import aspect, terrain_nodes


def _metrics(rd: RunDir):
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


def _curves(metrics, trial_id: int, steps: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
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


def build_figure(run_dir, trial=None, max_frames: int = MAX_FRAMES, samples: int | None = None):
    """The viewer's ``plotly.graph_objects.Figure`` of a run directory.

    Args:
        run_dir: a run directory path or a loaded :class:`~mjx_radar.viz.run_dir.RunDir`.
        trial: a trial position, a list of them, or ``None``: the first trials (at most
            :data:`.viewer_budget.MAX_TRIALS`) that fit :data:`.viewer_budget.SIZE_BUDGET`
            with the other options.
        max_frames: at most this many frames per trial (>= 1).
        samples: at most this many MPPI samples per frame (>= 0); ``None``: up to
            :data:`.viewer_budget.MAX_SAMPLES`, halved (down to 8) while the file would
            exceed the budget.

    Returns:
        ``(figure, ViewInfo)`` (``ViewInfo.path`` is ``None``).

    Raises:
        InputError: a damaged or incomplete run directory, a bad trial or option.
    """
    import plotly.graph_objects as go

    if isinstance(max_frames, bool) or not isinstance(max_frames, int) or max_frames < 1:
        raise InputError(f"--max-frames = {max_frames!r}: must be an integer >= 1")
    if samples is not None and (
        isinstance(samples, bool) or not isinstance(samples, int) or samples < 0
    ):
        raise InputError(f"--samples = {samples!r}: must be an integer >= 0")
    rd = run_dir if isinstance(run_dir, RunDir) else load_run(run_dir)
    metrics = _metrics(rd)
    trials = trial_list(trial, rd.trials)
    ids = rd.meta.get("trial_ids") or list(range(rd.trials))
    plans = rd.arrays.get("plan_xy")
    tr0 = load_trial(rd, trials[0] if trials else 0)
    ks = frame_steps(tr0.steps, max_frames)
    count, samples = fit_budget(
        tr0,
        ks,
        None if plans is None else plans[0],
        rd.trials,
        samples,
        None if trials is None else len(trials),
    )
    trials = trials or tuple(range(count))
    trs = [load_trial(rd, t) for t in trials]
    n, m = trs[0].radar.shape[1], trs[0].target.shape[1]
    boxes = np.array([tr.bounds() for tr in trs])
    lo, hi = boxes[:, 0].min(0), boxes[:, 1].max(0)
    for car in rd.scenario.moving_obstacles:  # the vehicles' roads in the scene too
        lo, hi = np.minimum(lo, np.min(car.path, 0)), np.maximum(hi, np.max(car.path, 0))
    zs = np.concatenate([tr.target[..., 2].reshape(-1) for tr in trs])
    zs = zs[np.isfinite(zs)]  # NaN truth (a diverged trial) sets no range
    ztop, zlow = max(float(zs.max()) * 1.15 if zs.size else 1.0, 1.0), 0.0
    cols = counts.count_columns(rd.scenario, metrics)
    fig = counts.subplots(bool(cols))
    for trace in static_traces(rd.scenario, lo, hi):
        fig.add_trace(trace)
        if trace["type"] == "surface":
            ztop, zlow = max(ztop, 1.1 * float(trace["z"].max())), float(trace["z"].min())
    first = len(fig.data)
    for style, data in zip(
        layer_styles(n, m, fixed_sites(rd.scenario, n), bool(rd.scenario.moving_obstacles)),
        frame_traces(trs[0], ks[0], samples, None, np.ones((n, m), bool)),
        strict=True,
    ):
        fig.add_trace(style | {k: v for k, v in data.items() if k != "line"})
    fig.add_trace(sample_legend(lo))
    anim = [*range(first, len(fig.data) - 1), len(fig.data)]  # the layers and the metrics marker
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
    if cols:
        anim.append(len(fig.data))
        fig.add_trace(counts.cursor_trace(), row=2, col=2)
    metric_idx, frames, sliders = [], [], []
    for j, (t, tr) in enumerate(zip(trials, trs, strict=True)):
        time, rmse, crlb = _curves(metrics, ids[t], tr.steps)
        metric_idx.append([len(fig.data), len(fig.data) + 1])
        for name, y, colour in (("RMSE", rmse, "rgb(0,90,200)"), ("PCRLB", crlb, "rgb(220,0,0)")):
            fig.add_trace(
                go.Scatter(
                    x=time,
                    y=y,
                    mode="lines",
                    name=f"{name} (trial {ids[t]})",
                    legendgroup="metrics",
                    visible=j == 0,
                    line={"color": colour},
                ),
                row=1,
                col=2,
            )
        count = counts.curves(metrics, ids[t], cols)
        for c, trace in zip(cols, counts.count_traces(cols), strict=True):
            metric_idx[-1].append(len(fig.data))
            fig.add_trace(trace.update(x=time, y=count[c], visible=j == 0), row=2, col=2)
        plan = None if plans is None else plans[t]
        vis = visibility(rd.scenario, tr.radar[ks, :, :3], tr.target[ks, :, :3], (ks + 1) * tr.dt)
        for i, k in enumerate(ks):
            data = frame_traces(tr, k, samples, plan, vis[i])
            data.append(dict(type="scatter", x=[time[k]] * 2, y=[rmse[k], crlb[k]]))
            if cols:
                data.append(
                    dict(
                        type="scatter",
                        x=[time[k]] * len(cols),
                        y=[float(count[c][k]) for c in cols],
                    )
                )
            frames.append(go.Frame(data=data, traces=anim, name=f"t{j}:{i}", group=f"trial{j}"))
        sliders.append(slider(j, time[ks], j == 0))
    fig.frames = frames
    if frames:  # the figure opens at the first frame of the first trial
        for i, d in zip(anim, frames[0].data, strict=True):
            fig.data[i].update(d)
    fig.data[first + 6].line.color = frames[0].data[6].line.color
    kept = int(trs[0].sample_xy.shape[1])
    stride = math.ceil(trs[0].steps / max_frames)
    terrain = ""
    if rd.scenario.terrain is not None:
        xs, ys, _, every = terrain_nodes(rd.scenario.terrain, lo, hi)
        terrain = f"terrain {len(xs)} x {len(ys)} nodes (every {every})"
    info = ViewInfo(
        None,
        trials,
        rd.trials,
        trs[0].steps,
        len(ks),
        stride,
        min(samples, kept),
        kept,
        terrain=terrain,
    )
    pad = 0.05 * float(max(hi - lo))
    span = np.maximum(hi - lo + 2 * pad, 1.0)
    hide_blocked_entry(fig, rd.scenario)
    fig.update_layout(
        title={
            "text": f"{rd.meta.get('scenario', rd.scenario.name)} / {rd.meta.get('method', '')}"
            f" — shown: {info.dropped()}",
            "font": {"size": 13},
        },
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
    return fig, info


def view(
    run_dir, out_path=None, trial=None, max_frames: int = MAX_FRAMES, samples: int | None = None
) -> ViewInfo:
    """Writes the viewer of a run directory as one self-contained HTML file.

    Args:
        run_dir: a complete run directory.
        out_path: ``.html`` file (default ``run_dir/view.html``).
        trial: see :func:`build_figure`.
        max_frames: at most this many frames per trial.
        samples: at most this many MPPI samples per frame.

    Returns:
        :class:`ViewInfo` with the path and the file's size.

    Raises:
        InputError: see :func:`build_figure`; a wrong extension or an unwritable path.
    """
    import plotly.io as pio

    out_path = Path(out_path or Path(run_dir) / "view.html")
    if out_path.suffix.lower() not in (".html", ".htm"):
        raise InputError(f"--out = {str(out_path)!r}: extension must be .html")
    fig, info = build_figure(run_dir, trial, max_frames, samples)
    check_writable(out_path, "--out")
    html = pio.to_html(
        fig,
        include_plotlyjs=True,
        full_html=True,
        default_height="96vh",
        auto_play=False,
        post_script=TRIAL_JS,
        config={"displaylogo": False},
    )
    html = html.replace("<head>", f"<head><title>{escape(fig.layout.title.text)}</title>", 1)
    data = html.encode()
    atomic_write(out_path, lambda tmp: Path(tmp).write_bytes(data))
    return dataclasses.replace(info, path=out_path, bytes=len(data))
