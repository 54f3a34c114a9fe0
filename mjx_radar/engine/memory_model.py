"""Bytes of the large arrays of a compiled closed-loop program, measured against XLA.

:func:`device_terms` sizes one segment program of ``T`` trials on one device
(``F`` bytes per number: 4, or 8 with ``--precision float64``) and one *program kind*
(what is compiled of the planner: ``"none"`` for ``stationary``, ``"sfim"`` or
``"pfim"`` for a planning method, a study's ``"sfim+pfim+none"``, or ``"all"``), with
``S`` MPPI samples, horizon ``H``, ``N`` radars, ``M`` targets, joint state ``D = 6M``
and ``Z = N·M·dim`` measurements per step (``dim`` 1 for ranges, 2 with azimuth).
``P`` is the number of cubature points per target in the planner's expectations:
``12M`` for the joint filter (``[filter] structure = "joint"``: its points live in the
6M-dimensional joint space) and ``12`` for the per-target bank.

* planner expectations: the objective of every sample, horizon step, cubature point
  and target, ``T·S·H·P·M·A·F``, where XLA keeps ``A`` arrays of shape
  ``[S, H, P·M]`` alive at once (:func:`objective_arrays`). The Fisher information is
  accumulated radar by radar, and XLA keeps two arrays per radar (the pair's weight
  ``w/r²`` and its product with the geometry; ``buffer-assignment`` of the CPU
  program): ``A = 3 + 2N`` for SFIM, ``6.3 + 2N`` for PFIM on the CPU, ``+5N`` when the
  planner weighs the information by detection with clutter; a program joining both
  under ``lax.cond`` (kind ``"all"``) fuses them, ``11.3 + N/2`` (``6 + N`` on a GPU).
  Quadratic in ``M`` for the joint filter: swarm_32r32t (``P·M = 12 288``) keeps 65
  arrays of 147 MB, 9.9 GB a trial on the CPU, against 0.3 GB with the per-target bank
  (``P·M = 384``);
* line of sight (scenes with obstacles): the planner tests every sample's radar-target
  segments against each obstacle, ``T·S·H·N·M·(K·F + C)`` tests for ``K`` polyhedra
  of ``F`` planes (boxes 6, meshes their hull's) and ``C`` cylinders, 1 number each
  on a GPU and 4 on the CPU in a ``"all"`` program, none kept in a program of one kind;
  the truth's line of sight in the loop ``6·N·M·(K·F + C)`` (and 270 numbers of each
  mesh's geometry in the loop state, 20 of any other obstacle's);
* MPPI sampling: the factored proposal draws ``e1 [S, S]`` per sub-iteration,
  ``6·T·S²·F`` (XLA asked for 24.0 TB at ``S = 10⁶``);
* MJX rollouts (``mpc.rollout = "mjx"``): one ``mjx.Data`` per sample,
  ``T·S·(400·(N + 1) + 50·obstacles)·F``; on the CPU no longer alive when the joint
  filter's expectations are, nor the obstacles' part in a program of one kind;
* filter: joint CKF: covariance, square root and gain work ``8·D²``, the 2D cubature
  points over the horizon ``2H·D²`` (a planning kind), measurement-space arrays
  (predicted measurements ``[2D, Z]``, cross covariance ``[D, Z]``: ``4·D·Z``) and the
  innovation covariance with its Cholesky work ``7·Z²`` (``9·D² + 5·Z²`` in all without
  a planner); per-target bank: the joint
  covariance kept between steps ``6·D²`` plus ``M`` small filters ``7·M·(N·dim)² +
  24·Z + 72·H·M`` (``4·D² + M·(N·dim)² + 24·Z`` without a planner);
* the MHT (``[tracker] association = "mht"``): every hypothesis's joint events, scored and
  mixed, ``K·E·M·3.5`` numbers a trial (K hypotheses, ``E = (G + 1)^M`` events), and with
  ``merge_labels`` the label-free distances of the ``s·K`` screened children over the M!
  orders, ``3·(s·K)²·M!`` (:func:`mht_numbers`), and its K banks ``K·(42M + 1)`` in the
  loop state. The event tables live apart from the planner's
  arrays in the step, so a planning program keeps only what exceeds those (measured: the
  CPU, clutter_3r4t, K = 16-1024, 2 trials, 0.96-1.01 of XLA's figure);
* loop state: the carry (joint ``4·D² + 120·D``, bank ``576·M + 4·D²``, the
  ``2·32·H·N`` kept MPPI samples, 2500 numbers of keys, clocks and small arrays), a
  segment's records (``run``: ``3D + 6N + 22`` numbers a filter step and
  ``2(N + HN + 32·HN + 32)`` a control step; a study: ``8M + 12`` a step) and the task's
  parameters (with ``[[target_motion]]`` the motion tables of the file's ``K`` steps,
  ``(9K + 7)·M``, for all trials): the whole program of ``stationary``.

On a GPU a program of one kind or a study's keeps fewer arrays (XLA fuses more), and
the device's peak adds the runtime's floor to a small program:
:mod:`mjx_radar.engine.memory_model_gpu`.

XLA's figure for a program is ``compiled.memory_analysis()`` of its step program:
temporaries + arguments + outputs - donated aliases (``scripts/measure_memory.py``).
The estimate / that figure lies in 0.86-1.13 for every bundled scenario x kind at 2
trials on the CPU (jax 0.10.2; 0.94-1.06 for programs above 1 MB), the table of
``tests/test_resources.py``, and in :data:`MEASURED_FACTOR` on its synthetic shapes
and H100 figures (kind ``"all"``). On one H200 (jax 0.11.2, 64 and 16 trials, every
bundled scenario x kind and a study's program;
``benchmarks/results/memory_model_gpu_h200_rows.json``) it lies in 0.84-1.17 of XLA's
figure but for smoke's programs of 1.4-24 MB (0.31-1.32: XLA keeps smoke's SFIM arrays
at 64 trials and fuses them at 16), and in 0.76-1.13 of the device's peak but for two
of clutter_3r4t's (0.62-0.63: its peak lies ~230 MB above the step program's figure).
"""

