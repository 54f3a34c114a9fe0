"""Start-up benchmark: cold and warm compilation caches, fresh processes (issue "Compile once").

Runs, each in a fresh process and in this order:

1. ``mjx-radar run SCENARIO --steps K`` with an empty cache directory (cold);
2. the same again (warm: XLA cache + program export cache);
3. the same with another R2T, SNR, weight and seed (a scenario file differing only in
   numbers: must hit the caches);
4. the README quick start, ``mjx-radar run scenarios/smoke.toml`` (80 steps), with
   an empty cache directory (skip with ``--no-quick-start``);
5. optionally (``--study-trials T``) ``mjx-radar study SCENARIO --methods M1,M2 --trials T
   --chunk T`` cold and warm.

Prints one line per step with the process wall time and the compile / simulation
split reported by the run, then the issue's table (issue 27, "Start in seconds":
quick start compile <= 15 s, ``run paper_3r4t --steps 600`` <= 30 s cold and <= 12 s
warm on the 2-core CPU) and the machine's load average. Usage::

    python scripts/bench_startup.py --scenario scenarios/paper_3r4t.toml --steps 600
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def _cli(args: list[str], cache: Path) -> tuple[float, int]:
    t0 = time.perf_counter()
    cmd = [sys.executable, "-m", "mjx_radar", *args, "--cache-dir", str(cache)]
    rc = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL).returncode
    return time.perf_counter() - t0, rc


def _variant(src: Path, dst: Path) -> Path:
    """A copy of the scenario with other numbers (same shape)."""
    import tomllib

    raw = tomllib.loads(src.read_text())
    raw["seed"] = int(raw.get("seed", 0)) + 17
    raw.setdefault("mpc", {})
    raw["mpc"]["r2t"] = float(raw["mpc"].get("r2t", 125.0)) - 5.0
    raw["mpc"]["alpha_r2r"] = float(raw["mpc"].get("alpha_r2r", 500.0)) * 2
    raw.setdefault("radar_equation", {})["snr_db"] = -18.0
    dst.write_text(_to_toml(raw))
    return dst


def _to_toml(d: dict, prefix: str = "") -> str:
    scalars, tables = [], []
    for k, v in d.items():
        if isinstance(v, dict):
            tables.append((k, v))
        else:
            scalars.append(f"{k} = {json.dumps(v)}")
    out = "\n".join(scalars) + "\n"
    for k, v in tables:
        out += f"\n[{prefix}{k}]\n" + _to_toml(v, f"{prefix}{k}.")
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="scenarios/paper_3r4t.toml")
    ap.add_argument("--steps", type=int, default=600)
    ap.add_argument("--method", default="ddr-sfim")
    ap.add_argument("--study-trials", type=int, default=0)
    ap.add_argument("--study-methods", default="ddr-sfim,ddr-pfim")
    ap.add_argument("--study-steps", type=int, default=600)
    ap.add_argument("--no-quick-start", action="store_true", help="skip the quick start row")
    args = ap.parse_args()
    work = Path(tempfile.mkdtemp(prefix="bench_startup_"))
    cache = work / "cache"
    src = Path(args.scenario)
    variant = _variant(src, work / f"{src.stem}.toml")
    rows = []
    run = ["run", "--steps", str(args.steps), "--method", args.method, "--force"]
    for label, scen in (("cold", src), ("warm", src), ("warm, other numbers", variant)):
        out = work / f"run_{len(rows)}"
        wall, rc = _cli([run[0], str(scen), *run[1:], "--out", str(out)], cache)
        meta = json.loads((out / "run.json").read_text()) if rc == 0 else {}
        rows.append((f"run {label}", wall, meta.get("compile_s"), meta.get("sim_s"), rc))
    if not args.no_quick_start:  # README quick start, its own empty cache
        out = work / "quick_start"
        smoke = Path(__file__).resolve().parents[1] / "scenarios" / "smoke.toml"
        cmd = ["run", str(smoke), "--out", str(out), "--force"]
        wall, rc = _cli(cmd, work / "cache_quick")
        meta = json.loads((out / "run.json").read_text()) if rc == 0 else {}
        rows.append(("quick start cold", wall, meta.get("compile_s"), meta.get("sim_s"), rc))
    if args.study_trials:
        for label in ("cold", "warm"):
            if label == "cold":
                cache = work / "cache_study"
            out = work / f"study_{label}"
            cmd = ["study", str(src), "--methods", args.study_methods]
            cmd += ["--trials", str(args.study_trials), "--chunk", str(args.study_trials)]
            cmd += ["--steps", str(args.study_steps), "--out", str(out)]
            wall, rc = _cli(cmd, cache)
            meta = json.loads((out / "study.json").read_text()) if rc == 0 else {}
            rows.append((f"study {label}", wall, meta.get("compile_s"), meta.get("sim_s"), rc))
    print(f"{'what':28s} {'wall_s':>8s} {'compile_s':>10s} {'sim_s':>8s} rc")
    for what, wall, comp, sim, rc in rows:
        f = lambda x: f"{x:10.1f}" if isinstance(x, float) else f"{'-':>10s}"  # noqa: E731
        print(f"{what:28s} {wall:8.1f} {f(comp)} {f(sim)[2:]:>8s} {rc}")
    _goals(rows, f"{src.stem} {args.steps} steps")
    print(json.dumps({"rows": rows, "load": os.getloadavg()}))


def _goals(rows, what: str) -> None:
    """The issue's table: measured vs goal (process wall time; compile for the quick start)."""
    got = {r[0]: r for r in rows}
    goals = [("run cold", f"run {what}, cold", 1, 30.0), ("run warm", f"run {what}, warm", 1, 12.0),
             ("quick start cold", "quick start compile", 2, 15.0)]  # fmt: skip
    print(f"\n{'goal (issue 27, CPU)':36s} {'measured_s':>10s} {'goal_s':>7s}")
    for key, label, col, goal in goals:
        if key in got and isinstance(got[key][col], float):
            print(f"{label:36s} {got[key][col]:10.1f} {goal:7.1f}")
    print(f"load average (1, 5, 15 min): {os.getloadavg()}")


if __name__ == "__main__":
    main()
