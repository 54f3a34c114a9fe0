"""The placement check's program kept on disk beside the loop's.

A study (every shape, before its first round) and ``mjx-radar validate`` check that each
trial can place its radars (:func:`mjx_radar.env.placement.check_placeable`; a single run
refuses from its trials' own initial conditions instead, before the first step, and
compiles no program for the check: :func:`mjx_radar.engine.runner.run_trials`, 1.0-1.6 s
of a cold quick start on two cores where the check's compilation competed with the
loop's). That check is a
small program of its own (rejection sampling of the radars, vmapped over the trials),
and a warm process used to trace, lower and look it up in JAX's cache every time: about
half a second of a warm ``mjx-radar run`` on the CPU. Here it is compiled once per shape
and trial count (padded to a power of two) and kept as an executable
(:mod:`mjx_radar.engine.executable_cache`, ``place-*.bin`` in ``<cache>/programs``).
"""

from __future__ import annotations

import functools
import hashlib

import jax
import jax.numpy as jnp
import numpy as np

from mjx_radar.engine import compile_cache, executable_cache, trace_queue
from mjx_radar.env import placement
from mjx_radar.errors import InputError


def check_placeable(spec, seed: int, trials) -> None:
    """The check of :func:`mjx_radar.env.placement.check_placeable` for the run ``spec``
    (:class:`~mjx_radar.engine.run_spec.RunSpec`) with the program cached on disk, its
    refusal as the user's error (``study``, ``run_study`` and ``validate``).

    ``trials``: a count (trials ``0..trials-1``) or the trial indices themselves (only
    those are drawn). It first waits until no loop program is being traced in this
    process (a study's programs start before the check, :mod:`mjx_radar.engine.trace_queue`):
    tracing holds the GIL, so the check's own small program is traced while XLA compiles
    theirs.

    Raises:
        InputError: a trial cannot place its radars (one line naming the fields).
    """
    from mjx_radar.task.method import METHODS

    trace_queue.QUEUE.wait_idle()
    try:
        params = spec.params(METHODS["stationary"], seed)
    except ValueError as err:
        raise InputError(str(err)) from None
    ids = np.arange(trials) if np.ndim(trials) == 0 else np.unique(np.asarray(trials))
    if not len(ids):  # no trial: nothing to place
        return
    size = max(8, 1 << int(len(ids) - 1).bit_length())  # padded: few distinct programs
    padded = np.concatenate([ids, np.full(size - len(ids), ids[0])])
    oks = np.asarray(_program(spec.shape)(params, jnp.asarray(padded)))[: len(ids)]
    if not oks.all():
        raise InputError(spec.refusal(int(ids[np.argmin(oks)])))


@functools.lru_cache(maxsize=32)
def _program(shape):
    """``f(params, ids) -> ok [len(ids)]`` for one shape: compiled per trial count,
    loaded from the executable cache when XLA compiled it before."""
    jitted = placement.placeable_program(shape)
    compiled: dict = {}

    def run(params, ids):
        leaves, tree = jax.tree.flatten(params)
        sig = (ids.shape, str(tree), tuple((jnp.shape(x), jnp.result_type(x)) for x in leaves))
        if sig not in compiled:
            compiled[sig] = _load_or_compile(shape, jitted, tree, ids, leaves, sig)
        return compiled[sig](ids, *leaves)[0]

    return run


def _load_or_compile(shape, jitted, tree, ids, leaves, sig):
    """The flat program ``(ids, *leaves) -> (ok,)``: from the executable cache, or
    compiled here (and written there when XLA compiled it)."""
    # this process's device: under jax.distributed, jax.devices()[0] belongs to process 0
    # (another process loaded the check's program onto it and could not read the result)
    device = jax.local_devices()[0]
    store = compile_cache.program_dir()
    parts = [repr(shape), sig, bool(jax.config.jax_enable_x64), compile_cache.code_fingerprint()]
    key = hashlib.sha256(repr(parts).encode()).hexdigest()[:32]
    file = executable_cache.path(store, key, device, prefix="place")
    loaded = executable_cache.load(file, [device])
    if loaded is not None:
        return loaded[0]

    def flat(ids, *leaves):
        return (jitted(jax.tree.unflatten(tree, leaves), ids),)

    specs = [jax.ShapeDtypeStruct(jnp.shape(x), jnp.result_type(x)) for x in (ids, *leaves)]
    (program,), _ = executable_cache.compile_and_save(file, (jax.jit(flat).lower(*specs),))
    return program
