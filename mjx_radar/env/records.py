"""What the closed loop records per filter step and per control step (host-side shapes).

Kept apart from the loop (:mod:`mjx_radar.loop.closed_loop`) so that code which only reads
the records (the runner, results, the live view) does not import the loop, and with it
MJX: a warm start from the export cache never traces the loop.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import jax


class ControlRecord(NamedTuple):
    """What a control step records (leading axis: control steps, after a scan).

    Attributes:
        control: ``[N, 2]`` the applied control (clipped to the action bounds).
        plan_xy: ``[H, N, 2]`` the planned radar positions (zeros for a planner that
            shows none).
        plan: the planner's own record of its plan, a pytree of arrays (the built-in
            planners: :class:`mjx_radar.planners.records.SampleRecord`).
    """

    control: jax.Array
    plan_xy: jax.Array
    plan: Any = ()


def control_arrays(record) -> dict:
    """A :class:`ControlRecord`'s arrays by name, the planner's record's fields flattened in.

    ``{"control": ..., "plan_xy": ..., **plan fields}`` (the names of the run files);
    ``plan`` a named tuple, a dict or ``()``.
    """
    plan = record.plan
    extra = plan._asdict() if hasattr(plan, "_asdict") else dict(plan or {})
    return {"control": record.control, "plan_xy": record.plan_xy, **extra}


class StepRecord(NamedTuple):
    """Per filter step outputs (leading axis K after the scan)."""

    target: jax.Array  # [M, 6] true target states
    mean: jax.Array  # [6M] posterior mean
    cov_diag: jax.Array  # [6M] posterior variances
    radar: jax.Array  # [N, 6] radar states
    rmse_pos: jax.Array  # [] sqrt(mean_m |p_hat - p|^2)
    rmse_state: jax.Array  # [] sqrt(mean_m |x_hat - x|^2)
    nees: jax.Array  # [] normalised estimation error squared (6M dof)
    crlb_pos: jax.Array  # [] sqrt(mean_m tr[J_m^-1]_pos), PFIM along the truth
    obstacle_contacts: jax.Array  # [] int32 radars in contact with an obstacle
    visible_pairs: jax.Array  # [] int32 radar-target pairs with line of sight (of N*M)
    detections: jax.Array  # [] int32 visible pairs detected (= visible_pairs: perfect detection)
    false_alarms: jax.Array  # [] int32 false alarms of all radars (0 without clutter)
    lost: jax.Array  # [] bool track lost (diverged, mirror lock or error beyond k sigma)
    diverged: jax.Array  # [] bool the filter became non-finite or not positive definite
    targets_present: jax.Array  # [] int32 targets present ([[target_motion]] appear/leave)
    present: jax.Array  # [M] bool the targets present at this step (the truth set of GOSPA)
    track_pos: jax.Array  # [K, 3] estimated positions (K = M, the joint estimate, unless managed)
    track_exist: jax.Array  # [K] bool estimates that exist (managed: confirmed tracks)
    visible: jax.Array  # [N, M] bool line of sight to a present target (sum: visible_pairs)
    detected: jax.Array  # [N, M] bool visible and detected (sum: detections)


#: the per-pair masks of :class:`StepRecord`: a run outputs them only when asked
#: (``masks=True``; otherwise they are dropped before the program's outputs)
MASK_FIELDS = ("visible", "detected")


#: the sets of the GOSPA metrics (issue 35), in the metrics-only output of the loop
SET_KEYS = ("truth_pos", "present", "track_pos", "track_exists")


def estimate_sets(target, track_pos, track_exist, present) -> dict:
    """The truths and the estimates as sets (:mod:`mjx_radar.estimation.tracks.gospa`).

    Works on jax and numpy arrays with any leading axes. The estimates are the step's
    ``track_pos`` / ``track_exist`` (:class:`StepRecord`): for a tracker that knows the
    drones, track m is the estimate of drone m and exists while drone m is present; for
    the managed track table, the confirmed tracks.

    Returns:
        ``{"truth_pos": [..., M, 3], "present": [..., M], "track_pos": [..., K, 3],
        "track_exists": [..., K]}`` (:data:`SET_KEYS`).
    """
    return {
        "truth_pos": target[..., :3],
        "present": present,
        "track_pos": track_pos,
        "track_exists": track_exist,
    }


class TrialResult(NamedTuple):
    steps: StepRecord
    controls: ControlRecord
    placement_ok: jax.Array  # [] bool: the radars could be placed
