"""One Monte Carlo study from its options to ``study.json``: ``mjx-radar study`` and
``mjx_radar.run_study`` both call :func:`run_study` (chunks and files:
:mod:`mjx_radar.study.driver`).

Order of work: the scenarios are loaded and validated, the worker is set up (a
``jax.distributed`` process, a ``--shard``, or the only one), ``--out`` is locked
(:func:`lock_out`), the study directory is checked against a resumed study's settings and
memory for every scenario; then the programs start compiling in the background
(:mod:`mjx_radar.study.schedule`) while placement is checked, and only then is anything
written; each device runs the next chunk as soon as it is free and the chunk's program is
ready (:mod:`mjx_radar.study.lanes`), the host writing the chunks meanwhile, and the worker
that finds every chunk present consolidates.

One study per directory at a time (:mod:`mjx_radar.io.lock`): a plain study (or a
resume) holds the directory's lock exclusively, so a second one is refused in one line
(exit 2 on the command line). The workers of ``--shard I/N`` and ``--distributed``
share the directory on purpose, so they hold it *shared* (still excluding a plain
study or a resume of it) plus an exclusive lock of their own worker,
``.lock.shard-I-of-N``, so the same shard cannot run twice at once.
"""

from __future__ import annotations

import dataclasses
import sys
import time
from collections.abc import Callable
from pathlib import Path

from mjx_radar.errors import InputError
from mjx_radar.io.atomic import create_dir, remove_empty_dirs


@dataclasses.dataclass
class StudyOptions:
    """What a study runs (the options of ``mjx-radar study``).

    Attributes:
        scenarios: scenario files or bundled names.
        methods: canonical method names, each once.
        trials, steps, seed, chunk, rollouts: as ``mjx-radar study --help`` says
            (``steps``/``seed``/``rollouts`` ``None``: each scenario's).
        out: the study directory.
        resume: continue the study in ``out``.
        precision: ``"float32"`` or ``"float64"`` (x64 must already be on for the latter).
        progress: show a progress bar on stderr.
        deterministic: deterministic GPU kernels (``None``: on where they can still be
            set; :func:`mjx_radar.engine.determinism.apply`).
    """

    scenarios: list
    methods: list
    trials: int
    steps: int | None
    seed: int | None
    chunk: int
    rollouts: str | None
    out: Path
    resume: bool = False
    precision: str = "float32"
    progress: bool = True
    deterministic: bool | None = None


def lock_out(out: Path, worker) -> tuple[list[Path], list]:
    """Creates ``out`` if needed and takes its locks (see the module docstring).

    Returns:
        ``(created, locks)``: the directories it created and the held
        :class:`~mjx_radar.io.lock.DirLock` s.

    Raises:
        InputError: ``out`` is a file or cannot be created, or another process holds
            a conflicting lock.
    """
    from mjx_radar.io.lock import lock_dir

    out = Path(out)
    created = create_dir(out)
    locks = []
    try:
        if worker.kind == "single":
            locks.append(lock_dir(out))
        else:
            locks.append(lock_dir(out, shared=True))
            own = f"{worker.kind}-{worker.index}-of-{worker.count}"
            what = f"is running {worker.kind} {worker.index}/{worker.count} there"
            locks.append(lock_dir(out, name=f".lock.{own}", what=what))
    except InputError:
        for lock in locks:
            lock.release()
        remove_empty_dirs(created)
        raise
    return created, locks


def run_study(opts: StudyOptions, make_worker: Callable | None = None) -> int:
    """Runs (or resumes, or joins) the study of ``opts``; 0 when this worker is done.

    Args:
        opts: the study.
        make_worker: returns this process's :class:`~mjx_radar.study.driver.Worker`
            (called after the scenarios validated); default the only worker.

    Raises:
        ScenarioError, InputError: bad scenarios or options, an unusable or locked
            ``out``, settings differing from the resumed study's, a study too large.
    """
    from mjx_radar.engine import determinism

    # before anything starts JAX's backend; from here on: whether the kernels are
    opts = dataclasses.replace(opts, deterministic=determinism.apply(opts.deterministic))
    from mjx_radar.engine.runner import COMPILE_LOG
    from mjx_radar.study import driver

    times = driver.StudyTimes(first_program=len(COMPILE_LOG))
    scenarios, config = driver.load_scenarios(
        opts.scenarios,
        opts.methods,
        opts.trials,
        opts.steps,
        opts.seed,
        opts.chunk,
        opts.rollouts,
        opts.precision,
    )
    worker = make_worker() if make_worker else driver.Worker()
    created, locks = lock_out(opts.out, worker)
    try:
        return _study(opts, scenarios, config, worker, times)
    except BaseException:
        for lock in locks:
            lock.release()
        if worker.kind == "single":  # workers may be creating the directory together
            remove_empty_dirs(created)  # only if still empty: a refusal before the manifest
        raise
    finally:
        for lock in locks:
            lock.release()


