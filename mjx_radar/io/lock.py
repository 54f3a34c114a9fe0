"""One writer per output directory: an advisory ``flock`` on ``DIR/.lock``.

Two processes writing one run or study directory at once would interleave their
files and both claim the results. :func:`lock_dir` takes an exclusive, non-blocking
``fcntl.flock`` on ``DIR/.lock`` (created if missing, holding the holder's pid) and
keeps it until :meth:`DirLock.release` (or the ``with`` block ends, or the process
exits: the kernel drops a ``flock`` with its last file descriptor, so a ``kill -9``
never leaves a stale lock). A second writer gets a one-line
:class:`~mjx_radar.errors.InputError` naming the holder's pid (exit 2 on the command
line). Locks belong to an open file description, so a second :func:`lock_dir` on the
same directory conflicts even within one process.

``shared=True`` takes a shared lock instead: workers that deliberately share one
directory (``study --shard I/N``, ``--distributed``) hold it together, and it still
excludes an exclusive writer (a plain ``study`` or ``--resume`` of the same
directory). Such workers add an exclusive lock of their own (``name``, e.g.
``.lock.shard-0-of-4``) so that the same shard cannot run twice at once.

On release the file is removed while exclusively locked (a shared holder first tries
to upgrade without waiting, and leaves the file to the others if that fails); a
writer that locked a file which was meanwhile removed (its inode no longer at the
path) retries on the new one, so two writers never hold locks on different inodes.
A lock file left by a killed writer is harmless: the next writer locks and reuses it.
On a file system without ``flock`` support (some network mounts) the lock is skipped.
"""

from __future__ import annotations

import contextlib
import errno
import os
from pathlib import Path

from mjx_radar.io.checks import InputError

LOCK_NAME = ".lock"


class DirLock:
    """A held lock on a directory (see :func:`lock_dir`); release it once.

    Attributes:
        path: the lock file, ``DIR/.lock``.
    """

    def __init__(self, path: Path, fd: int | None):
        self.path = path
        self._fd = fd

    @property
    def held(self) -> bool:
        """True until :meth:`release` (False from the start where ``flock`` is unsupported)."""
        return self._fd is not None

    def release(self) -> None:
        """Drops the lock, removing the file if no one else holds it (idempotent)."""
        import fcntl

        fd, self._fd = self._fd, None
        if fd is None:
            return
        with contextlib.suppress(OSError):  # fails if others hold it shared: keep the file
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            if os.fstat(fd).st_ino == os.stat(self.path).st_ino:
                self.path.unlink()
        os.close(fd)

    def __enter__(self) -> DirLock:
        return self

    def __exit__(self, *exc) -> None:
        self.release()


def holder_pid(path: str | Path) -> int | None:
    """The pid written in a lock file (the last writer that locked it), or None."""
    try:
        return int(Path(path).read_text().split()[0])
    except (OSError, ValueError, IndexError):
        return None


def is_lock_file(path: str | Path) -> bool:
    """True for the files of this module (``.lock``, ``.lock.*``)."""
    name = Path(path).name
    return name == LOCK_NAME or name.startswith(LOCK_NAME + ".")


def lock_dir(
    directory: str | Path,
    field: str = "--out",
    *,
    shared: bool = False,
    name: str = LOCK_NAME,
    what: str = "is writing there",
) -> DirLock:
    """Takes the writer's lock of ``directory`` (which must exist).

    Args:
        directory: the run or study directory.
        field: the option named in the error message.
        shared: a shared lock (workers of one study) instead of an exclusive one.
        name: the lock file's name in ``directory`` (:func:`is_lock_file` must hold).
        what: what the holder does, for the error message.

    Returns:
        The held :class:`DirLock` (a context manager).

    Raises:
        InputError: another process (or another lock in this one) holds it:
            ``--out = 'DIR': another mjx-radar process (pid N) is writing there``;
            or the lock file cannot be created.
    """
    import fcntl

    path = Path(directory) / name
    mode = fcntl.LOCK_SH if shared else fcntl.LOCK_EX
    for _ in range(100):  # retried only when the file was replaced under us
        try:
            fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o644)
        except OSError as err:
            reason = err.strerror or type(err).__name__
            raise InputError(f"{field} = {str(directory)!r}: cannot lock it ({reason})") from None
        try:
            fcntl.flock(fd, mode | fcntl.LOCK_NB)
        except OSError as err:
            os.close(fd)
            if err.errno in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                pid = holder_pid(path)
                who = f"another mjx-radar process (pid {pid})" if pid else "another process"
                raise InputError(
                    f"{field} = {str(directory)!r}: {who} {what}; wait for it to finish "
                    f"or use another directory"
                ) from None
            return DirLock(path, None)  # ENOLCK / EOPNOTSUPP: no locking on this mount
        try:
            same = os.fstat(fd).st_ino == os.stat(path).st_ino
        except FileNotFoundError:
            same = False
        if same:
            os.ftruncate(fd, 0)
            os.write(fd, f"{os.getpid()}\n".encode())
            return DirLock(path, fd)
        os.close(fd)  # released and removed by its holder meanwhile: lock the new file
    raise InputError(f"{field} = {str(directory)!r}: cannot lock it (lock file keeps changing)")
