"""Every bundled scenario x a few methods in one Python process (issue 36: a long sweep must
not die).

A script that simulated every bundled scenario with three methods in one process used to
die after ~28 compiled programs (``LLVM compilation error: Cannot allocate memory``: XLA's
CPU JIT maps memory per executable, and every program stayed alive). The runner now keeps
at most ``$MJX_RADAR_LIVE_PROGRAMS`` programs alive (:mod:`mjx_radar.engine.live_programs`).
This script runs the whole sweep with few trials and steps, one line per case::

    python scripts/sweep_bundled.py [--scenarios smoke,paper_3r4t] \
        [--methods stationary,ddr-sfim,ddr-pfim] [--steps 4] [--trials 1] [--json FILE]

Each line: scenario, method, wall / compile seconds, the mean position RMSE (finite),
the process's peak resident memory (``ru_maxrss``), the programs alive in the runner's
cache and the memory maps in use against ``vm.max_map_count``. ``--steps`` is rounded up
to a whole control period of each scenario. Exit status 0 when every case ran and gave
finite metrics, else 1 (the failing cases are listed at the end).
"""

from __future__ import annotations

import argparse
import json
import math
import resource
import sys
import time
import traceback

DEFAULT_METHODS = "stationary,ddr-sfim,ddr-pfim"


def peak_rss_mib() -> float:
    """The process's peak resident set size [MiB] (Linux reports ``ru_maxrss`` in KiB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def run_case(name: str, method: str, steps: int, trials: int, cache: bool) -> dict:
    """One scenario and method: a run of ``steps`` (rounded up to a control period)."""
    import numpy as np

    import mjx_radar
    from mjx_radar.engine import live_programs, programs

    s = mjx_radar.load_scenario(name)
    every = s.timing.control_every
    k = max(every, -(-steps // every) * every)
    t0 = time.perf_counter()
    run = mjx_radar.simulate(s, method, trials=trials, steps=k, progress=False, cache=cache)
    rmse = float(np.mean(run.metrics["rmse_pos"]))
    maps = live_programs.map_usage()
    return {
        "scenario": name,
        "method": method,
        "steps": k,
        "wall_s": time.perf_counter() - t0,
        "compile_s": float(run.meta["compile_s"]),
        "rmse_pos": rmse,
        "finite": bool(math.isfinite(rmse) and np.isfinite(run.metrics["nees"]).all()),
        "peak_rss_mib": peak_rss_mib(),
        "live_programs": len(programs._CACHE),
        "maps": None if maps is None else maps[0],
        "max_map_count": None if maps is None else maps[1],
    }


def line(r: dict) -> str:
    if "error" in r:
        return f"{r['scenario']:<16} {r['method']:<11} FAILED {r['error']}"
    maps = "" if r["maps"] is None else f", maps {r['maps']}/{r['max_map_count']}"
    return (
        f"{r['scenario']:<16} {r['method']:<11} {r['steps']:>3} steps {r['wall_s']:7.1f} s "
        f"(compile {r['compile_s']:5.1f} s), rmse {r['rmse_pos']:9.3f} m, peak RSS "
        f"{r['peak_rss_mib']:7.0f} MiB, live programs {r['live_programs']}{maps}"
    )


def main(argv=None) -> int:
    import mjx_radar

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scenarios", default=None, help="comma list (default: every bundled one)")
    p.add_argument("--methods", default=DEFAULT_METHODS, help=f"comma list ({DEFAULT_METHODS})")
    p.add_argument("--steps", type=int, default=4, help="filter steps (whole control periods)")
    p.add_argument("--trials", type=int, default=1)
    p.add_argument("--no-cache", action="store_true", help="no persistent compilation cache")
    p.add_argument("--json", default=None, help="also write the rows to this JSON file")
    a = p.parse_args(argv)
    names = a.scenarios.split(",") if a.scenarios else mjx_radar.bundled_scenarios()
    methods = a.methods.split(",")
    rows, t0 = [], time.perf_counter()
    print(f"{len(names)} scenarios x {len(methods)} methods in one process", flush=True)
    for name in names:
        for method in methods:
            try:
                r = run_case(name, method, a.steps, a.trials, not a.no_cache)
            except Exception as err:  # noqa: BLE001 -- reported per case, the sweep goes on
                last = traceback.format_exception_only(err)[-1].strip()
                r = {"scenario": name, "method": method, "error": last[:300]}
            rows.append(r)
            print(line(r), flush=True)
    bad = [r for r in rows if "error" in r or not r["finite"]]
    print(
        f"{len(rows) - len(bad)} of {len(rows)} cases completed in "
        f"{time.perf_counter() - t0:.0f} s; peak RSS {peak_rss_mib():.0f} MiB",
        flush=True,
    )
    for r in bad:
        print(f"  not completed: {r['scenario']} {r['method']}", flush=True)
    if a.json:
        with open(a.json, "w") as f:
            json.dump(rows, f, indent=1)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
