"""The GPU memory tables from the rows of ``scripts/measure_memory.py --peak``.

Writes two result files: ``memory_model_gpu_h200_rows`` (every measured program: XLA's
figure and the device's peak, in bytes; ``tests/test_resources.py`` checks the model
against it) and ``memory_model_gpu_h200`` (one row per bundled scenario: the model's
prediction / XLA's figure and / the device's peak per program kind, from the model as
it is now)::

    python benchmarks/memory_gpu_result.py gpu_sfim64.json gpu_nonepfim64.json \\
        gpu_study64.json gpu_sfim16.json --commit 7aa1d9f --date 2026-11-28

``--commit``, ``--date`` and the versions describe the measuring machine (defaults: the
H200 run of the bundled tables).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from results import RESULTS, problems  # noqa: E402

from mjx_radar.engine.run_spec import program_size  # noqa: E402

MEASURE = "CUDA_VISIBLE_DEVICES=0 python scripts/measure_memory.py --peak --steps 8"
COMMANDS = [
    f"{MEASURE} --kinds sfim --trials 64 --jobs 5 --json gpu_sfim64.json",
    f"{MEASURE} --kinds none,pfim --trials 64 --jobs 6 --json gpu_nonepfim64.json",
    f"{MEASURE} --kinds sfim+pfim+none --metrics-only --trials 64 --jobs 5 --json gpu_study64.json",
    f"{MEASURE} --kinds sfim --trials 16 --jobs 5 --json gpu_sfim16.json",
]
ROWS_COLUMNS = [
    "scenario", "filter", "program kind", "program", "trials", "XLA [bytes]",
    "device peak [bytes]",
]  # fmt: skip
#: the per-scenario table's programs: (column, program kind, program, trials)
PROGRAMS = [
    ("stationary", "none", "run", 64),
    ("SFIM", "sfim", "run", 64),
    ("PFIM", "pfim", "run", 64),
    ("study (all three)", "sfim+pfim+none", "study", 64),
    ("SFIM, 16 trials", "sfim", "run", 16),
]


XLA = "XLA's figure"
PEAK = "the device's peak"


def _write(ident: str, result: dict) -> None:
    bad = problems(result, ident)
    if bad:
        raise ValueError("; ".join(bad))
    (RESULTS / f"{ident}.json").write_text(json.dumps(result, indent=2, ensure_ascii=False) + "\n")


def predicted(scenario: str, kind: str, program: str, trials: int) -> tuple[int, int]:
    """The model's XLA figure and device peak of one measured program (an H200)."""
    from mjx_radar.engine import memory_model, runner
    from mjx_radar.scenario.reader import load_scenario

    s = load_scenario(scenario)
    seg = runner.segment_periods(s, 8) * s.timing.control_every  # --steps 8
    x = sum(
        memory_model.device_terms(
            program_size(s), trials, "gpu", kind, program == "run", seg
        ).values()
    )
    return x, memory_model.device_peak(x, "gpu")


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("raw", nargs="+", help="JSON files of scripts/measure_memory.py --peak")
    p.add_argument("--commit", default="7aa1d9f")
    p.add_argument("--date", default="2026-11-28")
    p.add_argument("--jax", default="0.11.2")
    p.add_argument("--mujoco", default="4.0.0")
    p.add_argument("--python", default="3.12.3")
    a = p.parse_args()
    software = {
        "mjx_radar": "0.1.0", "commit": a.commit, "jax": a.jax, "jaxlib": a.jax,
        "mujoco": a.mujoco, "python": a.python,
    }  # fmt: skip
    raw = [r for f in a.raw for r in json.loads(Path(f).read_text()) if "error" not in r]
    rows = sorted(
        [r["scenario"], r["structure"], r["kind"], "run" if r["full"] else "study",
         r["trials"], r["xla_peak"], r["device_peak"]]
        for r in raw
    )  # fmt: skip
    common = {"hardware": "NVIDIA H200", "software": software, "date": a.date}
    _write("memory_model_gpu_h200_rows", {
        "id": "memory_model_gpu_h200_rows",
        "title": "XLA's memory analysis and the device's peak of every bundled scenario x "
                 "program kind, one segment program (8 steps), one H200",
        "command": COMMANDS, **common, "columns": ROWS_COLUMNS, "rows": rows,
        "notes": "XLA's figure: temporaries + arguments + outputs - aliases; device peak: "
                 "peak_bytes_in_use of one segment run in a fresh process "
                 "(XLA_PYTHON_CLIENT_PREALLOCATE=false). program: run (trajectories) or "
                 "study (metrics only).",
    })  # fmt: skip
    measured = {(r[0], r[2], r[3], r[4]): r for r in rows}
    table, lo = [], []
    for name in sorted({r[0] for r in rows}):
        cells, peaks = [], []
        for column, kind, program, trials in PROGRAMS:
            r = measured.get((name, kind, program, trials))
            if r is None:
                cells.append("–")
                continue
            x, peak = predicted(name, kind, program, trials)
            qx, qp = x / r[5], peak / r[6]
            lo.append((name, column, qx, qp, r[5]))
            cells.append(f"{qx:.2f} / {qp:.2f}")
            peaks.append(r[6])
        filt = next(r[1] for r in rows if r[0] == name)
        table.append([name, filt, *cells, f"{max(peaks) / 1e9:.2f}"])

    def summary(i: int, what: str) -> str:  # the range within 25 % and the rows outside
        inside = [q[i] for q in lo if 0.75 <= q[i] <= 1.25]
        out = [q for q in lo if not 0.75 <= q[i] <= 1.25]
        text = f"{min(inside):.2f}–{max(inside):.2f} of {what}"
        if out:
            names = ", ".join(f"{q[0]} ({q[1]}) {q[i]:.2f}" for q in out)
            text += f" but {names}"
        return text

    _write("memory_model_gpu_h200", {
        "id": "memory_model_gpu_h200",
        "title": "Predicted peak device memory / XLA's memory analysis and / the device's "
                 "peak, every bundled scenario x program kind, one H200",
        "command": [*COMMANDS, "python benchmarks/memory_gpu_result.py gpu_*.json"],
        **common,
        "columns": ["scenario", "filter", *(c for c, *_ in PROGRAMS),
                    "largest device peak [GB]"],
        "rows": table,
        "notes": f"Each cell: predicted / XLA's figure, predicted / device peak; 64 trials "
                 f"unless noted. {len(lo)} programs: {summary(2, XLA)}; {summary(3, PEAK)}. "
                 f"Fit on the 64-trial programs of one kind; the 16-trial and study "
                 f"programs are held out. smoke: XLA keeps its SFIM arrays at 64 trials and "
                 f"fuses them at 16 (programs of a few MB, under the runtime's floor); "
                 f"clutter_3r4t: its device peak lies above the step program's figure by "
                 f"more than the floor. Each program's figures: memory_model_gpu_h200_rows.",
    })  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
