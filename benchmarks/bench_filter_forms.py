"""Cost of the square-root CKF vs the covariance form (issue 26; docs/filters.md).

Micro: one filter step (predict + range update, DDR noise) of the paper_3r4t shape
(N = 3 radars, M = 4 targets), joint (n = 24, p = 12) and per-target bank, for a
batch of trials (vmap), timed as a ``lax.scan`` of ``--scan`` steps (per-step time
reported). Closed loop: ``run_trials`` of a scenario, both forms and structures,
warm (median ``sim_s`` of interleaved repeats; compilation excluded).

    python benchmarks/bench_filter_forms.py --trials 8 --steps 200 [--skip-loop]
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_timing import median_seconds  # noqa: E402

from mjx_radar.engine.run_spec import run_spec
from mjx_radar.estimation.filters import ckf_sqrt, filter_bank  # noqa: E402
from mjx_radar.estimation.sensor import sensing
from mjx_radar.physics import motion  # noqa: E402
from mjx_radar.scenario.schema import RadarEquation  # noqa: E402

N, M, DT = 3, 4, 0.025


def _step_fn(form: str, structure: str, radars, c):
    ops = ckf_sqrt.form_ops(form)
    A, Q = motion.cv_transition(DT, M), motion.cv_process_noise(DT, 10.0, M)
    q, q6 = ops.noise(Q), ops.noise(Q[:6, :6])
    R = filter_bank.ddr_R(c)

    def h(x):
        pos = x.reshape(M, 6)[:, :3]
        return 2.0 * jnp.linalg.norm(pos[None] - radars[:, None], axis=-1).reshape(-1)

    def step(carry, z):
        mean, C = carry
        if structure == "per-target":
            mean, C = filter_bank.predict_joint(mean, C, A[:6, :6], q6, form)
            means, Cs = filter_bank.joint_to_bank(mean, C)
            zb = z.reshape(N, M, 1)
            post = filter_bank.update_bank(
                means, Cs, zb, radars, filter_bank.range_pair, R, form=form
            )
            mean, C = filter_bank.bank_to_joint(*post)
        else:
            mean, C = ops.predict(mean, C, lambda v: A @ v, q)
            mean, C = ops.update(mean, C, z, h, R)
        return (mean, C), None

    return step, ops


def micro(batch: int, scan: int) -> list[tuple]:
    rng = np.random.default_rng(0)
    radars = jnp.asarray(np.c_[rng.uniform(-400, 400, (N, 2)), np.zeros(N)], jnp.float32)
    truth = np.array(
        [[0, 0, 55, 20, 10, 0], [15.4, 15.32, 70, 15, 20, 0],
         [10, 10, 55, 17, 19, 0], [20, 20, 45, 6, 8, 0]], np.float32,
    )  # fmt: skip
    c = sensing.noise_constant(RadarEquation(), M)
    z0 = 2.0 * np.linalg.norm(truth[None, :, :3] - np.asarray(radars)[:, None], axis=-1)
    zs = jnp.asarray(np.broadcast_to(z0.reshape(-1), (batch, scan, N * M)), jnp.float32)
    rows = []
    for structure in ("joint", "per-target"):
        for form in ("covariance", "sqrt"):
            step, ops = _step_fn(form, structure, radars, c)
            mean0 = jnp.broadcast_to(jnp.asarray(truth.reshape(-1)) + 1.0, (batch, 6 * M))
            C0 = jnp.broadcast_to(ops.carry(50.0 * jnp.eye(6 * M)), (batch, 6 * M, 6 * M))
            run = jax.jit(jax.vmap(lambda m, C, z: jax.lax.scan(step, (m, C), z)[0]))  # noqa: B023
            sec = median_seconds(run, mean0, C0, zs, calls=5)
            rows.append((structure, form, batch, 1e6 * sec / scan))
    return rows


def loop(scenario: str, trials: int, steps: int, repeat: int) -> list[tuple]:
    """Compiles the four programs, then ``repeat`` interleaved rounds of warm runs
    (a shared host's load drifts: interleaving spreads it over the four); median sim_s."""
    from mjx_radar.engine import runner
    from mjx_radar.scenario.reader import load_scenario

    sc = load_scenario(scenario)
    configs = [(st, fm) for st in ("joint", "per-target") for fm in ("covariance", "sqrt")]

    def run(st, fm):
        s = dataclasses.replace(sc, filter=dataclasses.replace(sc.filter, structure=st, form=fm))
        return runner.run_trials(run_spec(s), "ddr-sfim", 0, np.arange(trials), steps, full=False)

    compile_s = {c: run(*c)["compile_s"] for c in configs}
    sims = {c: [] for c in configs}
    for _ in range(repeat):
        for c in configs:
            sims[c].append(run(*c)["sim_s"])
            print(*c, sims[c][-1], flush=True)
    return [(*c, compile_s[c], float(np.median(sims[c]))) for c in configs]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="paper_3r4t")
    ap.add_argument("--trials", type=int, default=8)
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--batch", type=int, nargs="+", default=[1, 64])
    ap.add_argument("--scan", type=int, default=200)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--skip-loop", action="store_true")
    ap.add_argument("--skip-micro", action="store_true")
    a = ap.parse_args()
    print(f"device: {jax.devices()[0].device_kind} ({jax.default_backend()})")
    if not a.skip_micro:
        print("| structure | form | batch | µs per filter step (batch) |\n|---|---|---|---|")
        for b in a.batch:
            for row in micro(b, a.scan):
                print("| {} | {} | {} | {:.1f} |".format(*row), flush=True)
    if not a.skip_loop:
        print(f"closed loop {a.scenario}, {a.trials} trials x {a.steps} steps (ddr-sfim):")
        print("| structure | form | compile s | sim_s (warm, median) |\n|---|---|---|---|")
        for row in loop(a.scenario, a.trials, a.steps, a.repeat):
            print("| {} | {} | {:.1f} | {:.2f} |".format(*row))


if __name__ == "__main__":
    main()
