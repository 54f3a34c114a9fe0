"""What the engine, the study and the memory model need of one scenario, read once.

The engine's other modules and ``study/`` never read a scenario: the caller that
holds one (``api/``, ``cli/``, the study's loader) builds its :class:`RunSpec` once
with :func:`run_spec` and hands that down. A :class:`RunSpec` holds the compiled
shape (:func:`~mjx_radar.task.params.shape_key`, the programs' static key and the
task's source, opaque to the engine), the sizes the memory model reads
(:class:`ProgramSize`), the clocks, the set-metric settings, and the two things the
engine asks of the runtime numbers: the :class:`~mjx_radar.task.params.TaskParams` of a
method and seed (built when asked: their dtype follows the caller's precision) and the
one line that refuses a trial whose radars cannot be placed.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable

from mjx_radar.scenario.schema import Scenario, Timing
from mjx_radar.scenario.schema_metrics import MetricsConfig
from mjx_radar.scenario.tracker_roles import composed
from mjx_radar.task.method import Method
from mjx_radar.task.params import TaskParams, shape_key, task_params

__all__ = ["ProgramSize", "RunSpec", "program_size", "run_spec"]


@dataclasses.dataclass(frozen=True)
class ProgramSize:
    """What the large arrays of a compiled program are sized by
    (:mod:`mjx_radar.engine.memory_model`, :mod:`mjx_radar.engine.resources`).

    Attributes:
        n_radars, n_targets: N, M.
        samples, horizon: the MPPI samples S and the MPC horizon H.
        dim: measurement numbers per radar-target pair (2: range + azimuth, else 1).
        structure: the filter's structure (``"joint"`` or ``"per-target"``).
        obstacles: the static obstacles' tables (their line-of-sight tests and carry).
        clutter_planner: clutter with the detection-weighted planner information.
        control_every: filter steps per control step; steps: the scenario's K.
        target_motion: the scenario has ``[[target_motion]]`` tables.
        rollout: the planner's rollout backend (``"mjx"`` or ``"analytic"``).
        hypotheses, events, merge_pairs: the MHT's K hypotheses, its ``E = (G + 1)^M``
            joint events per hypothesis and radar, and the ``screen · K`` children whose
            label-free distances it merges on (0 where it does not; all 0 without the MHT).
    """

    n_radars: int
    n_targets: int
    samples: int
    horizon: int
    dim: int
    structure: str
    obstacles: tuple
    clutter_planner: bool
    control_every: int
    steps: int
    target_motion: bool
    rollout: str
    hypotheses: int = 0
    events: int = 0
    merge_pairs: int = 0

    @property
    def joint(self) -> bool:
        """Whether the filter is one joint state of every target."""
        return self.structure == "joint"


@dataclasses.dataclass(frozen=True, eq=False)
class RunSpec:
    """One scenario as the engine and the study see it (built by :func:`run_spec`).

    Attributes:
        name: the scenario's name (file names, logs, messages).
        shape: the compiled shape (:func:`~mjx_radar.task.params.shape_key`): the
            programs' static key, handed to :func:`~mjx_radar.task.task.make_task`.
        size: the sizes of its programs (:class:`ProgramSize`).
        timing: its clocks.
        metrics: its set-metric settings (GOSPA / OSPA cutoff and order).
        make_params: ``(method, seed) -> TaskParams`` (see :meth:`params`).
        refusal: ``trial -> str``: the one line refusing a trial whose radars cannot be
            placed (:func:`~mjx_radar.env.placement.placement_error`).
    """

    name: str
    shape: Scenario
    size: ProgramSize
    timing: Timing
    metrics: MetricsConfig
    make_params: Callable[[Method, int | None], TaskParams]
    refusal: Callable[[int], str]

    @property
    def control_every(self) -> int:
        """Filter steps per control step."""
        return self.timing.control_every

    def params(self, method: Method, seed: int | None = None) -> TaskParams:
        """The runtime numbers for ``method`` and base ``seed`` (default the scenario's),
        in JAX's float dtype at the time of the call (float64 under x64)."""
        return self.make_params(method, seed)


def program_size(scenario: Scenario) -> ProgramSize:
    """The :class:`ProgramSize` of a scenario."""
    det, t = scenario.detection, scenario.tracker
    mht = composed(scenario) == "mht"
    k = t.hypotheses if mht else 0
    g = min(t.candidates, scenario.n_targets + det.max_false_alarms)  # capped at the scan
    labels = mht and t.merge_labels and t.merge_distance > 0
    return ProgramSize(
        n_radars=scenario.n_radars,
        n_targets=scenario.n_targets,
        samples=scenario.mppi.samples,
        horizon=scenario.mpc.horizon,
        dim=2 if scenario.measurement.model == "range-azimuth" else 1,
        structure=scenario.filter.structure,
        obstacles=tuple(scenario.obstacles),
        clutter_planner=bool(det.clutter and det.planner),
        control_every=scenario.timing.control_every,
        steps=scenario.timing.steps,
        target_motion=bool(scenario.target_motion),
        rollout=scenario.mpc.rollout,
        hypotheses=k,
        events=(g + 1) ** scenario.n_targets if mht else 0,
        merge_pairs=t.merge_screen * k if labels else 0,
    )


def run_spec(scenario: Scenario) -> RunSpec:
    """The :class:`RunSpec` of a validated scenario (read once, handed down)."""
    from mjx_radar.env.placement import placement_error

    return RunSpec(
        name=scenario.name,
        shape=shape_key(scenario),
        size=program_size(scenario),
        timing=scenario.timing,
        metrics=scenario.metrics,
        make_params=functools.partial(task_params, scenario),
        refusal=functools.partial(placement_error, scenario),
    )
