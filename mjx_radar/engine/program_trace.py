"""Tracing a shape's two closed-loop programs (:mod:`mjx_radar.engine.programs`).

:func:`init_program` and :func:`step_program` wrap
:func:`mjx_radar.loop.closed_loop.init_carry` and
:func:`~mjx_radar.loop.closed_loop.advance` into the flat (arrays only), vmapped,
shard_mapped and jitted ``init`` and ``step``; :func:`trace` traces them for one batch
and mesh into :mod:`jax.export` form (or lowers them where they cannot be exported),
``init`` first: its trace gives the loop state's shapes that ``step`` takes.
Imported only when a program is traced: a warm start (export cache) imports no MJX.

A device that runs one trial (``mjx-radar run``'s default, a study's ``--chunk 1``) gets
the loop itself with a leading axis of one, not a ``vmap`` of size one: JAX traces a
vmapped loop's bodies once and batches them a second time, and XLA then compiles batch
dimensions of size one. The single-trial program traces in about a quarter less time
and compiles about a tenth faster (docs/notes/scaling-history.md). Like every batch
size's program it has its own float32 round-off: a trial's numbers depend on the
per-device batch size, never on its batch mates (docs/scaling.md, "Why the numbers do
not depend on the device count").
"""

from __future__ import annotations

import contextlib
import os

import jax
import jax.numpy as jnp
from jax.sharding import Mesh, NamedSharding

from mjx_radar.engine import export_cache
from mjx_radar.engine.export_cache import SPLIT, WHOLE
from mjx_radar.env import records
from mjx_radar.loop import closed_loop
from mjx_radar.rundir import results
from mjx_radar.task.task import make_task


def init_program(
    task, mesh: Mesh, n_params: int, params_tree, planner="mppi", single=False, seen=None
):
    """The flat, shard_mapped, jitted ``init`` (traced when lowered or exported).

    It returns the non-empty per-trial loop-state leaves and the placement flag. Empty
    leaves (size 0, e.g. MJX's contact arrays of a contact-free plant) never cross the
    program boundary (:func:`step_program` rebuilds them). ``seen``, a list, gets the
    per-trial loop state's shapes (``jax.ShapeDtypeStruct`` leaves) each time ``init`` is
    traced: :func:`step_program` needs them, and tracing the loop's start a second time
    for its shapes alone (``jax.eval_shape``) cost a tenth of a study program's tracing.
    """

    def init_flat(trial, *p):
        params = jax.tree.unflatten(params_tree, p)
        carry, ok = closed_loop.init_carry(task, params, trial, planner)
        if seen is not None:
            seen.append(jax.tree.map(lambda x: jax.ShapeDtypeStruct(x.shape, x.dtype), carry))
        return (*[x for x in jax.tree.leaves(carry) if x.size > 0], ok)

    if single:  # the loop itself: no vmap of size one (module docstring)

        def init_device(trial, *p):
            return tuple(x[None] for x in init_flat(trial[0], *p))

    else:
        init_device = jax.vmap(init_flat, in_axes=(0,) + (None,) * n_params)
    init = jax.shard_map(
        init_device,
        mesh=mesh,
        in_specs=(SPLIT,) + (WHOLE,) * n_params,
        out_specs=SPLIT,
        check_vma=False,
    )
    return jax.jit(init)


def step_program(
    task,
    periods: int,
    full: bool,
    mesh: Mesh,
    n_params: int,
    params_tree,
    c_shapes,
    planner: str = "mppi",
    masks: bool = False,
    single: bool = False,
):
    """The flat, shard_mapped, jitted ``step`` (traced when lowered or exported).

    ``c_shapes`` are the per-trial loop-state leaves (``jax.ShapeDtypeStruct``). Empty
    leaves never cross the program boundary: they are rebuilt inside (sharding
    zero-size arrays over several GPUs crashed XLA's compiler). ``single``: each device
    runs one trial, and the per-device program is the unbatched loop with a leading
    axis of one (module docstring); else a ``vmap`` over the device's trials.
    """
    carry_tree = jax.tree.structure(c_shapes)
    shapes = jax.tree.leaves(c_shapes)
    live = [x.size > 0 for x in shapes]

    def step_flat(*rest):
        params = jax.tree.unflatten(params_tree, rest[:n_params])
        given = iter(rest[n_params:])
        leaves = [
            next(given) if keep else jnp.zeros(s.shape, s.dtype)
            for s, keep in zip(shapes, live, strict=True)
        ]
        carry = jax.tree.unflatten(carry_tree, leaves)
        carry, steps, controls = closed_loop.advance(task, params, carry, periods, planner)
        if not full:
            sets = records.estimate_sets(
                steps.target, steps.track_pos, steps.track_exist, steps.present
            )
            steps = {k: getattr(steps, k) for k in results.LOOP_COLUMNS} | sets
            controls = None
        elif not masks:  # not outputs: XLA drops their computation (the same program)
            steps = steps._replace(**dict.fromkeys(records.MASK_FIELDS))
        out = [x for x, keep in zip(jax.tree.leaves(carry), live, strict=True) if keep]
        return (*out, *jax.tree.leaves((steps, controls)))

    n_carry = sum(live)
    if single:  # the loop itself: no vmap of size one (module docstring)

        def step_device(*rest):
            carry = [x[0] for x in rest[n_params:]]
            return tuple(x[None] for x in step_flat(*rest[:n_params], *carry))

    else:
        shared = [s for s, keep in zip(_shared_leaves(c_shapes), live, strict=True) if keep]
        axes = (None,) * n_params + tuple(None if s else 0 for s in shared)
        batched = jax.vmap(step_flat, in_axes=axes)

        def step_device(*rest):  # a shared leaf: the first trial's value, unbatched
            given = [x[0] if s else x for x, s in zip(rest[n_params:], shared, strict=True)]
            return batched(*rest[:n_params], *given)

    step = jax.shard_map(
        step_device,
        mesh=mesh,
        in_specs=(WHOLE,) * n_params + (SPLIT,) * n_carry,
        out_specs=SPLIT,
        check_vma=False,
    )
    donate = tuple(range(n_params, n_params + n_carry))
    return jax.jit(step, donate_argnums=donate)