from __future__ import annotations

import functools
import math
from typing import TYPE_CHECKING

from mjx_radar.engine.memory_model_gpu import device_peak, gpu_terms  # noqa: F401

if TYPE_CHECKING:
    from mjx_radar.engine.run_spec import ProgramSize

KEEP = 32  # MPPI samples kept per control step (planners.records.N_KEEP_SAMPLES)
#: numbers per line-of-sight test kept at once, {(platform, kind "all"): numbers}: a
#: program of one information kind computes them apart from the objective's arrays on
#: the CPU (none kept); one that joins both under ``lax.cond`` keeps them
LOS_NUMBERS = {("cpu", False): 0, ("cpu", True): 4, ("gpu", True): 1}
FLOAT = 4  # bytes (float32; 8 with --precision float64, see :func:`float_bytes`)
#: estimate / XLA's figure for the step program on the shapes of tests/test_resources.py
MEASURED_FACTOR = (0.8, 1.35)
#: ... for every bundled scenario x program kind (the goal: within 25 %)
BUNDLED_FACTOR = (0.75, 1.25)


def float_bytes() -> int:
    """Bytes per number of the simulation: 8 in JAX's x64 mode (``--precision float64``)."""
    import jax

    return 8 if jax.config.jax_enable_x64 else FLOAT


#: arrays ``[S, H, P·M]`` of a trial that XLA keeps at once in the planner's expectations
#: on the CPU, ``a + b·N`` per information kind (``N`` radars; module docstring)
OBJECTIVE_ARRAYS = {
    ("cpu", "sfim"): (3.0, 2.0),
    ("cpu", "pfim"): (6.3, 2.0),
}
#: the same for a program that joins both informations under ``lax.cond`` (kind "all"):
#: XLA then fuses the per-radar terms
JOINED_ARRAYS = {"cpu": (11.3, 0.5), "gpu": (6.0, 1.0)}
#: extra arrays per radar when the planner weighs the information by the detection
#: probability with clutter (the PDA planner factor, ``[detection] planner = true``)
CLUTTER_ARRAYS = 5.0


#: numbers a trial per MHT hypothesis, joint event and target (scores, events, mixtures)
MHT_EVENT_NUMBERS = 3.5
#: numbers a trial per pair of screened children and target order (label-free merging)
MHT_LABEL_NUMBERS = 3.0


def mht_numbers(size: ProgramSize) -> float:
    """Numbers a trial of the MHT's event tables and label-free merge distances (0 without
    the MHT): ``K·E·M·3.5 + 3·(s·K)²·M!``."""
    m = size.n_targets
    events = MHT_EVENT_NUMBERS * size.hypotheses * size.events * m
    labels = MHT_LABEL_NUMBERS * size.merge_pairs**2 * math.factorial(m) if size.merge_pairs else 0
    return events + labels


def objective_arrays(kind: str, n: int, platform: str, clutter: bool = False) -> float:
    """Arrays ``[S, H, P·M]`` per trial of the planner's expectations of a program kind
    on the CPU, or of kind ``"all"`` on either platform (a GPU's other kinds:
    :data:`GPU_OBJECTIVE_ARRAYS`).

    ``"none"`` compiles no planner (0). A kind of several informations joined by a
    runtime switch holds the larger of its branches; ``"all"`` (``lax.cond`` on the
    method's flags) fuses more (:data:`JOINED_ARRAYS`).
    """
    plat = "gpu" if platform == "gpu" else "cpu"
    infos = [k for k in kind.split("+") if k in ("sfim", "pfim")]
    if kind == "all":
        a, b = JOINED_ARRAYS[plat]
    elif infos:
        a, b = max(OBJECTIVE_ARRAYS[(plat, k)] for k in infos)
    else:
        return 0.0
    return a + b * n + (CLUTTER_ARRAYS * n if clutter else 0.0)


