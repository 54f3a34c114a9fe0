"""Deterministic GPU kernels: XLA's ``--xla_gpu_deterministic_ops``, on by default.

With XLA's default GPU settings a seed does not fix a run's numbers. XLA *autotunes*
its GPU kernels at compile time, timing candidate implementations and keeping the
fastest, so two cold compilations of one program can pick different kernels (XLA's
``docs/determinism.md``); and some kernels (scatter-adds, split reductions) use atomics,
whose summation order varies from run to run. Measured on one H100 (docs/notes/scaling-history.md,
"Deterministic kernels"): the same 250-trial DDR-PFIM run of ``paper_3r4t``, compiled
cold twice with XLA's defaults, differed in 987 k of 3.15 M metric values (mean RMSE
2.151 vs 2.160 m); with the flag two cold compilations gave identical numbers.

The flag also compiles faster (14-41 % on five bundled worlds, one H100) and costs
nothing measurable where the GPU is busy (a study chunk's 250 vmapped PFIM calls: 19.6-19.9
against 19.7-20.4 ms); a single control call is bound by the host's kernel launches,
not by the kernels (1.8 ms of GPU work in a 3.5-5.7 ms call, either way), and its
median moves by tens of percent from one process to the next with either setting. So
the entry points (``mjx-radar run`` / ``study``, :func:`mjx_radar.simulate`,
:func:`mjx_radar.run_study`) turn it on where a GPU backend may start, unless asked not
to (``--no-deterministic``, ``deterministic=False``) or ``XLA_FLAGS`` already says
``false``.

XLA reads the flag once, when JAX starts its backend: :func:`apply` sets it in
``XLA_FLAGS`` before that (the command line even earlier, :func:`request_in_env`); once
a GPU backend runs, an explicit request it cannot honour is refused in one line and the
default takes what the process has. On CPUs nothing is set (XLA_FLAGS is part of the
compilation cache's key): XLA's CPU kernels are deterministic.
"""

from __future__ import annotations

import functools
import os
import pkgutil
import sys

from mjx_radar.errors import InputError

FLAG = "xla_gpu_deterministic_ops"
_TRUE = ("", "true", "1")  # a bare flag is on
_GPU_PLATFORMS = {"cuda", "gpu", "rocm"}


def flag_in_env() -> bool | None:
    """The value ``XLA_FLAGS`` gives :data:`FLAG` (the last one given), or None if absent."""
    value = None
    for part in os.environ.get("XLA_FLAGS", "").split():
        name, _, v = part.lstrip("-").partition("=")
        if name == FLAG:
            value = v.strip().lower() in _TRUE
    return value


def gpu_possible() -> bool:
    """Whether JAX may start a GPU backend in this process, told without importing JAX:
    ``JAX_PLATFORMS`` (or ``jax.config``, once imported) allows one and a CUDA or ROCm
    PJRT plugin is installed where JAX looks for plugins (the ``jax_plugins`` namespace
    package and entry points)."""
    jax = sys.modules.get("jax")
    platforms = (jax.config.jax_platforms if jax else None) or os.environ.get("JAX_PLATFORMS")
    if platforms and not {p.strip() for p in platforms.lower().split(",")} & _GPU_PLATFORMS:
        return False
    return _gpu_plugin_installed()


@functools.cache
def _gpu_plugin_installed() -> bool:
    from importlib import metadata, util

    names = {ep.value.split(":")[0] for ep in metadata.entry_points(group="jax_plugins")}
    spec = util.find_spec("jax_plugins")
    if spec is not None and spec.submodule_search_locations:
        names |= {
            f"jax_plugins.{m.name}" for m in pkgutil.iter_modules(spec.submodule_search_locations)
        }
    return any(("cuda" in n or "rocm" in n) and util.find_spec(n) is not None for n in names)


def request_in_env(deterministic: bool | None = True) -> None:
    """Sets the flag in ``XLA_FLAGS`` as asked, where a GPU backend may start
    (:func:`gpu_possible`; on a CPU ``XLA_FLAGS``, a compilation cache key, is left alone).

    Args:
        deterministic: ``True`` on, ``False`` off (XLA's autotuned kernels), ``None`` on
            unless ``XLA_FLAGS`` already turns it off. Appended: every other flag, and an
            earlier value of this one, stays in the string; the last one counts.

    No JAX import: the command line calls this before anything starts JAX.
    """
    if not gpu_possible():
        return
    now = flag_in_env()
    want = now is not False if deterministic is None else deterministic
    if want != bool(now):
        flags = os.environ.get("XLA_FLAGS", "")
        os.environ["XLA_FLAGS"] = f"{flags} --{FLAG}={str(want).lower()}".strip()


def _backend_started() -> bool:
    from jax._src import xla_bridge  # no public API tells without starting a backend

    return xla_bridge.backends_are_initialized()


def apply(deterministic: bool | None = None) -> bool:
    """Deterministic kernels as asked (``None``: on where it can still be set); returns
    whether the run has them.

    Args:
        deterministic: ``True``, ``False`` or ``None`` (the default, see
            :func:`request_in_env`).

    Returns:
        ``True`` if the flag is on for this process's GPU backend (set here or before) or
        the backend is a CPU's, whose kernels are deterministic anyway; otherwise
        ``False`` (what ``run.json`` and ``study.json`` record as ``deterministic``).

    Raises:
        InputError: ``True`` or ``False`` after JAX started a GPU backend with the other
            setting (checked without starting a backend: a fresh process is never
            refused); ``None`` then takes what the process has.
    """
    if not _backend_started():
        if not gpu_possible():
            return True  # a CPU's kernels; XLA_FLAGS (the cache key) left alone
        request_in_env(deterministic)
        return flag_in_env() is True
    import jax

    if not any(d.platform == "gpu" for d in jax.devices()):
        return True
    has = flag_in_env() is True
    if deterministic is None or deterministic == has:
        return has
    raise InputError(
        f"deterministic = {deterministic}: JAX has started its GPU backend with XLA's "
        f"--{FLAG}={str(has).lower()}; set XLA_FLAGS before importing jax"
    )
