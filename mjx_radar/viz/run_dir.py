"""Loading a run directory (``mjx-radar run --out DIR``) for ``render`` and ``snapshot``.

One entry point, :func:`load_run`, reads ``DIR/run.json``, ``DIR/trajectories.npz``
(schema in :mod:`mjx_radar.rundir.results`) and the scenario. The scenario is
``DIR/scenario.toml``, its mesh paths resolved relative to ``DIR``; if that file is
missing or does not load (e.g. a run made before meshes were copied into
``DIR/meshes``), the original scenario named in ``run.json`` is used
(``source_scenario``, or ``scenario_file`` of older runs). The figures draw its
:class:`~mjx_radar.viz.scene.Scene`, built here once (:func:`~mjx_radar.viz.scene.scene_of`).

A damaged directory (missing, garbage or truncated files, a missing key, arrays
of the wrong shape) raises :class:`~mjx_radar.errors.InputError` with one line
naming the file, never a parser's own exception. :class:`Trial` holds the numpy
arrays of one trial.
"""

from __future__ import annotations

import dataclasses
import json
import zipfile
import zlib
from pathlib import Path

import numpy as np

from mjx_radar.errors import InputError
from mjx_radar.viz.scene import Scene, scene_of

TRAIL_CONTROL_STEPS = 25
META_NUMBERS = ("dt_filter", "dt_control", "r2t", "r2r", "noise_constant")
# key -> (ndim, size of the last axis or None); T trials lead every array.
ARRAYS = {
    "target": (4, 6),  # [T, K, M, 6]
    "mean": (3, None),  # [T, K, 6M]
    "cov_diag": (3, None),  # [T, K, 6M]
    "radar": (4, 6),  # [T, K, N, 6]
    "sample_xy": (6, 2),  # [T, C, S, H, N, 2]
    "sample_weight": (3, None),  # [T, C, S]
}


@dataclasses.dataclass(frozen=True)
class RunDir:
    """A loaded run directory: metadata, trajectory arrays, the scenario (for
    :meth:`mjx_radar.Run.load`) and the scene the figures draw."""

    path: Path
    meta: dict
    arrays: dict  # name -> numpy array (ARRAYS keys at least)
    scenario: object  # mjx_radar.scenario.schema.Scenario
    scene: Scene

    @property
    def trials(self) -> int:
        return self.arrays["radar"].shape[0]


