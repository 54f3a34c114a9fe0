"""Threads that compile: a stack large enough for XLA, the caller's x64 mode, and calls
run side by side."""

from __future__ import annotations

import threading
import weakref

import jax

_LIVE: weakref.WeakSet = weakref.WeakSet()  # the threads compile_thread made

#: stack size of threads that compile (XLA's compiler recurses deeply on large programs;
#: the default 8 MiB thread stack overflowed compiling a 2-GPU program)
COMPILE_THREAD_STACK = 512 * 1024 * 1024


def compile_thread(target, name: str = "compile"):
    """A thread with a stack large enough for XLA compilation, tracing in the creating
    thread's x64 mode.

    JAX's ``jax.enable_x64`` context holds only in the thread that entered it, so a
    program traced in a new thread under ``simulate(..., precision="float64")`` was
    float32 and its float64 arguments were refused.

    Not a daemon: an interpreter that ends while such a thread is inside XLA waits for
    the compilation to finish (XLA cannot be stopped). A daemon thread there aborted the
    process at exit ("terminate called ...", exit 134): e.g. after ``simulate`` refused
    radars that cannot be placed while its program compiled in the background. The
    ``mjx-radar`` command does not wait (:func:`busy`; ``cli.main.entry``, and
    ``os._exit`` on Ctrl-C).
    """
    x64 = bool(jax.config.jax_enable_x64)

    def run():
        with jax.enable_x64(x64):
            target()

    old = threading.stack_size(COMPILE_THREAD_STACK)
    try:
        thread = threading.Thread(target=run, name=name, daemon=False)
    finally:
        threading.stack_size(old)
    _LIVE.add(thread)
    return thread


def busy() -> bool:
    """Whether a :func:`compile_thread` is still running (e.g. a program compiling in the
    background for a run that was refused meanwhile)."""
    return any(t.is_alive() for t in list(_LIVE))


class Started:
    """``fn()`` running in a :func:`compile_thread` from now on; :meth:`result` waits for it.

    The caller waits in short slices, so Ctrl-C is honoured at once even while the
    thread sits in an XLA compilation that does not return to Python for minutes.
    """

    def __init__(self, fn, name: str = "compile"):
        self._box: dict = {}

        def work():
            try:
                self._box["value"] = fn()
            except BaseException as err:  # noqa: BLE001 -- re-raised by result()
                self._box["error"] = err

        self._thread = compile_thread(work, name)
        self._thread.start()

    def running(self) -> bool:
        """Whether ``fn()`` is still running."""
        return self._thread.is_alive()

    def wait(self, poll: float = 0.2) -> None:
        """Returns once ``fn()`` returned or raised."""
        while self._thread.is_alive():
            self._thread.join(poll)

    def result(self, poll: float = 0.2):
        """``fn()``'s value, once it returned; its error is raised here."""
        self.wait(poll)
        if "error" in self._box:
            raise self._box["error"]
        return self._box["value"]


def parallel(fns) -> list:
    """``[f() for f in fns]``, each call in its own big-stack thread (:class:`Started`).

    Every call is waited for, in short slices, so Ctrl-C is honoured at once even during
    an XLA compilation; then the error of the first call that failed (in the order
    given) is raised in the caller's thread.
    """
    started = [Started(f) for f in fns]
    for s in started:
        s.wait()
    return [s.result() for s in started]
