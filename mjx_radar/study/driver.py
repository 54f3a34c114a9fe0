"""A resumable Monte Carlo study over scenarios x methods (SPEC §9), on any number of devices.

The trials ``0..T-1`` of every scenario x method are cut into *chunks* of ``chunk``
trials (the last one padded by repeating its last trial; padding is dropped). A chunk
is the unit of work and of the files: every device runs one chunk per call with the
same per-device program (:func:`mjx_radar.engine.runner.run_trials` over a mesh of
the local devices), so a trial's numbers depend only on the configuration and the
chunk size -- never on the number of devices, processes or shards, nor on where a
run was cut. Work is split between workers (``jax.distributed`` processes or
``--shard I/N`` jobs) by chunk: worker w of W takes the chunks ``i`` with ``i % W == w``.

Study directory schema::

    DIR/manifest.json      configuration (written first), commands that ran
    DIR/scenarios/*.toml   verbatim copies of the scenario files
    DIR/chunks/<scenario>__<method>__<first>-<last>.parquet
                           metrics of trials first..last (long format, as ``run``),
                           each written atomically when its chunk finishes
    DIR/metrics.parquet    all chunks, ordered by scenario, method, trial, step
    DIR/study.json         metadata, written last: the study is complete

A study killed at any point (even ``kill -9``) resumes with ``--resume`` and loses at
most the chunks in flight; the result is identical to an uninterrupted run.
"""

from __future__ import annotations

import hashlib
import json
import shlex
import shutil
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

from mjx_radar.errors import InputError
from mjx_radar.registry import PLANNERS
from mjx_radar.study.chunks import Chunk
from mjx_radar.task.method import METHODS, parse_method

#: settings that must be the same when a study is resumed (they change the numbers)
CONFIG_KEYS = ("scenarios", "methods", "trials", "steps", "seed", "chunk", "rollouts", "precision")


@dataclass
class Worker:
    """This process's share of the chunks: ``index`` of ``count`` workers."""

    index: int = 0
    count: int = 1
    kind: str = "single"  # "single" | "shard" | "distributed"

    def mine(self, chunks: list[Chunk]) -> list[Chunk]:
        return [c for i, c in enumerate(chunks) if i % self.count == self.index]


@dataclass
class StudyTimes:
    compile_s: float = 0.0  # the rounds waited for programs (study.schedule)
    compile_wall_s: float = 0.0  # from the programs' start until the last was ready
    sim_s: float = 0.0
    chunks_run: int = 0
    start: float = field(default_factory=time.perf_counter)
    first_program: int = 0  # the study's first entry of engine.runner.COMPILE_LOG


def load_scenarios(names, methods, trials, steps, seed, chunk, rollouts, precision="float32"):
    """The scenarios with the command-line overrides, each read once into
    ``(spec, file, steps, seed)`` (its :class:`~mjx_radar.engine.run_spec.RunSpec`: what
    the study's other modules and the engine take), and the study configuration."""
    from mjx_radar.engine.run_spec import run_spec
    from mjx_radar.scenario.motion import check_present
    from mjx_radar.scenario.reader import load_with_overrides, resolve_path

    methods = list(methods)
    for i, m in enumerate(methods):  # before anything runs: duplicates break consolidation
        if m.partition("+")[0] not in METHODS:
            raise InputError(f"methods: {m!r} is not one of {', '.join(METHODS)}")
        try:  # a planner of its own ("METHOD+PLANNER"): registered in this process
            planner = parse_method(m).planner
            PLANNERS.get(planner)
            PLANNERS.key((planner,))  # "policy:DIR": DIR checked before anything runs
        except ValueError as err:
            raise InputError(f"methods: {err}") from None
        if m in methods[:i]:
            raise InputError(f"methods: {m!r} given twice")
    scenarios, entries = [], []
    for name in names:
        s, n_steps = load_with_overrides(name, rollouts, steps)
        check_present(s, n_steps, "steps")  # a run with no target: an RMSE of nothing
        if s.name in [e["name"] for e in entries]:
            raise InputError(f"SCENARIO: scenario name {s.name!r} given twice")
        src = resolve_path(name)
        digest = hashlib.sha256(src.read_bytes()).hexdigest()
        entries.append({"name": s.name, "file": str(src), "sha256": digest})
        scenarios.append((run_spec(s), src, n_steps, s.seed if seed is None else seed))
    config = {"scenarios": entries, "methods": list(methods), "trials": trials}
    config |= {"steps": steps, "seed": seed, "chunk": chunk, "rollouts": rollouts}
    config["precision"] = precision
    return scenarios, config


