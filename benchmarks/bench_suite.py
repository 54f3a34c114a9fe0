"""Where the test suite's time goes: per file and per test, wall and JAX compilation.

Runs pytest with the README's test options (``DEFAULT``, or the arguments given after
``--``) and the suite's ``--compile-profile`` option, then sums the per-test records: wall seconds
(setup + call + teardown), XLA compilations (count, seconds), tracing and lowering
seconds in the test's own process (a test's subprocesses are counted only in its wall)::

    python benchmarks/bench_suite.py [--out runs/suite.jsonl] [--top 25] [--summarise-only]
        [-- -m "not slow" -n 2 --dist loadfile tests/]

With ``--compile-profile`` a record holds its worker and start time (the summary gives each
worker's busy seconds and span) and lists the closed-loop programs the test compiled
or loaded (``engine.programs.COMPILE_LOG``: key, scenario, batch, kind, planner, source)
and its compilations of 1 s or more by function name (``xla_long``); the summary ends
with the programs by key. A test with many XLA compilations and little work calls JAX
eagerly (each primitive compiles on first use): jit what it compares. One with a few long
compilations compiles a closed loop of its own: share a program with another test, or mark
it ``slow``.
"""

from __future__ import annotations

import argparse
import collections
import json
import subprocess
import sys
import time
from pathlib import Path

DEFAULT = ["-q", "-m", "not slow", "-n", "2", "--dist", "loadfile"]


def summarise(path: Path, top: int) -> str:
    rows = [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
    files: dict[str, collections.Counter] = collections.defaultdict(collections.Counter)
    for r in rows:
        f = files[r["id"].split("::")[0]]
        f["tests"] += 1
        for k in ("wall", "xla_n", "xla_s", "trace_s", "lower_s"):
            f[k] += r.get(k, 0)
    total = collections.Counter()
    for f in files.values():
        total.update(f)
    out = [
        f"{len(rows)} tests: wall {total['wall']:.0f} s summed over workers, XLA "
        f"{total['xla_n']:.0f} compilations {total['xla_s']:.0f} s, tracing "
        f"{total['trace_s']:.0f} s, lowering {total['lower_s']:.0f} s",
        *workers(rows),
        "",
        f"{'wall s':>7} {'XLA n':>6} {'XLA s':>6}  file",
    ]
    for name, f in sorted(files.items(), key=lambda kv: -kv[1]["wall"])[:top]:
        out.append(f"{f['wall']:7.1f} {f['xla_n']:6.0f} {f['xla_s']:6.1f}  {name}")
    out += ["", f"{'wall s':>7} {'XLA n':>6} {'XLA s':>6}  test"]
    for r in sorted(rows, key=lambda r: -r["wall"])[:top]:
        out.append(f"{r['wall']:7.1f} {r.get('xla_n', 0):6.0f} {r.get('xla_s', 0):6.1f}  {r['id']}")
    return "\n".join(out + programs(rows, top))


def workers(rows: list[dict]) -> list[str]:
    """Per pytest worker: tests, seconds busy in tests and the span from its first test's
    start to its last test's end (a span much longer than the busy time: imbalance)."""
    by: dict[str, list] = collections.defaultdict(list)
    for r in rows:
        if "start" in r:  # records of suites profiled before the timeline was kept lack it
            by[r.get("worker", "main")].append((r["start"], r["start"] + r["wall"]))
    t0 = min((s for spans in by.values() for s, _ in spans), default=0.0)
    return [
        f"worker {w}: {len(spans)} tests, busy {sum(e - s for s, e in spans):.0f} s, "
        f"first start +{min(s for s, _ in spans) - t0:.0f} s, last end "
        f"+{max(e for _, e in spans) - t0:.0f} s"
        for w, spans in sorted(by.items())
    ]


def programs(rows: list[dict], top: int) -> list[str]:
    """The closed-loop programs (``engine.programs.COMPILE_LOG`` entries the profile
    records per test) by program key, costliest first: which tests traced and compiled
    each, and which loaded it from the session's caches. A program compiled by one test
    only, of a shape or option no other test uses, is a candidate for sharing."""
    seen: dict[str, list] = collections.defaultdict(list)
    for r in rows:
        for p in r.get("programs", []):
            seen[p["key"]].append((r["id"], p))
    if not seen:
        return []
    cost = {k: sum(p["trace_lower_s"] + p["xla_compile_s"] for _, p in v) for k, v in seen.items()}
    out = ["", f"{len(seen)} closed-loop programs, {sum(len(v) for v in seen.values())} uses:"]
    for key in sorted(seen, key=lambda k: -cost[k])[:top]:
        p = seen[key][0][1]
        uses = "; ".join(f"{i.split('/')[-1]} ({q['source']})" for i, q in seen[key])
        out.append(
            f"{cost[key]:7.1f} s  {key} {p.get('scenario', '?')} batch {p['batch']} "
            f"kind {p['kind']} planner {p.get('planner', '?')}: {uses}"
        )
    return out


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    pytest_args = argv[argv.index("--") + 1 :] if "--" in argv else DEFAULT
    own = argv[: argv.index("--")] if "--" in argv else argv
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("runs/suite_profile.jsonl"))
    ap.add_argument("--top", type=int, default=25)
    ap.add_argument("--summarise-only", action="store_true", help="only read --out")
    args = ap.parse_args(own)
    if args.top < 1:
        ap.error("--top must be >= 1")
    if not args.summarise_only:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.unlink(missing_ok=True)
        cmd = [sys.executable, "-m", "pytest", *pytest_args, f"--compile-profile={args.out}"]
        t0 = time.perf_counter()
        rc = subprocess.call(cmd)
        print(f"pytest exit {rc}, {time.perf_counter() - t0:.0f} s wall")
    if not args.out.is_file():
        print(f"bench_suite: no profile at {args.out}", file=sys.stderr)
        return 2
    print(summarise(args.out, args.top))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
