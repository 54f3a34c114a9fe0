"""The clutter trackers' cost in the closed loop: control rate and tracker time per step.

For each tracker variant of ``benchmarks/studies/compare_trackers.py`` (``known``,
``jpda``, ``mht-jpda``, ...) and method, ``mjx_radar.simulate`` of ``--trials`` trials x
``--steps`` filter steps, twice (compilation timed apart: ``compile_s`` of the first
call; ``sim_s`` the lesser of the two, the second loading the compiled program).
Prints and writes, per row:

* the control rate ``steps / (filter steps per period * sim_s)`` [Hz] of the batch and
  its ratio to real time (``1 / dt_control``): the simulated seconds the batch advances
  per second;
* with ``stationary`` rows (no planner, so the tracker and the truth dominate) the
  tracker's extra time per filter step and trial against the ``known`` row of the same
  method: ``(sim_s - sim_s(known)) / (steps * trials)``, the cost of associating the
  unlabelled returns amortised over the batch (the known row's own per-target update
  is not in it).

::

    python benchmarks/bench_trackers.py [--scenario clutter_3r4t] [--variants known,jpda,mht-jpda]
        [--methods stationary,ddr-sfim] [--trials 128] [--steps 200] [--result ID]

``--result ID`` writes ``benchmarks/results/ID.json``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent / "studies"))

from compare_trackers import VARIANTS, known_variant, variant  # noqa: E402

import mjx_radar  # noqa: E402

COLUMNS = [
    "variant",
    "method",
    "trials",
    "steps",
    "compile [s]",
    "simulation [s]",
    "control rate [Hz]",
    "x real time",
    "tracker per filter step and trial [ms]",
]


def measure(scenario, variants, methods, trials: int, steps: int) -> list[list]:
    """One row per (variant, method): the module docstring's figures."""
    per_period = round(scenario.timing.dt_control / scenario.timing.dt_filter)
    rows, known = [], {}
    for name in variants:
        sc = variant(scenario, name)
        for method in methods:
            runs = [mjx_radar.simulate(sc, method, trials=trials, steps=steps) for _ in "ab"]
            comp = float(runs[0].meta["compile_s"])  # the second call loads the program
            sim = min(float(r.meta["sim_s"]) for r in runs)
            rate = steps / per_period / sim
            if name == "known":
                known[method] = sim
            extra = "–"
            if method == "stationary" and method in known and name != "known":
                extra = round(1e3 * (sim - known[method]) / (steps * trials), 4)
            rows.append(
                [
                    name,
                    method,
                    trials,
                    steps,
                    round(comp, 1),
                    round(sim, 3),
                    round(rate, 1),
                    round(rate * scenario.timing.dt_control, 2),
                    extra,
                ]
            )
            print(" | ".join(str(v) for v in rows[-1]), flush=True)
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scenario", default="clutter_3r4t")
    ap.add_argument("--variants", default="known,jpda,mht-jpda")
    ap.add_argument("--methods", default="stationary,ddr-sfim")
    ap.add_argument("--trials", type=int, default=128)
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--result", default=None, help="write benchmarks/results/ID.json")
    a = ap.parse_args(argv)
    variants = [v for v in a.variants.split(",") if v]
    unknown = [v for v in variants if not known_variant(v)]
    if unknown:
        ap.error(f"--variants: unknown {unknown}; known: {', '.join(VARIANTS)}")
    if "known" in variants:  # first: the other rows are timed against it
        variants = ["known"] + [v for v in variants if v != "known"]
    scenario = mjx_radar.load_scenario(a.scenario)
    rows = measure(scenario, variants, a.methods.split(","), a.trials, a.steps)
    if a.result:
        import jax
        from results import write_result

        command = "python benchmarks/bench_trackers.py " + " ".join(argv or sys.argv[1:])
        write_result(
            a.result,
            f"Clutter trackers in the closed loop: {a.scenario}, {a.trials} trials",
            command,
            jax.devices()[0].device_kind if jax.default_backend() == "gpu" else "2-core CPU",
            COLUMNS,
            rows,
            notes="Simulation: the lesser of two simulate calls of each row, compilation "
            "timed apart; the "
            "tracker's time is the stationary row's simulation time above the known "
            "association's, per filter step and trial.",
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
