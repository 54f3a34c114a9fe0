"""Deterministic GPU kernels (``--deterministic``): XLA's ``--xla_gpu_deterministic_ops``.

With XLA's default GPU settings a seed does not fix a run's numbers. XLA *autotunes*
its GPU kernels at compile time, timing candidate implementations and keeping the
fastest, so two cold compilations of one program can pick different kernels (XLA's
``docs/determinism.md``); and some kernels (MJX's scatter-adds) use atomics, whose
summation order varies from run to run. Measured on one H100 (docs/scaling.md,
"Deterministic kernels"): the same 250-trial DDR-PFIM run of ``paper_3r4t``, compiled
cold twice with the defaults, differed in 987 k of 3.15 M metric values (all 250 trials;
mean RMSE 2.151 vs 2.160 m), while a warm run (the cached executable) repeated its
compilation's numbers exactly. With the flag (no autotuning, deterministic kernels) two
cold compilations gave identical numbers and compiled in 29-33 s instead of 40-45 s;
the 250-trial simulation took 5 % longer and one PFIM control call 4.6-7.0 ms instead of
3.3-3.8 ms (two machines), which is why it stays a choice, off by default.

XLA reads the flag once, when JAX starts its backend: :func:`apply` sets it in
``XLA_FLAGS`` before that (the command line even earlier, :func:`request_in_env`) and
refuses in one line where a GPU backend already runs without it. On CPUs the flag
changes nothing: XLA's CPU kernels are deterministic.
"""

from __future__ import annotations

import os

from mjx_radar.errors import InputError

FLAG = "xla_gpu_deterministic_ops"
_TRUE = ("", "true", "1")  # a bare flag is on


def flag_in_env() -> bool | None:
    """The value ``XLA_FLAGS`` gives :data:`FLAG` (the last one given), or None if absent."""
    value = None
    for part in os.environ.get("XLA_FLAGS", "").split():
        name, _, v = part.lstrip("-").partition("=")
        if name == FLAG:
            value = v.strip().lower() in _TRUE
    return value


def request_in_env() -> None:
    """Turns the flag on in ``XLA_FLAGS`` (appended: a ``false`` given there before is
    overridden, every other flag kept). No JAX import: the command line calls this
    before anything starts JAX."""
    if flag_in_env() is not True:
        flags = os.environ.get("XLA_FLAGS", "")
        os.environ["XLA_FLAGS"] = f"{flags} --{FLAG}=true".strip()


def _backend_started() -> bool:
    from jax._src import xla_bridge  # no public API tells without starting a backend

    return xla_bridge.backends_are_initialized()


def apply(deterministic: bool) -> bool:
    """Asks for deterministic kernels if ``deterministic``; returns whether the run has them.

    Returns:
        ``True`` if the flag is on (set here or before) or the backend is a CPU's, whose
        kernels are deterministic anyway; otherwise ``False`` (what ``run.json`` and
        ``study.json`` record as ``deterministic``).

    Raises:
        InputError: ``deterministic`` after JAX started a GPU backend without the flag
            (checked without starting a backend: a fresh process is never refused).
    """
    if flag_in_env() is True:
        return True
    if not deterministic:
        return False
    if not _backend_started():
        request_in_env()
        return True
    import jax

    if any(d.platform == "gpu" for d in jax.devices()):
        raise InputError(
            f"deterministic = True: JAX has started its GPU backend without XLA's --{FLAG}="
            "true; set XLA_FLAGS before importing jax"
        )
    return True  # CPU kernels are deterministic; XLA_FLAGS (the cache key) left alone
