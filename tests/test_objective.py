"""The radar-placement objective and MPPI in closed loop (issue 4 behaviour)."""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_radar.estimation.information import fisher
from mjx_radar.estimation.sensor.sensing import noise_constant
from mjx_radar.loop import closed_loop
from mjx_radar.scenario.reader import scenario_from_dict
from mjx_radar.task import objective
from mjx_radar.task.task import build

HOVER = {
    "name": "hover",
    "n_radars": 1,
    "targets": [[0.0, 0.0, 50.0, 0.0, 0.0, 0.0]],
    "radars": [[400.0, 0.0, 2.0]],
    "sigma_w2": 0.0,
    "timing": {"steps": 400},
    "mppi": {"samples": 128, "iterations": 4},
}


def _run(raw, method="ddr-sfim"):
    s = scenario_from_dict(raw)
    task, params = build(s, method, 0)
    res = jax.jit(lambda: closed_loop.simulate(task, params, 0))()
    return s, res


def test_single_radar_closes_in_and_holds_outside_r2t():
    s, res = _run(HOVER)
    radar = np.asarray(res.steps.radar)[:, 0, :3]
    target = np.asarray(res.steps.target)[:, 0, :3]
    dist = np.linalg.norm(radar - target, axis=-1)
    r2t = s.mpc.r2t
    assert dist[0] > 390  # starts 400 m away
    assert dist.min() >= r2t  # never inside the keep-out
    assert np.all(dist[-100:] <= r2t + 25.0), dist[-100:].max()  # holds close


@pytest.mark.slow  # a 200-step closed loop of its own (25-35 s on 2 cores); test_closed_loop
# checks the R2R keep-out of every mobile method in CI
def test_two_radars_never_within_r2r():
    raw = HOVER | {
        "n_radars": 2,
        "radars": [[300.0, 0.0, 3.1], [300.0, 30.0, 3.1]],
        "timing": {"steps": 200},
        "mpc": {"r2r": 25.0},
    }
    s, res = _run(raw)
    radar = np.asarray(res.steps.radar)[..., :2]
    d = np.linalg.norm(radar[:, 0] - radar[:, 1], axis=-1)
    assert d.min() >= s.mpc.r2r


def test_objective_terms_against_direct_computation():
    # Radars held still: the SFIM term is the discounted mean over cubature points of
    # sum_m log det J_m computed directly with fisher.sfim; penalties counted by hand.
    # float64: a rank-2 FIM's log det holds log(floor) terms that float32 cannot resolve.
    with jax.enable_x64(True):
        _objective_terms()


def _planned(task, u, radar, mean, cov, params):
    """The objective of ``u`` from the planning context of (radar, mean, cov), and the
    context's cubature points, as one jitted program (eagerly, each of their hundreds of
    small ops compiles on its own)."""

    @jax.jit
    def run(u, radar, mean, cov, params):
        ctx = objective.plan_context(task, radar, mean, cov)
        return *objective.make_objective(task)(u, ctx, params), ctx.target_points

    return run(u, radar, mean, cov, params)


def _objective_terms():
    raw = {
        "name": "obj",
        "n_radars": 2,
        "targets": [[0.0, 0.0, 50.0, 0.0, 0.0, 0.0], [60.0, 0.0, 50.0, 0.0, 0.0, 0.0]],
        "mpc": {"horizon": 4, "rollout": "analytic"},
    }
    s = scenario_from_dict(raw)
    radar = jnp.array([[100.0, 0, 0, 0, 0, 0], [105.0, 0, 0, 0, 0, 0]])  # 5 m apart < R2R
    mean = jnp.asarray(s.target_init, jnp.float32).reshape(-1)
    cov = 4.0 * jnp.eye(12)
    task, params = build(s, "ddr-sfim")
    cost, plan, pts = _planned(task, jnp.zeros((4, 4)), radar, mean, cov, params)
    c = noise_constant(s.radar_eq, 2)
    pts = np.asarray(pts)  # [H, P, M, 6]
    sfim_logdet = jax.jit(lambda p: fisher.logdet(fisher.sfim(radar[:, :3], p, c)))
    info = 0.0
    n_rt = 0.0
    for t in range(4):
        ld = [np.sum(np.asarray(sfim_logdet(jnp.asarray(p[:, :3])))) for p in pts[t]]
        info += s.mpc.gamma**t * np.mean(ld)
        d = np.linalg.norm(pts[t][:, None, :, :3] - np.asarray(radar)[None, :, None, :3], axis=-1)
        n_rt += s.mpc.gamma**t * np.mean(np.sum(d < s.mpc.r2t, axis=(1, 2)))
    n_rr = sum(s.mpc.gamma**t for t in range(4))  # the pair is inside R2R at every step
    expected = -info + s.mpc.alpha_r2r * n_rr + s.mpc.alpha_r2t * n_rt
    # float64; the only difference is the O(1e-15) relative jitter of the factorisations.
    np.testing.assert_allclose(float(cost), expected, rtol=1e-9)
    np.testing.assert_allclose(-float(plan.terms["information"]), info, rtol=1e-9)
    np.testing.assert_allclose(float(plan.terms["radar_radar"]), s.mpc.alpha_r2r * n_rr, rtol=1e-12)
    np.testing.assert_allclose(float(plan.terms["radar_target"]), s.mpc.alpha_r2t * n_rt, rtol=1e-9)
    assert set(plan.terms) == {"information", "radar_radar", "radar_target"}