def check_out(out: Path, config: dict, resume: bool, joining: bool = False) -> dict | None:
    """The manifest to resume from (None: fresh study); raises InputError.

    ``joining``: one of several workers started together; a directory that another
    worker is creating (only ``scenarios/``, ``chunks/`` or temporaries, no manifest
    yet) counts as a fresh study.
    """
    from mjx_radar.io.lock import is_lock_file

    if not out.exists() or (out.is_dir() and all(map(is_lock_file, out.iterdir()))):
        return None  # new, empty, or only the lock files of this study's workers
    if not out.is_dir():
        raise InputError(f"--out = {str(out)!r}: exists and is not a directory")
    if not resume:
        raise InputError(f"--out = {str(out)!r}: not empty; pass --resume or an empty/new dir")
    path = out / "manifest.json"
    starting = all(
        p.name in ("scenarios", "chunks") or p.name.startswith(".") for p in out.iterdir()
    )
    if not path.exists() and joining and starting:
        return None
    if not path.exists():
        raise InputError(f"--out = {str(out)!r}: not a study directory (no manifest.json)")
    try:
        manifest = json.loads(path.read_text())
        old_config = manifest["config"]
    except (OSError, ValueError, KeyError, TypeError):
        raise InputError(f"{path}: damaged study manifest") from None
    for key in CONFIG_KEYS:
        old, new = old_config.get(key, "float32" if key == "precision" else None), config[key]
        if key == "scenarios":
            old = [(e["name"], e["sha256"]) for e in old or []]
            new = [(e["name"], e["sha256"]) for e in new]
        if old != new:
            raise InputError(f"--resume: {key} = {new!r} differs from the study's {old!r}")
    return manifest


def _gospa_settings(metrics) -> dict:
    """The GOSPA / OSPA cutoff and order (a ``[metrics]`` table) a scenario's columns were
    computed with."""
    return {"cutoff": metrics.gospa_cutoff, "order": metrics.gospa_order}


def start_manifest(out: Path, scenarios, config: dict, manifest: dict | None) -> dict:
    """Creates (or extends) ``manifest.json`` and the scenario copies."""
    from mjx_radar.rundir import results

    if manifest is None:
        for s, src, _, _ in scenarios:
            dst = out / "scenarios" / f"{s.name}.toml"
            results.atomic_write(dst, lambda tmp, src=src: shutil.copyfile(src, tmp))
        manifest = {"config": config, "commands": []}
    manifest.setdefault("commands", []).append(shlex.join(sys.argv))
    results.write_json(out / "manifest.json", manifest)
    return manifest


def remove_temporaries(chunks: list[Chunk]) -> None:
    """Removes the temporaries (``.NAME.XXXXXXXX.part``) of killed writes of ``chunks``.

    Call it with the chunks this worker owns (:meth:`Worker.mine`): their only writer
    is this worker, under its lock, so none of them is another worker's write in flight.
    """
    names = {c.path.name for c in chunks}
    for folder in {c.path.parent for c in chunks}:
        for part in folder.glob(".*.part") if folder.is_dir() else ():
            if part.name[1:-5].rsplit(".", 1)[0] in names:
                part.unlink(missing_ok=True)


def finish(
    out,
    scenarios,
    config,
    manifest,
    chunks,
    times: StudyTimes,
    devices: str,
    n_dev: int,
    deterministic: bool = False,
    stream=None,
    host: dict | None = None,
):
    """Consolidates every chunk into ``metrics.parquet`` and writes ``study.json``
    (``deterministic``: whether the kernels were, :func:`mjx_radar.engine.determinism.apply`);
    ``stream``: the :class:`~mjx_radar.study.consolidate.Stream` that wrote it while the
    chunks ran (the chunk files are read back if it is None or incomplete). Returns
    ``(rows, study.json's contents)``."""
    from mjx_radar.engine.runner import program_log
    from mjx_radar.rundir import results
    from mjx_radar.study import consolidate

    t_finish = time.perf_counter()
    summary = stream.finish() if stream is not None else None
    if summary is None:
        order = [e["name"] for e in config["scenarios"]]
        frame = consolidate.read_chunks([c.path for c in chunks], order)
        results.write_parquet(out / "metrics.parquet", frame)
        summary = consolidate.summarise(frame)
    meta = {
        "scenarios": [s.name for s, *_ in scenarios],
        "scenario_files": {s.name: str(src) for s, src, _, _ in scenarios},
        "methods": config["methods"],
        "trials": config["trials"],
        "steps": {s.name: steps for s, _, steps, _ in scenarios},
        "seed": {s.name: seed for s, _, _, seed in scenarios},
        "chunk": config["chunk"],
        "precision": config["precision"],
        "deterministic": deterministic,
        "rollouts": {s.name: s.size.rollout for s, *_ in scenarios},
        "gospa": {s.name: _gospa_settings(s.metrics) for s, *_ in scenarios},
        "wall_s": time.perf_counter() - times.start,
        "compile_s": times.compile_s,
        "compile_wall_s": times.compile_wall_s,
        "sim_s": times.sim_s,
        "programs": program_log(times.first_program),
        "devices": devices,
        "n_devices": n_dev,
        "command": shlex.join(sys.argv),
        "commands": manifest.get("commands", []),
        "non_finite": summary.non_finite,
        "lost": summary.lost,
    }
    if host is not None:
        meta["host"] = host
        meta["host"]["consolidate_s"] = round(time.perf_counter() - t_finish, 3)
    results.write_json(out / "study.json", meta)
    return summary.rows, meta
