"""A plug-in's own exception, shown as the user's frames and one line naming the call.

When a registered planner, tracker or sensor raises while the simulator calls it
(usually while the closed loop is traced), :func:`failure` turns the exception into a
:class:`~mjx_radar.contracts.PluginError`: its message is one line naming the plug-in,
the call (``plan``, ``init``, ``record``, ...) and the error; its ``frames`` are the
traceback lines of the user's own files only (not this package's, JAX's or the standard
library's). The command line prints the frames, then ``error: LINE`` (exit 2); from
Python they are a note on the exception. An ``AttributeError`` on a named tuple (the
planner's ``Observation``) lists the fields it has. :func:`guarded_call` wraps one of a
plug-in's functions so (a tracker's ``FilterOps``, a sensor's methods, a cost term).
"""

from __future__ import annotations

import functools
import sysconfig
import traceback
from pathlib import Path

from mjx_radar.contracts import PluginError

_PACKAGE = str(Path(__file__).resolve().parent)


def _library_dirs() -> tuple[str, ...]:
    paths = sysconfig.get_paths()
    dirs = {paths.get(k) for k in ("stdlib", "platstdlib", "purelib", "platlib")}
    return (_PACKAGE, *sorted(str(Path(d).resolve()) for d in dirs if d))


def user_frames(err: BaseException) -> str:
    """The traceback lines of ``err`` in the user's files (empty if none)."""
    libs = _library_dirs()
    frames = [
        f
        for f in traceback.extract_tb(err.__traceback__)
        if not str(Path(f.filename).resolve()).startswith(libs) and not f.filename.startswith("<")
    ]
    return "".join(traceback.format_list(frames)).rstrip("\n")


def _detail(err: BaseException) -> str:
    text = str(err).splitlines()[0] if str(err) else ""
    obj = getattr(err, "obj", None) if isinstance(err, AttributeError) else None
    fields = getattr(type(obj), "_fields", None)
    if fields:
        text = text.split(". Did you mean")[0]
        text += f" (it has: {', '.join(fields)})"
    return f"{type(err).__name__}: {text}" if text else type(err).__name__


def failure(kind: str, name: str, call: str, err: BaseException) -> PluginError:
    """The :class:`PluginError` of ``err``, raised by plug-in ``name``'s ``call``."""
    if isinstance(err, PluginError):  # already explained (a nested plug-in)
        return err
    out = PluginError(f"{kind} {name!r}: {call}() raised {_detail(err)}")
    out.frames = user_frames(err)
    if out.frames:
        out.add_note(out.frames)
    return out


def guarded_call(kind: str, name: str, call: str, fn):
    """``fn`` unchanged, except that its own exception becomes :func:`failure`'s
    :class:`PluginError` (one already explained passes through)."""

    @functools.wraps(fn)
    def guarded(*args, **kwargs):
        try:
            return fn(*args, **kwargs)
        except PluginError:
            raise
        except Exception as err:  # noqa: BLE001 -- the user's code: one line and its frames
            raise failure(kind, name, call, err) from None

    return guarded