def test_pfim_objective_against_direct_recursion():
    # PFIM term: per target, J_{t+1} = pfim_step(J_t, A, W, E_p[J_D]) from the inverse of the
    # target's marginal covariance block; discounted sum of log det J_t.
    with jax.enable_x64(True):
        raw = {
            "name": "obj",
            "n_radars": 3,
            "targets": [[0.0, 0.0, 50.0, 3.0, 1.0, 0.0], [60.0, 10.0, 70.0, -2.0, 0.0, 0.0]],
            "mpc": {"horizon": 5, "rollout": "analytic"},
        }
        s = scenario_from_dict(raw)
        radar = jnp.array([[200.0, 0, 0, 0, 0, 0], [-150.0, 90, 0, 0, 0, 0], [0, -210, 0, 0, 0, 0]])
        mean = jnp.asarray(s.target_init).reshape(-1)
        cov = jnp.diag(jnp.linspace(1.0, 9.0, 12))
        task, params = build(s, "ddr-pfim")
        _, plan, pts = _planned(task, jnp.zeros((5, 6)), radar, mean, cov, params)
        from mjx_radar.physics import motion

        c = noise_constant(s.radar_eq, 2)
        a = np.asarray(motion.cv_transition(s.timing.dt_control, 1))
        w = np.asarray(motion.cv_process_noise(s.timing.dt_control, s.sigma_w2, 1))
        pts = np.asarray(pts)
        sfim = jax.jit(lambda p: fisher.sfim(radar[:, :3], p, c))
        info = 0.0
        for m in range(2):
            j = np.linalg.inv(np.asarray(cov)[6 * m : 6 * m + 6, 6 * m : 6 * m + 6])
            for t in range(5):
                jd = np.zeros((6, 6))
                for p in pts[t]:
                    jd[:3, :3] += np.asarray(sfim(jnp.asarray(p[:, :3])))[m]
                jd /= len(pts[t])
                j = np.linalg.inv(w + a @ np.linalg.inv(j) @ a.T) + jd  # textbook numpy
                floored = j + fisher.INFO_FLOOR * np.eye(6)  # the documented log-det floor
                info += s.mpc.gamma**t * np.linalg.slogdet(floored)[1]
        # float64 with numpy inverses as the reference; jitter is O(1e-15) relative.
        np.testing.assert_allclose(-float(plan.terms["information"]), info, rtol=1e-9)


def test_one_objective_per_task_traced_once():
    """The objective is one jitted function per task (kept on it): called eagerly (a
    notebook, an environment's ``objective(obs)`` per step) it compiles once, not per
    call; in a traced program its Python runs once although MPPI calls it three times."""
    from mjx_radar.task.planner import make_planner

    raw = HOVER | {"mpc": {"horizon": 3, "rollout": "analytic"}, "mppi": {"samples": 16}}
    task, params = build(scenario_from_dict(raw), "ddr-sfim", 0)
    cost = objective.make_objective(task)
    assert objective.make_objective(task) is cost and hasattr(cost, "lower")  # jitted
    traced = []
    term = task.terms[0]

    def counted(hz, task_, params_):
        traced.append(1)
        return term.fn(hz, task_, params_)

    counting = dataclasses.replace(task, terms=(term._replace(fn=counted), *task.terms[1:]))
    assert objective.make_objective(counting) is not cost  # another task, its own
    plan = make_planner(counting)
    radar = jnp.array([[400.0, 0.0, 0.0, 0.0, 0.0, 0.0]])
    mean = jnp.array([0.0, 0.0, 50.0, 0.0, 0.0, 0.0])
    jax.jit(lambda *a: plan(*a, params)[0].mean).lower(
        radar, mean, jnp.eye(6), jnp.zeros((3, 2)), jax.random.PRNGKey(0)
    )
    assert len(traced) == 1  # MPPI's three calls (aux shape, samples, plan): one trace


def test_objective_traced_once_inside_shard_map():
    """Inside a program's ``shard_map`` the iteration's samples vary over the trial axis
    (they come from the split warm start): MPPI's aux-shape probe has their type, so the
    objective is traced once there too (the probe typed as a plain array traced it a
    second time in every closed-loop program)."""
    from jax.sharding import Mesh, PartitionSpec

    from mjx_radar.task.planner import make_planner

    raw = HOVER | {"mpc": {"horizon": 3, "rollout": "analytic"}, "mppi": {"samples": 16}}
    task, params = build(scenario_from_dict(raw), "ddr-sfim", 0)
    traced = []
    term = task.terms[0]

    def counted(hz, task_, params_):
        traced.append(1)
        return term.fn(hz, task_, params_)

    plan = make_planner(
        dataclasses.replace(task, terms=(term._replace(fn=counted), *task.terms[1:]))
    )
    radar = jnp.array([[400.0, 0.0, 0.0, 0.0, 0.0, 0.0]])
    mean = jnp.array([0.0, 0.0, 50.0, 0.0, 0.0, 0.0])

    def per_device(u_plan):  # [1, H, 2]: this device's trial
        key = jax.random.PRNGKey(0)
        return plan(radar, mean, jnp.eye(6), u_plan[0], key, params)[0].mean[None]

    mesh = Mesh(jax.devices()[:1], ("trial",))
    split = PartitionSpec("trial")
    program = jax.shard_map(per_device, mesh=mesh, in_specs=split, out_specs=split, check_vma=False)
    jax.jit(program).lower(jnp.zeros((1, 3, 2)))
    assert len(traced) == 1  # the probe, the samples and the plan: one trace
