"""Memory and compile-time estimate of a batch of closed-loop trials, before compiling.

A run far too large for the machine is refused in a second with a line naming what
is too big and what to change, not after minutes of compilation with XLA's
``RESOURCE_EXHAUSTED`` traceback. :func:`estimate` adds up the device arrays of one
segment program (:mod:`mjx_radar.engine.memory_model`: planner expectations, MPPI
sampling, MJX rollouts, filter; within a documented factor of XLA's own figures; on a
GPU its own terms and the runtime's floor of the device's peak, about 150 MB) and
the host's kept trajectories: ``T·K·(3D + 6N + 22)`` plus ``T·C·(2N + 2HN + 64·HN +
64)`` numbers for ``K`` filter steps and ``C`` control steps (controls, plans and the
32 kept MPPI samples; 12 metrics per step for a study), counted twice (per-segment
chunks and their concatenation).

A run is refused when the estimate of its program (per program kind: a ``stationary``
run compiles no planner, a study's shared program every method's) exceeds the memory
available (:mod:`mjx_radar.engine.memory_available`): ``MemAvailable`` on the CPU, where
device and host share it, the device's free memory on a GPU, either capped by
``$MJX_RADAR_MEMORY_LIMIT``. The refusal names the dominant term, the largest
``--trials`` (``run``, ``simulate``) or ``--chunk`` (``study``) that fits, and the
change that shrinks the term (``[filter] structure = "per-target"`` for the joint
filter's expectations, fewer samples, a shorter horizon). XLA's own out-of-memory error,
should it still come, is one line too (:mod:`mjx_radar.engine.oom`).

Compile size: the packed Fisher information unrolls a loop over the N radars, the
CKF and the objective unroll over the M targets, and the MJX model holds N bodies
and every obstacle geom, so the program grows with ``N``, ``M`` and ``N·M``. A
program with ``N > 64``, ``M > 64``, ``N·M > 1024`` or more than 256 obstacles is
flagged large ("compiling a program this large can take minutes"). The compile-time
guess ``compile_s`` is a rough linear fit (tens of seconds for the bundled scenarios on a
CPU host, on the high side); it is printed so a long compile does not look like a hang.
"""

from __future__ import annotations

import dataclasses

from mjx_radar.engine import memory_model
from mjx_radar.engine.memory_available import (  # noqa: F401 (LIMIT_ENV, the GPU setting)
    LIMIT_ENV,
    allocate_gpu_memory_on_demand,
    capped,
    host_available,
    memory_limit,
)
from mjx_radar.engine.memory_available import device_available as _device_available
from mjx_radar.engine.memory_available import platform as _platform
from mjx_radar.engine.memory_model import FLOAT, MEASURED_FACTOR, float_bytes  # noqa: F401
from mjx_radar.engine.run_spec import ProgramSize, RunSpec
from mjx_radar.errors import InputError

KEEP = 32  # MPPI samples kept per control step (planners.records.N_KEEP_SAMPLES)
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


def device_terms(
    size: ProgramSize,
    trials: int,
    platform: str | None = None,
    kind: str = "all",
    full: bool = True,
    segment_steps: int | None = None,
) -> dict:
    """:func:`memory_model.device_terms` on ``platform`` (default: this process's device)."""
    plat = platform or _platform()
    return memory_model.device_terms(size, trials, plat, kind, full, segment_steps)


