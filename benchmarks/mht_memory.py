"""The memory model's MHT terms against XLA's figures (``engine/memory_model.py``).

For each MHT configuration of :data:`CONFIGS` on ``clutter_3r4t`` (``[tracker]`` as
given) and each program kind (``none``: a run of ``stationary``; ``sfim+pfim+none``: a
study's metrics-only program of every built-in method), it compiles the segment program
(``scripts/measure_memory.py``'s :func:`measure`: nothing is run) and writes one row: XLA's
figure (``compiled.memory_analysis()``: temporaries + arguments + outputs - donated
aliases), the model's estimate and their ratio. ``tests/test_resources.py`` checks the
model as it is now against the rows' XLA figures::

    python benchmarks/mht_memory.py --trials 64 --result memory_model_mht_h200
    JAX_PLATFORMS=cpu python benchmarks/mht_memory.py --trials 2 --kinds none
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))
sys.path.insert(0, str(ROOT / "benchmarks"))

MHT = {"association": "mht", "branch_scans": 1, "merge_screen": 2}
#: configuration name -> the ``[tracker]`` table of clutter_3r4t
CONFIGS = {
    "K=16": {**MHT, "hypotheses": 16},
    "K=256": {**MHT, "hypotheses": 256},
    "K=1024": {**MHT, "hypotheses": 1024},
    "K=1024 settling to 64": {**MHT, "hypotheses": 1024, "settle_scans": 100},
    "K=64 label-free merging": {**MHT, "hypotheses": 64, "merge_labels": True},
    "K=256 label-free merging": {**MHT, "hypotheses": 256, "merge_labels": True},
}
COLUMNS = ["configuration", "program kind", "program", "trials", "XLA [bytes]", "estimate / XLA"]


def scenario(name: str):
    """clutter_3r4t with the ``[tracker]`` table of configuration ``name``."""
    from mjx_radar.scenario.reader import load_scenario

    tracker = dict(CONFIGS[name])
    if "settle_scans" in tracker:
        tracker["settled_hypotheses"] = 64
    return load_scenario("clutter_3r4t").replace(tracker=tracker)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=2)
    ap.add_argument("--kinds", default="none,sfim+pfim+none")
    ap.add_argument("--result", default=None, help="write benchmarks/results/ID.json")
    args = ap.parse_args(argv)
    from measure_memory import measure

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for i, name in enumerate(CONFIGS):
            path = Path(tmp) / f"mht_{i}.toml"
            scenario(name).to_toml(path)
            for kind in args.kinds.split(","):
                study = "+" in kind  # a study's program: every method, metrics only
                row = measure(str(path), kind, args.trials, 8, full=not study)
                program = "study" if study else "run"
                rows.append([name, kind, program, args.trials, row["xla_peak"], row["ratio"]])
                print(" | ".join(map(str, rows[-1])), flush=True)
    if args.result:
        import jax
        from results import write_result

        dev = jax.devices()[0]
        hardware = dev.device_kind if dev.platform == "gpu" else "CPU"
        command = "python benchmarks/mht_memory.py " + " ".join(argv or sys.argv[1:])
        title = "The memory model's MHT terms against XLA's figures: clutter_3r4t"
        print("wrote", write_result(args.result, title, command, hardware, COLUMNS, rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
