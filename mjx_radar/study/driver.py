"""``mjx-radar study``: a resumable Monte Carlo study over scenarios x methods (SPEC §9).

For every scenario and method the trials ``0..T-1`` run in chunks of ``--chunk``
trials, each chunk one vmapped batch (:func:`mjx_radar.simulation.runner.run_trials`)
split over every local device along the trial axis (a 1-D ``Mesh`` of
``jax.devices()``). Every chunk is padded to the same batch size (repeating its
last trial, padding dropped), so each scenario x method compiles once and a
trial's numbers depend only on the configuration, never on where a run was cut.

Study directory schema::

    DIR/manifest.json      configuration (written first), devices and finished chunks
    DIR/scenarios/*.toml   verbatim copies of the scenario files
    DIR/chunks/<scenario>__<method>__<first>-<last>.parquet
                           metrics of trials first..last (long format, as ``run``),
                           each written atomically when its chunk finishes
    DIR/metrics.parquet    all chunks, ordered by scenario, method, trial, step
    DIR/study.json         metadata, written last: the study is complete

A study killed at any point (even ``kill -9``) resumes with ``--resume`` and
loses at most the chunk in flight; the result is identical to an uninterrupted
run with the same arguments (same devices count: the per-device batch size
enters the floating-point rounding).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import shlex
import shutil
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

from mjx_radar.cli.args import method_list, positive_int
from mjx_radar.errors import InputError
from mjx_radar.task.method import METHODS

#: arguments that must be the same when a study is resumed
CONFIG_KEYS = ("scenarios", "methods", "trials", "steps", "seed", "chunk", "rollouts")


def add_arguments(p: argparse.ArgumentParser) -> None:
    from mjx_radar.cli.args import seed as _seed

    p.add_argument("scenarios", nargs="+", metavar="SCENARIO", help="scenario files or names")
    p.add_argument("--methods", type=method_list, default=list(METHODS), help="default: all")
    p.add_argument("--trials", type=positive_int("--trials", 10**6), default=500)
    p.add_argument("--steps", type=positive_int("--steps"), default=None, help="filter steps")
    p.add_argument("--seed", type=_seed, default=None, help="base seed (default: scenario's)")
    p.add_argument("--chunk", type=positive_int("--chunk", 10**6), default=50, help="trials/batch")
    p.add_argument("--rollouts", choices=("mjx", "analytic"), default=None, help="planner rollouts")
    p.add_argument("--out", type=Path, required=True, help="study directory")
    p.add_argument("--resume", action="store_true", help="continue the study in --out")


def _load(args) -> tuple[list, dict]:
    """Scenarios (with overrides) and the study configuration; raises InputError."""

    from mjx_radar.cli.args import load_with_overrides
    from mjx_radar.io.scenario import resolve_path

    scenarios, entries = [], []
    for name in args.scenarios:
        s, steps = load_with_overrides(name, args.rollouts, args.steps)
        if s.name in [e["name"] for e in entries]:
            raise InputError(f"SCENARIO: scenario name {s.name!r} given twice")
        src = resolve_path(name)
        seed = s.seed if args.seed is None else args.seed
        digest = hashlib.sha256(src.read_bytes()).hexdigest()
        entries.append({"name": s.name, "file": str(src), "sha256": digest})
        scenarios.append((s, src, steps, seed))
    config = {"scenarios": entries, "methods": list(args.methods), "trials": args.trials}
    config |= {"steps": args.steps, "seed": args.seed, "chunk": args.chunk}
    return scenarios, config | {"rollouts": args.rollouts}


def _check_out(out: Path, config: dict, resume: bool) -> dict | None:
    """The manifest to resume from (None: fresh study); raises InputError."""
    if not out.exists() or (out.is_dir() and not any(out.iterdir())):
        return None
    if not out.is_dir():
        raise InputError(f"--out = {str(out)!r}: exists and is not a directory")
    if not resume:
        raise InputError(f"--out = {str(out)!r}: not empty; pass --resume or an empty/new dir")
    path = out / "manifest.json"
    if not path.exists():
        raise InputError(f"--out = {str(out)!r}: not a study directory (no manifest.json)")
    manifest = json.loads(path.read_text())
    for key in CONFIG_KEYS:
        old, new = manifest["config"][key], config[key]
        if key == "scenarios":
            old = [(e["name"], e["sha256"]) for e in old]
            new = [(e["name"], e["sha256"]) for e in new]
        if old != new:
            raise InputError(f"--resume: {key} = {new!r} differs from the study's {old!r}")
    return manifest


def _tasks(scenarios, methods, trials: int, chunk: int, out: Path) -> list[tuple]:
    """All chunks in study order: ``(scenario, method, steps, seed, first, last, path)``."""
    tasks = []
    for s, _, steps, seed in scenarios:
        for method in methods:
            for first in range(0, trials, chunk):
                last = min(first + chunk, trials) - 1
                path = out / "chunks" / f"{s.name}__{method}__{first}-{last}.parquet"
                tasks.append((s, method, steps, seed, first, last, path))
    return tasks


def _sharding():
    """``(NamedSharding of the trial axis over the local devices or None, count, description)``."""
    import jax
    from jax.sharding import Mesh, NamedSharding, PartitionSpec

    devices = jax.devices()
    if len(devices) == 1:  # default placement; lets run_trials use precompiled programs
        return None, 1, str(devices)
    mesh = Mesh(np.asarray(devices), ("trial",))
    return NamedSharding(mesh, PartitionSpec("trial")), len(devices), str(devices)


def main(args) -> int:
    """Runs (or resumes) the study; returns the exit code (input errors raise InputError)."""
    from tqdm import tqdm

    from mjx_radar.cli.args import check_placement as _check_placement
    from mjx_radar.io import results
    from mjx_radar.simulation import runner

    t0 = time.perf_counter()
    scenarios, config = _load(args)
    out = args.out
    manifest = _check_out(out, config, args.resume)
    for s, _, _, seed in scenarios:
        _check_placement(s, seed, args.trials)
    sharding, n_dev, device_str = _sharding()
    chunk = min(args.chunk, args.trials)
    batch = -(-chunk // n_dev) * n_dev  # padded to a multiple of the device count
    if manifest is None:
        for s, src, _, _ in scenarios:
            dst = out / "scenarios" / f"{s.name}.toml"
            results.atomic_write(dst, lambda tmp, src=src: shutil.copyfile(src, tmp))
        manifest = {"config": config, "devices": n_dev, "commands": [], "chunks": {}}
    elif manifest["devices"] != n_dev:
        print(
            f"warning: study started on {manifest['devices']} device(s), resumed on {n_dev}: "
            "trials of new chunks round differently (float32) than an uninterrupted run",
            file=sys.stderr,
        )
    manifest["commands"].append(shlex.join(sys.argv))
    results.write_json(out / "manifest.json", manifest)
    for part in (out / "chunks").glob(".*.part"):  # temporaries of a killed write
        part.unlink()

    tasks = _tasks(scenarios, args.methods, args.trials, chunk, out)
    todo = [t for t in tasks if not t[-1].exists()]
    total = sum(t[2] for t in tasks)
    print(
        f"study: {len(scenarios)} scenario(s) x {len(args.methods)} method(s) x "
        f"{args.trials} trials in chunks of {chunk} ({len(tasks) - len(todo)}/{len(tasks)} "
        f"chunks done) on {n_dev} device(s): {device_str}",
        file=sys.stderr,
    )
    jobs = list(dict.fromkeys((t[0], t[1], t[3]) for t in todo))
    if jobs and n_dev == 1:
        print(f"study: compiling {len(jobs)} program(s) in parallel ...", file=sys.stderr)
        steps0 = todo[0][2]
        same_steps = [j for j in jobs if all(t[2] == steps0 for t in todo if t[0] == j[0])]
        wall = runner.precompile(same_steps, batch, steps0)
        print(f"study: compiled in {wall:.1f} s", file=sys.stderr)
    with tqdm(total=total, initial=total - sum(t[2] for t in todo), unit="step",
              desc="study", file=sys.stderr, dynamic_ncols=True) as bar:  # fmt: skip
        for s, method, steps, seed, first, last, path in todo:
            bar.set_postfix_str(f"{s.name} {method} trials {first}-{last}")
            ids = np.arange(first, last + 1)
            padded = np.concatenate([ids, np.full(batch - len(ids), last)])
            res = runner.run_trials(
                s, method, seed, padded, steps, full=False, progress=bar.update, sharding=sharding
            )
            time_s = s.timing.dt_filter * np.arange(1, steps + 1)
            metrics = {k: res[k][: len(ids)] for k in results.METRIC_COLUMNS}
            results.write_parquet(path, results.metrics_frame(s.name, method, ids, time_s, metrics))
            manifest["chunks"][path.name] = {"wall_s": res["wall_s"]}
            results.write_json(out / "manifest.json", manifest)

    frame = consolidate([t[-1] for t in tasks], [e["name"] for e in config["scenarios"]])
    results.write_parquet(out / "metrics.parquet", frame)
    _finish(out, args, scenarios, manifest, frame, device_str, n_dev, time.perf_counter() - t0)
    return 0


def consolidate(paths: list[Path], scenario_order: list[str]) -> pd.DataFrame:
    """Concatenates chunk files (in the given order) into one long-format table."""
    frame = pd.concat([pd.read_parquet(p) for p in paths], ignore_index=True)
    methods = [m for m in METHODS if m in set(frame["method"].astype(str))]
    frame["scenario"] = pd.Categorical(frame["scenario"].astype(str), categories=scenario_order)
    frame["method"] = pd.Categorical(frame["method"].astype(str), categories=methods)
    return frame


def _finish(out, args, scenarios, manifest, frame, device_str, n_dev, wall_s) -> None:
    from mjx_radar.io import results

    values = frame[list(results.METRIC_COLUMNS)].to_numpy()
    bad = int((~np.isfinite(values)).sum())
    if bad:
        print(f"warning: {bad} non-finite metric values in the study", file=sys.stderr)
    meta = {
        "scenarios": [s.name for s, *_ in scenarios],
        "scenario_files": {s.name: str(src) for s, src, _, _ in scenarios},
        "methods": list(args.methods),
        "trials": args.trials,
        "steps": {s.name: steps for s, _, steps, _ in scenarios},
        "seed": {s.name: seed for s, _, _, seed in scenarios},
        "chunk": args.chunk,
        "rollouts": {s.name: s.mpc.rollout for s, *_ in scenarios},
        "wall_s": wall_s,
        "chunk_wall_s_total": sum(c["wall_s"] for c in manifest["chunks"].values()),
        "devices": device_str,
        "n_devices": n_dev,
        "command": shlex.join(sys.argv),
        "commands": manifest["commands"],
        "non_finite": bad,
    }
    results.write_json(out / "study.json", meta)
    print(f"study complete: {len(frame)} rows in {out / 'metrics.parquet'}; wall {wall_s:.1f} s")
