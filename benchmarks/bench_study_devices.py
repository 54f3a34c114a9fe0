"""A study on several device counts of one host, cold, its numbers compared value by value.

Runs ``mjx-radar study STUDY_ARGS`` once per entry of ``--gpus`` (the host's first N GPUs,
``CUDA_VISIBLE_DEVICES``), each in a fresh process with a fresh cache directory; an entry
``PxN`` runs P ``--distributed`` processes of N GPUs each on localhost. Reads each
``study.json`` (wall, compile, simulation, the host's seconds after the last chunk),
compares every metric value with the first entry's study (``compare_studies.py``) and
writes ``benchmarks/results/ID.json`` (``--results``) with one row per entry; speed-ups
are against the entry ``1``. Usage (the paper study of docs/scaling.md)::

    python benchmarks/bench_study_devices.py --id paper_study_gpus_h200 \\
        --hardware "4x NVIDIA H200" --gpus 1 2 4 -- \\
        scenarios/paper_3r4t.toml scenarios/paper_6r3t.toml scenarios/paper_4r4t.toml \\
        --trials 500 --chunk 250
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import shlex
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from compare_studies import main as compare  # noqa: E402
from results import write_result  # noqa: E402


def _entry(text: str) -> tuple[int, int]:
    """``"4"`` -> (1 process, 4 GPUs); ``"2x2"`` -> (2 processes, 2 GPUs each)."""
    p, _, n = text.rpartition("x")
    return int(p or 1), int(n)


def run(entry: str, study: list[str], root: Path, port: int) -> tuple[dict, list[str]]:
    """One cold study; returns its study.json and the commands it ran."""
    procs, gpus = _entry(entry)
    out, cmds, running = root / f"study_{entry}", [], []
    for i in range(procs):
        devices = ",".join(str(d) for d in range(i * gpus, (i + 1) * gpus))
        args = [*study, "--out", str(out), "--cache-dir", str(root / f"cache_{entry}_{i}")]
        if procs > 1:
            args += ["--distributed", "--coordinator", f"127.0.0.1:{port}"]
            args += ["--num-processes", str(procs), "--process-id", str(i)]
        cmd = [sys.executable, "-m", "mjx_radar", "study", *args]
        cmds.append(f"CUDA_VISIBLE_DEVICES={devices} mjx-radar study {shlex.join(args)}")
        env = dict(os.environ, CUDA_VISIBLE_DEVICES=devices)
        running.append(subprocess.Popen(cmd, env=env, stderr=subprocess.DEVNULL))
    if any(p.wait() for p in running):
        raise SystemExit(f"bench_study_devices: the study on {entry} GPUs failed")
    return json.loads((out / "study.json").read_text()), cmds


def _differing(a: Path, b: Path) -> int:
    """Metric values that differ between two studies (``compare_studies.py``)."""
    text = io.StringIO()
    with contextlib.redirect_stdout(text):
        compare(a, b)
    last = text.getvalue().strip().splitlines()[-1]
    return int(last.split("=")[1]) if last.startswith("differing_values=") else -1


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--id", required=True, help="result file id")
    parser.add_argument("--title", default=None, help="default: the study's arguments")
    parser.add_argument("--hardware", required=True, help='e.g. "4x NVIDIA H200"')
    parser.add_argument("--gpus", nargs="+", default=["1", "2", "4"], help="N or PxN")
    parser.add_argument("--results", type=Path, default=HERE / "results")
    parser.add_argument("--keep", type=Path, default=None, help="copy each study.json here")
    parser.add_argument("study", nargs=argparse.REMAINDER, help="-- mjx-radar study arguments")
    a = parser.parse_args(argv)
    study = a.study[1:] if a.study[:1] == ["--"] else a.study
    rows, commands, metas = [], [], {}
    with tempfile.TemporaryDirectory(prefix="bench-devices-") as tmp:
        root = Path(tmp)
        for k, entry in enumerate(a.gpus):
            meta, cmds = run(entry, study, root, 29600 + k)
            metas[entry], commands = meta, commands + cmds
            if a.keep:
                a.keep.mkdir(parents=True, exist_ok=True)
                (a.keep / f"{a.id}_{entry}.json").write_text(json.dumps(meta, indent=1))
            differ = _differing(root / f"study_{a.gpus[0]}", root / f"study_{entry}") if k else 0
            host = meta.get("host", {})
            tail = host.get("after_last_chunk_s", 0.0) + host.get("consolidate_s", 0.0)
            rows.append([entry, meta["wall_s"], meta["compile_s"], meta["sim_s"], tail, differ])
    one = metas.get("1")
    out = []
    for entry, wall, comp, sim, tail, differ in rows:
        sim_up = f"{one['sim_s'] / sim:.2f}x" if one else "-"
        wall_vs = f"{wall / one['wall_s']:.2f}x" if one else "-"
        same = "identical" if not differ else "DIFFERENT"
        out.append(
            [
                entry,
                round(wall, 1),
                round(comp, 1),
                round(sim, 1),
                sim_up,
                wall_vs,
                f"{100 * tail / wall:.1f}%",
                same,
            ]
        )
    columns = [
        "GPUs",
        "wall [s]",
        "compile held the GPUs [s]",
        "simulation [s]",
        "simulation speed-up",
        "wall vs 1 GPU",
        "host after the last chunk",
        f"metrics vs {a.gpus[0]} GPU(s)",
    ]
    title = a.title or f"mjx-radar study {shlex.join(study)}, cold caches, per device count"
    path = write_result(a.id, title, commands, a.hardware, columns, out, root=a.results)
    print(f"wrote {path}")
    for row in out:
        print(row)
    return 0


if __name__ == "__main__":
    sys.exit(main())
