"""Result files: atomic writes, the metrics table and the trajectory archive.

Run directory schema (``mjx-radar run ... --out DIR``)::

    DIR/run.json           metadata: scenario, method, seed, trials, steps, dt_filter,
                           dt_control, n_radars, n_targets, r2t, r2r, noise_constant,
                           wall_s, control_hz, gospa_cutoff, gospa_order
    DIR/scenario.toml      the scenario file used (verbatim copy)
    DIR/metrics.parquet    long format, one row per (trial, step): scenario, method,
                           trial, step, time_s, rmse_pos [m], rmse_state [m, m/s],
                           nees [-], crlb_pos [m], obstacle_contacts [-] (radars
                           touching an obstacle), visible_pairs [-] (radar-target
                           pairs with line of sight), detections [-] (visible
                           pairs detected, docs/detection.md), false_alarms [-]
                           (clutter returns of all radars), diverged [0/1] (numerical failure;
                           values kept finite), lost [0/1] (lost-track flag of
                           that step: env.track_health, docs/statistics.md),
                           targets_present [-] (targets present at that step:
                           M, fewer with [[target_motion]] appear / leave),
                           gospa [m], gospa_localisation / gospa_missed /
                           gospa_false [m^p] (its parts), ospa [m], label_switches
                           [-], broken_tracks [-] (events at that step; sums per
                           trial): SET_COLUMNS, docs/tracking_metrics.md
    DIR/trajectories.npz   arrays (T trials, K filter steps, C = K / control_every
                           control steps, S kept MPPI samples, H horizon):
                             time_s [K], target [T,K,M,6], mean [T,K,6M],
                             cov_diag [T,K,6M], radar [T,K,N,6] ([x,y,z,theta,v,omega]),
                             control [T,C,N,2], plan_xy [T,C,H,N,2],
                             sample_xy [T,C,S,H,N,2], sample_weight [T,C,S],
                             sample_cost [T,C,S]; with --masks
                             (simulate(masks=True)) also visible [T,K,N,M]
                             (line of sight to a present drone) and
                             detected [T,K,N,M] (visible and detected), bool

Every file is written to a temporary name in the same directory and renamed
into place (atomic on POSIX), ``run.json`` last: a directory whose ``run.json``
exists is complete.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from mjx_radar.io.atomic import atomic_write  # also used as results.atomic_write

if TYPE_CHECKING:  # pandas is imported when a table is made (0.3-0.5 s: not on a run's start)
    import pandas as pd

LOOP_COLUMNS = (  # computed in the closed loop, per step
    "rmse_pos",
    "rmse_state",
    "nees",
    "crlb_pos",
    "obstacle_contacts",  # radars touching an obstacle (0 without obstacles)
    "visible_pairs",  # radar-target pairs with line of sight (N*M without obstacles)
    "detections",  # visible pairs detected (= visible_pairs with perfect detection)
    "false_alarms",  # false alarms of all radars at that scan (0 without clutter)
    "lost",  # 1.0 when the track is lost at that step (env.track_health), else 0.0
    "diverged",  # 1.0 when the filter became non-finite / not positive definite, else 0.0
    "targets_present",  # targets present at that step (M unless [[target_motion]] appear/leave)
)
SET_COLUMNS = (  # computed on the host from the loop's sets (set_columns, docs/tracking_metrics.md)
    "gospa",  # GOSPA [m] of the present targets vs the existing tracks ([metrics] c, p)
    "gospa_localisation",  # its localisation part: sum of d^p over assigned pairs [m^p]
    "gospa_missed",  # its missed-target part: c^p/2 per unassigned target [m^p]
    "gospa_false",  # its false-track part: c^p/2 per unassigned track [m^p]
    "ospa",  # OSPA [m] (same c, p)
    "label_switches",  # tracks whose assigned target changed at that step [-]
    "broken_tracks",  # present targets whose track changed or was lost at that step [-]
)
METRIC_COLUMNS = LOOP_COLUMNS + SET_COLUMNS


def set_columns(sets: dict, cutoff: float, order: float) -> dict:
    """The :data:`SET_COLUMNS` ``[T, K]`` of a run from its sets.

    Args:
        sets: :data:`mjx_radar.env.records.SET_KEYS` arrays ``[T, K, ...]``
            (:func:`mjx_radar.env.records.estimate_sets`).
        cutoff: GOSPA / OSPA cutoff c [m]; order: their order p.
    """
    from mjx_radar.estimation.tracks.continuity import continuity_events
    from mjx_radar.estimation.tracks.gospa import set_metrics

    truth, here = sets["truth_pos"], sets["present"]
    out = set_metrics(truth, here, sets["track_pos"], sets["track_exists"], cutoff, order)
    switches, broken = continuity_events(out.assignment, here, sets["track_exists"])
    cols = (out.gospa, out.localisation, out.missed, out.false, out.ospa, switches, broken)
    return {k: np.asarray(v, np.float64) for k, v in zip(SET_COLUMNS, cols, strict=True)}


def metrics_frame(
    scenario_name: str, method: str, trials: np.ndarray, time_s: np.ndarray, metrics: dict
) -> pd.DataFrame:
    """Long-format metrics table.

    Args:
        scenario_name: the scenario's name.
        method: method name.
        trials: [T] trial indices.
        time_s: [K] time of each step [s].
        metrics: name -> [T, K] array for each of :data:`METRIC_COLUMNS`.
    """
    import pandas as pd

    t, k = len(trials), len(time_s)
    one = np.zeros(t * k, np.int8)  # the codes of a one-category column (not t·k strings)
    columns = {
        "scenario": pd.Categorical.from_codes(one, [scenario_name]),
        "method": pd.Categorical.from_codes(one, [method]),
        "trial": np.repeat(np.asarray(trials, np.int32), k),
        "step": np.tile(np.arange(1, k + 1, dtype=np.int32), t),
        "time_s": np.tile(np.asarray(time_s, np.float64), t),
    }
    for name in METRIC_COLUMNS:
        columns[name] = np.asarray(metrics[name], np.float64).reshape(-1)
    return pd.DataFrame(columns)


def write_parquet(path: Path, frame: pd.DataFrame) -> None:
    atomic_write(path, lambda tmp: frame.to_parquet(tmp, index=False))


def write_npz(path: Path, arrays: dict) -> None:
    def write(tmp):
        with open(tmp, "wb") as fh:
            np.savez_compressed(fh, **arrays)

    atomic_write(path, write)


def write_json(path: Path, obj: dict) -> None:
    atomic_write(path, lambda tmp: Path(tmp).write_text(json.dumps(obj, indent=2) + "\n"))


def read_run(run_dir: Path) -> tuple[dict, dict]:
    """Loads ``(run.json, trajectories.npz arrays)`` of a complete run directory."""
    run_dir = Path(run_dir)
    meta_path = run_dir / "run.json"
    if not meta_path.exists():
        raise ValueError(f"RUN_DIR = {str(run_dir)!r}: no run.json, not a complete run directory")
    meta = json.loads(meta_path.read_text())
    with np.load(run_dir / "trajectories.npz") as npz:
        arrays = {k: npz[k] for k in npz.files}
    return meta, arrays
