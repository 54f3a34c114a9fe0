"""What a closed-loop program is made of: its HLO operations by source module (issue 37).

Compiles one program (``engine.programs.compile_programs``) with XLA's dumps on, in a
fresh process and an empty compilation cache, then attributes every operation of the
largest module (before XLA's optimisations) to the innermost ``mjx_radar`` source file of
its stack trace (``mujoco`` for MJX's own code), and counts what XLA made of it: the
operations after optimisation, the fusions and, on the CPU, the separately compiled
kernels. Prints the compile seconds (trace and lower, XLA) and the table::

    python benchmarks/program_anatomy.py [--scenario smoke] [--kind none] [--batch 1]
        [--periods 4] [--top 15] [--functions]

``--kind``: the program kind (``none``: no planner, ``sfim``, ``pfim``, ``all``);
``--functions`` breaks the operations down by function instead of by file.
"""

from __future__ import annotations

import argparse
import collections
import os
import re
import sys
import tempfile
from pathlib import Path

from mjx_radar.engine.run_spec import run_spec


def _table(lines: list[str], start: str, stop: str) -> list[str]:
    a = lines.index(start)
    b = lines.index(stop) if stop else len(lines)
    return lines[a + 1 : b]


def _ids(d: dict, a: str, b: str) -> tuple[int, int]:
    return int(d.get(a, 0)), int(d.get(b, 0))


def attribute(text: str, by_function: bool = False) -> collections.Counter:
    """Operations of an HLO module's text by the innermost ``mjx_radar`` frame of their
    stack traces (file, or ``file:function``); ``mujoco`` when MJX's code is on it."""
    lines = text.splitlines()
    named = lambda rows: {  # noqa: E731
        int(m.group(1)): m.group(2)
        for m in (re.match(r"\s*(\d+)\s+\"(.*)\"", r) for r in rows)
        if m
    }
    files = named(_table(lines, "FileNames", "FunctionNames"))
    funcs = named(_table(lines, "FunctionNames", "FileLocations"))
    locs, frames = {}, {}
    for row in _table(lines, "FileLocations", "StackFrames"):
        m = re.match(r"\s*(\d+)\s+\{(.*)\}", row)
        if m:
            d = dict(re.findall(r"(\w+)=(\d+)", m.group(2)))
            locs[int(m.group(1))] = (
                int(d.get("file_name_id", 0)),
                int(d.get("function_name_id", 0)),
            )
    for row in lines[lines.index("StackFrames") + 1 :]:
        m = re.match(r"\s*(\d+)\s+\{(.*)\}", row)
        if not m:
            if not row.strip():
                break
            continue
        d = dict(re.findall(r"(\w+)=(\d+)", m.group(2)))
        frames[int(m.group(1))] = (
            int(d.get("file_location_id", 0)),
            int(d.get("parent_frame_id", 0)),
        )
    out: collections.Counter = collections.Counter()
    for m in re.finditer(r"stack_frame_id=(\d+)", text):
        fid, seen, chain = int(m.group(1)), set(), []
        while fid in frames and fid not in seen:  # innermost frame first
            seen.add(fid)
            loc, fid = frames[fid]
            chain.append(locs.get(loc, (0, 0)))
        names = [(files.get(f, "?"), funcs.get(g, "?")) for f, g in chain]
        if any("mujoco" in f for f, _ in names):
            out["mujoco"] += 1
            continue
        own = [(f.split("mjx_radar/")[-1], g) for f, g in names if "/mjx_radar/" in f]
        f, g = own[0] if own else (names[0] if names else ("?", "?"))
        out[f"{f}:{g}" if by_function else f] += 1
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="smoke")
    ap.add_argument("--kind", default="none", choices=("none", "sfim", "pfim", "all"))
    ap.add_argument("--batch", type=int, default=1)
    ap.add_argument("--periods", type=int, default=4)
    ap.add_argument("--top", type=int, default=15)
    ap.add_argument("--functions", action="store_true")
    args = ap.parse_args(argv)
    if args.batch < 1 or args.periods < 1:
        print("error: --batch and --periods must be >= 1", file=sys.stderr)
        return 2
    dump = Path(tempfile.mkdtemp(prefix="anatomy_"))
    os.environ["XLA_FLAGS"] = (
        os.environ.get("XLA_FLAGS", "") + f" --xla_dump_to={dump} --xla_dump_hlo_as_text"
    )
    os.environ["MJX_RADAR_CACHE_DIR"] = str(dump / "cache")  # empty: compiled, not loaded
    import mjx_radar
    from mjx_radar.engine.programs import COMPILE_LOG, compile_programs
    from mjx_radar.io.checks import ScenarioError

    try:
        scenario = mjx_radar.load_scenario(args.scenario)
    except ScenarioError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    compile_programs(run_spec(scenario), args.batch, args.periods, False, None, args.kind)
    log = COMPILE_LOG[-1]
    before = max(dump.glob("*.before_optimizations.txt"), key=lambda p: p.stat().st_size)
    module = before.name.split(".")[0]
    after = next(dump.glob(f"{module}.*cpu_after_optimizations.txt"), None) or next(
        dump.glob(f"{module}.*after_optimizations.txt"), None
    )
    ops = attribute(before.read_text(), args.functions)
    total = sum(ops.values())
    print(
        f"{args.scenario}, kind {args.kind}: trace and lower {log['trace_lower_s']:.1f} s, "
        f"XLA {log['xla_compile_s']:.1f} s; {module}: {len(before.read_text().splitlines())} "
        f"lines before optimisation, {total} operations with a stack trace"
    )
    if after is not None:
        text = after.read_text()
        kernels = len(list(dump.glob(f"{module}.*.ll")))
        fusions = len(re.findall(r"= [^ ]+ fusion\(", text))
        print(
            f"after optimisation: {len(text.splitlines())} lines, {fusions} fusions"
            + (f", {kernels} kernel modules" if kernels else "")
        )
    for name, n in ops.most_common(args.top):
        print(f"{n:7d} {100 * n / total:5.1f} %  {name}")
    print(f"(dumps in {dump})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
