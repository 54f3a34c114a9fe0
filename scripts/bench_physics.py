"""Env-steps/s of the batched MJX radar rollout vs the pure-JAX analytic rollout (issue 2).

An "env" is one sample holding all N radars; one env-step advances all of them by
one control step. Each measurement is a jitted, vmapped 15-step rollout, timed
after warm-up (median of --repeats).

    python scripts/bench_physics.py [--batches 200,1000,8192] [--radars 3,6] [--horizon 15]
"""

from __future__ import annotations

import argparse
import functools

import jax
import jax.numpy as jnp
from bench_timing import median_seconds  # scripts/, on the path when run

from mjx_radar import physics
from mjx_radar.physics.kinematics import unicycle_rollout
from mjx_radar.scenario.schema import RadarLimits


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--batches", default="200,1000,8192")
    ap.add_argument("--radars", default="3,6")
    ap.add_argument("--horizon", type=int, default=15)
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    lim, dt, h = RadarLimits(), 0.1, args.horizon
    print(f"device={jax.devices()[0].device_kind} horizon={h}")
    print(
        f"{'B':>6} {'N':>3} {'mjx_ms':>9} {'mjx_env_steps/s':>16} {'jax_ms':>8} "
        f"{'jax_env_steps/s':>16} {'ratio':>6}"
    )
    for n in (int(x) for x in args.radars.split(",")):
        plant = physics.make_plant(n, 0, dt, lim)
        mjx_fn = jax.jit(jax.vmap(functools.partial(physics.radar_rollout, plant)))
        jax_fn = jax.jit(jax.vmap(lambda s, u: unicycle_rollout(s, u, dt, lim)))
        for b in (int(x) for x in args.batches.split(",")):
            k1, k2 = jax.random.split(jax.random.PRNGKey(b + n))
            s0 = jnp.zeros((b, n, 6)).at[..., :2].set(jax.random.normal(k1, (b, n, 2)) * 300)
            u = jax.random.normal(k2, (b, h, n, 2)) * jnp.array([25.0, 0.8])
            t_mjx = median_seconds(mjx_fn, s0, u, calls=args.repeats)
            t_jax = median_seconds(jax_fn, s0, u, calls=args.repeats)
            print(
                f"{b:6d} {n:3d} {t_mjx * 1e3:9.2f} {b * h / t_mjx:16.3e} {t_jax * 1e3:8.2f} "
                f"{b * h / t_jax:16.3e} {t_mjx / t_jax:6.1f}"
            )


if __name__ == "__main__":
    main()
