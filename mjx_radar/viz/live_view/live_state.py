"""The live view's data side: the records kept so far, a trial's arrays up to any step,
the scene box (:mod:`mjx_radar.viz.live_view.live`).

Every segment's records are kept (references to the arrays the runner already holds on
the host, no copy), so the page can show any step received from the run's start, not
only the latest: ``/state.json?step=K`` (the page replays the run from its start when it
is opened, and its slider goes back to any step).
"""

from __future__ import annotations

import numpy as np

from mjx_radar.env.records import control_arrays
from mjx_radar.viz.run_dir import Trial

STEP_KEYS = (
    "target",
    "mean",
    "cov_diag",
    "radar",
    "rmse_pos",
    "crlb_pos",
    "detections",
    "visible_pairs",
    "false_alarms",
    "targets_present",
)
CONTROL_KEYS = ("plan_xy", "sample_xy", "sample_weight")


class Records:
    """The segments received: step records ``[T, K, ...]`` and control records ``[T, C, ...]``,
    concatenated on demand (once per new segment), and the steps at the segments' ends."""

    def __init__(self):
        self._steps: list[dict] = []
        self._controls: list[dict] = []
        self.ends: list[int] = []

    def add(self, done: int, records) -> None:
        steps, controls = records
        self._steps.append({k: getattr(steps, k) for k in STEP_KEYS})
        arrays = control_arrays(controls)
        self._controls.append({k: arrays[k] for k in CONTROL_KEYS})
        self.ends.append(int(done))

    def arrays(self) -> tuple[dict, dict] | None:
        """``(steps, controls)`` so far, each segment list concatenated (and kept so)."""
        if not self._steps:
            return None
        for parts, keys in ((self._steps, STEP_KEYS), (self._controls, CONTROL_KEYS)):
            if len(parts) > 1:
                parts[:] = [{k: np.concatenate([p[k] for p in parts], axis=1) for k in keys}]
        return self._steps[0], self._controls[0]


def trial_at(scene, a: dict, c: dict, j: int, upto: int) -> Trial:
    """Trial position ``j``'s :class:`~mjx_radar.viz.run_dir.Trial` of steps ``1..upto``
    (``scene``: the run's :class:`~mjx_radar.viz.scene.Scene`)."""
    m, timing = a["target"].shape[2], scene.timing
    return Trial(
        meta={"r2t": scene.r2t},
        scene=scene,
        target=a["target"][j, :upto],
        mean=a["mean"][j, :upto].reshape(-1, m, 6)[..., :3],
        sigma=np.sqrt(np.maximum(a["cov_diag"][j, :upto].reshape(-1, m, 6)[..., :3], 0)),
        radar=a["radar"][j, :upto],
        sample_xy=c["sample_xy"][j],
        sample_weight=c["sample_weight"][j],
        every=timing.control_every,
        dt=float(timing.dt_filter),
    )


def paths_box(scene, steps: int) -> tuple:
    """``(lo, hi, ztop)`` of the drones' constant-velocity paths over the run and the
    vehicles' roads (``scene``: the run's :class:`~mjx_radar.viz.scene.Scene`)."""
    init = np.asarray(scene.target_init, float)
    t = np.linspace(0.0, steps * scene.timing.dt_filter, 11)[:, None, None]
    path = (init[None, :, :3] + t * init[None, :, 3:]).reshape(-1, 3)
    top = 1.15 * float(path[:, 2].max())
    if scene.ground.present:  # the whole grid's top: the surface fits
        from mjx_radar.world.terrain import node_heights

        top = max(top, 1.1 * float(node_heights(scene.ground.config).max()))
    roads = [np.asarray(car.path, float) for car in scene.moving.vehicles]
    xy = np.concatenate([path[:, :2], *roads])
    return xy.min(0), xy.max(0), max(top, 1.0)


def grow_box(box, tr: Trial) -> tuple:
    """Scene box ``(lo, hi, ztop)``: ``box`` grown to what ``tr`` shows (radars with their
    R2T discs, drones); it never shrinks (the page relayouts and redraws the ground)."""
    lo, hi = tr.bounds()
    return (
        np.minimum(lo, box[0]),
        np.maximum(hi, box[1]),
        max(box[2], 1.15 * float(tr.target[..., 2].max())),
    )
