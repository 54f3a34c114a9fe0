"""Start-up benchmark: cold and warm compilation caches, fresh processes (issue "Compile once").

Runs, each in a fresh process and in this order:

1. ``mjx-radar run SCENARIO --steps K`` with an empty cache directory (cold);
2. the same again (warm: XLA cache + program export cache);
3. the same with another R2T, SNR, weight and seed (a scenario file differing only in
   numbers: must hit the caches);
4. the README quick start, ``mjx-radar run scenarios/smoke.toml`` (80 steps), with
   an empty cache directory (skip with ``--no-quick-start``);
5. optionally (``--study-trials T``) ``mjx-radar study SCENARIO --methods M1,M2 --trials T
   --chunk T`` cold and warm;
6. one MPPI call at paper settings, DDR-SFIM and DDR-PFIM (``benchmarks/bench_mppi.py``,
   median of ``--mppi-calls`` calls; 0 skips it).

Prints one line per step with the process wall time and the compile / simulation
split reported by the run, then the issue's table (issue 27, "Start in seconds") with
the goals of the device it ran on: on a CPU, quick start compile <= 15 s and
``run paper_3r4t --steps 600`` <= 30 s cold and <= 12 s warm; on a GPU (H100) that
run <= 20 s cold and <= 8 s warm and one MPPI call <= 4 ms (SFIM) and <= 6 ms (PFIM);
and the machine's load average. Usage::

    python benchmarks/bench_startup.py --scenario scenarios/paper_3r4t.toml --steps 600
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
    ap.add_argument("--mppi-calls", type=int, default=30, help="MPPI call rows (0: skip)")
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
    mppi = _mppi_calls(args.mppi_calls) if args.mppi_calls else {}
    print(f"{'what':28s} {'wall_s':>8s} {'compile_s':>10s} {'sim_s':>8s} rc")
    for what, wall, comp, sim, rc in rows:
        f = lambda x: f"{x:10.1f}" if isinstance(x, float) else f"{'-':>10s}"  # noqa: E731
        print(f"{what:28s} {wall:8.1f} {f(comp)} {f(sim)[2:]:>8s} {rc}")
    for method, ms in mppi.items():
        print(f"{'MPPI call ' + method:28s} {ms:8.2f} ms (median of {args.mppi_calls})")
    device = _device()
    _goals(rows, mppi, f"{src.stem} {args.steps} steps", device)
    print(json.dumps({"rows": rows, "mppi_ms": mppi, "device": device,
                      "load": os.getloadavg()}))  # fmt: skip


def _device() -> str:
    out = subprocess.run([sys.executable, "-c", "import jax; print(jax.devices()[0].device_kind)"],
                         capture_output=True, text=True)  # fmt: skip
    return out.stdout.strip().splitlines()[-1] if out.returncode == 0 else "unknown"


def _mppi_calls(calls: int) -> dict[str, float]:
    """Median ms of one MPPI call per method (``bench_mppi.py``, paper settings)."""
    bench = Path(__file__).resolve().parent / "bench_mppi.py"
    cmd = [sys.executable, str(bench), "--methods", "ddr-sfim,ddr-pfim", "--calls", str(calls)]
    out = subprocess.run(cmd, capture_output=True, text=True).stdout.splitlines()
    meds = [float(line.split("=")[1]) * 1e3 for line in out if line.startswith("mppi_call_s=")]
    return dict(zip(("DDR-SFIM", "DDR-PFIM"), meds, strict=False))


def _goals(rows, mppi: dict, what: str, device: str) -> None:
    """The issue's table: measured vs goal (process wall time; compile for the quick start;
    milliseconds for the MPPI call), the goals of a CPU or of a GPU (H100)."""
    got = {r[0]: r for r in rows}
    cpu = device.lower() == "cpu"
    cold, warm = (30.0, 12.0) if cpu else (20.0, 8.0)
    goals = [("run cold", f"run {what}, cold", 1, cold), ("run warm", f"run {what}, warm", 1, warm)]
    if cpu:
        goals.append(("quick start cold", "quick start compile", 2, 15.0))
    print(f"\n{'goal (issue 27, ' + device + ')':40s} {'measured':>10s} {'goal':>7s}")
    for key, label, col, goal in goals:
        if key in got and isinstance(got[key][col], float):
            print(f"{label:40s} {got[key][col]:8.1f} s {goal:5.1f} s")
    if not cpu:
        for method, goal in (("DDR-SFIM", 4.0), ("DDR-PFIM", 6.0)):
            if method in mppi:
                print(f"{'MPPI call ' + method:40s} {mppi[method]:7.2f} ms {goal:4.1f} ms")
    print(f"load average (1, 5, 15 min): {os.getloadavg()}")


if __name__ == "__main__":
    main()
