"""Writing a run directory: what ``mjx-radar run --out DIR`` and ``Run.save(DIR)`` write.

One function, :func:`write_run`, used by the command line and the Python API, so a
run made in Python is a run directory like any other (``render``, ``snapshot`` and
``Run.load`` read it). Schema: :mod:`mjx_radar.rundir.results`. Every file is written
atomically, ``run.json`` last; on any error (or Ctrl-C) the files written so far
are removed, so a directory either holds a complete run or none.
"""

from __future__ import annotations

import dataclasses
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


@dataclasses.dataclass(frozen=True)
class RunHeader:
    """What a run directory records of its scenario (``run.json``'s scenario fields),
    built once by the caller that holds the scenario
    (:func:`mjx_radar.api.run_case.run_header`).

    Attributes:
        name: the scenario's name.
        dt_filter, dt_control: its clocks [s].
        n_radars, n_targets: N, M.
        r2t, r2r: the keep-out distances [m].
        rollout: the planner's rollout backend.
        noise_constant: the range-noise constant ``C`` of the scenario's radar equation.
        noise_constants: a mixed fleet's ``C`` of each radar (None: one radar equation).
        gospa_cutoff, gospa_order: the set metrics' settings.
    """

    name: str
    dt_filter: float
    dt_control: float
    n_radars: int
    n_targets: int
    r2t: float
    r2r: float
    rollout: str
    noise_constant: float
    noise_constants: tuple | None
    gospa_cutoff: float
    gospa_order: float


def run_meta(
    head: RunHeader, method: str, seed: int, trials, steps: int, res: dict, **extra
) -> dict:
    """The contents of ``run.json`` (see :mod:`mjx_radar.rundir.results`)."""
    trials = np.asarray(trials)
    meta = {
        "scenario": head.name,
        "scenario_file": "scenario.toml",  # relative to the run directory
        "source_scenario": extra.pop("source_scenario", None),
        "method": method,
        "planner": extra.pop("planner", None) or parse_method(method).planner,
        "seed": int(seed),
        "trials": int(len(trials)),
        "trial_ids": [int(t) for t in trials],
        "steps": int(steps),
        "dt_filter": head.dt_filter,
        "dt_control": head.dt_control,
        "n_radars": head.n_radars,
        "n_targets": head.n_targets,
        "r2t": head.r2t,
        "r2r": head.r2r,
        "rollout": head.rollout,
        "noise_constant": head.noise_constant,
        "wall_s": float(res["wall_s"]),
        "compile_s": float(res["compile_s"]),
        "sim_s": float(res["sim_s"]),
        "control_hz": float(res["control_hz"]),
        "precision": extra.pop("precision", "float32"),
        "deterministic": bool(extra.pop("deterministic", False)),
        "lost_trials": int(np.asarray(res["lost"]).any(axis=-1).sum()),
        "lost_steps": int(np.asarray(res["lost"]).sum()),
        "gospa_cutoff": head.gospa_cutoff,
        "gospa_order": head.gospa_order,
    }
    if head.noise_constants is not None:  # a mixed fleet: C of each radar
        meta["noise_constants"] = list(head.noise_constants)
    div = res.get("diverged")
    if div is not None:
        meta["diverged_trials"] = [int(t) for t in trials[np.asarray(div).any(axis=-1)]]
    return meta | extra


def write_run(
    out: Path,
    head: RunHeader,
    method: str,
    seed: int,
    trials,
    steps: int,
    res: dict,
    source: Path | None = None,
    toml: str | None = None,
    **extra,
) -> Path:
    """Writes a complete run directory; removes what it wrote on any error.

    Args:
        out: the run directory (created if needed).
        head: the scenario's :class:`RunHeader`.
        method: method name.
        seed: base seed.
        trials: [T] trial indices.
        steps: filter steps K.
        res: the result of :func:`mjx_radar.engine.runner.run_trials` (``full=True``).
        source: the scenario file, copied verbatim (comments kept); ``None``: ``toml``,
            the scenario's text (:meth:`~mjx_radar.scenario.schema.Scenario.to_toml`).
        **extra: more ``run.json`` entries (``precision``, ``deterministic``).

    Returns:
        ``out``.
    """
    from mjx_radar.io.atomic import atomic_write
    from mjx_radar.rundir import results
    from mjx_radar.scenario.bundle import bundle_scenario

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    trials = np.asarray(trials)
    written: list[Path] = []
    try:
        time_s = head.dt_filter * np.arange(1, steps + 1)
        frame = results.metrics_frame(head.name, method, trials, time_s, res)
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
                atomic_write(src, lambda part: Path(part).write_text(toml))
                written += bundle_scenario(src, out)
        meta = run_meta(head, method, seed, trials, steps, res, **extra)
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
