"""Offscreen OpenGL backend selection for MuJoCo rendering (``MUJOCO_GL``).

MuJoCo reads ``MUJOCO_GL`` once, when ``mujoco`` is first imported, so the
command line calls :func:`configure` at the very start of
:func:`mjx_radar.cli.main.main`, before any module that imports ``mujoco`` is loaded.
The choice, highest priority first:

1. ``--gl egl|osmesa`` on the command line;
2. an existing ``MUJOCO_GL`` environment variable;
3. ``egl`` when an NVIDIA device is present (``nvidia-smi`` or ``/dev/nvidia0``);
4. ``osmesa`` when ``libOSMesa`` is installed, else ``egl`` when ``libEGL`` is.

Only rendering commands (``render``, ``run --video``) are configured; the others
never touch OpenGL: for them ``MUJOCO_GL`` is set to ``disable`` while ``mujoco`` is
imported (so ``MUJOCO_GL=osmesa`` without ``libOSMesa`` cannot break ``validate``), then
restored. A rendering command whose backend library is missing is refused with one
line (:class:`~mjx_radar.errors.InputError`), e.g. ``MUJOCO_GL=osmesa: libOSMesa not
found; apt-get install libosmesa6 or set MUJOCO_GL=egl``.

:func:`make_renderer` builds a :class:`mujoco.Renderer` on the chosen backend even
when ``mujoco`` was imported before :func:`configure` ran (e.g. inside a test session
or a notebook).
"""

from __future__ import annotations

import contextlib
import ctypes.util
import os
import shutil
import sys
from collections.abc import Sequence

from mjx_radar.errors import InputError

BACKENDS = ("egl", "osmesa")
RENDER_COMMANDS = ("render",)
# backend -> (library, Debian package, the other backend)
_LIBRARIES = {"egl": ("EGL", "libegl1", "osmesa"), "osmesa": ("OSMesa", "libosmesa6", "egl")}
_SAVED_GL: list = []  # MUJOCO_GL before a non-rendering command disabled it


def _has_nvidia() -> bool:
    return shutil.which("nvidia-smi") is not None or os.path.exists("/dev/nvidia0")


def auto_backend() -> str | None:
    """The backend this machine supports best, or ``None`` if neither library exists."""
    if _has_nvidia():
        return "egl"
    if ctypes.util.find_library("OSMesa"):
        return "osmesa"
    if ctypes.util.find_library("EGL"):
        return "egl"
    return None


def _flag_value(argv: Sequence[str], flag: str) -> str | None:
    for i, arg in enumerate(argv):
        if arg == flag and i + 1 < len(argv):
            return argv[i + 1]
        if arg.startswith(flag + "="):
            return arg.split("=", 1)[1]
    return None


def _renders(argv: Sequence[str]) -> bool:
    command = next((a for a in argv if not a.startswith("-")), None)
    return command in RENDER_COMMANDS or (command == "run" and "--video" in argv)


def configure(argv: Sequence[str] | None = None) -> str | None:
    """Sets ``MUJOCO_GL`` for a rendering command line; call before importing mujoco.

    Args:
        argv: the command-line arguments (default ``sys.argv[1:]``).

    Returns:
        The backend now in ``MUJOCO_GL``, or ``None`` if the command does not render
        (then ``MUJOCO_GL`` is ``disable`` until :func:`restore` when ``mujoco`` is not
        imported yet).

    Raises:
        InputError: the rendering backend's library is not installed.
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    if not _renders(argv):
        if "mujoco" not in sys.modules:
            _SAVED_GL.append(os.environ.get("MUJOCO_GL"))
            os.environ["MUJOCO_GL"] = "disable"
        return None
    chosen = _flag_value(argv, "--gl")
    if chosen in BACKENDS:
        os.environ["MUJOCO_GL"] = chosen
    elif not os.environ.get("MUJOCO_GL"):
        backend = auto_backend()
        if backend is None:
            return None
        os.environ["MUJOCO_GL"] = backend
    backend = os.environ["MUJOCO_GL"].lower().strip()
    if backend in BACKENDS:
        check_library(backend)
        os.environ.setdefault("PYOPENGL_PLATFORM", backend)
    return os.environ["MUJOCO_GL"]


def check_library(backend: str) -> None:
    """Raises :class:`InputError` (one line) if ``backend``'s OpenGL library is missing."""
    lib, package, other = _LIBRARIES[backend]
    if backend == "egl" and _has_nvidia():
        return  # the NVIDIA driver ships its own libEGL
    if not ctypes.util.find_library(lib):
        raise InputError(
            f"MUJOCO_GL={backend}: lib{lib} not found; apt-get install {package} "
            f"or set MUJOCO_GL={other}"
        )


def restore() -> None:
    """Restores the ``MUJOCO_GL`` that :func:`configure` disabled for a non-rendering command."""
    while _SAVED_GL:
        old = _SAVED_GL.pop()
        if old is None:
            os.environ.pop("MUJOCO_GL", None)
        else:
            os.environ["MUJOCO_GL"] = old


def _context_class(backend: str):
    if backend == "egl":
        from mujoco.egl import GLContext
    else:
        from mujoco.osmesa import GLContext
    return GLContext


def make_renderer(model, width: int, height: int, backend: str | None = None):
    """A :class:`mujoco.Renderer` on ``backend`` (default: ``MUJOCO_GL`` or auto).

    Args:
        model: the ``MjModel``; its offscreen buffer is enlarged to fit if needed.
        width: image width [px].
        height: image height [px].
        backend: ``"egl"`` or ``"osmesa"``; ``None`` for the configured one.

    Returns:
        The renderer; the caller must ``close()`` it.
    """
    import mujoco
    from mujoco.rendering.classic import gl_context

    backend = (backend or os.environ.get("MUJOCO_GL") or auto_backend() or "").lower()
    model.vis.global_.offwidth = max(int(model.vis.global_.offwidth), width)
    model.vis.global_.offheight = max(int(model.vis.global_.offheight), height)
    if backend not in BACKENDS:
        return mujoco.Renderer(model, height=height, width=width)
    saved = getattr(gl_context, "GLContext", None)
    # mujoco picked its context class at import time; swap in the chosen one for
    # this construction only (a no-op when MUJOCO_GL was set before the import).
    with contextlib.ExitStack() as stack:
        gl_context.GLContext = _context_class(backend)
        stack.callback(setattr, gl_context, "GLContext", saved)
        return mujoco.Renderer(model, height=height, width=width)
