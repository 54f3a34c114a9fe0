"""A cost term of your own, registered from the script (docs/extending.md).

    python examples/custom_cost.py [--small]

The term keeps the radars within 300 m of the origin (a road network, a base) by
penalising every metre beyond it. Registered terms enter every objective built
afterwards and are reported by name in the planner's ``Plan.terms``; their code is
part of the program cache key, so editing the term recompiles.
"""

import jax
import jax.numpy as jnp
from _common import parse, small

import mjx_radar

RADIUS, WEIGHT = 300.0, 50.0  # [m], cost per metre beyond the radius per radar and step


def stay_home(h, task, params):
    """``WEIGHT * sum_n relu(|p_n| - RADIUS)`` per horizon step; h.radar is [H, N, 6]."""
    r = jnp.linalg.norm(h.radar[..., :2], axis=-1)  # [H, N]
    return WEIGHT * jax.nn.relu(r - RADIUS).sum(-1)  # [H]


args = parse(__doc__.splitlines()[0], "custom_cost")
scenario = small(mjx_radar.load_scenario("smoke" if args.small else "paper_3r4t"), args)
trials, steps = (2, 16) if args.small else (8, None)

free = mjx_radar.simulate(scenario, trials=trials, steps=steps, seed=0, progress=False)
mjx_radar.register_cost_term("stay_home", stay_home)
try:
    homed = mjx_radar.simulate(scenario, trials=trials, steps=steps, seed=0, progress=False)
finally:
    mjx_radar.unregister_cost_term("stay_home")

lines = []
for name, run in (("without", free), ("with", homed)):
    xy = run.trajectories.radar_states.sel(radar_state=["x", "y"]).isel(step=-1)
    dist = float(((xy**2).sum("radar_state") ** 0.5).mean())  # mean over trials and radars
    lines.append(
        f"{name:>7} stay_home: radars end {dist:7.1f} m from the origin on average, "
        f"mean RMSE {run.summary()['rmse_pos']:.3f} m"
    )
print("\n".join(lines))
(args.out / "custom_cost.txt").write_text("\n".join(lines) + "\n")
