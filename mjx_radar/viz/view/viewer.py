"""``mjx-radar view``: one self-contained, offline HTML file to look inside a saved run.

A plotly figure (docs/viewer.md): left, a 3-D scene animated by frames with a time
slider and play / pause — ground extent and obstacle wireframes, radars with their
trails and R2T rings, true drones, CKF estimates with their 2-sigma axes, the kept
MPPI samples (at the radars' height, coloured by relative weight), the plan and
the radar-to-drone lines of sight (:mod:`mjx_radar.viz.view.viewer_traces`); right, the
position RMSE and the PCRLB of the selected trial against time with a marker at the
current step, and below it, where the run has them, the detection counts and the targets
present (:mod:`mjx_radar.viz.view.viewer_counts`). A dropdown selects the trial; each trial
has its own frames and slider (a few lines of JavaScript swap them:
:mod:`mjx_radar.viz.view.viewer_controls`). Each layer is one named trace, shown or
hidden from the legend. plotly.js is embedded: opening the file makes no request.

Steps are subsampled to at most ``max_frames`` frames per trial (every k-th filter
step, the last step always included) and at most ``samples`` MPPI samples (the
highest weights) per frame; a terrain surface is subsampled to at most 160 nodes per
side (:mod:`mjx_radar.viz.view.viewer_world`); the title says what was dropped.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from html import escape
from pathlib import Path

import numpy as np

from mjx_radar.errors import InputError
from mjx_radar.io.atomic import atomic_write, check_writable
from mjx_radar.viz.run_dir import RunDir, load_run, load_trial
from mjx_radar.viz.view import viewer_counts as counts
from mjx_radar.viz.view import viewer_figure as stages
from mjx_radar.viz.view.viewer_budget import (
    MAX_FRAMES,
    ViewInfo,
    fit_budget,
    frame_steps,
    trial_list,
)
from mjx_radar.viz.view.viewer_controls import TRIAL_JS
from mjx_radar.viz.view.viewer_legend import hide_blocked_entry
from mjx_radar.viz.view.viewer_los import visibility
from mjx_radar.viz.view.viewer_traces import layer_styles, static_traces
from mjx_radar.viz.view.viewer_world import terrain_nodes


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
    stages.check_options(max_frames, samples)
    rd = run_dir if isinstance(run_dir, RunDir) else load_run(run_dir)
    metrics = stages.metrics_table(rd)
    trials = trial_list(trial, rd.trials)
    ids = rd.meta.get("trial_ids") or list(range(rd.trials))
    plans = rd.arrays.get("plan_xy")
    tr0 = load_trial(rd, trials[0] if trials else 0)
    ks = frame_steps(tr0.steps, max_frames)
    first_plan = None if plans is None else plans[0]
    shown = None if trials is None else len(trials)
    count, samples = fit_budget(tr0, ks, first_plan, rd.trials, samples, shown)
    trials = trials or tuple(range(count))
    trs = [load_trial(rd, t) for t in trials]
    sc = rd.scene
    box = stages.scene_box(trs, sc.moving.vehicles)
    cols = counts.count_columns(sc, metrics)
    fig = counts.subplots(bool(cols))
    n, m = trs[0].radar.shape[1], trs[0].target.shape[1]
    styles = layer_styles(n, m, np.array(sc.fixed, bool), sc.moving.present)
    layers = (functools.partial(static_traces, sc), styles)
    first, anim, zrange = stages.add_scene(fig, layers, trs[0], ks[0], samples, box, cols)
    view = dict(metrics=metrics, cols=cols, ks=ks, samples=samples, anim=anim)
    view["visibility"] = functools.partial(visibility, sc.ground, sc.obstacles, sc.moving)
    metric_idx, frames, sliders = [], [], []
    for j, (t, tr) in enumerate(zip(trials, trs, strict=True)):
        view["plan"] = None if plans is None else plans[t]
        idx, trial_frames, trial_slider = stages.add_trial(fig, j, tr, ids[t], view)
        metric_idx.append(idx)
        frames += trial_frames
        sliders.append(trial_slider)
    fig.frames = frames
    if frames:  # the figure opens at the first frame of the first trial
        for i, d in zip(anim, frames[0].data, strict=True):
            fig.data[i].update(d)
    fig.data[first + 6].line.color = frames[0].data[6].line.color
    info = _info(rd, trials, trs, ks, samples, max_frames, box)
    hide_blocked_entry(fig, sc.occluded)
    title = f"{rd.meta.get('scenario', sc.name)} / {rd.meta.get('method', '')}"
    controls = (trials, ids, metric_idx, sliders)
    stages.figure_layout(fig, f"{title} — shown: {info.dropped()}", box, zrange, controls, cols)
    return fig, info


def _info(rd, trials, trs, ks, samples, max_frames, box) -> ViewInfo:
    """What the figure shows of the run (and what it dropped)."""
    kept = int(trs[0].sample_xy.shape[1])
    stride = math.ceil(trs[0].steps / max_frames)
    terrain, ground = "", rd.scene.ground
    if ground.present:
        xs, ys, _, every = terrain_nodes(ground.config, box[0], box[1])
        terrain = f"terrain {len(xs)} x {len(ys)} nodes (every {every})"
    return ViewInfo(
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