def device_terms(
    size: ProgramSize,
    trials: int,
    platform: str = "cpu",
    kind: str = "all",
    full: bool = True,
    segment_steps: int | None = None,
) -> dict:
    """Bytes of the large arrays of one program of ``trials`` trials on one device.

    Args:
        size: the program's sizes (N, M, S, H, filter structure, measurement model,
            obstacles, rollout kind, clutter; :class:`~mjx_radar.engine.run_spec.ProgramSize`).
        trials: T, trials per device.
        platform: ``"cpu"`` or ``"gpu"`` (``jax.Device.platform``): XLA keeps a
            different number of the objective's arrays on each (module docstring).
        kind: the program kind (:data:`mjx_radar.task.method.PROGRAM_KINDS`): what is
            compiled of the planner (``"none"``: nothing).
        full: the program returns trajectories (``run``) or only metrics (``study``).
        segment_steps: filter steps of one segment program (its records); default one
            control period.

    Returns:
        ``{"planner expectations", "MPPI sampling", "filter", "loop state"[, "MJX
        rollouts", "line of sight", "MHT hypotheses"]: bytes}`` (no planner terms for kind
        ``"none"``).
    """
    n, m = size.n_radars, size.n_targets
    s, h, dim, joint = size.samples, size.horizon, size.dim, size.joint
    d, z = 6 * m, n * m * dim
    p = 12 * m if joint else 12  # cubature points per target in the expectations
    plans = kind != "none"  # the planner's context: the cubature points over the horizon
    if joint and plans:
        filt = 8 * d * d + 2 * h * d * d + 4 * d * z + 7 * z * z
        state = 4 * d * d + 120 * d
    elif joint:
        filt = 9 * d * d + 5 * z * z
        state = 4 * d * d + 120 * d
    elif plans:
        filt = 6 * d * d + 7 * m * (n * dim) ** 2 + 24 * z + 72 * h * m
        state = 16 * 36 * m + 4 * d * d
    else:
        filt = 4 * d * d + m * (n * dim) ** 2 + 24 * z
        state = 16 * 36 * m + 4 * d * d
    obstacles = size.obstacles
    if obstacles:  # the truth's line of sight in the loop, radar x target x face
        filt += 6 * n * m * occluder_tests(obstacles)
        meshes = sum(o.kind == "mesh" for o in obstacles)  # their geometry: carry
        state += 270 * meshes + 20 * (len(obstacles) - meshes)
    k = segment_steps or size.control_every
    state += _records(size, full, k) + 2 * KEEP * h * n + 2500  # + keys, clocks, small
    state += size.hypotheses * (42 * m + 1)  # the MHT's K banks and weights
    f = float_bytes()
    # the motion tables, accel, mean_v [K, M, 3], vel [K+1, M, 3]
    motion = (9 * size.steps + 7) * m * f if size.target_motion else 0
    if platform == "gpu" and kind != "all":
        tests = occluder_tests(obstacles) if obstacles else 0
        return gpu_terms(
            size, trials, kind, state * trials * f + motion, tests, f, mht_numbers(size)
        )
    terms = {"filter": trials * filt * f, "loop state": trials * state * f + motion}
    arrays = objective_arrays(kind, n, platform, size.clutter_planner)
    if arrays:
        terms["planner expectations"] = trials * s * h * (p * m * arrays + 8 * n) * f
        terms["MPPI sampling"] = 6 * trials * s * s * f
        gpu = platform == "gpu"
        los = LOS_NUMBERS[("gpu" if gpu else "cpu", kind == "all")]
        if obstacles and los:
            tests = s * h * n * m * occluder_tests(obstacles)
            terms["line of sight"] = trials * tests * los * f
        # the rollouts' mjx.Data: on the CPU no longer alive beside the joint filter's
        # (larger) expectations, nor are the obstacles' beside one information kind's
        if size.rollout == "mjx" and (gpu or not joint or kind == "all"):
            n_obs = len(obstacles) if gpu or kind == "all" else 0
            terms["MJX rollouts"] = trials * s * (400 * (n + 1) + 50 * n_obs) * f
    if size.hypotheses:  # apart from the planner's arrays: only what exceeds them
        planner = terms.get("planner expectations", 0) + terms.get("MPPI sampling", 0)
        terms["MHT hypotheses"] = max(0.0, trials * mht_numbers(size) * f - planner)
    return {k: int(v) for k, v in terms.items()}


def _records(size: ProgramSize, full: bool, k: int) -> int:
    """Numbers a trial of a segment's records of ``k`` filter steps, and the kept MPPI
    samples of a ``run`` (``full``)."""
    n, m, h, every = size.n_radars, size.n_targets, size.horizon, size.control_every
    if full:
        d = 6 * m
        return k * (3 * d + 6 * n + 22) + (k // every) * 2 * (n + h * n + KEEP * h * n + KEEP)
    return k * (8 * m + 12)


@functools.lru_cache(maxsize=64)
def occluder_tests(obstacles: tuple) -> int:
    """Half-space and cylinder tests of one segment: ``K·F + C`` of the occluders."""
    from mjx_radar.world.occlusion import occluders

    occ = occluders(obstacles)
    return int(occ.planes.shape[0] * occ.planes.shape[1] + occ.cylinders.shape[0])
