"""The MHT's work in one filter step at study batch, phase by phase.

    python benchmarks/bench_mht_step.py [--scenario clutter_3r4t] [--trials 128]
        [--hypotheses 1024] [--settled 64] [--repeats 20] [--result ID]

The tracker is docs/tracking.md's recommended configuration (**Selecting it**: K
hypotheses branching over the first scan, JPDA within each, the K₂ heaviest after the
settling scan, the ground and altitude priors, the consensus estimate) with K and K₂ from
the command line. One filter step is what the loop asks of it: the time update, every
radar's scan, the priors after them and the reported estimate (``FilterOps.predict``
then ``update``), ``vmap``-ed over the trials and jitted, the scan counter shared by the
batch as in the study's program. Three phases: the branching scan (scan 0), a soft scan
(every hypothesis live) and a settled scan (K₂ live of K slots, after the settling
scan). The inputs are synthetic and the same for every trial: the scenario's drones at
their start, the hypotheses scattered 2 m about them, three radars 300 m out, each scan
the drones' ranges and the buffer's clutter. Prints and (``--result ID``) writes the
lesser of ``--repeats`` timings after compilation, per step of the batch and per trial.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

import mjx_radar
from mjx_radar.env import mht_ops
from mjx_radar.env.scan import Scan
from mjx_radar.estimation.data_association import mht
from mjx_radar.task.task import build

sys.path.insert(0, str(Path(__file__).resolve().parent))

COLUMNS = ["phase", "hypotheses K", "live hypotheses", "trials", "step [ms]", "per trial [us]"]


def scenario(name: str, k: int, k2: int):
    """The recommended MHT (docs/tracking.md) with K = k, K₂ = k2 (settling at scan 200)."""
    return mjx_radar.load_scenario(name).replace(
        tracker={
            "association": "mht",
            "hypotheses": k,
            "merge_screen": 2,
            "branch_scans": 1,
            "settle_scans": 200,
            "settled_hypotheses": k2,
            "estimate": "consensus",
            "height_std": 40.0,
        },
        filter={"ground_prior": True},
        detection={"gate_probability": 0.9999},
    )


def inputs(sc, k: int, live: int, scans: int, rng):
    """``(modes, scan, radar_pos)`` of one trial: K slots, the first ``live`` weighing."""
    truth = np.asarray(sc.target_init, np.float32)
    m, n = truth.shape[0], sc.n_radars
    angle = 2 * np.pi * np.arange(n) / n
    radar_pos = np.stack([300 * np.cos(angle), 300 * np.sin(angle), np.zeros(n)], 1)
    radar_pos = radar_pos.astype(np.float32)
    means = truth[None, :, :6] + rng.normal(0, 2, (k, m, 6)).astype(np.float32)
    covs = np.tile(4 * np.eye(6, dtype=np.float32), (k, m, 1, 1))
    logw = np.where(np.arange(k) < live, -np.log(live), -np.inf).astype(np.float32)
    modes = mht.HypState(*map(jnp.asarray, (means, covs, logw)), jnp.asarray(scans, jnp.int32))
    cap = m + sc.detection.max_false_alarms
    d = np.linalg.norm(truth[None, :, :3] - radar_pos[:, None], axis=-1)
    zs = np.zeros((n, cap, 1), np.float32)
    zs[:, :m, 0] = 2 * d
    zs[:, m:, 0] = rng.uniform(0, 2 * sc.detection.clutter_range_max, (n, cap - m))
    scan = Scan(None, jnp.asarray(n * m), jnp.asarray(n * m), jnp.asarray(n * (cap - m)),
                jnp.asarray(zs), jnp.ones((n, cap), bool))  # fmt: skip
    return modes, scan, jnp.asarray(radar_pos)


def time_step(sc, modes, scan, radar_pos, trials: int, repeats: int) -> float:
    """The lesser of ``repeats`` timings [s] of one jitted, vmapped filter step."""
    ops = mht_ops.mht_bank(*build(sc, "stationary"))
    m = modes.means.shape[1]
    mean, cov = jnp.zeros(6 * m), jnp.eye(6 * m)
    z = jnp.zeros((radar_pos.shape[0], m, 1))

    def step(modes):
        pm, pc, modes = ops.predict(mean, cov, modes)
        return ops.update(pm, pc, modes, z, radar_pos, scan)

    axes = mht.HypState(0, 0, 0, None)  # the scan counter: the batch's (the study's program)
    tile = lambda x: jnp.broadcast_to(x, (trials, *x.shape))  # noqa: E731
    batch = modes._replace(means=tile(modes.means), covs=tile(modes.covs), logw=tile(modes.logw))
    run = jax.jit(jax.vmap(step, in_axes=(axes,)))
    jax.block_until_ready(run(batch))
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        jax.block_until_ready(run(batch))
        best = min(best, time.perf_counter() - t0)
    return best


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scenario", default="clutter_3r4t")
    ap.add_argument("--trials", type=int, default=128)
    ap.add_argument("--hypotheses", type=int, default=1024)
    ap.add_argument("--settled", type=int, default=64)
    ap.add_argument("--repeats", type=int, default=20)
    ap.add_argument("--result", default=None, help="write benchmarks/results/ID.json")
    a = ap.parse_args(argv)
    for name, v, lo in (("--trials", a.trials, 1), ("--hypotheses", a.hypotheses, 2),
                        ("--settled", a.settled, 1), ("--repeats", a.repeats, 1)):  # fmt: skip
        if v < lo:
            ap.error(f"{name} = {v}: must be >= {lo}")
    if a.settled >= a.hypotheses:
        ap.error(f"--settled = {a.settled}: must be < --hypotheses = {a.hypotheses}")
    k, k2 = a.hypotheses, a.settled
    sc = scenario(a.scenario, k, k2)
    rng = np.random.default_rng(0)
    rows = []
    for phase, live, scans in (("branching", 1, 0), ("soft", k, 5), ("settled", k2, 205)):
        modes, scan, radar_pos = inputs(sc, k, live, scans, rng)
        s = time_step(sc, modes, scan, radar_pos, a.trials, a.repeats)
        rows.append([phase, k, live, a.trials, round(s * 1e3, 3), round(s * 1e6 / a.trials, 1)])
        print(" | ".join(map(str, rows[-1])), flush=True)
    if a.result:
        from results import write_result

        device = jax.devices()[0]
        write_result(
            a.result,
            f"The MHT's filter step by phase: {a.scenario}, K = {k}, K2 = {k2}, {a.trials} trials",
            "python benchmarks/bench_mht_step.py " + " ".join(argv or sys.argv[1:]),
            device.device_kind if jax.default_backend() == "gpu" else "2-core CPU",
            COLUMNS,
            rows,
            notes="The lesser of the repeats, after compilation; synthetic inputs (module "
            "docstring); branching: one live hypothesis; soft: every slot live; settled: "
            "K2 live, after the settling scan.",
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
