"""``mjx-radar study``: a resumable Monte Carlo study (see :mod:`mjx_radar.study.driver`).

One process uses every local device. Many processes split the chunks between them:
``--shard I/N`` (independent jobs, e.g. a SLURM array: scripts/slurm_study.sh) or
``--distributed`` (JAX's multi-controller runtime, ``jax.distributed.initialize``).
Each worker writes its chunks to the shared ``--out``; the worker that finds every
chunk present (process 0 under ``--distributed``, which waits for the others)
consolidates the study.
"""

from __future__ import annotations

import argparse
import sys
import time
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
    p.add_argument("--trials", type=positive_int("--trials", 10**6), default=500,
                   help="Monte Carlo trials per scenario and method (default 500)")  # fmt: skip
    p.add_argument("--steps", type=positive_int("--steps"), default=None, help="filter steps")
    p.add_argument("--seed", type=seed, default=None, help="base seed (default: scenario's)")
    p.add_argument("--chunk", type=positive_int("--chunk", 10**6), default=50,
                   help="trials per device per call, and per result file (default 50)")  # fmt: skip
    p.add_argument("--rollouts", choices=("mjx", "analytic"), default=None, help="planner rollouts")
    p.add_argument("--out", type=Path, required=True, help="study directory")
    p.add_argument("--resume", action="store_true", help="continue the study in --out")
    g = p.add_argument_group("many processes")
    g.add_argument("--shard", type=_shard, default=None, metavar="I/N",
                   help="run only shard I of N (independent jobs sharing --out)")  # fmt: skip
    g.add_argument("--distributed", action="store_true",
                   help="jax.distributed.initialize() (SLURM / env auto-detection)")  # fmt: skip
    g.add_argument("--coordinator", default=None, help="HOST:PORT of process 0 (--distributed)")
    g.add_argument("--num-processes", type=int, default=None, help="(--distributed)")
    g.add_argument("--process-id", type=int, default=None, help="(--distributed)")


def _worker(args):
    from mjx_radar.study.driver import Worker

    if args.shard and args.distributed:
        raise InputError("--shard and --distributed: choose one")
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
        jax.distributed.initialize(**kw)
        return Worker(jax.process_index(), jax.process_count(), "distributed")
    return Worker()


def main(args) -> int:
    from tqdm import tqdm

    from mjx_radar.cli.args import check_placement
    from mjx_radar.simulation import runner
    from mjx_radar.study import driver

    times = driver.StudyTimes()
    scenarios, config = driver.load_scenarios(
        args.scenarios, args.methods, args.trials, args.steps, args.seed, args.chunk,
        args.rollouts, args.precision,
    )  # fmt: skip
    worker = _worker(args)
    joining = worker.kind != "single"  # workers share the directory
    manifest = driver.check_out(args.out, config, args.resume or joining, joining)
    for s, _, _, sd in scenarios:
        check_placement(s, sd, args.trials)
    if worker.index == 0 or worker.kind == "shard":
        manifest = driver.start_manifest(args.out, scenarios, config, manifest)
    chunks = driver.all_chunks(scenarios, args.methods, args.trials, args.chunk, args.out)
    todo = [c for c in worker.mine(chunks) if not c.path.exists()]
    mesh = runner.device_mesh()
    n_dev, devices = mesh.size, str(list(mesh.devices.flat))
    from mjx_radar.simulation import resources

    for s, _, n_steps, _ in scenarios:  # refuse what cannot fit before compiling anything
        resources.check(s, args.chunk * n_dev, n_steps, devices=n_dev)
    print(
        f"study: {len(scenarios)} scenario(s) x {len(args.methods)} method(s) x {args.trials} "
        f"trials, chunks of {args.chunk}; worker {worker.index + 1}/{worker.count}: "
        f"{len(todo)} chunk(s) to run on {n_dev} device(s): {devices}",
        file=sys.stderr,
    )
    if todo:
        steps0 = todo[0].steps
        shapes = [c.scenario for c in todo if c.steps == steps0]
        print(f"study: compiling for {n_dev} device(s) ...", file=sys.stderr)
        wall = runner.precompile(shapes, args.chunk * n_dev, steps0, mesh=mesh)
        times.compile_s += wall
        print(f"study: compiled in {wall:.1f} s", file=sys.stderr)
    total = sum(c.steps * (c.last - c.first + 1) for c in todo)
    with tqdm(total=total, unit="trial-step", desc="study", file=sys.stderr,
              dynamic_ncols=True, disable=not todo) as bar:  # fmt: skip
        for group in driver.rounds(todo, n_dev):
            bar.set_postfix_str(f"{group[0].scenario.name} {group[0].method}")
            done = sum(c.last - c.first + 1 for c in group)
            driver.run_round(
                group, args.chunk, n_dev, mesh, lambda k, n=done: bar.update(k * n), times
            )
    if worker.kind == "distributed":
        # Every process waits: JAX's shutdown barrier gives up after 300 s, so a process
        # that left early would abort the others. Process 0 then consolidates.
        _wait_for(chunks)
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
    frame, meta = driver.finish(
        args.out, scenarios, config, manifest or {}, chunks, times, devices, n_dev
    )
    print(
        f"study complete: {len(frame)} rows in {args.out / 'metrics.parquet'}; wall "
        f"{meta['wall_s']:.1f} s (compile {meta['compile_s']:.1f} s, simulation "
        f"{meta['sim_s']:.1f} s)"
    )
    return 0


def _wait_for(chunks, timeout_s: float = 7 * 24 * 3600.0) -> None:
    """A process of a distributed study waits until every chunk file exists."""
    deadline = time.monotonic() + timeout_s
    while not all(c.path.exists() for c in chunks):
        if time.monotonic() > deadline:
            raise TimeoutError("distributed study: chunks still missing after the timeout")
        time.sleep(1.0)
