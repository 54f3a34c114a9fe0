"""``mjx-radar run``: the closed loop on one scenario, results in a run directory.

Before anything is compiled the command checks, each failure one line and exit 2:
the scenario and options, that ``--out`` can be created and written (a probe file),
that no other process is writing there (it holds ``--out``'s lock until it is done:
:mod:`mjx_radar.io.lock`; ``--force`` does not override a live writer), that it does
not hold a complete run (unless ``--force``), and that the run fits in memory
(:mod:`mjx_radar.engine.resources`). That the radars can be placed is checked by the
run's own initial conditions before its first step (:func:`mjx_radar.engine.runner.run_trials`:
one line, exit 2, nothing written; the compiled program stays in the cache for the
corrected scenario); ``mjx-radar validate`` checks it without compiling the loop.
The simulation runs in a worker thread so Ctrl-C is honoured at once, even in the
middle of a long compilation: one line, exit 130, no result file. Results are
written atomically, ``run.json`` last; an interrupted write removes what it wrote.
``--force`` discards the old run's ``run.json`` before the simulation starts, so an
interrupted overwrite never leaves a directory that looks complete. Trials whose
filter diverged (``res["diverged"]``) make the command exit 1 after writing the
results, unless ``--keep-diverged``. ``--view`` serves a live view of the run
(:mod:`mjx_radar.viz.live_view.live`) at the URL it prints; after the results are written it keeps
serving the whole run until Ctrl-C, or ``--view-linger`` seconds.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
from pathlib import Path

import numpy as np

from mjx_radar.cli.run_args import add_arguments  # noqa: F401 (the sub-command's options)
from mjx_radar.cli.run_output import finish
from mjx_radar.errors import EXIT_INTERRUPTED, InputError
from mjx_radar.io.atomic import create_dir, remove_empty_dirs
from mjx_radar.io.lock import DirLock, lock_dir


def prepare_out(out: Path, force: bool) -> tuple[list[Path], DirLock]:
    """Checks that ``out`` can hold a new run, creating and locking it.

    Returns:
        ``(created, lock)``: the directories it created (for :func:`remove_dirs`) and
        the writer's lock of ``out`` (:mod:`mjx_radar.io.lock`), to release when done.

    Raises:
        InputError: ``out`` is a file, holds a complete run (without ``force``),
            cannot be created or written (checked with a probe file), or another
            process is writing there.
    """
    out = Path(out)
    created = create_dir(out, probe=True)
    try:
        lock = lock_dir(out)  # checked after locking: a writer may finish meanwhile
        if (out / "run.json").exists() and not force:
            lock.release()
            raise InputError(
                f"--out = {str(out)!r}: holds a complete run; pass --force or another dir"
            )
    except InputError:
        remove_dirs(created)
        raise
    return created, lock


def remove_dirs(created: list[Path]) -> None:
    """Removes the directories :func:`prepare_out` created, if still empty (deepest first)."""
    remove_empty_dirs(created)


def simulate(fn):
    """``fn()`` in a worker thread; Ctrl-C in the main thread is seen at once.

    The main thread only waits (in short, interruptible slices), so a
    ``KeyboardInterrupt`` is raised here even while the worker sits in a long XLA
    compilation that would not return to Python for minutes.
    """
    from mjx_radar.engine.threads import Started

    return Started(fn, name="closed-loop").result(poll=0.1)


def main(args) -> int:
    from mjx_radar.api import run_case
    from mjx_radar.engine import resources

    req = run_case.request(  # the checks and defaults of mjx_radar.simulate
        args.scenario,
        cli=True,
        method=args.method,
        planner=args.planner,
        trials=args.trials,
        steps=args.steps,
        seed=args.seed,
        rollouts=args.rollouts,
        association=getattr(args, "association", None),
        precision=getattr(args, "precision", "float32"),
        deterministic=getattr(args, "deterministic", None),
        cache=not getattr(args, "no_cache", False),
        cache_dir=getattr(args, "cache_dir", None),
        plugins=args.plugin,
        gospa_cutoff=getattr(args, "gospa_cutoff", None),
        gospa_order=getattr(args, "gospa_order", None),
        masks=bool(getattr(args, "masks", False)),
    )
    s, steps, seed_ = req.scenario, req.steps, req.seed
    args.method = req.method.name  # "METHOD+PLANNER" with --planner
    out = args.out or Path("runs") / f"{s.name}_{args.method}"
    created, lock = prepare_out(out, args.force)

    def drop():  # an unfinished run: release the lock, remove the directories it made
        lock.release()
        remove_dirs(created)

    try:
        est = resources.check(req.spec, args.trials, steps, kind=req.method.kind)
    except BaseException:
        drop()
        raise
    fmt = resources.fmt_bytes
    print(
        f"{s.name}: {args.method}, {args.trials} trial(s) x {steps} steps, seed {seed_}, "
        f"~{fmt(est.device_bytes)} device / ~{fmt(est.host_bytes)} host memory",
        file=sys.stderr,
    )
    if est.large:
        print(f"warning: {est.large_line()}; Ctrl-C stops it", file=sys.stderr, flush=True)
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, _terminate)  # kill PID: the same clean exit as Ctrl-C
    trials = np.arange(args.trials)
    live = None
    try:
        live = _live_view(args, s, trials, steps)
        programs = run_case.start_programs(req, live)
        threading.Thread(target=_import_writers, name="writers", daemon=True).start()
        if args.force:
            (out / "run.json").unlink(missing_ok=True)  # the old run is incomplete from now on
        print(est.compile_line(), file=sys.stderr, flush=True)
        res = simulate(lambda: _run(req, live, programs))
    except KeyboardInterrupt:
        drop()
        print("\ninterrupted: no results written", file=sys.stderr, flush=True)
        os._exit(EXIT_INTERRUPTED)  # the worker may be inside XLA; do not wait for it
    except BaseException:
        drop()
        if live is not None:
            live.close()
        raise
    try:
        return finish(out, args, s, seed_, trials, steps, res)
    finally:
        lock.release()
        if live is not None:
            live.linger(args.view_linger)


def _live_view(args, s, trials, steps):
    """The live server of ``--view`` (``None`` without it)."""
    if not (args.view or args.view_port is not None):
        return None
    from mjx_radar.viz.live_view.live import start
    from mjx_radar.viz.scene import scene_of

    return start(scene_of(s), trials, steps, args.view_port)


def _import_writers() -> None:
    """pandas and pyarrow (0.3-0.5 s of imports), which only the result files need,
    imported while the run loads its programs and simulates (both mostly outside the GIL)."""
    import pandas  # noqa: F401
    import pyarrow.parquet  # noqa: F401


def _terminate(signum, frame):
    raise KeyboardInterrupt


def _run(req, live=None, programs=None):
    from tqdm import tqdm

    from mjx_radar.api import run_case
    from mjx_radar.api.simulate import bar_phase

    with tqdm(total=req.steps, unit="step", desc="closed loop", file=sys.stderr) as bar:
        return run_case.execute(req, bar.update, bar_phase(bar), live, False, programs)
