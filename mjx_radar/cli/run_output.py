"""What ``mjx-radar run`` does once its trials are done: the run directory, the summary
line, the line on diverged trials, the video; the command's exit code."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from mjx_radar.errors import EXIT_FAILURE, EXIT_INTERRUPTED


def diverged_line(
    diverged, trials, out: Path, keep: bool, method: str = "", controls=None
) -> str | None:
    """The one-line report of diverged trials (``None`` if none diverged).

    Args:
        diverged: [T, K] bool, True from the step a trial's estimate or covariance
            became non-finite or non-positive-definite.
        trials: [T] trial indices.
        out: the run directory.
        keep: ``--keep-diverged`` (a warning instead of an error).
        method: the run's method; a ``METHOD+PLANNER`` one names its planner.
        controls: ``[T, J, N, 2]`` the applied controls (a planner's NaN is named).
    """
    if diverged is None:
        return None
    div = np.asarray(diverged, bool).reshape(len(trials), -1)
    bad = np.flatnonzero(div.any(axis=1))
    if bad.size == 0:
        return None
    first_step = div[bad].argmax(axis=1)  # 0-based step of each diverged trial
    j = int(np.argmin(first_step))  # earliest; ties -> lowest trial
    where = f"first at trial {int(trials[bad[j]])}, step {int(first_step[j]) + 1}"
    if "+" in method:  # a planner of the user's choice: name it (a NaN action diverges)
        where += f"; method {method}, planner {method.partition('+')[2]!r}"
        if controls is not None:
            u = ~np.isfinite(np.asarray(controls)).reshape(len(trials), -1)
            if u.any():
                t = int(np.flatnonzero(u.any(axis=1))[0])
                where += f", whose plan() returned NaN or inf controls (trial {int(trials[t])})"
    head = f"{bad.size} of {len(trials)} trials diverged ({where}); results in {out}"
    if keep:
        return f"warning: {head}; kept (--keep-diverged)"
    return f"error: {head}; pass --keep-diverged to accept"


def finish(out: Path, args, s, seed_, trials, steps, res) -> int:
    """Writes the run directory, prints the summary, renders the video; the exit code."""
    try:
        write_results(out, args, s, seed_, trials, steps, res)
    except KeyboardInterrupt:
        print("interrupted: no results written", file=sys.stderr)
        return EXIT_INTERRUPTED
    summary(s, args, res, out)
    line = diverged_line(
        res.get("diverged"), trials, out, args.keep_diverged, args.method, res.get("control")
    )
    if line:
        print(line, file=sys.stderr)
    if args.video:
        from mjx_radar.viz import render

        render.render_run(out, trial=0, out_path=out / "video.mp4")
    return EXIT_FAILURE if line and not args.keep_diverged else 0


def write_results(out: Path, args, s, seed_, trials, steps, res) -> None:
    """Writes the run directory (:func:`mjx_radar.rundir.writer.write_run`)."""
    from mjx_radar.api.run_case import run_header
    from mjx_radar.rundir.writer import write_run
    from mjx_radar.scenario.reader import resolve_path

    write_run(
        out,
        run_header(s),
        args.method,
        seed_,
        trials,
        steps,
        res,
        source=resolve_path(args.scenario),
        precision=getattr(args, "precision", "float32"),
        deterministic=bool(res.get("deterministic", False)),
    )


def summary(s, args, res, out: Path) -> None:
    """The run's summary: one short line; ``--verbose`` adds a line of further figures."""
    print(summary_line(args, res, out))
    if getattr(args, "verbose", False):
        print(detail_line(s, args, res))


def summary_line(args, res, out: Path) -> str:
    """Mean position RMSE against the PCRLB, lost trials, times and the run directory."""
    lost = int(np.asarray(res["lost"]).any(axis=-1).sum())
    return (
        f"mean position RMSE {float(np.mean(res['rmse_pos'])):.3f} m "
        f"(PCRLB {np.mean(res['crlb_pos']):.3f} m); {lost} of {args.trials} trial(s) lost "
        f"track; compile {res['compile_s']:.1f} s, simulation {res['sim_s']:.1f} s; "
        f"results in {out}"
    )


def detail_line(s, args, res) -> str:
    """``--verbose``: final-step RMSE, control rate, GOSPA / OSPA and track continuity."""
    return (
        f"final-step RMSE {np.mean(res['rmse_pos'][:, -1]):.3f} m; control rate "
        f"{res['control_hz']:.1f} Hz for the batch of {args.trials} (real time: "
        f"{1 / s.timing.dt_control:g} Hz); {set_line(s, res)}"
    )


def set_line(s, res) -> str:
    """Mean GOSPA (its parts), OSPA and track continuity of the run, in words."""
    m = s.metrics
    parts = "/".join(
        f"{np.mean(res['gospa_' + k]):.2f}" for k in ("localisation", "missed", "false")
    )
    return (
        f"mean GOSPA {np.mean(res['gospa']):.3f} m (c = {m.gospa_cutoff:g} m, p = "
        f"{m.gospa_order:g}; localisation/missed/false {parts} m^p), OSPA "
        f"{np.mean(res['ospa']):.3f} m, {int(np.sum(res['label_switches']))} label switch(es), "
        f"{int(np.sum(res['broken_tracks']))} broken track(s)"
    )
