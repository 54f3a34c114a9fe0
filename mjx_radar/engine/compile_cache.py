"""JAX's persistent compilation cache, on by default for the command line.

Compiled XLA programs are stored in a per-user directory and reused by later
processes (a program is keyed by its HLO, so only a change of the scenario's *shape*
recompiles; see :mod:`mjx_radar.task.params`). The directory is, in order:
``--cache-dir DIR``, ``$MJX_RADAR_CACHE_DIR``, ``$JAX_COMPILATION_CACHE_DIR``,
``$XDG_CACHE_HOME/mjx_radar/xla``, ``~/.cache/mjx_radar/xla``. ``--no-cache`` (or
``MJX_RADAR_CACHE_DIR=off``) disables it. JAX writes cache entries atomically, so
several processes may share a directory. Nothing happens at import: the CLI calls
:func:`enable` at start-up.

A damaged cache entry (a truncated or overwritten file) makes JAX warn with a
multi-line ``UserWarning`` for every program it cannot read, then recompile.
:func:`enable` turns those warnings into ONE line of ours per process::

    warning: compilation cache entry in DIR unreadable; recompiling (delete DIR to clear it)

(and likewise for entries it cannot write), through a ``warnings.showwarning`` hook
that passes every other warning on unchanged.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import importlib.metadata
import sys
import threading
import warnings
from pathlib import Path

from mjx_radar.io.cache_dirs import default_dir

_DIR: list[Path] = []  # the directory enabled in this process (at most one)


def enable(directory: str | Path | None = None) -> Path | None:
    """Turns the persistent cache on in ``directory`` (default :func:`default_dir`).

    Returns:
        The directory in use, or None if it is disabled or cannot be created (then
        programs are compiled in every process, as without a cache).
    """
    import jax

    path = Path(directory).expanduser() if directory else default_dir()
    if path is None:
        return None
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError:
        return None
    jax.config.update("jax_compilation_cache_dir", str(path))
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)
    jax.config.update("jax_persistent_cache_min_entry_size_bytes", 0)
    _DIR[:] = [path]
    _install_warning_hook()
    return path


#: JAX's cache warnings (jax/_src/compiler.py) -> our one line ({dir}: the cache directory)
_CACHE_WARNINGS = {
    "Error reading persistent compilation cache entry": (
        "warning: compilation cache entry in {dir} unreadable; recompiling "
        "(delete {dir} to clear it)"
    ),
    "Error writing persistent compilation cache entry": (
        "warning: cannot write compilation cache entries in {dir}; compiling without "
        "caching (check the directory's permissions and free space, or pass --no-cache)"
    ),
}
_SHOWN: set[str] = set()
_SHOWN_LOCK = threading.Lock()


def cache_warning_line(message: str) -> str | None:
    """Our one line for one of JAX's persistent-cache warnings (None for any other)."""
    for head, line in _CACHE_WARNINGS.items():
        if message.startswith(head):
            where = str(_DIR[0]) if _DIR else "the compilation cache"
            return line.format(dir=where)
    return None


def _install_warning_hook() -> None:
    """Wraps ``warnings.showwarning`` once: JAX's cache warnings become one line each."""
    previous = warnings.showwarning
    if getattr(previous, "_mjx_radar_cache_hook", False):
        return

    def show(message, category, filename, lineno, file=None, line=None):
        ours = cache_warning_line(str(message)) if issubclass(category, UserWarning) else None
        if ours is None:
            return previous(message, category, filename, lineno, file, line)
        with _SHOWN_LOCK:  # compile threads may warn at once
            if ours in _SHOWN:
                return None
            _SHOWN.add(ours)
        print(ours, file=sys.stderr if file is None else file, flush=True)
        return None

    show._mjx_radar_cache_hook = True
    warnings.showwarning = show


def program_dir() -> Path | None:
    """Where traced programs are exported (``<cache>/programs``), or None if disabled."""
    if not _DIR:
        return None
    path = _DIR[0] / "programs"
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError:
        return None
    return path


@contextlib.contextmanager
def program_lock(path: Path | None):
    """Holds an exclusive lock on the file ``path`` while this process traces and
    compiles one program: another process (a test worker, a study shard, a second run of
    the same shape) or thread taking the same lock waits, then loads the program from
    both caches instead of compiling it a second time. The lock goes with the file's
    closing or the process's end; nothing happens without a path or without ``fcntl``."""
    try:
        import fcntl

        lock = open(path, "ab") if path is not None else None  # noqa: SIM115
    except (ImportError, OSError):
        lock = None
    try:
        if lock is not None:
            fcntl.flock(lock, fcntl.LOCK_EX)
        yield
    finally:
        if lock is not None:
            lock.close()


def enabled() -> bool:
    """True if XLA's persistent compilation cache is on in this process (ours or the user's)."""
    import jax

    return jax.config.jax_compilation_cache_dir is not None


def disable() -> None:
    """Turns the persistent cache off for this process."""
    import jax

    jax.config.update("jax_compilation_cache_dir", None)
    _DIR.clear()


@functools.cache
def code_fingerprint() -> str:
    """Hash of the package's code and models and of the JAX / MuJoCo versions."""
    h = hashlib.sha256()
    root = Path(__file__).resolve().parents[1]  # the package
    for path in sorted(root.rglob("*.py")) + sorted(root.parent.glob("models/*.xml")):
        h.update(path.name.encode())
        h.update(path.read_bytes())
    for dist in ("jax", "jaxlib", "mujoco", "mujoco-mjx"):
        try:
            h.update(f"{dist}={importlib.metadata.version(dist)}".encode())
        except importlib.metadata.PackageNotFoundError:
            pass
    return h.hexdigest()
