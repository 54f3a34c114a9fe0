"""Bytes of the large arrays of a compiled closed-loop program, measured against XLA.

:func:`device_terms` sizes one segment program of ``T`` trials on one device
(``F`` bytes per number: 4, or 8 with ``--precision float64``), with ``S`` MPPI
samples, horizon ``H``, ``N`` radars, ``M`` targets, joint state ``D = 6M`` and
``Z = N·M·dim`` measurements per step (``dim`` 1 for ranges, 2 with azimuth). ``P``
is the number of cubature points per target in the planner's expectations: ``12M``
for the joint filter (``[filter] structure = "joint"``: its points live in the
6M-dimensional joint space) and ``12`` for the per-target bank.

* planner expectations: the objective of every sample, horizon step, cubature point
  and target, ``T·S·H·P·M·A·F``, where XLA keeps ``A`` arrays of shape
  ``[S, H, P·M]`` (the Fisher-information entries, log dets, keep-out counts,
  per-radar geometry): ``A = 11 + dim·N/2`` on the CPU and ``8 + dim·N`` on a GPU.
  Quadratic in ``M`` for the joint filter: 300 targets
  give ``P·M = 1.08·10⁶`` points per sample and step, 26.8 GB at S = 64, H = 8
  (XLA's request when such a run died), against 85 MB with the per-target bank;
* line of sight (scenes with obstacles): the planner tests every sample's radar-target
  segments against each obstacle, ``T·S·H·N·M·(K·F + C)`` tests for ``K`` polyhedra
  of ``F`` planes (boxes 6, meshes their hull's) and ``C`` cylinders, 4 numbers each
  on the CPU, 1 on a GPU (city_4r4t: 96 planes, 64 MB a trial; forest_4r4t: 150 trees);
* MPPI sampling: the factored proposal draws ``e1 [S, S]`` per sub-iteration,
  ``6·T·S²·F`` (XLA asked for 24.0 TB at ``S = 10⁶``);
* MJX rollouts (``mpc.rollout = "mjx"``): one ``mjx.Data`` per sample,
  ``T·S·(400·(N + 1) + 50·obstacles)·F``;
* filter: joint CKF: covariance, square root and gain work ``8·D²``, the 2D cubature
  points over the horizon ``2H·D²``, measurement-space arrays (predicted
  measurements ``[2D, Z]``, cross covariance ``[D, Z]``: ``4·D·Z``) and the innovation
  covariance with its Cholesky work ``7·Z²``; per-target bank: the joint covariance
  kept between steps ``6·D²`` plus ``M`` small filters ``7·M·(N·dim)² + 24·Z + 72·H·M``.

XLA's figure for a program is ``compiled.memory_analysis()`` of its step program:
temporaries + arguments + outputs - donated aliases (``scripts/measure_memory.py``).
The estimate / that figure lies in :data:`MEASURED_FACTOR` on every shape of
``tests/test_resources.py``: 0.91-1.27 on 21 CPU shapes (joint and per-target, 2 to
300 targets, 2 to 48 radars, MJX and analytic rollouts, boxes, meshes and trees,
azimuth), 1.02-1.32 for the bundled scenarios at study sizes (1 to 500 trials per
device) on an H100; 1.6 for the 0.7 MB smoke program, which the GPU fuses more tightly.
"""

from __future__ import annotations

import functools

from mjx_radar.scenario.schema import Scenario

FLOAT = 4  # bytes (float32; 8 with --precision float64, see :func:`float_bytes`)
#: estimate / XLA's figure for the step program on the shapes of tests/test_resources.py
MEASURED_FACTOR = (0.85, 1.5)


def float_bytes() -> int:
    """Bytes per number of the simulation: 8 in JAX's x64 mode (``--precision float64``)."""
    import jax

    return 8 if jax.config.jax_enable_x64 else FLOAT


def device_terms(scenario: Scenario, trials: int, platform: str = "cpu") -> dict:
    """Bytes of the large arrays of one program of ``trials`` trials on one device.

    Args:
        scenario: the scenario (N, M, S, H, filter structure, measurement model,
            obstacles, rollout kind).
        trials: T, trials per device.
        platform: ``"cpu"`` or ``"gpu"`` (``jax.Device.platform``): XLA keeps a
            different number of the objective's arrays on each (module docstring).

    Returns:
        ``{"planner expectations", "MPPI sampling", "filter"[, "MJX rollouts"]: bytes}``.
    """
    n, m = scenario.n_radars, scenario.n_targets
    s, h = scenario.mppi.samples, scenario.mpc.horizon
    dim = 2 if scenario.measurement.model == "range-azimuth" else 1
    joint = scenario.filter.structure == "joint"
    d, z = 6 * m, n * m * dim
    p = 12 * m if joint else 12  # cubature points per target in the expectations
    if joint:
        filt = 8 * d * d + 2 * h * d * d + 4 * d * z + 7 * z * z
    else:
        filt = 6 * d * d + 7 * m * (n * dim) ** 2 + 24 * z + 72 * h * m
    gpu = platform == "gpu"
    arrays = 8 + dim * n if gpu else 11 + dim * n / 2
    f = float_bytes()
    terms = {
        "planner expectations": trials * s * h * (p * m * arrays + 8 * n) * f,
        "MPPI sampling": 6 * trials * s * s * f,
        "filter": trials * filt * f,
    }
    if scenario.obstacles:
        tests = s * h * n * m * occluder_tests(scenario.obstacles)
        terms["line of sight"] = trials * tests * (1 if gpu else 4) * f
    if scenario.mpc.rollout == "mjx":
        n_obs = len(scenario.obstacles)
        terms["MJX rollouts"] = trials * s * (400 * (n + 1) + 50 * n_obs) * f
    return {k: int(v) for k, v in terms.items()}


@functools.lru_cache(maxsize=64)
def occluder_tests(obstacles: tuple) -> int:
    """Half-space and cylinder tests of one segment: ``K·F + C`` of the occluders."""
    from mjx_radar.world.occlusion import occluders

    occ = occluders(obstacles)
    return int(occ.planes.shape[0] * occ.planes.shape[1] + occ.cylinders.shape[0])
