"""The trajectories of a run as an ``xarray.Dataset``: named dimensions and units.

Built from the arrays of ``trajectories.npz`` (schema: :mod:`mjx_radar.rundir.results`).
Dimensions: ``trial`` (trial index), ``step`` (filter step, coordinate ``time_s``),
``target`` (M), ``radar`` (N), ``state`` (``x y z vx vy vz``), ``radar_state``
(``x y z theta v omega``), ``control_step`` (MPPI call, coordinate ``control_time_s``),
``input`` (``a alpha``), ``horizon`` (H), ``sample`` (kept MPPI samples), ``xy``.
The filter's ``[6M]`` mean (``estimate``) and ``variance`` are split per target;
``radar_states`` holds the radar vehicles' states. Every variable
carries ``units`` and ``description`` attributes.

Example::

    ds = run.trajectories
    err = ds.estimate - ds.truth                        # [trial, step, target, state]
    ds.radar_states.sel(radar_state="x").isel(trial=0)  # radar x over time
"""

from __future__ import annotations

import numpy as np

STATE = ["x", "y", "z", "vx", "vy", "vz"]
RADAR_STATE = ["x", "y", "z", "theta", "v", "omega"]
STATE_UNITS = "m (x, y, z); m/s (vx, vy, vz)"

# variable -> (array key, dims, units, description)
VARIABLES = {
    "truth": ("target", ("trial", "step", "target", "state"), STATE_UNITS, "true drone states"),
    "estimate": (
        "mean",
        ("trial", "step", "target", "state"),
        STATE_UNITS,
        "filter posterior mean",
    ),
    "variance": (
        "cov_diag",
        ("trial", "step", "target", "state"),
        "m^2 (x, y, z); m^2/s^2 (vx, vy, vz)",
        "filter posterior variances",
    ),
    "radar_states": (
        "radar",
        ("trial", "step", "radar", "radar_state"),
        "m (x, y, z); rad (theta); m/s (v); rad/s (omega)",
        "radar vehicle states",
    ),
    "control": (
        "control",
        ("trial", "control_step", "radar", "input"),
        "m/s^2 (a); rad/s^2 (alpha)",
        "applied accelerations",
    ),
    "plan_xy": (
        "plan_xy",
        ("trial", "control_step", "horizon", "radar", "xy"),
        "m",
        "planned radar positions (MPPI mean sequence)",
    ),
    "sample_xy": (
        "sample_xy",
        ("trial", "control_step", "sample", "horizon", "radar", "xy"),
        "m",
        "kept MPPI sample trajectories",
    ),
    "sample_weight": (
        "sample_weight",
        ("trial", "control_step", "sample"),
        "1",
        "MPPI weights of the kept samples",
    ),
    "sample_cost": (
        "sample_cost",
        ("trial", "control_step", "sample"),
        "1",
        "MPPI costs of the kept samples",
    ),
    "diverged": ("diverged", ("trial", "step"), "1", "filter numerically failed"),
    "visible": (
        "visible",
        ("trial", "step", "radar", "target"),
        "1",
        "line of sight to a present target (run with masks=True / --masks)",
    ),
    "detected": (
        "detected",
        ("trial", "step", "radar", "target"),
        "1",
        "pair visible and detected (run with masks=True / --masks)",
    ),
}


COUNTS = {  # metrics column -> description (a [trial, step] count per variable)
    "visible_pairs": "radar-target pairs with line of sight (of N*M)",
    "detections": "visible pairs detected",
    "false_alarms": "false alarms of all radars",
    "targets_present": "targets present",
}


def to_dataset(arrays: dict, trials, scenario, method=None, metrics=None):
    """``xarray.Dataset`` of a run's trajectory arrays.

    Args:
        arrays: name -> numpy array as in ``trajectories.npz`` (leading ``[T, ...]``).
        trials: ``[T]`` trial indices (the ``trial`` coordinate).
        scenario: the run's scenario (clocks, names, presence times).
        method: the run's method: a scalar ``method`` coordinate, so the datasets of
            several methods ``xr.concat(..., dim="method")``.
        metrics: the run's metrics table: its per-step counts (:data:`COUNTS`) become
            ``[trial, step]`` variables; the per-pair masks ``visible`` and ``detected``
            ``[trial, step, radar, target]`` are there when the run recorded them
            (``masks=True``).

    Returns:
        The dataset; absent arrays are left out. ``present`` ``[step, target]`` is each
        target's presence (``appear <= t < leave``, as the loop evaluates it).
    """
    import xarray as xr

    data = {}
    for name, (key, dims, units, doc) in VARIABLES.items():
        if key not in arrays:
            continue
        a = np.asarray(arrays[key])
        if key in ("mean", "cov_diag"):
            a = a.reshape(*a.shape[:2], -1, 6)
        data[name] = xr.Variable(dims, a, {"units": units, "description": doc})
    steps = np.asarray(arrays["radar"]).shape[1]
    time_s = np.asarray(arrays.get("time_s", scenario.timing.dt_filter * np.arange(1, steps + 1)))
    coords = {
        "trial": np.asarray(trials),
        "step": np.arange(1, steps + 1),
        "time_s": ("step", time_s, {"units": "s"}),
        "state": STATE,
        "radar_state": RADAR_STATE,
    }
    data["present"] = xr.Variable(
        ("step", "target"), presence(scenario, steps), {"units": "1", "description": "present"}
    )
    for col, doc in COUNTS.items():
        if metrics is not None and col in metrics and len(metrics) == len(trials) * steps:
            a = np.asarray(metrics[col]).reshape(len(trials), steps)
            data[col] = xr.Variable(("trial", "step"), a, {"units": "1", "description": doc})
    if method is not None:
        coords["method"] = str(method)
    if "control" in arrays:
        c = np.asarray(arrays["control"]).shape[1]
        coords["control_step"] = np.arange(c)
        coords["control_time_s"] = (
            "control_step",
            scenario.timing.dt_control * np.arange(c),
            {"units": "s"},
        )
        coords["input"] = ["a", "alpha"]
    if "plan_xy" in arrays or "sample_xy" in arrays:
        coords["xy"] = ["x", "y"]
    attrs = {
        "scenario": scenario.name,
        "dt_filter": scenario.timing.dt_filter,
        "dt_control": scenario.timing.dt_control,
    }
    return xr.Dataset(data, coords=coords, attrs=attrs)


def presence(scenario, steps: int) -> np.ndarray:
    """``[K, M]`` bool: target m present at filter step k (time ``k dt``), evaluated in
    float32 like the loop (``appear <= t < leave``; every target without a table)."""
    m = scenario.n_targets
    appear, leave = np.zeros(m, np.float32), np.full(m, np.inf, np.float32)
    for tm in scenario.target_motion:
        appear[tm.target], leave[tm.target] = tm.appear, tm.leave
    t = np.arange(1, steps + 1, dtype=np.float32) * np.float32(scenario.timing.dt_filter)
    return (t[:, None] >= appear[None]) & (t[:, None] < leave[None])
