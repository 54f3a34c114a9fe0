"""How long the MHT's hypotheses compete, and how far the planner's mixture is from the best.

The closed loop of ``clutter_3r4t`` with the ``mht-jpda`` tracker (K = 64, merge screen 2,
one branching scan) and ``plan_on = "mixture"`` (docs/tracking.md, "Planning for the
hypotheses"), trials 0 to T-1 side by side (``vmap``), advanced one control period at a
time. After each period: the heaviest hypothesis's weight, the effective number of
hypotheses ``1 / Σ_h w_h²``, and the largest distance over targets and axes between the
position the planner sees (the mixture) and the heaviest hypothesis's (what the metrics
score)::

    python benchmarks/studies/mht_weights.py [--trials 4] [--periods 30] [--method ddr-sfim]
        [--every 1] [--result ID]

Prints one line per period (with ``--every N`` the first and every N-th); ``--result ID``
writes ``benchmarks/results/ID.json`` with the median over trials of each (and the largest
shift of any trial).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

TRACKER = {
    "association": "mht",
    "hypotheses": 64,
    "merge_screen": 2,
    "branch_scans": 1,
    "plan_on": "mixture",
}
COLUMNS = [
    "period",
    "time [s]",
    "median heaviest weight",
    "median effective hypotheses",
    "median planner shift [m]",
    "largest planner shift [m]",
]


def measure(trials: int, periods: int, method: str, every: int = 1) -> list[list]:
    """One row per control period (module doc)."""
    import jax
    import jax.numpy as jnp

    import mjx_radar
    from mjx_radar.loop import closed_loop
    from mjx_radar.task.method import parse_method
    from mjx_radar.task.params import shape_key, task_params
    from mjx_radar.task.task import make_task

    s = mjx_radar.load_scenario("clutter_3r4t").replace(tracker=TRACKER)
    m = parse_method(method)
    task = make_task(shape_key(s), m.kind)
    params = task_params(s, m, None)
    init = jax.vmap(lambda t: closed_loop.init_carry(task, params, t)[0])
    carry = jax.jit(init)(jnp.arange(trials))
    advance = jax.jit(jax.vmap(lambda c: closed_loop.advance(task, params, c, 1)[0]))
    rows = []
    for j in range(1, periods + 1):
        carry = advance(carry)
        st = carry.state
        w = np.exp(np.asarray(st.loop.modes.logw, np.float64))  # [T, K]
        diff = np.asarray(st.obs.mean) - np.asarray(st.loop.mean)
        shift = np.abs(diff.reshape(trials, -1, 6)[..., :3]).max((1, 2))  # [T]
        row = [j, round(j * task.timing.dt_control, 3), np.median(w.max(-1))]
        row += [np.median(1.0 / np.sum(w**2, -1)), np.median(shift), shift.max()]
        if j == 1 or j % every == 0:
            rows.append([*row[:2], *(float(f"{v:.3g}") for v in row[2:])])
            print(*rows[-1], flush=True)
    return rows


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--trials", type=int, default=4)
    p.add_argument("--periods", type=int, default=30)
    p.add_argument("--method", default="ddr-sfim")
    p.add_argument("--every", type=int, default=1, help="keep the first and every N-th period")
    p.add_argument("--result", default=None, help="also write benchmarks/results/ID.json")
    args = p.parse_args(argv)
    print(*COLUMNS, sep=" | ")
    rows = measure(args.trials, args.periods, args.method, args.every)
    if args.result:
        import jax

        sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
        from results import write_result

        dev = jax.devices()[0]
        hardware = dev.device_kind if dev.platform == "gpu" else "CPU"
        argv = sys.argv[1:] if argv is None else argv
        command = " ".join(["python benchmarks/studies/mht_weights.py", *argv])
        title = f"The MHT's hypotheses over the first periods: {args.trials} trials, {args.method}"
        notes = (
            "clutter_3r4t, mht-jpda (K = 64, merge screen 2, branch_scans = 1) with plan_on = "
            '"mixture", seed 0; shift: the largest |mixture - heaviest| over targets and '
            "position axes of the planner's observation; the medians are over trials."
        )
        path = write_result(args.result, title, command, hardware, COLUMNS, rows, notes)
        print(f"wrote {path}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
