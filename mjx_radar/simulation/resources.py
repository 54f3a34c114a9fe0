"""Memory and compile-time estimate of a batch of closed-loop trials, before compiling.

A run far too large for the machine should be refused in a second with a line naming
what to reduce, not after minutes of compilation with an out-of-memory traceback.
:func:`estimate` sizes the largest arrays of a batch of ``T`` trials (float32, 4 bytes),
with ``S`` MPPI samples, horizon ``H``, ``N`` radars, ``M`` targets, ``D = 6M`` joint
state, ``P = 2D = 12M`` cubature points, ``K`` filter steps and ``C = K / control_every``
control steps:

* MPPI sampling (device): the factored proposal draws ``e1 [S, S]`` standard normals
  per sub-iteration (``Sigma = F F^T + diag(b^2)`` with ``F [P, S]``), quadratic in
  ``S``: ``6·T·S²`` floats (random bits, the normals and the product; measured: XLA
  asked for 24.0 TB at ``S = 10^6``, i.e. 24 bytes per entry);
* planner (device): the objective of every sample, horizon step and cubature point,
  ``T·S·H·P·M·(N + 6)`` floats (radar-target distances ``[.., N, M]`` and the packed
  SFIM ``[.., M, 6]``), plus the MPPI samples ``4·T·S·H·2N``;
* MJX rollouts (device, ``mpc.rollout = "mjx"``): one ``mjx.Data`` per sample,
  about ``T·S·(400·(N + 1) + 50·obstacles)`` floats;
* filter (device): the joint CKF's cubature points and covariances
  ``T·(4·P·D + 8·D² + H·P·D)`` floats;
* trajectories (host): everything ``run`` keeps, ``T·K·(3D + 6N + 22)`` floats plus
  ``T·C·(2N + 2HN + 64·HN + 64)`` for controls, plans and the 32 kept MPPI samples,
  counted twice (per-segment chunks and their concatenation).

These are lower bounds of the peak (XLA adds temporaries), so a run is refused only
when they alone exceed the memory available: ``MemAvailable`` of ``/proc/meminfo``
(``os.sysconf`` elsewhere) on the CPU, where device and host share it, and
``bytes_limit - bytes_in_use`` of ``jax.Device.memory_stats()`` on a GPU.

Compile size: the packed Fisher information unrolls a loop over the N radars, the
CKF and the objective unroll over the M targets, and the MJX model holds N bodies
and every obstacle geom, so the program grows with ``N``, ``M`` and ``N·M``. A
program with ``N > 64``, ``M > 64``, ``N·M > 1024`` or more than 256 obstacles is
flagged large ("compiling a program this large can take minutes"). The compile-time
guess ``compile_s`` is a rough linear fit (a few tens of seconds for the bundled
scenarios on a CPU host); it is printed so a long compile does not look like a hang.
"""

from __future__ import annotations

import dataclasses
import os

from mjx_radar.config import Scenario
from mjx_radar.errors import InputError

FLOAT = 4  # bytes (float32)
KEEP = 32  # MPPI samples kept per control step (closed_loop.N_KEEP_SAMPLES)
LARGE_N, LARGE_M, LARGE_NM, LARGE_OBSTACLES = 64, 64, 1024, 256


@dataclasses.dataclass(frozen=True)
class Estimate:
    """Estimated memory [bytes] per term, where it lives, and the compile size.

    Attributes:
        device: term -> bytes on the compute device (planner, rollouts, filter).
        host: term -> bytes in host memory (trajectories).
        device_available: free device memory [bytes], ``None`` if unknown.
        host_available: free host memory [bytes], ``None`` if unknown.
        shared: device and host are the same memory (JAX on the CPU).
        compile_s: rough compile-time guess [s].
        large: the program exceeds the compile-size thresholds.
        summary: ``"N radars x M targets, R rollouts"``.
    """

    device: dict
    host: dict
    device_available: int | None
    host_available: int | None
    shared: bool
    compile_s: float
    large: bool
    summary: str

    @property
    def device_bytes(self) -> int:
        return sum(self.device.values())

    @property
    def host_bytes(self) -> int:
        return sum(self.host.values())

    def compile_line(self) -> str:
        """One line announcing the compilation and its rough duration."""
        return f"compiling ({self.summary}): this can take ~{self.compile_s:.0f} s"

    def large_line(self) -> str:
        """Why the program is large (meaningful when :attr:`large`)."""
        return (
            f"{self.summary}: compiling a program this large can take minutes "
            f"(~{self.compile_s:.0f} s; large means N > {LARGE_N}, M > {LARGE_M}, "
            f"N*M > {LARGE_NM} or > {LARGE_OBSTACLES} obstacles)"
        )


