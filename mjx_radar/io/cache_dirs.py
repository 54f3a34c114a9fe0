"""The per-user cache folder of mjx_radar (compiled programs, generated map meshes).

``$MJX_RADAR_CACHE_DIR``, else ``$JAX_COMPILATION_CACHE_DIR``, else
``$XDG_CACHE_HOME/mjx_radar/xla``, else ``~/.cache/mjx_radar/xla``; one of the two
variables set to ``off`` (or ``0``, ``none``, ``false``, empty) disables it.
"""

from __future__ import annotations

import os
from pathlib import Path

OFF = {"", "0", "off", "none", "false"}


def default_dir() -> Path | None:
    """The cache directory from the environment, or None if disabled there."""
    for var in ("MJX_RADAR_CACHE_DIR", "JAX_COMPILATION_CACHE_DIR"):
        if var in os.environ:
            value = os.environ[var]
            return None if value.strip().lower() in OFF else Path(value).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "mjx_radar" / "xla"
