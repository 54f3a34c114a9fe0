"""Atomic file writes: write to a temporary file beside the target, then rename.

A reader never sees a half-written result: ``os.replace`` within one directory is
atomic on POSIX, and on any failure (including ``KeyboardInterrupt``) the
temporary file is removed and an existing file at the target is left untouched.
Temporaries are named ``.NAME.XXXXXXXX.part`` (hidden, in the target directory)
so a killed writer's leftovers are easy to find (``.*.part``).
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable
from pathlib import Path

from mjx_radar.io.checks import InputError


def atomic_write(path: str | Path, write: Callable[[str], object], *, keep_suffix=False) -> None:
    """Calls ``write(tmp_path)`` then renames the temporary file onto ``path``.

    Args:
        path: the file to create or replace; its directory is created if needed.
        write: writes the whole content to the path it is given.
        keep_suffix: end the temporary name in ``.part`` + ``path``'s suffix (for
            writers that pick the format from the extension, e.g. ffmpeg).
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    suffix = ".part" + (path.suffix if keep_suffix else "")
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=suffix)
    os.close(fd)
    try:
        write(tmp)
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def atomic_write_bytes(path: str | Path, data: bytes) -> None:
    """Writes ``data`` to ``path`` atomically."""
    atomic_write(path, lambda tmp: Path(tmp).write_bytes(data))


def atomic_write_text(path: str | Path, text: str) -> None:
    """Writes ``text`` (UTF-8) to ``path`` atomically."""
    atomic_write(path, lambda tmp: Path(tmp).write_text(text, encoding="utf-8"))


def check_writable(path: str | Path, field: str = "--out") -> Path:
    """Checks, before any long computation, that ``path`` can be written atomically.

    Creates the missing parent directories and a probe temporary file in the
    parent (removed at once): this catches read-only and uncreatable locations
    even when running as root, where ``os.access`` always says yes.

    Args:
        path: the output file.
        field: the option named in the error message.

    Returns:
        ``path`` as a :class:`~pathlib.Path`.

    Raises:
        InputError: one line naming ``field`` when the file cannot be written.
    """
    path = Path(path)
    if path.is_dir():
        raise InputError(f"{field} = {str(path)!r}: is a directory, must be a file")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, probe = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".part")
    except OSError as err:
        reason = err.strerror or type(err).__name__
        raise InputError(f"{field} = {str(path)!r}: cannot write there ({reason})") from None
    os.close(fd)
    os.unlink(probe)
    return path


def remove_empty_dirs(created: list[Path]) -> None:
    """Removes directories a command created, if still empty, deepest first (stops at the
    first that is not empty)."""
    for d in created:
        try:
            Path(d).rmdir()
        except OSError:
            return


def create_dir(out: str | Path, field: str = "--out", probe: bool = False) -> list[Path]:
    """Creates directory ``out`` (and parents); returns the directories it created.

    Args:
        out: the directory.
        field: the option named in an error message.
        probe: also check that a file can be written there (a temporary probe file).

    Raises:
        InputError: ``out`` is a file, or cannot be created (or written), in one line.
    """
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise InputError(f"{field} = {str(out)!r}: exists and is not a directory")
    created = [p for p in [out, *out.parents] if not p.exists()]
    try:
        out.mkdir(parents=True, exist_ok=True)
        if probe:
            fd, name = tempfile.mkstemp(dir=out, prefix=".probe.", suffix=".part")
            os.close(fd)
            os.unlink(name)
    except OSError as err:
        remove_empty_dirs(created)
        reason = err.strerror or type(err).__name__
        what = "create or write there" if probe else "create it"
        raise InputError(f"{field} = {str(out)!r}: cannot {what} ({reason})") from None
    return created
