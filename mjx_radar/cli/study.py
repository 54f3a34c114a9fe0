"""``mjx-radar study``: a resumable Monte Carlo study (see :mod:`mjx_radar.study.driver`).

One process uses every local device. Many processes split the chunks between them:
``--shard I/N`` (independent jobs, e.g. a SLURM array: scripts/slurm_study.sh) or
``--distributed`` (JAX's multi-controller runtime, ``jax.distributed.initialize``).
Each worker writes its chunks to the shared ``--out``; the worker that finds every
chunk present (process 0 under ``--distributed``, which waits for the others)
consolidates the study.

One study per directory at a time (:mod:`mjx_radar.io.lock`): a plain study (or
``--resume``) holds ``--out``'s lock exclusively, so a second one is refused in one
line (exit 2). The workers of ``--shard I/N`` and ``--distributed`` share the
directory on purpose, so they hold it *shared* (still excluding a plain study or
``--resume`` of it) plus an exclusive lock of their own worker,
``.lock.shard-I-of-N``, so the same shard cannot run twice at once.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from mjx_radar.cli.args import method_list, positive_int, seed
from mjx_radar.errors import InputError
from mjx_radar.task.method import METHODS


def _shard(text: str) -> tuple[int, int]:
    try:
        i, n = (int(x) for x in text.split("/"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"--shard = {text!r}: must be I/N, e.g. 0/4") from None
    if not (n >= 1 and 0 <= i < n):
        raise argparse.ArgumentTypeError(f"--shard = {text!r}: need 0 <= I < N")
    return i, n


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("scenarios", nargs="+", metavar="SCENARIO", help="scenario files or names")
    p.add_argument("--methods", type=method_list, default=list(METHODS), help="default: all")
    p.add_argument(
        "--planners",
        default=None,
        metavar="A,B",
        help="run every planning method with each of these planners (mppi, ps, cem, "
        "grad, hybrid, policy:DIR, or registered by a --plugin file): METHOD+PLANNER",
    )
    p.add_argument(
        "--plugin",
        action="append",
        default=[],
        metavar="FILE",
        help="a Python file run first, e.g. one that registers a planner",
    )
    p.add_argument(
        "--trials",
        type=positive_int("--trials", 10**6),
        default=500,
        help="Monte Carlo trials per scenario and method (default 500)",
    )
    p.add_argument("--steps", type=positive_int("--steps"), default=None, help="filter steps")
    p.add_argument("--seed", type=seed, default=None, help="base seed (default: scenario's)")
    p.add_argument(
        "--chunk",
        type=positive_int("--chunk", 10**6),
        default=50,
        help="trials per device per call, and per result file (default 50)",
    )
    p.add_argument("--rollouts", choices=("mjx", "analytic"), default=None, help="planner rollouts")
    p.add_argument("--out", type=Path, required=True, help="study directory")
    p.add_argument("--resume", action="store_true", help="continue the study in --out")
    g = p.add_argument_group("many processes")
    g.add_argument(
        "--shard",
        type=_shard,
        default=None,
        metavar="I/N",
        help="run only shard I of N (independent jobs sharing --out)",
    )
    g.add_argument(
        "--distributed",
        action="store_true",
        help="jax.distributed.initialize() (SLURM / env auto-detection)",
    )
    g.add_argument("--coordinator", default=None, help="HOST:PORT of process 0 (--distributed)")
    g.add_argument("--num-processes", type=int, default=None, help="(--distributed)")
    g.add_argument("--process-id", type=int, default=None, help="(--distributed)")


def check_processes(args) -> None:
    """The many-process flags: one of --shard and --distributed; --coordinator,
    --num-processes and --process-id only with --distributed, in range (one line)."""
    given = [
        flag
        for flag, v in (
            ("--coordinator", args.coordinator),
            ("--num-processes", args.num_processes),
            ("--process-id", args.process_id),
        )
        if v is not None
    ]
    if args.shard and args.distributed:
        raise InputError("--shard and --distributed: choose one")
    if given and not args.distributed:
        raise InputError(f"{given[0]}: only with --distributed (else one process runs it all)")
    n, i = args.num_processes, args.process_id
    if n is not None and n < 1:
        raise InputError(f"--num-processes = {n}: must be an integer >= 1")
    if i is not None and (n is None or not 0 <= i < n):
        need = "give --num-processes too" if n is None else f"must be in [0, {n - 1}]"
        raise InputError(f"--process-id = {i}: {need}")
    if args.coordinator is not None:
        host, colon, port = args.coordinator.rpartition(":")
        if not (colon and host and port.isdigit() and 0 < int(port) < 65536):
            raise InputError(f"--coordinator = {args.coordinator!r}: must be HOST:PORT")


def _worker(args):
    from mjx_radar.study.driver import Worker

    if args.shard:
        return Worker(args.shard[0], args.shard[1], "shard")
    if args.distributed:
        import jax

        kw = {
            k: v
            for k, v in (
                ("coordinator_address", args.coordinator),
                ("num_processes", args.num_processes),
                ("process_id", args.process_id),
            )
            if v is not None
        }
        try:
            jax.distributed.initialize(**kw)
        except (ValueError, RuntimeError) as err:  # no cluster found, coordinator unreachable
            first = str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__
            if args.coordinator is None and "coordinator_address" in first:
                first = "no coordinator given and no cluster found"
            raise InputError(
                f"--distributed: {first} (give --coordinator HOST:PORT, --num-processes N and "
                "--process-id I, or run under SLURM)"
            ) from None
        return Worker(jax.process_index(), jax.process_count(), "distributed")
    return Worker()


def main(args) -> int:
    from mjx_radar.api.run_case import load_plugins
    from mjx_radar.planners import PLANNERS
    from mjx_radar.study import execute
    from mjx_radar.task.method import with_planners

    check_processes(args)
    load_plugins(args.plugin)
    methods = args.methods
    if args.planners is not None:
        planners = [x.strip() for x in args.planners.split(",") if x.strip()]
        if not planners:
            raise InputError(f"--planners = {args.planners!r}: give one or more planner names")
        try:
            for name in planners:
                PLANNERS.get(name)
            methods = with_planners(methods, planners)
        except ValueError as err:
            raise InputError(f"--planners: {err}") from None
    opts = execute.StudyOptions(
        scenarios=args.scenarios,
        methods=methods,
        trials=args.trials,
        steps=args.steps,
        seed=args.seed,
        chunk=args.chunk,
        rollouts=args.rollouts,
        out=args.out,
        resume=args.resume,
        precision=args.precision,
        deterministic=args.deterministic,
    )
    return execute.run_study(opts, lambda: _worker(args))
