"""The executable cache: a shape's compiled ``init`` and ``step``, loaded without lowering.

The export cache (:mod:`mjx_radar.engine.export_cache`) spares a warm start the
tracing, but not the rest of JAX's way to XLA's persistent cache: lowering the
exported call (which also imports SciPy for LAPACK), serialising and hashing the
StableHLO module for the cache key, then decompressing and loading the executable.
On the CPU that is about half of the second a warm ``mjx-radar run`` spends on its
programs. Here the compiled executables themselves are kept beside the export
(:func:`jax.experimental.serialize_executable.serialize`, JAX's pickling of PjRt
executables) and a warm start only deserialises and loads them.

The file ``exe-KEY-dDEVICE-XKEY.bin`` holds both programs for one device of one host kind;
``XKEY`` (:func:`compile_key`) hashes what changes XLA's output besides the program:
``XLA_FLAGS``, the backend's platform and version, the device kind, JAX's
configuration options of compilation (x64, matmul precision) and, on the CPU, the
processor's instruction-set flags. Anything unreadable, stale or foreign is ignored
(the programs are then lowered and compiled as before, and the file rewritten);
writing is best effort. The same trust as XLA's persistent cache: only a directory of
the user's own is read.

On the CPU only executables XLA compiled in this process are written
(:func:`compile_and_save`; :func:`compile_lowered` says which): an executable that JAX
loaded from its persistent cache serialises without its generated code there (jaxlib
0.10: the copy loads, then fails with "Function ... not found" when it runs), so such a
pair keeps JAX's way to the cache. On GPUs it serialises whole and is written too
(loaded and run again on an H100 with the same metrics), so a program whose HLO JAX's
cache already held (a package upgrade that changed no program; a host's second GPU)
still gets its file.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import os
import platform
import threading
import time
from pathlib import Path

import jax

from mjx_radar.engine.threads import parallel

_MAGIC = b"mjx-radar-exe-1\n"
_CACHE_HIT = "/jax/compilation_cache/cache_hits"
_SEEN = threading.local()  # per compiling thread: did JAX's persistent cache answer?


@functools.cache
def _listen() -> None:
    """Registers (once) a listener of JAX's cache-hit event; it runs in the thread that
    compiles, so each thread learns whether its own compilation was a cache hit."""

    def on_event(event: str, **_):
        if event == _CACHE_HIT:
            _SEEN.hit = True

    jax.monitoring.register_event_listener(on_event)


def compile_lowered(lowered):
    """``(lowered.compile(), fresh)``: ``fresh`` is False when JAX's persistent cache
    answered instead of XLA (such an executable is not worth writing, module docstring)."""
    _listen()
    _SEEN.hit = False
    compiled = lowered.compile()
    return compiled, not _SEEN.hit


def compile_all(lowered) -> tuple[tuple, bool]:
    """``(compiled, worth writing)``: the ``lowered`` programs compiled side by side (XLA
    frees the GIL); worth writing except on the CPU when JAX's cache answered one of
    them (module docstring)."""
    both = parallel([functools.partial(compile_lowered, x) for x in lowered])
    compiled = tuple(c for c, _ in both)
    return compiled, all(fresh for _, fresh in both) or _platform(compiled) != "cpu"


def compile_and_save(file: Path | None, lowered) -> tuple[tuple, float]:
    """``(compiled, seconds writing)``: :func:`compile_all`, then written to ``file`` if
    worth it."""
    compiled, worth = compile_all(lowered)
    if not worth:
        return compiled, 0.0
    t0 = time.perf_counter()
    save(file, compiled)
    return compiled, time.perf_counter() - t0


def save_later(file: Path | None, compiled, held: contextlib.ExitStack) -> threading.Thread:
    """:func:`save` in a background thread, which then closes ``held`` (the program's
    lock, :func:`mjx_radar.engine.compile_cache.program_lock`): the run starts while the
    file is written (0.3-1.8 s for a paper shape on an H100), and another process waiting
    for the lock still finds the file. Not a daemon: a process that ends meanwhile
    finishes the file first."""

    def write():
        with held:
            save(file, compiled)

    thread = threading.Thread(target=write, name="mjx-radar-save-exe", daemon=False)
    thread.start()
    return thread


def _platform(compiled) -> str:
    """The platform the compiled programs run on."""
    try:
        return next(iter(compiled[0].input_shardings[0][0].device_set)).platform
    except Exception:  # noqa: BLE001 -- unknown: treat as the CPU (write nothing doubtful)
        return "cpu"


@functools.cache
def _cpu_flags() -> str:
    """The processor's instruction-set flags (Linux), part of a CPU executable's key."""
    try:
        text = Path("/proc/cpuinfo").read_text()
    except OSError:
        return platform.processor()
    return next((ln for ln in text.splitlines() if ln.startswith("flags")), "")


def compile_key(device) -> str:
    """What besides the program determines the executable XLA builds for ``device``."""
    client = device.client
    parts = [
        os.environ.get("XLA_FLAGS", ""),
        client.platform,
        client.platform_version,
        device.device_kind,
        bool(jax.config.jax_enable_x64),
        str(jax.config.jax_default_matmul_precision),
        platform.machine(),
        _cpu_flags() if device.platform == "cpu" else "",
    ]
    return hashlib.sha256(repr(parts).encode()).hexdigest()[:16]


def path(store: Path | None, key: str, device, prefix: str = "exe") -> Path | None:
    """The file of a program key's executables for ``device`` (None without a store)."""
    if store is None:
        return None
    return store / f"{prefix}-{key}-d{device.id}-{compile_key(device)}.bin"


def save(file: Path | None, compiled) -> None:
    """Writes the compiled programs (best effort: an executable JAX cannot serialise, or
    a full disk, leaves no file)."""
    if file is None:
        return
    from jax.experimental import serialize_executable

    from mjx_radar.io.atomic import atomic_write_bytes

    try:
        blobs = []
        for c in compiled:
            blob, in_tree, out_tree = serialize_executable.serialize(c)
            n_in, n_out = in_tree.num_leaves, out_tree.num_leaves
            blobs.append(b"%d %d %d\n" % (n_in, n_out, len(blob)) + blob)
        atomic_write_bytes(file, _MAGIC + b"".join(blobs))
    except Exception:  # noqa: BLE001 -- a cache: never worth failing a run for
        return


def load(file: Path | None, devices) -> tuple | None:
    """The compiled programs of ``file`` loaded on ``devices`` (a mesh's), or None."""
    if file is None or not file.exists():
        return None
    from jax.experimental import serialize_executable

    try:
        raw = file.read_bytes()
        if not raw.startswith(_MAGIC):
            return None
        pos, out = len(_MAGIC), []
        while pos < len(raw):
            end = raw.index(b"\n", pos)
            n_in, n_out, size = (int(x) for x in raw[pos:end].split())
            blob = raw[end + 1 : end + 1 + size]
            pos = end + 1 + size
            in_tree = jax.tree.structure((tuple(range(n_in)), {}))  # flat programs
            out_tree = jax.tree.structure(tuple(range(n_out)))
            out.append(
                serialize_executable.deserialize_and_load(
                    blob, in_tree, out_tree, devices[0].client, list(devices)
                )
            )
        return tuple(out)
    except Exception:  # noqa: BLE001 -- damaged, stale or foreign: compile again
        return None