def estimate(scenario: Scenario, trials: int, steps: int, devices: int = 1) -> Estimate:
    """Memory and compile size of ``trials`` closed-loop trials of ``steps`` filter steps.

    Args:
        scenario: the scenario (sizes N, M, S, H, obstacles, rollout kind).
        trials: T, the batch size (split evenly over ``devices`` for the device terms).
        steps: K filter steps.
        devices: number of devices the batch is sharded over.

    Returns:
        The :class:`Estimate` (available memory queried from this machine).
    """
    n, m = scenario.n_radars, scenario.n_targets
    s, h = scenario.mppi.samples, scenario.mpc.horizon
    d, p = 6 * m, 12 * m
    t_dev = -(-trials // max(1, devices))
    c = steps // scenario.timing.control_every
    n_obs = len(scenario.obstacles)
    device = {
        "MPPI sampling": 6 * t_dev * s * s * FLOAT,
        "planner": t_dev * s * h * (p * m * (n + 6) + 8 * n) * FLOAT,
        "filter": t_dev * (4 * p * d + 8 * d * d + h * p * d) * FLOAT,
    }
    if scenario.mpc.rollout == "mjx":
        device["MJX rollouts"] = t_dev * s * (400 * (n + 1) + 50 * n_obs) * FLOAT
    per_step = 3 * d + 6 * n + 22
    per_control = 2 * n + 2 * h * n + 2 * KEEP * h * n + 2 * KEEP
    host = {"trajectories": 2 * trials * (steps * per_step + c * per_control) * FLOAT}
    shared, dev_avail = _device_available()
    host_avail = host_available()
    if shared:
        dev_avail = host_avail
    # Rough linear fit of the compile time [s] in the program's unrolled size.
    size = n + m + 0.05 * n * m + 0.25 * n_obs
    compile_s = (15.0 + 2.0 * size) * (2.0 if scenario.mpc.rollout == "mjx" else 1.0)
    large = n > LARGE_N or m > LARGE_M or n * m > LARGE_NM or n_obs > LARGE_OBSTACLES
    summary = f"{n} radars x {m} targets, {scenario.mpc.rollout} rollouts"
    return Estimate(device, host, dev_avail, host_avail, shared, compile_s, large, summary)


_KNOBS = {
    "MPPI sampling": ("mppi.samples", "mppi.samples or --trials"),
    "planner": ("mppi.samples", "mppi.samples, mpc.horizon or --trials"),
    "MJX rollouts": ("mppi.samples", "mppi.samples or --trials, or use --rollouts analytic"),
    "filter": ("targets", "the number of targets or --trials"),
    "trajectories": ("--steps", "--steps or --trials"),
}


def check(scenario: Scenario, trials: int, steps: int, devices: int = 1) -> Estimate:
    """:func:`estimate`, refusing a run whose arrays cannot fit in the available memory.

    Raises:
        InputError: one line naming the dominant term, its size, the memory available
            and the fields or options to reduce.
    """
    est = estimate(scenario, trials, steps, devices)
    need = est.device | est.host if est.shared else est.device
    avail = est.host_available if est.shared else est.device_available
    where = "in host RAM" if est.shared else "on the device"
    _refuse_if(scenario, trials, need, avail, where)
    if not est.shared:
        _refuse_if(scenario, trials, est.host, est.host_available, "in host RAM")
    return est


def _refuse_if(scenario: Scenario, trials: int, need: dict, avail: int | None, where: str):
    if avail is None or sum(need.values()) <= avail:
        return
    term = max(need, key=need.get)
    field, knobs = _KNOBS[term]
    value = {
        "mppi.samples": scenario.mppi.samples,
        "targets": scenario.n_targets,
        "--steps": None,
    }[field]
    verb = "need" if term.endswith("s") else "needs"
    what = f"{field} = {value}, --trials {trials}" if value is not None else f"--trials {trials}"
    raise InputError(
        f"{what}: the {term} {verb} ~{fmt_bytes(need[term])} (all arrays "
        f"~{fmt_bytes(sum(need.values()))}), this machine has {fmt_bytes(avail)} free {where}; "
        f"reduce {knobs}"
    )


def fmt_bytes(b: float) -> str:
    """``1.5e9`` -> ``"1.4 GiB"``."""
    for unit in ("B", "KiB", "MiB", "GiB", "TiB"):
        if b < 1024 or unit == "TiB":
            return f"{b:.0f} {unit}" if unit == "B" else f"{b:.1f} {unit}"
        b /= 1024
    return f"{b:.1f} TiB"


def host_available() -> int | None:
    """Free host memory [bytes]: ``MemAvailable`` of ``/proc/meminfo``, else ``os.sysconf``."""
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


def _device_available() -> tuple[bool, int | None]:
    """``(shared with the host, free bytes on this process's first device or None)``."""
    import jax

    dev = jax.local_devices()[0]  # under jax.distributed, devices()[0] is process 0's
    if dev.platform == "cpu":
        return True, None
    try:
        stats = dev.memory_stats() or {}
    except Exception:  # backends without memory statistics
        return False, None
    if "bytes_limit" not in stats:
        return False, None
    return False, int(stats["bytes_limit"]) - int(stats.get("bytes_in_use", 0))