@dataclasses.dataclass(frozen=True)
class Trial:
    """One trial of a run directory (numpy arrays; K filter steps, C control steps)."""

    meta: dict
    scene: Scene  # what is drawn besides the arrays (world, fixed sites, routes)
    target: np.ndarray  # [K, M, 6] true drone states
    mean: np.ndarray  # [K, M, 3] CKF position estimates
    sigma: np.ndarray  # [K, M, 3] CKF position standard deviations
    radar: np.ndarray  # [K, N, 6] radar states [x, y, z, theta, v, omega]
    sample_xy: np.ndarray  # [C, S, H, N, 2] MPPI sampled radar paths
    sample_weight: np.ndarray  # [C, S]
    every: int  # filter steps per control step
    dt: float  # filter step [s]

    @property
    def steps(self) -> int:
        return self.radar.shape[0]

    def control_index(self, k: int) -> int:
        """The control step whose plan was acting at filter step ``k``."""
        return min(k // self.every, self.sample_xy.shape[0] - 1)

    def trail(self, k: int) -> np.ndarray:
        """``[L, N, 3]`` radar positions at steps k, k - every, ... (last 25 control steps)."""
        ks = np.arange(k, max(k - TRAIL_CONTROL_STEPS * self.every, 0) - 1, -self.every)
        return self.radar[ks[ks >= 0], :, :3]

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper xy corners of the drone paths and the radars' R2T discs."""
        radar, r2t = self.radar[..., :2].reshape(-1, 2), self.meta["r2t"]
        xy = np.concatenate([radar - r2t, radar + r2t, self.target[..., :2].reshape(-1, 2)])
        xy = xy[np.isfinite(xy).all(1)]  # a diverged trial's NaN positions draw no range
        if not len(xy):
            return np.full(2, -1.0), np.full(2, 1.0)
        return xy.min(0), xy.max(0)


def _first_line(err: BaseException) -> str:
    text = str(err).strip().splitlines()
    return f"{type(err).__name__}: {text[0]}" if text else type(err).__name__


def _read_meta(path: Path) -> dict:
    try:
        meta = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as err:
        raise InputError(f"{path}: unreadable run metadata ({_first_line(err)})") from None
    if not isinstance(meta, dict):
        raise InputError(f"{path}: must hold a JSON object, got {type(meta).__name__}")
    for key in META_NUMBERS:
        value = meta.get(key)
        if isinstance(value, bool) or not isinstance(value, int | float) or not value >= 0:
            raise InputError(f"{path}: key {key!r} = {value!r}: must be a number >= 0")
    if not meta["dt_filter"] > 0 or meta["dt_control"] < meta["dt_filter"]:
        raise InputError(f"{path}: need 0 < dt_filter <= dt_control")
    return meta


def _read_arrays(path: Path) -> dict:
    try:
        with np.load(path, allow_pickle=False) as npz:
            missing = [k for k in ARRAYS if k not in npz.files]
            if missing:
                raise InputError(f"{path}: missing array {missing[0]!r}; damaged trajectory file")
            arrays = {k: np.asarray(npz[k]) for k in npz.files}
    except InputError:
        raise
    except (OSError, ValueError, EOFError, KeyError, zipfile.BadZipFile, zlib.error) as err:
        raise InputError(f"{path}: damaged trajectory file ({_first_line(err)})") from None
    for key, (ndim, last) in ARRAYS.items():
        a = arrays[key]
        if a.ndim != ndim or (last is not None and a.shape[-1] != last) or a.shape[0] < 1:
            raise InputError(f"{path}: array {key!r} has shape {a.shape}; damaged trajectory file")
        if a.shape[0] != arrays["radar"].shape[0]:
            raise InputError(
                f"{path}: array {key!r} holds {a.shape[0]} trials, radar holds "
                f"{arrays['radar'].shape[0]}; damaged trajectory file"
            )
    k, m = arrays["radar"].shape[1], arrays["target"].shape[2]
    if arrays["target"].shape[1] != k or any(
        arrays[key].shape[1:] != (k, 6 * m) for key in ("mean", "cov_diag")
    ):
        raise InputError(f"{path}: target, mean, cov_diag and radar disagree on steps or targets")
    return arrays


def _read_scenario(run_dir: Path, meta: dict):
    from mjx_radar.scenario.reader import ScenarioError, load_scenario

    local = run_dir / "scenario.toml"
    try:
        return load_scenario(local)
    except ScenarioError as err:
        first = err
    # Older runs name the original file in scenario_file; newer ones in source_scenario.
    candidates = [meta.get("source_scenario"), meta.get("scenario_file")]
    for original in candidates:
        path = Path(original) if isinstance(original, str) and original else None
        if path is not None and path.is_absolute() and path.is_file():
            try:
                return load_scenario(path)
            except ScenarioError:
                pass
    if not local.exists():
        names = " / ".join(repr(c) for c in candidates if c)
        raise InputError(
            f"{local}: missing, and run.json's original scenario ({names}) does not load"
        )
    raise InputError(f"{local}: {first}")


def load_run(run_dir: str | Path) -> RunDir:
    """Loads a complete run directory.

    Args:
        run_dir: the directory written by ``mjx-radar run --out``.

    Returns:
        :class:`RunDir`.

    Raises:
        InputError: one line naming the missing or damaged file.
    """
    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        raise InputError(f"RUN_DIR = {str(run_dir)!r}: no such directory")
    meta_path, traj_path = run_dir / "run.json", run_dir / "trajectories.npz"
    for p in (meta_path, traj_path):
        if not p.is_file():
            raise InputError(
                f"RUN_DIR = {str(run_dir)!r}: not a complete run directory (no {p.name})"
            )
    meta = _read_meta(meta_path)
    arrays = _read_arrays(traj_path)
    scenario = _read_scenario(run_dir, meta)
    return RunDir(run_dir, meta, arrays, scenario, scene_of(scenario))


def load_trial(run_dir: str | Path | RunDir, trial: int = 0) -> Trial:
    """One trial of a run directory (a path or a loaded :class:`RunDir`).

    Raises:
        InputError: bad run directory (see :func:`load_run`) or ``trial`` out of range.
    """
    run = run_dir if isinstance(run_dir, RunDir) else load_run(run_dir)
    if not 0 <= trial < run.trials:
        raise InputError(f"--trial = {trial}: must be in [0, {run.trials - 1}]")
    a, meta = run.arrays, run.meta
    m = a["target"].shape[2]
    return Trial(
        meta=meta,
        scene=run.scene,
        target=a["target"][trial],
        mean=a["mean"][trial].reshape(-1, m, 6)[..., :3],
        sigma=np.sqrt(np.maximum(a["cov_diag"][trial].reshape(-1, m, 6)[..., :3], 0.0)),
        radar=a["radar"][trial],
        sample_xy=a["sample_xy"][trial],
        sample_weight=a["sample_weight"][trial],
        every=max(int(round(meta["dt_control"] / meta["dt_filter"])), 1),
        dt=float(meta["dt_filter"]),
    )
