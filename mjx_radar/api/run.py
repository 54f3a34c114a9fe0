""":class:`Run`: the result of the closed loop from a Python script.

``mjx_radar.simulate`` (:mod:`mjx_radar.api.simulate`) validates the scenario by the
rules of a TOML file, checks that the run fits in memory, and runs the same compiled
program as ``mjx-radar run`` (:func:`mjx_radar.engine.runner.run_trials`, which refuses
radars that cannot be placed before the first step), so a fixed seed gives the same
numbers from either. A :class:`Run` holds the result:

- ``metrics``: a pandas DataFrame with the columns of ``metrics.parquet``
  (one row per trial and step);
- ``trajectories``: an ``xarray.Dataset`` with named dimensions and units;
- ``summary()``: the figures ``mjx-radar run`` prints;
- ``save(dir)`` writes a run directory (exactly what ``mjx-radar run --out dir``
  writes), ``Run.load(dir)`` reads any run directory back, ``render`` and
  ``snapshot`` draw it, ``view`` writes the interactive HTML viewer.
"""

from __future__ import annotations

import dataclasses
import json
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

from mjx_radar.api.trajectories import to_dataset
from mjx_radar.errors import InputError


@dataclasses.dataclass
class Run:
    """A closed-loop run: its scenario, metrics and trajectories.

    Attributes:
        scenario: the (validated) scenario.
        method: method name (``mjx_radar.METHODS``).
        seed: base seed.
        trials: ``[T]`` trial indices.
        steps: filter steps K per trial.
        metrics: long-format table, one row per (trial, step): scenario, method, trial,
            step, time_s and :data:`mjx_radar.rundir.results.METRIC_COLUMNS`.
        arrays: the arrays of ``trajectories.npz`` (schema in :mod:`mjx_radar.rundir.results`).
        meta: the contents of ``run.json``.
        path: the run directory it was saved to or loaded from (``None``: not saved).
    """

    scenario: object
    method: str
    seed: int
    trials: np.ndarray
    steps: int
    metrics: pd.DataFrame
    arrays: dict
    meta: dict
    path: Path | None = None
    _res: dict | None = dataclasses.field(default=None, repr=False)

    def __repr__(self) -> str:
        """A few lines: what ran and its headline figures (never the arrays)."""
        m = self.metrics
        rmse = float(m["rmse_pos"].mean()) if len(m) else float("nan")
        crlb = float(m["crlb_pos"].mean()) if len(m) else float("nan")
        return (
            f"Run(scenario={self.scenario.name!r}, method={self.method!r}, "
            f"trials={len(self.trials)}, steps={self.steps}, seed={self.seed},\n"
            f"    rmse_pos={rmse:.3f} m, crlb_pos={crlb:.3f} m, "
            f"path={None if self.path is None else str(self.path)!r})"
        )

    @property
    def trajectories(self):
        """``xarray.Dataset`` of the trajectories (dims trial, step, target, radar, ...),
        with ``present`` ``[step, target]``, the per-step counts and a ``method`` coordinate."""
        return to_dataset(self.arrays, self.trials, self.scenario, self.method, self.metrics)

    def summary(self) -> dict:
        """The figures ``mjx-radar run`` prints (RMSE and PCRLB in m, times in s).

        ``gospa`` and ``ospa`` [m] are means over trials and steps (with the scenario's
        ``[metrics]`` cutoff and order), ``gospa_localisation`` / ``_missed`` / ``_false``
        the means of GOSPA's parts [m^p]; ``label_switches`` and ``broken_tracks`` count
        the events of every trial (docs/tracking_metrics.md).

        Example:
            >>> run = mjx_radar.simulate("smoke", trials=2)  # doctest: +SKIP
            >>> run.summary()["rmse_pos"]  # doctest: +SKIP
        """
        m = self.metrics
        last = m[m["step"] == m["step"].max()]
        lost = m.groupby("trial")["lost"].max()
        return {
            "scenario": self.scenario.name,
            "method": self.method,
            "trials": len(self.trials),
            "steps": self.steps,
            "rmse_pos": float(m["rmse_pos"].mean()),
            "rmse_pos_final": float(last["rmse_pos"].mean()),
            "crlb_pos": float(m["crlb_pos"].mean()),
            "lost_trials": int((lost > 0).sum()),
            "diverged_trials": int((m.groupby("trial")["diverged"].max() > 0).sum()),
            **_set_summary(m),
            "control_hz": self.meta.get("control_hz"),
            "compile_s": self.meta.get("compile_s"),
            "sim_s": self.meta.get("sim_s"),
        }

    def save(self, path: str | Path, force: bool = False) -> Path:
        """Writes the run directory ``path`` (what ``mjx-radar run --out path`` writes).

        Raises:
            InputError: ``path`` holds a complete run (without ``force``), is a file,
                cannot be written, or another process is writing there.
        """
        from mjx_radar.api.run_case import run_header
        from mjx_radar.io.atomic import create_dir
        from mjx_radar.io.lock import lock_dir
        from mjx_radar.rundir.writer import write_run

        if self._res is None:
            raise InputError("Run.save: this run was loaded from a directory; copy that instead")
        path = Path(path)
        create_dir(path, "path", probe=True)
        with lock_dir(path, "path", what="is writing a run there"):
            if (path / "run.json").exists() and not force:
                raise InputError(f"path = {str(path)!r}: holds a complete run; pass force=True")
            write_run(
                path,
                run_header(self.scenario),
                self.method,
                self.seed,
                self.trials,
                self.steps,
                self._res,
                toml=self.scenario.to_toml(),
                precision=self.meta.get("precision", "float32"),
            )
        self.path = path
        self.meta = json.loads((path / "run.json").read_text())
        return path

    @classmethod
    def load(cls, path: str | Path) -> Run:
        """Reads a run directory (``mjx-radar run --out`` or :meth:`save`).

        Raises:
            InputError: not a complete run directory, or a damaged file (one line naming it).
        """
        from mjx_radar.viz.run_dir import load_run

        rd = load_run(path)
        try:
            metrics = pd.read_parquet(rd.path / "metrics.parquet")
        except Exception as err:  # pyarrow raises many types for a damaged file
            first = str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__
            where = rd.path / "metrics.parquet"
            raise InputError(f"{where}: damaged metrics file ({first})") from None
        trials = np.asarray(rd.meta.get("trial_ids", sorted(metrics["trial"].unique())))
        steps = int(rd.meta.get("steps", rd.arrays["radar"].shape[1]))
        return cls(
            rd.scenario,
            rd.meta.get("method", ""),
            int(rd.meta.get("seed", 0)),
            trials,
            steps,
            metrics,
            rd.arrays,
            rd.meta,
            rd.path,
        )

    def _saved(self) -> Path:
        if self.path is None:  # render and snapshot read a run directory
            self.save(Path(tempfile.mkdtemp(prefix=f"mjx_radar_{self.scenario.name}_")))
        return self.path

    def render(self, path: str | Path, camera: str = "top", trial: int = 0, **options) -> Path:
        """Renders one trial to an MP4 or GIF (``mjx-radar render``).

        Args:
            path: ``.mp4`` or ``.gif`` file.
            camera: ``"top"``, ``"follow"`` or ``"free"`` (:data:`mjx_radar.viz.render.CAMERAS`).
            trial: trial index into ``trials`` (0-based position).
            **options: fields of :class:`mjx_radar.viz.render.RenderOptions` (fps, width,
                height, frames, backend).
        """
        from mjx_radar.viz.render import RenderOptions, render_run

        _check_int("trial", trial, 0, len(self.trials) - 1)
        render_run(self._saved(), trial, Path(path), RenderOptions(camera=camera, **options))
        return Path(path)

    def snapshot(
        self, step: int, path: str | Path | None = None, trial: int = 0, grid: int = 120
    ) -> Path:
        """Two-panel figure at filter step ``step`` (``mjx-radar snapshot``); returns its path."""
        from mjx_radar.viz.snapshot import snapshot

        _check_int("step", step, 1, self.steps)  # Python's names, not the command line's
        _check_int("trial", trial, 0, len(self.trials) - 1)
        _check_int("grid", grid, 2, 1000)
        return Path(snapshot(self._saved(), step, trial, path, grid))

    def view(
        self,
        path: str | Path | None = None,
        trial=None,
        max_frames: int = 150,
        samples: int | None = None,
    ) -> Path:
        """Interactive 3-D view as one offline HTML file (``mjx-radar view``); returns its path.

        Args:
            path: ``.html`` file (default ``view.html`` in the run directory; an unsaved
                run is saved to a temporary directory first).
            trial: a trial position or a list of them (default: as many as fit ~14 MB).
            max_frames: at most this many frames per trial (every k-th filter step).
            samples: MPPI samples per frame (default up to 32, fewer to fit ~14 MB).
        """
        from mjx_radar.viz.view.viewer import view

        return view(self._saved(), path, trial, max_frames, samples).path


def _set_summary(m: pd.DataFrame) -> dict:
    """Mean GOSPA (and parts, m^p), OSPA and the trials' label switches and broken tracks
    (totals over trials); NaN for a run directory written before these columns."""
    out = {}
    for c in ("gospa", "gospa_localisation", "gospa_missed", "gospa_false", "ospa"):
        out[c] = float(m[c].mean()) if c in m.columns else float("nan")
    for c in ("label_switches", "broken_tracks"):
        out[c] = int(m[c].sum()) if c in m.columns else float("nan")
    return out


def _check_int(name: str, value, lo: int, hi: int) -> None:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or not lo <= value <= hi:
        raise InputError(f"{name} = {value!r}: must be an integer in [{lo}, {hi}]")