def estimate(
    spec: RunSpec,
    trials: int,
    steps: int,
    devices: int = 1,
    full: bool = True,
    kind: str = "all",
) -> Estimate:
    """Memory and compile size of ``trials`` closed-loop trials of ``steps`` filter steps.

    Args:
        spec: the run's :class:`~mjx_radar.engine.run_spec.RunSpec` (its sizes N, M,
            S, H, obstacles, rollout kind, filter; its clocks).
        trials: T, the batch size (split evenly over ``devices`` for the device terms).
        steps: K filter steps.
        devices: number of devices the batch is sharded over.
        full: trajectories are kept (``run``); False: only the metrics (``study``).
        kind: the program kind (:data:`mjx_radar.task.method.PROGRAM_KINDS`): ``"none"``
            compiles no planner, a study's shared program every method's.

    Returns:
        The :class:`Estimate` (available memory queried from this machine).
    """
    sz = spec.size
    n, m = sz.n_radars, sz.n_targets
    h, d = sz.horizon, 6 * sz.n_targets
    c = steps // sz.control_every
    n_obs = len(sz.obstacles)
    from mjx_radar.engine.runner import segment_periods  # the runner's segments

    seg = segment_periods(spec, steps) * sz.control_every
    per_device = -(-trials // max(1, devices))
    plat = _platform()
    device = device_terms(sz, per_device, plat, kind, full, seg)
    # a GPU's runtime floor: the device's peak above XLA's figure of a small program
    peak = memory_model.device_peak(sum(device.values()), plat)
    if peak > sum(device.values()):
        device["GPU runtime"] = peak - sum(device.values())
    per_step = 3 * d + 6 * n + 22 if full else 12
    per_control = 2 * n + 2 * h * n + 2 * KEEP * h * n + 2 * KEEP if full else 0
    traj = 2 * trials * (steps * per_step + c * per_control) * float_bytes()
    host = {"trajectories": traj}
    shared, dev_avail = _device_available()
    host_avail = host_available()
    if shared:
        dev_avail = host_avail
    dev_avail, host_avail = capped(dev_avail), capped(host_avail)
    # Rough linear fit of the compile time [s] in the program's unrolled size. Measured on
    # the 2-core CPU with the fused physics step (issue 27): smoke (size 4.2) 9.6-11.5 s,
    # paper_3r4t (7.6) 10.4 s, swarm_8r8t (19.2) 13.0 s; MJX and analytic rollouts now
    # compile alike (smoke analytic 13.0 s). The slope is kept from the earlier fit, so
    # that large, unmeasured programs are not promised a short compile.
    size = n + m + 0.05 * n * m + 0.25 * n_obs
    compile_s = 8.0 + 2.0 * size
    large = n > LARGE_N or m > LARGE_M or n * m > LARGE_NM or n_obs > LARGE_OBSTACLES
    summary = f"{n} radars x {m} targets, {sz.rollout} rollouts"
    return Estimate(device, host, dev_avail, host_avail, shared, compile_s, large, summary)


def check(
    spec: RunSpec,
    trials: int,
    steps: int,
    devices: int = 1,
    *,
    full: bool = True,
    batch_option: str = "--trials",
    kind: str = "all",
) -> Estimate:
    """:func:`estimate`, refusing a run whose arrays cannot fit in the available memory.

    Args:
        spec, trials, steps, devices, full, kind: as :func:`estimate`.
        batch_option: the option that sets the batch, named in the refusal
            (``"--trials"``, or ``"--chunk"``: trials per device).

    Raises:
        InputError: one line naming the dominant term, its size, the memory available,
            the largest ``batch_option`` that fits and the change that shrinks the term.
    """
    est = estimate(spec, trials, steps, devices, full, kind)
    need = est.device | est.host if est.shared else est.device
    avail = est.host_available if est.shared else est.device_available
    where = "in host RAM" if est.shared else "on the device"
    per_call = -(-trials // devices) if batch_option == "--chunk" else trials

    def fits(batch: int) -> bool:  # the batch in batch_option's unit
        t = batch * devices if batch_option == "--chunk" else batch
        e = estimate(spec, t, steps, devices, full, kind)
        ok = _fits(e.device | e.host if e.shared else e.device, avail)
        return ok and (e.shared or _fits(e.host, e.host_available))

    batch = f"{batch_option} {per_call}"
    if not _fits(need, avail):
        _refuse(spec, batch, need, avail, where, _largest(fits, per_call), kind)
    if not est.shared and not _fits(est.host, est.host_available):
        fit = _largest(fits, per_call)
        _refuse(spec, batch, est.host, est.host_available, "in host RAM", fit, kind)
    return est


def _fits(need: dict, avail: int | None) -> bool:
    return avail is None or sum(need.values()) <= avail


def _largest(fits, below: int) -> int:
    """The largest batch ``< below`` with ``fits(batch)`` (memory grows with the batch),
    0 if not even one trial fits."""
    lo, hi = 0, below  # fits(lo) (0: vacuously), not fits(hi)
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (mid, hi) if fits(mid) else (lo, mid)
    return lo


def _refuse(spec: RunSpec, batch: str, need: dict, avail: int, where: str, fit: int, kind: str):
    term = max(need, key=need.get)
    what, fix = _advice(spec.size, term, batch, need[term], kind)
    option = batch.split()[0]
    if fit:
        fix = f"{option} {fit} fits; or {fix}"
    else:
        fix = f"not even {option} 1 fits: {fix.replace(f' or {option}', '')}"
    verb = "need" if term.endswith("s") else "needs"
    raise InputError(
        f"{spec.name}: {what}: the {term} {verb} ~{fmt_bytes(need[term])} (all arrays "
        f"~{fmt_bytes(sum(need.values()))}), this machine has {fmt_bytes(avail)} free {where}; "
        f"{fix}"
    )


def _advice(sz: ProgramSize, term: str, batch: str, size: int, kind: str) -> tuple[str, str]:
    """``(the settings behind term, the change that shrinks it)`` for a refusal line."""
    s, h, m, joint = sz.samples, sz.horizon, sz.n_targets, sz.joint
    per_target = 'set [filter] structure = "per-target"'
    if term == "planner expectations":
        p = 12 * m if joint else 12
        what = (
            f"mppi.samples = {s}, mpc.horizon = {h}, {m} targets x {p} cubature points "
            f"({sz.structure} filter), {batch}"
        )
        fix = f"reduce mppi.samples, mpc.horizon or {batch.split()[0]}"
        if joint:
            alt = dataclasses.replace(sz, structure="per-target")
            ratio = device_terms(alt, 1, kind=kind)[term] / device_terms(sz, 1, kind=kind)[term]
            if ratio <= 1.0:  # not on a GPU's fused joint SFIM, which the bank would exceed
                fix = f"{per_target} (12 points per target: ~{fmt_bytes(size * ratio)}) or {fix}"
        return what, fix
    if term == "filter":
        what = f"{m} targets ({sz.structure} filter), {batch}"
        fix = f"reduce the number of targets or {batch.split()[0]}"
        return what, f"{per_target} or {fix}" if joint else fix
    if term == "MHT hypotheses":
        merge = sz.merge_pairs > 0
        what = f"tracker.hypotheses = {sz.hypotheses} of {sz.events} joint events each"
        what += f", label-free merging over {m}! target orders" if merge else ""
        fix = f"reduce tracker.hypotheses, tracker.candidates or {batch.split()[0]}"
        return f"{what}, {batch}", f"set tracker.merge_labels = false, or {fix}" if merge else fix
    if term == "line of sight":
        return f"{len(sz.obstacles)} obstacles, mppi.samples = {s}, {batch}", (
            f"reduce mppi.samples, mpc.horizon, the obstacles or {batch.split()[0]}"
        )
    if term == "trajectories":
        return batch, f"reduce --steps or {batch.split()[0]}"
    fix = f"reduce mppi.samples or {batch.split()[0]}"
    if term == "MJX rollouts":
        fix += ", or use --rollouts analytic"
    return f"mppi.samples = {s}, {batch}", fix


def fmt_bytes(b: float) -> str:
    """``1.5e9`` -> ``"1.4 GiB"``."""
    for unit in ("B", "KiB", "MiB", "GiB", "TiB"):
        if b < 1024 or unit == "TiB":
            return f"{b:.0f} {unit}" if unit == "B" else f"{b:.1f} {unit}"
        b /= 1024
    return f"{b:.1f} TiB"
