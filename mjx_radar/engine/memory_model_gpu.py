"""The GPU side of the memory model: fewer arrays kept, and the device's peak.

On a GPU XLA fuses more, and a term holds only what is alive at the program's peak:
:func:`gpu_terms` sizes a program of one kind or a study's (kind ``"all"`` and the
symbols ``T, S, H, P, M, N, D, Z, F``: :mod:`mjx_radar.engine.memory_model`):

* planner expectations: ``T·S·H·(P·M·A + N·M)·F``, the kept arrays ``[S, H, P·M]`` and
  one number a sample, horizon step and radar-target pair (the pair's geometry).
  :data:`GPU_OBJECTIVE_ARRAYS`: the joint filter's SFIM is fused (``A = 0``) up to
  :data:`GPU_JOINT_FUSED_TARGETS` targets and keeps ``A = 1.5·N`` above (``3.4·N`` for
  one trial, :data:`GPU_JOINT_UNFUSED`), its PFIM keeps one array per radar (``A = N``);
  the per-target bank keeps ``1.65·(N - 1)`` (SFIM) and ``3 + 1.2N`` (PFIM), ``+1.9N`` /
  ``+0.85N`` with clutter. A study's program holds the larger of its branches;
* cuBLAS workspace: a program with a large matrix product (a planner of ``S ≥ 128``
  samples; without a planner the per-target bank, ``D ≥ 48`` or ``≥ 200`` obstacle
  faces) holds a 32 MiB workspace, in the same buffers as the kept arrays (planner) or
  the filter's temporaries (no planner): it adds ``max(0, 32 MiB - those)``;
* MPPI sampling ``T·S²·F`` (one draw ``[S, S]``); MJX rollouts ``80·(N + 1)`` numbers
  a sample, ``T·S·80·(N + 1)·F``; no line of sight kept;
* filter: as on the CPU, but the truth's line of sight is 1 number a test and without
  a planner the joint filter keeps ``2·D² + 5·Z²``; beside a planner the filter's
  temporaries live apart from the planner's and add only what exceeds them;
* loop state: as on the CPU.

The device's peak (``peak_bytes_in_use``, one segment run in a fresh process) adds the
runtime's floor to XLA's figure ``x`` of a small program and is ``x`` for a large one:
``max(x, 150 MB + x/2)`` (:func:`device_peak`; about 150 MB for a program of a few MB).

The constants are fit to one H200 (jax 0.11.2; ``benchmarks/results/
memory_model_gpu_h200_rows.json``) on the 64-trial programs of one kind and checked on
the held-out 16-trial and study programs (``tests/test_resources.py``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from mjx_radar.engine.run_spec import ProgramSize

#: arrays ``[S, H, P·M]`` a trial keeps, ``a + b·N``, per filter structure and
#: information: the joint filter's SFIM expectations are fused (none kept)
GPU_OBJECTIVE_ARRAYS = {
    ("joint", "sfim"): (0.0, 0.0),
    ("joint", "pfim"): (0.0, 1.0),
    ("per-target", "sfim"): (-1.65, 1.65),
    ("per-target", "pfim"): (3.0, 1.2),
}
#: the joint filter's SFIM expectations are fused up to this many targets (20 measured
#: fused, 24 and 32 not); above it a trial keeps ``b·N`` arrays ``[S, H, P·M]``, b from
#: GPU_JOINT_UNFUSED: one trial (the plain loop) keeps about twice a batched trial's
GPU_JOINT_FUSED_TARGETS = 20
GPU_JOINT_UNFUSED = {"one trial": 3.4, "batched": 1.5}
#: extra arrays per radar with the detection-weighted information and clutter
GPU_CLUTTER_ARRAYS = {"sfim": 1.9, "pfim": 0.85}
#: numbers of an MJX rollout kept per sample and body (N radars + the world)
GPU_ROLLOUT_NUMBERS = 80
#: cuBLAS's workspace [bytes] (32 MiB on Hopper), in a program with a large matrix
#: product: a planner of at least GPU_GEMM_SAMPLES samples, or without a planner a
#: per-target bank, a joint state of GPU_GEMM_STATE or more, or GPU_GEMM_TESTS faces
GPU_WORKSPACE = 32 * 2**20
GPU_GEMM_SAMPLES, GPU_GEMM_STATE, GPU_GEMM_TESTS = 128, 48, 200
#: the joint filter's ``D²`` work kept without a planner (``2·D² + 5·Z²``)
GPU_NONE_JOINT_FILTER = 2
#: the MHT's numbers (:func:`~mjx_radar.engine.memory_model.mht_numbers`) a GPU program
#: keeps, as a share of the CPU's
GPU_MHT_SHARE = 0.75
#: the device's peak: ``max(x, GPU_FLOOR + GPU_FLOOR_SHARE·x)`` for XLA's figure ``x``
GPU_FLOOR, GPU_FLOOR_SHARE = 150e6, 0.5


def gpu_terms(
    size: ProgramSize,
    trials: int,
    kind: str,
    loop_state: float,
    tests: int,
    f: int,
    mht: float = 0.0,
) -> dict:
    """``memory_model.device_terms`` of a program of one kind or a study's on a GPU.

    ``loop_state``: bytes of the loop state (as on the CPU); ``tests``: the obstacles'
    half-space and cylinder tests (``K·F + C``); ``f``: bytes per number; ``mht``: the
    MHT's numbers a trial (``memory_model.mht_numbers``), part of the filter's temporaries.
    """
    n, m = size.n_radars, size.n_targets
    s, h, dim, joint = size.samples, size.horizon, size.dim, size.joint
    d, z = 6 * m, n * m * dim
    p = 12 * m if joint else 12
    infos = [k for k in kind.split("+") if k in ("sfim", "pfim")]
    if joint and infos:
        filt = 8 * d * d + 2 * h * d * d + 4 * d * z + 7 * z * z
    elif joint:  # the covariance work fused but the innovation's
        filt = GPU_NONE_JOINT_FILTER * d * d + 5 * z * z
    elif infos:
        filt = 6 * d * d + 7 * m * (n * dim) ** 2 + 24 * z + 72 * h * m
    else:
        filt = 4 * d * d + m * (n * dim) ** 2 + 24 * z
    filt += n * m * tests  # the truth's line of sight, one number a test
    terms = {"filter": trials * filt * f, "loop state": loop_state}
    hyp = trials * GPU_MHT_SHARE * mht * f  # the MHT's events and merge distances
    if hyp:
        terms["MHT hypotheses"] = hyp
    if not infos:  # a matrix product large enough for cuBLAS: its workspace, shared
        # with the filter's temporaries
        gemm = not joint or d >= GPU_GEMM_STATE or tests >= GPU_GEMM_TESTS
        if gemm and GPU_WORKSPACE > terms["filter"] + hyp:
            terms["cuBLAS workspace"] = GPU_WORKSPACE - terms["filter"] - hyp
        return {k: int(v) for k, v in terms.items()}
    clutter = size.clutter_planner
    best = None
    for info in infos:  # a study's program holds the larger of its branches
        a, b = GPU_OBJECTIVE_ARRAYS[(size.structure, info)]
        if joint and info == "sfim" and m > GPU_JOINT_FUSED_TARGETS:  # not fused
            a, b = 0.0, GPU_JOINT_UNFUSED["one trial" if trials == 1 else "batched"]
        arrays = a + b * n + (GPU_CLUTTER_ARRAYS[info] * n if clutter else 0.0)
        kept = trials * s * h * p * m * arrays * f  # the [S, H, P·M] arrays
        pairs = trials * s * h * n * m * f  # one number a sample, step and radar-target pair
        shared = max(0.0, GPU_WORKSPACE - kept) if s >= GPU_GEMM_SAMPLES else 0.0
        if best is None or kept + shared > best[0] + best[2]:
            best = (kept, pairs, shared)
    kept, pairs, shared = best
    terms["planner expectations"] = kept + pairs
    terms["MPPI sampling"] = trials * s * s * f
    if size.rollout == "mjx":
        terms["MJX rollouts"] = trials * s * GPU_ROLLOUT_NUMBERS * (n + 1) * f
    if shared:
        terms["cuBLAS workspace"] = shared
    # the filter's temporaries (the MHT's with them) live apart from the planner's: only
    # what exceeds them
    planner = sum(
        v for k, v in terms.items() if k not in ("filter", "loop state", "MHT hypotheses")
    )
    both = max(0.0, terms["filter"] + hyp - planner)
    terms["filter"] = max(0.0, terms["filter"] - planner)
    if hyp:
        terms["MHT hypotheses"] = both - terms["filter"]
    return {k: int(v) for k, v in terms.items()}


def device_peak(xla_bytes: float, platform: str) -> int:
    """The device's peak ``peak_bytes_in_use`` of a program whose XLA figure is ``xla_bytes``.

    On a GPU the larger of the program's figure and the runtime floor plus half of it
    (:data:`GPU_FLOOR`, module docstring); on the CPU the figure itself.
    """
    if platform != "gpu":
        return int(xla_bytes)
    return int(max(xla_bytes, GPU_FLOOR + GPU_FLOOR_SHARE * xla_bytes))
