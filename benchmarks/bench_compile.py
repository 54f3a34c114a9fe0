"""Compile-time benchmark of studies and runs (issue 37): fresh caches, fresh processes.

Each case runs one ``mjx-radar`` command in a fresh process with an empty cache
directory (``cold``) or the case's own cache a second time (``warm``), with the
environment the case names, and records the process wall time and the compile /
simulation split the command reports (``study.json`` or the run line). Cases::

    town        study town_4r4t --methods ddr-sfim,stationary --trials 64 --chunk 64
    paper       study paper_3r4t paper_4r4t paper_6r3t (the paper's three shapes)
                --methods (the five) --trials 500 --chunk 250 --steps 600
    run         run paper_3r4t --steps 600 (cold, then warm)

and variants of the code path, set through the environment of the process:

    base        MJX's step for contacts (``physics.plant.MESH_CONTACTS = False``): the
                code before issue 37
    perkind     every method in its own kind's program (a study's stationary radars
                not riding along in a planning program: the code before the sixth session)
    staged      the staged truth step (physics/staged_step.py), the default
    fastxla     staged, with XLA_FLAGS=FAST_XLA (autotuning off, no expensive LLVM
                passes: compiles faster, changes float32 round-off; docs/scaling.md)

Appends one row per (case, variant, temperature) to ``OUT/compile.csv`` and skips rows
already there, so an interrupted run resumes::

    python benchmarks/bench_compile.py --out DIR --cases town,paper,run \\
        --variants base,staged,fastxla
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

PAPER = ["scenarios/paper_3r4t.toml", "scenarios/paper_4r4t.toml", "scenarios/paper_6r3t.toml"]
FIVE = "ccr-sfim,ccr-pfim,ddr-sfim,ddr-pfim,stationary"
CASES = {
    "town": [
        "study",
        "scenarios/town_4r4t.toml",
        "--methods",
        "ddr-sfim,stationary",
        "--trials",
        "64",
        "--chunk",
        "64",
        "--seed",
        "0",
    ],  # fmt: skip
    "paper": [
        "study",
        *PAPER,
        "--methods",
        FIVE,
        "--trials",
        "500",
        "--chunk",
        "250",
        "--steps",
        "600",
        "--seed",
        "0",
    ],  # fmt: skip
    "run": ["run", "scenarios/paper_3r4t.toml", "--steps", "600"],
}
FAST_XLA = "--xla_gpu_autotune_level=0 --xla_llvm_disable_expensive_passes=true"
VARIANTS = {
    "base": {},
    "perkind": {},
    "staged": {},
    "fastxla": {"XLA_FLAGS": FAST_XLA},
}
#: the base variant's process: MJX's own step for scenes with contacts
BASE = (
    "import runpy, sys; import mjx_radar.physics.plant as p; p.MESH_CONTACTS = False; "
    "sys.argv = ['mjx-radar', *sys.argv[1:]]; runpy.run_module('mjx_radar', run_name='__main__')"
)
#: the perkind variant's process: each method in the program of its own kind
PERKIND = (
    "import runpy, sys; import mjx_radar.engine.program_jobs as r; "
    "from mjx_radar.task.method import parse_method as pm; "
    "r.shared_programs = lambda ms: {pm(m).name: (pm(m).kind, pm(m).planner) for m in ms}; "
    "sys.argv = ['mjx-radar', *sys.argv[1:]]; runpy.run_module('mjx_radar', run_name='__main__')"
)
FIELDS = ["case", "variant", "temperature", "wall_s", "compile_s", "sim_s", "rc", "device"]


def _split(case: str, out: Path, text: str) -> tuple[float, float]:
    """(compile, simulation) seconds reported by the command."""
    if case != "run":
        meta = json.loads((out / "study.json").read_text())
        return meta["compile_s"], meta["sim_s"]
    c = re.search(r"compile ([0-9.]+) s", text)
    s = re.search(r"simulation ([0-9.]+) s", text)
    return (float(c.group(1)) if c else float("nan")), (float(s.group(1)) if s else float("nan"))


def _device() -> str:
    code = "import jax; d = jax.devices()[0]; print(d.platform, d.device_kind)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    return out.stdout.strip()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--cases", default="town,paper,run")
    ap.add_argument("--variants", default="base,staged")
    ap.add_argument("--warm", action="store_true", help="also rerun each case warm")
    ap.add_argument("--paper-trials", type=int, default=500, help="trials of the paper case")
    ap.add_argument(
        "--deterministic",
        action="store_true",
        help="pass --deterministic to the studies (the default of trees since 2026-11-26; for "
        "older trees, where XLA's autotuned kernels were the default)",
    )
    args = ap.parse_args()
    if args.paper_trials < 1:
        ap.error("--paper-trials must be >= 1")
    CASES["paper"][CASES["paper"].index("--trials") + 1] = str(args.paper_trials)
    if args.deterministic:  # compare_studies.py then shows what a change does to the numbers
        CASES["town"].append("--deterministic")
        CASES["paper"].append("--deterministic")
    args.out.mkdir(parents=True, exist_ok=True)
    table = args.out / "compile.csv"
    done = set()
    if table.exists():
        done = {(r["case"], r["variant"], r["temperature"]) for r in csv.DictReader(table.open())}
    device = _device()
    for case in args.cases.split(","):
        temps = ["cold", "warm"] if (args.warm or case == "run") else ["cold"]
        for variant in args.variants.split(","):
            cache = args.out / f"cache-{case}-{variant}"
            for temp in temps:
                if (case, variant, temp) in done:
                    continue
                if temp == "cold":
                    shutil.rmtree(cache, ignore_errors=True)
                res = args.out / f"res-{case}-{variant}-{temp}"
                shutil.rmtree(res, ignore_errors=True)
                env = dict(os.environ, **VARIANTS[variant], MJX_RADAR_CACHE_DIR=str(cache))
                entry = {"base": ["-c", BASE], "perkind": ["-c", PERKIND]}.get(
                    variant, ["-m", "mjx_radar"]
                )
                cmd = [sys.executable, *entry, *CASES[case], "--out", str(res)]
                t0 = time.perf_counter()
                p = subprocess.run(cmd, env=env, capture_output=True, text=True)
                wall = time.perf_counter() - t0
                comp, sim = _split(case, res, p.stdout + p.stderr) if p.returncode == 0 else (0, 0)
                row = dict(case=case, variant=variant, temperature=temp, wall_s=round(wall, 1),
                           compile_s=round(comp, 1), sim_s=round(sim, 1), rc=p.returncode,
                           device=device)  # fmt: skip
                print(json.dumps(row), flush=True)
                if p.returncode:
                    print(p.stderr[-2000:], file=sys.stderr)
                new = not table.exists()
                with table.open("a", newline="") as f:
                    w = csv.DictWriter(f, FIELDS)
                    if new:
                        w.writeheader()
                    w.writerow(row)


if __name__ == "__main__":
    main()
