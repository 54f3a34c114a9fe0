"""Exported programs with one source line per operation, on every JAX we admit.

:func:`mjx_radar.engine.program_trace.short_locations` keeps one Python frame per
traced operation. From JAX 0.11 (what pip picks on Python 3.12 and 3.13) every
equation's lowering is also cached as a function and inlined where it is called, and
the inliner wraps each inlined operation's location in a call site: ``callsite(inner
at outer)``, one level per nested loop, ``vmap`` or ``jit`` (10-11 deep in the closed
loop's step program). XLA turns those chains into stack frames that a GPU executable
turns into profiler annotations each time it is built or loaded.

:func:`flatten` rewrites an :class:`jax.export.Exported` so that each call site keeps
only its callee's location (the operation's own line, as JAX 0.10 gave), and a call of
a jitted function (``estimation.linalg``'s factorisations, JAX's PRNG) none: XLA
inlines it and made its location a parent stack frame of each operation inside
(a paper study program's frames grew by half with the jitted factorisations; without
call locations they are fewer than before). Locations are metadata, not code: the
program computes the same. If the rewrite is impossible (a JAX whose private serialiser
changed), the program is returned as it is.
"""

from __future__ import annotations

import dataclasses
import re

_CALLSITE = re.compile(r"^(#loc\d+) = loc\(callsite\((#loc\d+) at #loc\d+\)\)$", re.M)
_INLINE = re.compile(r"loc\(callsite\((#loc\d+) at #loc\d+\)\)")
_CALL = re.compile(r"^(\s*(?:%[^=\n]+ = )?(?:func\.)?call @[^\n]*) loc\(#loc\d+\)$", re.M)


def collapse(text: str) -> str:
    """A StableHLO module's text with every ``callsite(A at B)`` location replaced by A,
    and no location on a function call (XLA inlines the call and would make its
    location a parent frame of every inlined operation)."""
    text = _CALL.sub(lambda m: f"{m.group(1)} loc(unknown)", text)
    alias = dict((m.group(1), m.group(2)) for m in _CALLSITE.finditer(text))
    if not alias:
        return text

    def callee(ref: str) -> str:
        while ref in alias:
            ref = alias[ref]
        return ref

    text = _CALLSITE.sub(lambda m: f"{m.group(1)} = loc({callee(m.group(2))})", text)
    return _INLINE.sub(lambda m: f"loc({callee(m.group(1))})", text)


def flatten(exported):
    """``exported`` with call-site chains collapsed (module docstring), or as it is."""
    try:
        text = exported.mlir_module()
        new = collapse(text)
        if new == text:
            return exported
        from jax._src.export._export import _module_to_bytecode
        from jax._src.interpreters import mlir
        from jax._src.lib.mlir import ir

        with mlir.make_ir_context():
            blob = _module_to_bytecode(ir.Module.parse(new))
        return dataclasses.replace(exported, mlir_module_serialized=blob)
    except Exception:  # noqa: BLE001 -- metadata only: keep the program as JAX gave it
        return exported
