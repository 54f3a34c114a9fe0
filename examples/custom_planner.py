"""A planner of your own, registered from the script and run like MPPI (docs/extending.md).

    python examples/custom_planner.py [--small]
    mjx-radar run smoke --plugin examples/custom_planner.py --planner best-of-k

"Best of K": every control period, K constant-control candidates (one random [a, alpha]
per radar, held over the horizon) are scored with the method's information objective
(``env.objective``) and the best one's first control is applied. The planner sees only
``obs`` (the radars' states and the track estimate), never the truth.
"""

import jax
import jax.numpy as jnp

import mjx_radar

K = 64  # candidates per control period


@mjx_radar.register_planner("best-of-k")
class BestOfK(mjx_radar.Planner):
    def plan(self, carry, obs, key):
        lower, upper = self.env.action_bounds  # [N, 2] each
        u = jax.random.uniform(key, (K, *lower.shape), minval=lower, maxval=upper)  # [K, N, 2]
        horizon = self.env.task.mpc.horizon
        seqs = jnp.repeat(u[:, None], horizon, axis=1).reshape(K, horizon, -1)  # [K, H, 2N]
        cost, _ = jax.vmap(self.env.objective(obs))(seqs)
        return u[jnp.argmin(cost)], carry


if __name__ == "__main__":
    from _common import parse, small

    args = parse(__doc__.splitlines()[0], "custom_planner")
    scenario = small(mjx_radar.load_scenario("smoke" if args.small else "paper_3r4t"), args)
    trials, steps = (2, 16) if args.small else (8, None)
    lines = []
    for planner in ("mppi", "best-of-k"):
        run = mjx_radar.simulate(scenario, "ddr-sfim", trials=trials, steps=steps, seed=0,
                                 planner=planner, progress=False)  # fmt: skip
        s = run.summary()
        lines.append(f"{planner:>10}: mean RMSE {s['rmse_pos']:.3f} m, "
                     f"control rate {s['control_hz']:.0f} Hz")  # fmt: skip
    print("\n".join(lines))
    (args.out / "custom_planner.txt").write_text("\n".join(lines) + "\n")
