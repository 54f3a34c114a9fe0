"""XLA's out-of-memory error at the engine's boundary: one line, never a traceback.

The memory check (:mod:`mjx_radar.engine.resources`) refuses what its model says cannot
fit, before compiling. Should XLA still run out of memory (a model that misjudged a new
shape, another process taking the device, a custom planner's arrays), the
``RESOURCE_EXHAUSTED`` ``JaxRuntimeError`` raised while compiling or running a batch
becomes an :class:`~mjx_radar.errors.InputError` naming the batch per device and what to
reduce, which the command line prints on one line (exit 2) and the API raises.
"""

from __future__ import annotations

import functools
from typing import TYPE_CHECKING

from mjx_radar.errors import InputError

if TYPE_CHECKING:
    from mjx_radar.engine.run_spec import RunSpec


def out_of_memory(err: BaseException) -> bool:
    """Whether ``err`` is XLA running out of memory (``RESOURCE_EXHAUSTED``, on a GPU or the
    CPU, at compilation or at run time)."""
    import jax

    text = str(err)
    return isinstance(err, jax.errors.JaxRuntimeError) and (
        "RESOURCE_EXHAUSTED" in text or "Out of memory" in text or "Cannot allocate" in text
    )


def oom_as_input_error(run):
    """Decorates ``run(spec, method, seed, trials, ..., mesh=None)`` (the engine's
    :func:`~mjx_radar.engine.runner.run_trials`): XLA's out-of-memory error becomes one
    :class:`InputError` line naming the batch and what to reduce, never a traceback."""

    @functools.wraps(run)
    def guarded(spec, method, seed, trials, *args, **kwargs):
        try:
            return run(spec, method, seed, trials, *args, **kwargs)
        except Exception as err:
            if not out_of_memory(err):
                raise
            mesh = kwargs.get("mesh")
            per_device = -(-len(trials) // (1 if mesh is None else mesh.size))
            raise InputError(oom_line(spec, per_device, err)) from None

    return guarded


def oom_line(spec: RunSpec, per_device: int, err: BaseException) -> str:
    """The one line for XLA's out-of-memory ``err`` running ``per_device`` trials a device
    of the run ``spec`` (:class:`~mjx_radar.engine.run_spec.RunSpec`)."""
    lines = [x.strip() for x in str(err).splitlines() if x.strip()]
    said = next((x for x in lines if "allocat" in x.lower()), lines[0] if lines else "")
    joint = spec.size.joint and spec.size.n_targets > 1
    fix = "reduce mppi.samples or mpc.horizon"
    if per_device > 1:
        fix = (
            f"reduce --trials (a run) or --chunk (a study) to {per_device // 2} or fewer, "
            "or mppi.samples / mpc.horizon"
        )
    if joint:
        fix += '; or set [filter] structure = "per-target"'
    return (
        f"{spec.name}: out of memory running {per_device} trial(s) per device "
        f"(XLA: {said[:160]}); {fix}"
    )