def _study(args: StudyOptions, scenarios, config, worker, times) -> int:

    from mjx_radar.engine import live_programs, runner
    from mjx_radar.engine.placement_cache import check_placeable
    from mjx_radar.study import chunks as chunks_of
    from mjx_radar.study import driver, lanes, schedule

    joining = worker.kind != "single"  # workers share the directory
    manifest = driver.check_out(args.out, config, args.resume or joining, joining)
    mesh = runner.device_mesh()
    n_dev, devices = mesh.size, str(list(mesh.devices.flat))
    _check_resources(args, scenarios, n_dev)  # before writing anything
    chunks = chunks_of.all_chunks(scenarios, args.methods, args.trials, args.chunk, args.out)
    todo = [c for c in worker.mine(chunks) if not c.path.exists()]
    stream = _stream(args, scenarios, worker, chunks, todo)
    # One program per shape, kind and planner on each device: counting (scenario, method)
    # pairs instead kept 15 of the paper study's 36 programs alive on 4 GPUs, and the
    # evicted ones were loaded again round after round (61 loads instead of 27).
    with live_programs.keep_alive(
        runner.programs_needed([(c.spec, c.method) for c in todo], n_dev)
    ):
        # compiling from here on (study.schedule), beside the placement check
        started = schedule.start(todo, args.chunk * n_dev, mesh)
        for s, _, _, sd in scenarios:
            check_placeable(s, sd, args.trials)
        if worker.index == 0 or worker.kind == "shard":
            manifest = driver.start_manifest(args.out, scenarios, config, manifest)
        driver.remove_temporaries(worker.mine(chunks))  # of this worker's killed writes
        _announce(args, len(scenarios), worker, len(todo), len(started), (n_dev, devices))
        try:
            host = lanes.run_lanes(args, todo, mesh, times, started, stream)
        except BaseException:
            if stream is not None:
                stream.drop()  # the chunk files written so far stay for --resume
            raise
    if worker.kind == "distributed":
        # Every process waits: JAX's shutdown barrier gives up after 300 s, so a process
        # that left early would abort the others. Process 0 then consolidates.
        wait_for(chunks)
        if worker.index != 0:
            return 0
    missing = [c for c in chunks if not c.path.exists()]
    if missing:
        print(
            f"study: shard {worker.index}/{worker.count} done; {len(chunks) - len(missing)} of "
            f"{len(chunks)} chunks present; the last shard to finish (or --resume) consolidates",
            file=sys.stderr,
        )
        return 0
    run = (chunks, times, devices, n_dev, args.deterministic, stream, host)
    rows, meta = driver.finish(args.out, scenarios, config, manifest or {}, *run)
    print(
        f"study complete: {rows} rows in {args.out / 'metrics.parquet'}; wall "
        f"{meta['wall_s']:.1f} s (compile {meta['compile_s']:.1f} s before and between the "
        f"chunks, the last program ready after {meta['compile_wall_s']:.1f} s; simulation "
        f"{meta['sim_s']:.1f} s)"
    )
    return 0


def _check_resources(args: StudyOptions, scenarios, n_dev: int) -> None:
    """Refuses what cannot fit, for each program of each shape (engine.resources)."""
    from mjx_radar.engine import resources, runner

    programs = runner.program_map([(s, m) for s, *_ in scenarios for m in args.methods])
    for s, _, n_steps, _ in scenarios:
        shape = s.shape
        for kind in sorted({k for (sh, _), (k, _) in programs.items() if sh == shape}):
            opts = {"full": False, "batch_option": "--chunk", "kind": kind}
            resources.check(s, args.chunk * n_dev, n_steps, n_dev, **opts)


def _stream(args: StudyOptions, scenarios, worker, chunks, todo):
    """``metrics.parquet`` written while the chunks run (a fresh single-worker study), or
    None (study.consolidate); a killed run's partial file removed."""
    from mjx_radar.study import consolidate

    if worker.kind != "single":
        return None
    consolidate.remove_partial(args.out)  # of a killed run of this study
    if len(todo) != len(chunks):
        return None
    names = [s.name for s, *_ in scenarios]
    metrics = args.out / "metrics.parquet"
    return consolidate.Stream(metrics, [c.path for c in chunks], names, args.methods)


def _announce(args: StudyOptions, n_scenarios: int, worker, n_todo: int, n_started, where):
    """The study's first lines on stderr: its size, this worker's chunks, compiling."""
    n_dev, devices = where
    print(
        f"study: {n_scenarios} scenario(s) x {len(args.methods)} method(s) x "
        f"{args.trials} trials, chunks of {args.chunk}; worker {worker.index + 1}/"
        f"{worker.count}: {n_todo} chunk(s) to run on {n_dev} device(s): {devices}",
        file=sys.stderr,
    )
    if n_started:
        print(
            f"study: compiling {n_started} program(s) for {n_dev} device(s); each "
            "scenario's chunks start as soon as its program is ready",
            file=sys.stderr,
        )


def wait_for(chunks, timeout_s: float = 7 * 24 * 3600.0) -> None:
    """A process of a distributed study waits until every chunk file exists."""
    deadline = time.monotonic() + timeout_s
    while not all(c.path.exists() for c in chunks):
        if time.monotonic() > deadline:
            raise TimeoutError("distributed study: chunks still missing after the timeout")
        time.sleep(1.0)
