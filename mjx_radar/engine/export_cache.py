"""The export cache: both programs of a shape traced once, serialised beside XLA's cache.

:func:`export` traces the flat ``init`` and ``step`` programs into
:class:`jax.export.Exported` form, :func:`save` / :func:`load` keep them in the
program folder (:func:`mjx_radar.engine.compile_cache.program_dir`), :func:`lower`
lowers them for a device mesh without tracing the loop (a warm start imports no MJX).
"""

from __future__ import annotations

from pathlib import Path

import jax
from jax.sharding import NamedSharding, PartitionSpec

#: a program's trial axis (the carry, the trial indices) and its replicated parameters
SPLIT, WHOLE = PartitionSpec("trial"), PartitionSpec()


def export(init, step, init_args, step_args):
    """Both programs traced once into :class:`jax.export.Exported` form (None if impossible)."""
    both = (export_one(init, init_args), export_one(step, step_args))
    return None if None in both else both


def export_one(program, args):
    """One jitted program traced into :class:`jax.export.Exported` form (None if impossible)."""
    from mjx_radar.engine.locations import flatten

    try:
        return flatten(jax.export.export(program)(*args))
    except Exception:  # noqa: BLE001 -- an unexportable program still runs, traced directly
        return None


def save(path: Path, exported) -> None:
    """Serialises both programs beside the compilation cache (best effort)."""
    from mjx_radar.io.atomic import atomic_write_bytes

    try:
        blobs = [e.serialize() for e in exported]
        atomic_write_bytes(path, len(blobs[0]).to_bytes(8, "little") + blobs[0] + blobs[1])
    except (OSError, ImportError, ValueError):
        return


def load(path: Path):
    """Both :class:`jax.export.Exported` programs from the cache, or None."""
    try:
        raw = path.read_bytes()
        n = int.from_bytes(raw[:8], "little")
        return jax.export.deserialize(bytearray(raw[8 : 8 + n])), jax.export.deserialize(
            bytearray(raw[8 + n :])
        )
    except Exception:  # noqa: BLE001 -- missing, stale or damaged entry: trace again
        return None


def lower(exported, trials, p_specs, mesh):
    """``(init, step)`` lowered from exported programs (no Python tracing of the loop)."""
    e_init, e_step = exported
    n_params = len(p_specs)
    c_specs = [
        jax.ShapeDtypeStruct(a.shape, a.dtype, sharding=NamedSharding(mesh, SPLIT))
        for a in e_step.in_avals[n_params:]
    ]
    donate = tuple(range(n_params, n_params + len(c_specs)))
    init = jax.jit(e_init.call).lower(trials, *p_specs)
    step = jax.jit(e_step.call, donate_argnums=donate).lower(*p_specs, *c_specs)
    return init, step
