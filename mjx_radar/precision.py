"""Matmul precision of every traced program: full float32, also on GPUs (issue 26).

JAX leaves a float32 dot product's precision at ``DEFAULT``, which Ampere and later
NVIDIA GPUs compute in TF32 (10-bit mantissa). The cubature Kalman filter does not
survive that: on an H100 (paper_3r4t, ccr-sfim, 600 steps) 34 of 128 trials diverged
with the default precision and 0 with ``highest``, as on the CPU (whose float32
dots are always exact float32). So the precision is *pinned in the trace*: a dot
traced inside :func:`scope` carries ``precision = [HIGHEST, HIGHEST]`` in the
StableHLO (and in the exported programs of the export cache), whatever
``JAX_DEFAULT_MATMUL_PRECISION`` or ``jax.config`` say at run time.

Where it is pinned (one decorator, :func:`pinned`, on the entry points that trace):

* ``loop.closed_loop.init_carry`` and ``advance``: the whole closed loop
  (every program of ``engine.programs``, ``closed_loop.simulate``) at
  :data:`ESTIMATION`: CKF / filter-bank predict and update, PSD factorisations and
  solves, Fisher information, the PFIM / PCRLB recursion, NEES, the truth plant;
* ``task.planner``'s ``plan``, ``task.objective.plan_context`` and the objective's
  ``cost`` at :data:`ESTIMATION`: the cubature points and the expectations of the
  information and keep-out terms (also when called without the closed loop);
* at :data:`PLANNER`: the MPPI sampling and refit (``task.planner``, around
  ``control.mppi.optimize``) and the planner's rollouts (``task.rollout`` in the
  objective); the cost terms inside re-pin :data:`ESTIMATION`.

The public SPEC §11 functions (``mjx_radar.ckf``, ``mjx_radar.fisher``,
``mjx_radar.sensing``) are pinned too (:func:`pin_module`). Code that calls the
``mjx_radar.estimation`` functions directly outside those entry points (eagerly or
under its own ``jax.jit``) wraps the calls in ``with mjx_radar.precision.scope():``
(or decorates its function with :func:`pinned`). The host float64 PCRLB
(``estimation.information.pcrlb``) is numpy and needs nothing.

A user must not change :data:`ESTIMATION`. :data:`PLANNER` may be relaxed if the GPU
measurement (``benchmarks/check_precision.py``, ``benchmarks/bench_mppi.py``, docs/scaling.md)
shows the planner keeps its results and gains time; ``tests/test_precision.py``
checks both. The levels are read when a program is traced (set them before the first
compilation of a process); they are part of the export-cache key.
"""

from __future__ import annotations

import functools

import jax

__all__ = ["ESTIMATION", "PLANNER", "describe", "pin_module", "pinned", "scope"]

#: dots of the filter, the information, the PCRLB, the cubature expectations and the
#: truth plant. "highest": full float32 (never TF32). Do not change.
ESTIMATION = "highest"
#: dots of the MPPI sampling / refit and of the planner's MJX rollouts. "highest"
#: until a GPU measurement shows a cheaper setting keeps the results.
PLANNER = "highest"


def scope(kind: str = "estimation"):
    """Context manager: dots traced (or run eagerly) inside get ``kind``'s precision.

    ``kind`` is ``"estimation"`` (:data:`ESTIMATION`) or ``"planner"`` (:data:`PLANNER`).
    Inside a traced function it sets the precision of the dots traced inside it (JAX
    resolves a dot's default precision when the dot is traced; contexts nest, the
    innermost wins).
    """
    return jax.default_matmul_precision({"estimation": ESTIMATION, "planner": PLANNER}[kind])


def pinned(fn=None, *, kind: str = "estimation"):
    """Decorator: ``fn`` is called (so traced) inside :func:`scope` ``(kind)``."""
    if fn is None:
        return functools.partial(pinned, kind=kind)

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        with scope(kind):
            return fn(*args, **kwargs)

    wrapper.__precision_kind__ = kind
    return wrapper


def pin_module(namespace: dict, names) -> None:
    """Replaces the functions ``names`` of a module ``namespace`` by :func:`pinned` ones."""
    for name in names:
        obj = namespace[name]
        if callable(obj) and not isinstance(obj, type) and not hasattr(obj, "__precision_kind__"):
            namespace[name] = pinned(obj)


def describe() -> str:
    """The pinned levels, for cache keys and run metadata (``"estimation=highest,..."``)."""
    return f"estimation={ESTIMATION},planner={PLANNER}"
