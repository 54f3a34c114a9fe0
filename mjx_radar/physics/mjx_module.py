"""``mujoco.mjx``, imported on first use with its import-time chatter muted.

MJX prints "Failed to import warp" when its optional MJWarp backend is absent. The
plant modules import MJX through :func:`load`, and only code that builds or traces a
plant imports them, so a warm start from the export cache never loads MJX (nor the
trimesh and scipy it imports).
"""

from __future__ import annotations

import contextlib
import io
import sys
import threading

_LOCK = threading.Lock()


def load():
    """The ``mujoco.mjx`` module (imported once, with stdout and stderr muted)."""
    module = sys.modules.get("mujoco.mjx")
    if module is not None:
        return module
    muted = io.StringIO()
    with _LOCK, contextlib.redirect_stdout(muted), contextlib.redirect_stderr(muted):
        from mujoco import mjx
    return mjx
