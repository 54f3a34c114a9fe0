"""The compiled programs of a scenario shape: built, compiled ahead of time, cached.

Two programs advance a batch of trials (:mod:`mjx_radar.loop.closed_loop`,
vmapped over trials; the runner compiles them for a one-device mesh per device and
drives each device from its own thread), per scenario shape and *program kind* (what
is compiled of the planner: :data:`mjx_radar.task.method.PROGRAM_KINDS`):

* ``init(trials, *params) -> (*carry, ok)``
* ``step(*params, *carry) -> (*carry, *records)`` (the period index rides in the carry)

in a *flat* signature (arrays only): the host never looks inside the loop state, and
the programs can be exported (:mod:`jax.export`) without custom pytree serialisation.
Every device runs the same single-device program on its slice of the trials, so a
trial's numbers do not depend on the device count.

Two caches make start-up fast: JAX's persistent compilation cache (XLA's work, see
:mod:`mjx_radar.engine.compile_cache`) and, beside it, this module's *export
cache*: the traced and lowered program (StableHLO) keyed by the scenario shape and a
fingerprint of the package's code and the JAX/MuJoCo versions, so a warm start skips
Python tracing of the MJX step, the objective and the scans altogether.
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import threading
import time
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import Mesh, NamedSharding

from mjx_radar import precision
from mjx_radar.engine import compile_cache, executable_cache, export_cache, trace_queue
from mjx_radar.engine.export_cache import SPLIT, WHOLE
from mjx_radar.engine.live_programs import LiveCache
from mjx_radar.env import records
from mjx_radar.planners import records as plan_records
from mjx_radar.registry import ASSOCIATORS, PLANNERS, SENSORS, TRACKERS
from mjx_radar.rundir import results
from mjx_radar.task import cost_plugins
from mjx_radar.task.method import parse_method


@dataclasses.dataclass(frozen=True, eq=False)
class Programs:
    """Compiled ``init`` and ``step`` of one shape, batch and mesh."""

    init: object
    step: object
    n_params: int
    n_carry: int
    full: bool
    masks: bool
    trial_sharding: NamedSharding
    replicated: NamedSharding
    source: str  # "traced" | "traced directly" | "export cache" | "executable cache"


def device_mesh(devices=None) -> Mesh:
    """A 1-D mesh (axis ``"trial"``) over ``devices`` (default: every local device)."""
    return Mesh(np.asarray(devices if devices is not None else jax.local_devices()), ("trial",))


def record_template(full: bool, masks: bool = False):
    """Pytree of the per-segment records (leaf values are placeholders; the per-pair
    masks, :data:`~mjx_radar.env.records.MASK_FIELDS`, are ``None`` unless ``masks``)."""
    if full:
        steps = records.StepRecord(*[0] * len(records.StepRecord._fields))
        if not masks:
            steps = steps._replace(**dict.fromkeys(records.MASK_FIELDS))
        return steps, plan_records.TEMPLATE
    return {k: 0 for k in results.LOOP_COLUMNS + records.SET_KEYS}, None


def _variant(planner: str = "mppi") -> tuple:
    """What else a traced program depends on: x64, pinned precision, registered cost terms,
    the planner (and a registered planner's code)."""
    return (
        bool(jax.config.jax_enable_x64),
        precision.describe(),
        cost_plugins.registry_key(),
        planner,
        PLANNERS.key((planner,)),
        TRACKERS.key(),
        ASSOCIATORS.key(),
        SENSORS.key(),
    )


def _key(shape, periods, full, batch, mesh, kind, planner="mppi", masks=False) -> str:
    dev = mesh.devices.flat[0]
    parts = [
        repr(shape),
        periods,
        full,
        batch,
        mesh.size,
        dev.platform,
        dev.device_kind,
        kind,
        *_variant(planner),
        compile_cache.code_fingerprint(),
    ]
    if masks:
        parts.append("masks")
    for obs in shape.obstacles:  # mesh files: their content, not only their path
        if obs.path and Path(obs.path).exists():
            parts.append(hashlib.sha256(Path(obs.path).read_bytes()).hexdigest())
    return hashlib.sha256(repr(parts).encode()).hexdigest()[:32]


_CACHE = LiveCache()  # at most a few programs alive (engine.live_programs)
_LOCK = threading.Lock()
#: one entry per compiled program: tracing + lowering vs XLA compilation (or cache load) [s]
COMPILE_LOG: list[dict] = []


def _lower(path, trace_args, lower_args, ticket: int):
    """``(init, step, source, seconds queued)`` lowered from the export cache or, failing
    that, traced (:func:`mjx_radar.engine.program_trace.trace` of ``trace_args``) and
    lowered in ``ticket``'s turn of :data:`mjx_radar.engine.trace_queue.QUEUE`, then
    exported to ``path``; ``source`` "traced directly" when JAX cannot export them.
    ``lower_args``: ``(trials, p_specs, mesh)``, the programs' input specs."""
    exported = export_cache.load(path) if path else None
    if exported is not None:
        return *export_cache.lower(exported, *lower_args), "export cache", 0.0
    from mjx_radar.engine import program_trace  # the task, its plants and MJX: only here

    trials, p_specs, _ = lower_args
    t0 = time.perf_counter()
    with trace_queue.QUEUE.turn(ticket):  # lowering is Python too: the turn holds it
        queued = time.perf_counter() - t0
        init_l, step_l, exported = program_trace.trace(*trace_args, trials, p_specs)
        if exported is None:
            return init_l, step_l, "traced directly", queued
        init_l, step_l = export_cache.lower(exported, *lower_args)
    if path:
        export_cache.save(path, exported)
    return init_l, step_l, "traced", queued


def compile_programs(
    spec,
    batch: int,
    periods: int,
    full: bool = False,
    mesh=None,
    kind: str = "all",
    planner: str = "mppi",
    masks: bool = False,
):
    """Ahead-of-time compiled :class:`Programs` of a scenario's shape; ``(programs, seconds)``.

    Args:
        spec: the run's :class:`~mjx_radar.engine.run_spec.RunSpec` (only its shape
            matters).
        batch: trials per call, a multiple of the mesh's device count.
        periods: control periods per segment.
        full: return trajectories (else metrics only).
        mesh: devices to spread the trials over (default: the default device).
        kind: what is compiled of the planner (:data:`mjx_radar.task.method.PROGRAM_KINDS`):
            a method's ``kind`` (``"none"``, ``"sfim"``, ``"pfim"``: that method and the
            other noise model's) or ``"all"`` (every method).
        planner: the registered planner that drives the loop (:mod:`mjx_radar.planners`).
        masks: with ``full``, also return the per-pair line-of-sight and detection masks
            (``visible`` / ``detected`` ``[N, M]`` per step).

    Seconds are 0 when this process compiled them before. Programs asked for side by
    side are traced one at a time, in the order asked (:mod:`mjx_radar.engine.trace_queue`).
    """
    ticket = trace_queue.QUEUE.draw()
    try:
        return _compile(spec, batch, periods, full, mesh, kind, planner, masks, ticket)
    finally:
        trace_queue.QUEUE.finish(ticket)


def _compile(spec, batch, periods, full, mesh, kind, planner, masks, ticket):
    mesh = mesh if mesh is not None else device_mesh(jax.local_devices()[:1])
    if batch % mesh.size:
        raise ValueError(f"batch {batch} is not a multiple of {mesh.size} devices")
    shape = spec.shape
    PLANNERS.get(planner)  # an unknown name: one line before anything is traced
    masks = bool(full and masks)
    mem_key = (shape, periods, full, batch, mesh, kind, *_variant(planner), masks)
    with _LOCK:
        if mem_key in _CACHE:
            return _CACHE[mem_key], 0.0
    t0 = time.perf_counter()
    params = spec.params(parse_method("stationary"))
    p_leaves = jax.tree.leaves(params)
    trial_sh, rep = NamedSharding(mesh, SPLIT), NamedSharding(mesh, WHOLE)
    struct = lambda x, sh: jax.ShapeDtypeStruct(jnp.shape(x), jnp.result_type(x), sharding=sh)  # noqa: E731
    trials = jax.ShapeDtypeStruct((batch,), jnp.int32, sharding=trial_sh)
    p_specs = [struct(x, rep) for x in p_leaves]
    store = compile_cache.program_dir()
    key = _key(shape, periods, full, batch, mesh, kind, planner, masks)
    path = store / f"loop-{key}.jaxexport" if store else None
    # one process compiles a program for a device; the others wait, then load it (per
    # device: a host's GPUs load one compilation side by side, CPU devices compile apart)
    lock = store / f"loop-{key}-d{mesh.devices.flat[0].id}.lock" if store else None
    devices = list(mesh.devices.flat)
    exe = executable_cache.path(store, key, devices[0])
    t_lock = time.perf_counter()
    with contextlib.ExitStack() as held:
        held.enter_context(compile_cache.program_lock(lock))
        waited = time.perf_counter() - t_lock
        t1 = time.perf_counter()
        if any(f is not None and f.exists() for f in (exe, path)):
            trace_queue.QUEUE.finish(ticket)  # loaded, not traced: nobody waits for it
        compiled = executable_cache.load(exe, devices)  # no lowering at all
        source, queued = "executable cache", 0.0
        if compiled is None:
            trace_args = (shape, kind, planner, params, batch, periods, full, mesh, masks)
            lower_args = (trials, p_specs, mesh)
            init_l, step_l, source, queued = _lower(path, trace_args, lower_args, ticket)
            t1 = time.perf_counter()
            compiled, worth = executable_cache.compile_all((init_l, step_l))
            if worth:  # written in the background, the lock released after it
                executable_cache.save_later(exe, compiled, held.pop_all())
    init_c, step_c = compiled
    n_carry = init_c.out_tree.num_leaves - 1  # init returns (*carry, ok)
    progs = Programs(init_c, step_c, len(p_leaves), n_carry, full, masks, trial_sh, rep, source)
    t2 = time.perf_counter()
    with _LOCK:
        _CACHE[mem_key] = progs
        COMPILE_LOG.append(
            {
                "scenario": spec.name,
                "n_radars": spec.size.n_radars,
                "n_targets": spec.size.n_targets,
                "batch": batch,
                "devices": mesh.size,
                "kind": kind,
                "periods": periods,
                "full": full,
                "planner": planner,
                "key": key[:12],
                "source": source,
                "lock_wait_s": waited,  # another process compiling this program
                "trace_wait_s": queued,  # this process tracing another program
                "trace_lower_s": t1 - t0 - waited - queued,
                "xla_compile_s": t2 - t1,
            }
        )
    return progs, t2 - t0
