"""Writing a run directory: what ``mjx-radar run --out DIR`` and ``Run.save(DIR)`` write.

One function, :func:`write_run`, used by the command line and the Python API, so a
run made in Python is a run directory like any other (``render``, ``snapshot`` and
``Run.load`` read it). Schema: :mod:`mjx_radar.rundir.results`. Every file is written
atomically, ``run.json`` last; on any error (or Ctrl-C) the files written so far
are removed, so a directory either holds a complete run or none.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

from mjx_radar.task.method import parse_method

#: trajectory arrays of ``trajectories.npz`` (those present in the result)
TRAJECTORY_KEYS = (
    "target",
    "mean",
    "cov_diag",
    "radar",
    "control",
    "plan_xy",
    "sample_xy",
    "sample_weight",
    "sample_cost",
    "diverged",
    "visible",  # with masks (run --masks / simulate(masks=True))
    "detected",
)


def run_meta(scenario, method: str, seed: int, trials, steps: int, res: dict, **extra) -> dict:
    """The contents of ``run.json`` (see :mod:`mjx_radar.rundir.results`)."""
    from mjx_radar.estimation.sensing import noise_constant

    s = scenario
    trials = np.asarray(trials)
    meta = {
        "scenario": s.name,
        "scenario_file": "scenario.toml",  # relative to the run directory
        "source_scenario": extra.pop("source_scenario", None),
        "method": method,
        "planner": extra.pop("planner", None) or parse_method(method).planner,
        "seed": int(seed),
        "trials": int(len(trials)),
        "trial_ids": [int(t) for t in trials],
        "steps": int(steps),
        "dt_filter": s.timing.dt_filter,
        "dt_control": s.timing.dt_control,
        "n_radars": s.n_radars,
        "n_targets": s.n_targets,
        "r2t": s.mpc.r2t,
        "r2r": s.mpc.r2r,
        "rollout": s.mpc.rollout,
        "noise_constant": noise_constant(s.radar_eq, s.n_targets),
        "wall_s": float(res["wall_s"]),
        "compile_s": float(res["compile_s"]),
        "sim_s": float(res["sim_s"]),
        "control_hz": float(res["control_hz"]),
        "precision": extra.pop("precision", "float32"),
        "deterministic": bool(extra.pop("deterministic", False)),
        "lost_trials": int(np.asarray(res["lost"]).any(axis=-1).sum()),
        "lost_steps": int(np.asarray(res["lost"]).sum()),
        "gospa_cutoff": s.metrics.gospa_cutoff,
        "gospa_order": s.metrics.gospa_order,
    }
    if any(ov.radar_eq for ov in s.radar_override):  # a mixed fleet: C of each radar
        from mjx_radar.scenario.fleet import radar_equation

        meta["noise_constants"] = [
            noise_constant(radar_equation(s, i), s.n_targets) for i in range(s.n_radars)
        ]
    div = res.get("diverged")
    if div is not None:
        meta["diverged_trials"] = [int(t) for t in trials[np.asarray(div).any(axis=-1)]]
    return meta | extra


def write_run(
    out: Path,
    scenario,
    method: str,
    seed: int,
    trials,
    steps: int,
    res: dict,
    source: Path | None = None,
    **extra,
) -> Path:
    """Writes a complete run directory; removes what it wrote on any error.

    Args:
        out: the run directory (created if needed).
        scenario: the validated scenario.
        method: method name.
        seed: base seed.
        trials: [T] trial indices.
        steps: filter steps K.
        res: the result of :func:`mjx_radar.engine.runner.run_trials` (``full=True``).
        source: the scenario file, copied verbatim (comments kept); ``None``: the
            scenario is written by :meth:`~mjx_radar.scenario.schema.Scenario.to_toml`.
        **extra: more ``run.json`` entries (``precision``, ``deterministic``).

    Returns:
        ``out``.
    """
    from mjx_radar.rundir import results
    from mjx_radar.scenario.bundle import bundle_scenario

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    trials = np.asarray(trials)
    written: list[Path] = []
    try:
        time_s = scenario.timing.dt_filter * np.arange(1, steps + 1)
        frame = results.metrics_frame(scenario.name, method, trials, time_s, res)
        results.write_parquet(out / "metrics.parquet", frame)
        written.append(out / "metrics.parquet")
        traj = {k: res[k] for k in TRAJECTORY_KEYS if k in res}
        results.write_npz(out / "trajectories.npz", traj | {"time_s": time_s})
        written.append(out / "trajectories.npz")
        if source is not None:
            written += bundle_scenario(Path(source), out)
            extra["source_scenario"] = str(Path(source).resolve())
        else:
            with tempfile.TemporaryDirectory() as tmp:
                src = Path(tmp) / "scenario.toml"
                scenario.to_toml(src)
                written += bundle_scenario(src, out)
        meta = run_meta(scenario, method, seed, trials, steps, res, **extra)
        results.write_json(out / "run.json", meta)
    except BaseException:
        for path in reversed(written):
            path.unlink(missing_ok=True)
        for folder in ("meshes", "tracks", "terrain"):
            try:
                (out / folder).rmdir()
            except OSError:
                pass
        raise
    return out