#: the loop state's control-period index (``LoopCarry.state.info["period"]``); a leaf of the
#: planner's own carry with that key is per trial
PERIOD = ".state.info['period']"
#: the class attribute by which a NamedTuple of the loop state (a tracker's modes) names
#: its fields that every trial of a batch holds in common (``HypState``: ``("scans",)``)
BATCH_SHARED = "BATCH_SHARED"


def _declares(node) -> bool:
    return isinstance(getattr(type(node), BATCH_SHARED, None), tuple)


def _shared_leaves(c_shapes) -> list[bool]:
    """Per loop-state leaf: whether every trial of a batch holds the same value -- the
    control period's index (``state.info["period"]``: a batch's trials advance together)
    and the fields that a NamedTuple of the state names in its ``BATCH_SHARED`` (the MHT's
    scan counter, which follows the period: ``mht.HypState``).

    The step program hands them to the vmapped loop unbatched, so what depends on the
    period alone stays unbatched: a ``lax.cond`` on it (the MHT's branching and settled
    scans, :func:`mjx_radar.estimation.data_association.mht.update_bank`, and its settled
    time update, :func:`mjx_radar.estimation.data_association.mht.predict`) stays a branch
    instead of a ``select`` that computes both sides for every trial at every step. The
    values are the same either way, provided the state's owner keeps its declared fields
    equal across trials (the MHT: ``FilterOps.keep``)."""

    def mark(path, node):
        if _declares(node):  # its declared fields' leaves, True
            named = getattr(type(node), BATCH_SHARED)
            return node._replace(
                **{
                    f: jax.tree.map(lambda _, f=f: f in named, getattr(node, f))
                    for f in node._fields
                }
            )
        return jax.tree_util.keystr(path) == PERIOD

    marked = jax.tree_util.tree_map_with_path(mark, c_shapes, is_leaf=_declares)
    return jax.tree.leaves(marked)


def flat_programs(task, periods, full, mesh, n_params, tree, c_shapes, planner="mppi", **kw):
    """``(init, step)``: :func:`init_program` and :func:`step_program` (``c_shapes``:
    the per-trial loop-state leaves, ``jax.ShapeDtypeStruct``; ``kw``: ``masks``,
    ``single``)."""
    init = init_program(task, mesh, n_params, tree, planner, kw.get("single", False))
    step = step_program(task, periods, full, mesh, n_params, tree, c_shapes, planner, **kw)
    return init, step


def short_locations():
    """A context in which JAX gives each lowered operation one source line, not its whole
    Python traceback (up to 100 frames: vmaps, scans and closures nest deeply here).

    The tracebacks travel as metadata into XLA's program, and XLA's GPU executable turns
    every instruction's into a profiler annotation (merging and printing the stacks)
    each time it is built or loaded from a cache: most of the 2 s an H100 took to load a
    paper shape's step program. The metadata is not code: the executable computes the same.
    """
    from jax._src import config  # the option has no public context manager

    state = getattr(config, "include_full_tracebacks_in_locations", None)
    return state(False) if state is not None else contextlib.nullcontext()


def trace(shape, kind, planner, params, batch, periods, full, mesh, masks, trials, p_specs):
    """Traces both programs: ``(init, step, exported)`` lowered, or ``exported`` alone
    (``init``/``step`` None) when :mod:`jax.export` can take them."""
    with short_locations():
        return _trace(
            shape, kind, planner, params, batch, periods, full, mesh, masks, trials, p_specs
        )


def _trace(shape, kind, planner, params, batch, periods, full, mesh, masks, trials, p_specs):
    task = make_task(shape, kind)
    tree = jax.tree.structure(params)
    single = batch // mesh.size == 1  # one trial per device
    seen = []  # the loop state's shapes, from init's trace (init_program)
    init = init_program(task, mesh, len(p_specs), tree, planner, single, seen)
    exportable = os.environ.get("MJX_RADAR_EXPORT", "1") != "0"  # 0: skip jax.export
    e_init = export_cache.export_one(init, (trials, *p_specs)) if exportable else None
    init_l = None if e_init is not None else init.lower(trials, *p_specs)
    carry_shapes = seen[-1]
    trial_sh = NamedSharding(mesh, SPLIT)
    c_specs = [
        jax.ShapeDtypeStruct((batch, *x.shape), x.dtype, sharding=trial_sh)
        for x in jax.tree.leaves(carry_shapes)
        if x.size > 0
    ]
    step = step_program(
        task, periods, full, mesh, len(p_specs), tree, carry_shapes, planner, masks, single
    )
    e_step = export_cache.export_one(step, (*p_specs, *c_specs)) if e_init is not None else None
    if e_step is not None:
        return None, None, (e_init, e_step)
    # not exportable: compile the traced programs directly
    init_l = init_l if init_l is not None else init.lower(trials, *p_specs)
    return init_l, step.lower(*p_specs, *c_specs), None
