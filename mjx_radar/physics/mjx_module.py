"""``mujoco.mjx``, imported on first use with its import-time chatter muted.

MJX prints "Failed to import warp" when its optional MJWarp backend is absent. The
plant modules import MJX through :func:`load`, and only code that builds or traces a
plant imports them, so a warm start from the export cache never loads MJX (nor the
trimesh and scipy it imports).

The import usually runs in a compile thread while the main thread keeps reporting (the
progress bar, "interrupted: no results written" on Ctrl-C), so only the importing
thread's writes are muted: ``sys.stdout`` / ``sys.stderr`` become proxies that drop that
thread's text and pass every other thread's on (``contextlib.redirect_stdout`` would
silence the whole process meanwhile).
"""

from __future__ import annotations

import sys
import threading

_LOCK = threading.Lock()


class _MuteThread:
    """A text stream that drops the writes of one thread and forwards all others."""

    def __init__(self, target, thread: int):
        self._target, self._thread = target, thread

    def write(self, text: str) -> int:
        if threading.get_ident() == self._thread:
            return len(text)
        return self._target.write(text)

    def __getattr__(self, name: str):  # flush, fileno, isatty, encoding ...
        return getattr(self._target, name)


def load():
    """The ``mujoco.mjx`` module (imported once, this thread's output muted)."""
    module = sys.modules.get("mujoco.mjx")
    if module is not None:
        return module
    with _LOCK:
        me = threading.get_ident()
        out, err = _MuteThread(sys.stdout, me), _MuteThread(sys.stderr, me)
        sys.stdout, sys.stderr = out, err
        try:
            from mujoco import mjx
        finally:  # restore unless someone else replaced the streams meanwhile
            if sys.stdout is out:
                sys.stdout = out._target
            if sys.stderr is err:
                sys.stderr = err._target
    return mjx
