"""The compiled programs of a scenario shape: built, compiled ahead of time, cached.

Two programs advance a batch of trials (:mod:`mjx_radar.env.closed_loop`,
vmapped over trials; the runner compiles them for a one-device mesh per device and
drives each device from its own thread), per scenario shape and *program kind* (what
is compiled of the planner: :data:`mjx_radar.task.method.PROGRAM_KINDS`):

* ``init(trials, *params) -> (*carry, ok)``
* ``step(trials, start, *params, *carry) -> (*carry, *records)``

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

import dataclasses
import hashlib
import os
import threading
import time
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import Mesh, NamedSharding, PartitionSpec

from mjx_radar import precision
from mjx_radar.engine import compile_cache
from mjx_radar.engine.threads import parallel
from mjx_radar.env import records
from mjx_radar.rundir import results
from mjx_radar.task import costs
from mjx_radar.task.method import parse_method
from mjx_radar.task.params import shape_key, task_params

SPLIT, WHOLE = PartitionSpec("trial"), PartitionSpec()


@dataclasses.dataclass(frozen=True, eq=False)
class Programs:
    """Compiled ``init`` and ``step`` of one shape, batch and mesh."""

    init: object
    step: object
    n_params: int
    n_carry: int
    full: bool
    trial_sharding: NamedSharding
    replicated: NamedSharding
    source: str  # "traced" | "export cache"


def device_mesh(devices=None) -> Mesh:
    """A 1-D mesh (axis ``"trial"``) over ``devices`` (default: every local device)."""
    return Mesh(np.asarray(devices if devices is not None else jax.local_devices()), ("trial",))


def record_template(full: bool):
    """Pytree of the per-segment records (leaf values are placeholders)."""
    if full:
        steps = records.StepRecord(*[0] * len(records.StepRecord._fields))
        return steps, records.ControlRecord(*[0] * len(records.ControlRecord._fields))
    return {k: 0 for k in results.METRIC_COLUMNS}, None


def _traced(task, periods: int, full: bool, mesh: Mesh, n_params: int, params_tree, c_shapes):
    """The flat, shard_mapped, jitted ``init`` and ``step`` (traced when lowered).

    ``c_shapes`` are the per-trial loop-state leaves (``jax.ShapeDtypeStruct``). Empty
    leaves (size 0, e.g. MJX's contact arrays of a contact-free plant) never cross the
    program boundary: they are rebuilt inside (sharding zero-size arrays over several
    GPUs crashed XLA's compiler).
    """
    from mjx_radar.env import closed_loop  # the loop (and MJX): only when tracing

    carry_tree = jax.tree.structure(c_shapes)
    shapes = jax.tree.leaves(c_shapes)
    live = [x.size > 0 for x in shapes]

    def init_flat(trial, *p):
        carry, ok = closed_loop.init_carry(task, jax.tree.unflatten(params_tree, p), trial)
        leaves = jax.tree.leaves(carry)
        return (*[x for x, keep in zip(leaves, live, strict=True) if keep], ok)

    def step_flat(trial, start, *rest):
        params = jax.tree.unflatten(params_tree, rest[:n_params])
        given = iter(rest[n_params:])
        leaves = [
            next(given) if keep else jnp.zeros(s.shape, s.dtype)
            for s, keep in zip(shapes, live, strict=True)
        ]
        carry = jax.tree.unflatten(carry_tree, leaves)
        carry, steps, controls = closed_loop.advance(task, params, trial, carry, start, periods)
        if not full:
            steps = {k: getattr(steps, k) for k in results.METRIC_COLUMNS}
            controls = None
        out = [x for x, keep in zip(jax.tree.leaves(carry), live, strict=True) if keep]
        return (*out, *jax.tree.leaves((steps, controls)))

    n_carry = sum(live)
    init = jax.shard_map(
        jax.vmap(init_flat, in_axes=(0,) + (None,) * n_params),
        mesh=mesh,
        in_specs=(SPLIT,) + (WHOLE,) * n_params,
        out_specs=SPLIT,
        check_vma=False,
    )
    step = jax.shard_map(
        jax.vmap(step_flat, in_axes=(0, None) + (None,) * n_params + (0,) * n_carry),
        mesh=mesh,
        in_specs=(SPLIT, WHOLE) + (WHOLE,) * n_params + (SPLIT,) * n_carry,
        out_specs=SPLIT,
        check_vma=False,
    )
    donate = tuple(range(2 + n_params, 2 + n_params + n_carry))
    return jax.jit(init), jax.jit(step, donate_argnums=donate)


def _variant() -> tuple:
    """What else a traced program depends on: x64, pinned precision, registered cost terms."""
    return bool(jax.config.jax_enable_x64), precision.describe(), costs.registry_key()


def _key(shape, periods, full, batch, mesh, kind) -> str:
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
        *_variant(),
        compile_cache.code_fingerprint(),
    ]
    for obs in shape.obstacles:  # mesh files: their content, not only their path
        if obs.path and Path(obs.path).exists():
            parts.append(hashlib.sha256(Path(obs.path).read_bytes()).hexdigest())
    return hashlib.sha256(repr(parts).encode()).hexdigest()[:32]


_CACHE: dict = {}
_LOCK = threading.Lock()
#: one entry per compiled program: tracing + lowering vs XLA compilation (or cache load) [s]
COMPILE_LOG: list[dict] = []


def compile_programs(
    scenario, batch: int, periods: int, full: bool = False, mesh=None, kind: str = "all"
):
    """Ahead-of-time compiled :class:`Programs` of a scenario's shape; ``(programs, seconds)``.

    Args:
        scenario: the scenario (only its shape matters).
        batch: trials per call, a multiple of the mesh's device count.
        periods: control periods per segment.
        full: return trajectories (else metrics only).
        mesh: devices to spread the trials over (default: the default device).
        kind: what is compiled of the planner (:data:`mjx_radar.task.method.PROGRAM_KINDS`):
            a method's ``kind`` (``"none"``, ``"sfim"``, ``"pfim"``: that method and the
            other noise model's) or ``"all"`` (every method).

    Seconds are 0 when this process compiled them before.
    """
    mesh = mesh if mesh is not None else device_mesh(jax.local_devices()[:1])
    if batch % mesh.size:
        raise ValueError(f"batch {batch} is not a multiple of {mesh.size} devices")
    shape = shape_key(scenario)
    mem_key = (shape, periods, full, batch, mesh, kind, *_variant())
    with _LOCK:
        if mem_key in _CACHE:
            return _CACHE[mem_key], 0.0
    t0 = time.perf_counter()
    params = task_params(scenario, parse_method("stationary"))
    p_leaves, params_tree = jax.tree.flatten(params)
    trial_sh, rep = NamedSharding(mesh, SPLIT), NamedSharding(mesh, WHOLE)
    spec = lambda x, sh: jax.ShapeDtypeStruct(jnp.shape(x), jnp.result_type(x), sharding=sh)  # noqa: E731
    trials = jax.ShapeDtypeStruct((batch,), jnp.int32, sharding=trial_sh)
    start = jax.ShapeDtypeStruct((), jnp.int32, sharding=rep)
    p_specs = [spec(x, rep) for x in p_leaves]
    store = compile_cache.program_dir()
    key = _key(shape, periods, full, batch, mesh, kind)
    path = store / f"loop-{key}.jaxexport" if store else None
    exported = _load(path) if path else None
    source = "export cache" if exported else "traced"
    if exported is None:  # trace: the task, its plants and MJX are built only here
        from mjx_radar.env import closed_loop
        from mjx_radar.task.task import make_task

        task = make_task(shape, kind)
        carry_shapes = jax.eval_shape(
            lambda t, p: closed_loop.init_carry(task, p, t)[0],
            jax.ShapeDtypeStruct((), jnp.int32),
            params,
        )
        c_specs = [
            jax.ShapeDtypeStruct((batch, *x.shape), x.dtype, sharding=trial_sh)
            for x in jax.tree.leaves(carry_shapes)
            if x.size > 0
        ]
        init, step = _traced(task, periods, full, mesh, len(p_leaves), params_tree, carry_shapes)
        exported = None
        if os.environ.get("MJX_RADAR_EXPORT", "1") != "0":  # 0: skip jax.export (debugging)
            exported = _export(init, step, (trials, *p_specs), (trials, start, *p_specs, *c_specs))
        if exported is None:  # not exportable: compile the traced programs directly
            init_l = init.lower(trials, *p_specs)
            step_l = step.lower(trials, start, *p_specs, *c_specs)
        elif path:
            _save(path, exported)
    if exported is not None:
        init_l, step_l = _lower(exported, trials, start, p_specs, mesh)
    n_carry = len(init_l.out_info) - 1  # init returns (*carry, ok)
    t1 = time.perf_counter()
    init_c, step_c = parallel([init_l.compile, step_l.compile])  # XLA releases the GIL
    progs = Programs(init_c, step_c, len(p_leaves), n_carry, full, trial_sh, rep, source)
    t2 = time.perf_counter()
    with _LOCK:
        _CACHE[mem_key] = progs
        COMPILE_LOG.append(
            {
                "n_radars": scenario.n_radars,
                "n_targets": scenario.n_targets,
                "batch": batch,
                "devices": mesh.size,
                "kind": kind,
                "source": source,
                "trace_lower_s": t1 - t0,
                "xla_compile_s": t2 - t1,
            }
        )
    return progs, t2 - t0


def _export(init, step, init_args, step_args):
    """Both programs traced once into :class:`jax.export.Exported` form (None if impossible)."""
    try:
        return tuple(jax.export.export(f)(*a) for f, a in ((init, init_args), (step, step_args)))
    except Exception:  # noqa: BLE001 -- an unexportable program still runs, traced directly
        return None


def _save(path: Path, exported) -> None:
    """Serialises both programs beside the compilation cache (best effort)."""
    from mjx_radar.io.atomic import atomic_write_bytes

    try:
        blobs = [e.serialize() for e in exported]
        atomic_write_bytes(path, len(blobs[0]).to_bytes(8, "little") + blobs[0] + blobs[1])
    except (OSError, ImportError, ValueError):
        return


def _load(path: Path):
    """Both :class:`jax.export.Exported` programs from the cache, or None."""
    try:
        raw = path.read_bytes()
        n = int.from_bytes(raw[:8], "little")
        return jax.export.deserialize(bytearray(raw[8 : 8 + n])), jax.export.deserialize(
            bytearray(raw[8 + n :])
        )
    except Exception:  # noqa: BLE001 -- missing, stale or damaged entry: trace again
        return None


def _lower(exported, trials, start, p_specs, mesh):
    """``(init, step)`` lowered from exported programs (no Python tracing of the loop)."""
    e_init, e_step = exported
    n_params = len(p_specs)
    c_specs = [
        jax.ShapeDtypeStruct(a.shape, a.dtype, sharding=NamedSharding(mesh, SPLIT))
        for a in e_step.in_avals[2 + n_params :]
    ]
    donate = tuple(range(2 + n_params, 2 + n_params + len(c_specs)))
    init = jax.jit(e_init.call).lower(trials, *p_specs)
    step = jax.jit(e_step.call, donate_argnums=donate).lower(trials, start, *p_specs, *c_specs)
    return init, step
