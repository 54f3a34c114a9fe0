"""JAX's persistent compilation cache, on by default for the command line.

Compiled XLA programs are stored in a per-user directory and reused by later
processes (a program is keyed by its HLO, so only a change of the scenario's *shape*
recompiles; see :mod:`mjx_radar.task.params`). The directory is, in order:
``--cache-dir DIR``, ``$MJX_RADAR_CACHE_DIR``, ``$JAX_COMPILATION_CACHE_DIR``,
``$XDG_CACHE_HOME/mjx_radar/xla``, ``~/.cache/mjx_radar/xla``. ``--no-cache`` (or
``MJX_RADAR_CACHE_DIR=off``) disables it. JAX writes cache entries atomically, so
several processes may share a directory. Nothing happens at import: the CLI calls
:func:`enable` at start-up.
"""

from __future__ import annotations

import os
from pathlib import Path

_OFF = {"", "0", "off", "none", "false"}
_DIR: list[Path] = []  # the directory enabled in this process (at most one)


def default_dir() -> Path | None:
    """The cache directory from the environment, or None if disabled there."""
    for var in ("MJX_RADAR_CACHE_DIR", "JAX_COMPILATION_CACHE_DIR"):
        if var in os.environ:
            value = os.environ[var]
            return None if value.strip().lower() in _OFF else Path(value).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "mjx_radar" / "xla"


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
    return path


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


def enabled() -> bool:
    """True if XLA's persistent compilation cache is on in this process (ours or the user's)."""
    import jax

    return jax.config.jax_compilation_cache_dir is not None


def disable() -> None:
    """Turns the persistent cache off for this process."""
    import jax

    jax.config.update("jax_compilation_cache_dir", None)
    _DIR.clear()
