"""The task layer: methods, shape keys, runtime parameters, cost terms, objective flags."""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_radar.estimation.information import fisher
from mjx_radar.estimation.sensor import sensing
from mjx_radar.physics import motion
from mjx_radar.scenario.reader import scenario_from_dict
from mjx_radar.task import objective
from mjx_radar.task.method import METHODS, Method, parse_method
from mjx_radar.task.params import shape_key, task_params
from mjx_radar.task.task import build, make_task

BASE = {
    "name": "task",
    "n_radars": 2,
    "seed": 3,
    "targets": [[0.0, 0.0, 50.0, 4.0, -2.0, 0.0], [60.0, 10.0, 45.0, 0.0, 3.0, 1.0]],
    "mpc": {"horizon": 4, "rollout": "analytic"},
    "mppi": {"samples": 16, "iterations": 1},
}


def _scenario(**over):
    raw = {k: (dict(v) if isinstance(v, dict) else v) for k, v in BASE.items()}
    for k, v in over.items():
        if isinstance(v, dict):
            raw[k] = raw.get(k, {}) | v
        else:
            raw[k] = v
    return scenario_from_dict(raw)


# -- methods ------------------------------------------------------------------------------

EXPECTED = {  # name: (noise, info, flags (ccr, pfim, plans))
    "stationary": ("ddr", "none", (False, False, False)),
    "ccr-sfim": ("ccr", "sfim", (True, False, True)),
    "ccr-pfim": ("ccr", "pfim", (True, True, True)),
    "ddr-sfim": ("ddr", "sfim", (False, False, True)),
    "ddr-pfim": ("ddr", "pfim", (False, True, True)),
}


def test_every_method_parses_with_its_flags():
    assert set(METHODS) == set(EXPECTED)
    for name, (noise, info, flags) in EXPECTED.items():
        m = parse_method(name)
        assert (m.name, m.noise, m.info) == (name, noise, info)
        assert m.plans == flags[2]
        f = m.flags()
        got = tuple(bool(x) for x in (f.ccr, f.pfim, f.plans))
        assert got == flags, name
        assert all(jnp.shape(x) == () and jnp.asarray(x).dtype == bool for x in f)
        assert parse_method(m) is m  # a Method passes through


@pytest.mark.parametrize("bad", ["ddr_sfim", "DDR-SFIM", "", "pfim", 3, None])
def test_unknown_method_is_a_one_line_value_error(bad):
    with pytest.raises(ValueError) as e:
        parse_method(bad)
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith("method:")
    assert all(name in msg for name in METHODS)  # names the allowed values


def test_method_rejects_bad_noise_and_info():
    with pytest.raises(ValueError, match="noise"):
        Method("x", "cr", "sfim")
    with pytest.raises(ValueError, match="info"):
        Method("x", "ddr", "fim")


# -- shape key and runtime parameters -----------------------------------------------------


def test_shape_key_blanks_runtime_numbers():
    s = _scenario()
    numbers = _scenario(
        name="other",
        seed=9,
        sigma_w2=2.0,
        p0=7.0,
        targets=[[5.0, 1.0, 60.0, 0.0, 0.0, 0.0], [-60.0, 3.0, 40.0, 1.0, 1.0, 0.0]],
        mpc={"r2t": 90.0, "r2r": 20.0, "gamma": 0.8, "alpha_r2t": 5.0, "alpha_r2r": 6.0},
        radar_equation={"snr_db": -5.0, "fc": 2e8},
    )
    assert shape_key(s) == shape_key(numbers)
    assert hash(shape_key(s)) == hash(shape_key(numbers))
    for other in (
        _scenario(n_radars=3),
        _scenario(mpc={"horizon": 5}),
        _scenario(targets=BASE["targets"][:1]),  # M is shape
        _scenario(mpc={"rollout": "mjx"}),
        _scenario(mpc={"alpha_effort": 1.0}),  # adds a cost term: shape
    ):
        assert shape_key(other) != shape_key(s)


def test_blanked_fields_fail_loudly():
    key = shape_key(_scenario())
    for read in (
        lambda: key.mpc.r2t * 2.0,
        lambda: key.mpc.gamma ** jnp.arange(3),
        lambda: key.seed + 1,
        lambda: key.sigma_w2 * 1.0,
        lambda: key.radar_eq.snr_db / 10.0,
        lambda: key.target_init[0][2] + 1.0,
        lambda: key.p0 * jnp.eye(6),
    ):
        with pytest.raises(TypeError):
            read()
    with pytest.raises((TypeError, ValueError)):  # the noise constant needs the radar equation
        sensing.noise_constant(key.radar_eq, key.n_targets)
    # what stays: the shape
    assert key.n_radars == 2 and key.n_targets == 2 and key.mpc.horizon == 4


def test_task_params_equal_the_scenario_numbers():
    s = _scenario(sigma_w2=3.5, p0=12.0, mpc={"r2t": 110.0, "r2r": 15.0, "gamma": 0.9},
                  radars=[[200.0, 0.0, 0.5], [-200.0, 10.0, -1.0]])  # fmt: skip
    p = task_params(s, parse_method("ccr-pfim"), seed=17)
    c = sensing.noise_constant(s.radar_eq, s.n_targets)  # host float64
    # float32 storage of host float64 numbers: one rounding (2^-24 relative)
    np.testing.assert_allclose(float(p.noise.c), c, rtol=2**-23)
    np.testing.assert_allclose(float(p.noise.sigma_r2), c * 110.0**4, rtol=2**-23)
    np.testing.assert_allclose(float(p.noise.sigma_r2), float(sensing.ccr_variance(c, 110.0)),
                               rtol=2**-23)  # fmt: skip
    assert int(p.seed) == 17 and p.seed.dtype == jnp.uint32
    assert int(task_params(s, parse_method("ccr-pfim")).seed) == s.seed
    scalars = {"sigma_w2": 3.5, "p0": 12.0, "placement_half_width": 400.0, "gamma": 0.9,
               "r2t": 110.0, "r2r": 15.0, "alpha_r2r": 500.0, "alpha_r2t": 1000.0}  # fmt: skip
    for k, v in scalars.items():
        assert float(getattr(p, k)) == np.float32(v), k
    np.testing.assert_array_equal(p.target_init, np.float32(s.target_init))
    np.testing.assert_array_equal(p.radar_init, np.float32(s.radar_init))
    assert tuple(bool(x) for x in p.method) == (True, True, True)
    # without fixed starts the placeholder is zeros [N, 3]
    np.testing.assert_array_equal(task_params(_scenario(), METHODS["stationary"]).radar_init,
                                  np.zeros((2, 3)))  # fmt: skip


def test_make_task_is_cached_per_shape():
    s = _scenario()
    numbers = _scenario(seed=5, mpc={"r2t": 80.0}, radar_equation={"snr_db": 0.0})
    t1, _ = build(s, "ddr-sfim")
    t2, _ = build(numbers, "ccr-pfim")
    assert t1 is t2 is make_task(shape_key(s))
    t3, _ = build(_scenario(mpc={"horizon": 5}))
    assert t3 is not t1 and t3.mpc.horizon == 5


# -- cost terms ---------------------------------------------------------------------------


def _ctx(task, s, radar):
    """The planning context of ``radar``, jitted: eagerly, each of its many small ops
    would compile on its own."""

    @jax.jit
    def ctx(radar):
        mean = jnp.asarray(s.target_init, jnp.result_type(float)).reshape(-1)
        cov = 4.0 * jnp.eye(mean.shape[0], dtype=mean.dtype)
        return objective.plan_context(task, radar, mean, cov)

    return ctx(radar)


RADARS = jnp.array([[100.0, 0, 0, 0.3, 2.0, 0.1], [-80.0, 40.0, 0, -2.0, 0.0, 0.0]])


def test_control_effort_term_equals_hand_computation():
    s = _scenario(mpc={"alpha_effort": 2.5, "gamma": 0.9})
    task, params = build(s, "ddr-sfim")
    h, n = s.mpc.horizon, s.n_radars
    rng = np.random.default_rng(0)
    lim = np.array([s.limits.accel, s.limits.alpha])
    u = rng.uniform(-1.2, 1.2, (h, n, 2)) * lim  # some beyond the limits: penalised as given
    cost, plan = jax.jit(objective.make_objective(task))(
        jnp.asarray(u, jnp.float32).reshape(h, 2 * n), _ctx(task, s, RADARS), params
    )
    hand = sum(0.9**t * 2.5 * np.sum((u[t] / lim) ** 2) for t in range(h))
    # float32 sums of ~16 O(1) squares: relative error ~1e-6
    np.testing.assert_allclose(float(plan.terms["control_effort"]), hand, rtol=1e-5)
    names = ["information", "radar_radar", "radar_target", "control_effort"]
    assert [t.name for t in task.terms] == names and set(plan.terms) == set(names)
    total = sum(float(v) for v in plan.terms.values())
    np.testing.assert_allclose(float(cost), total, rtol=1e-6, atol=1e-6)

    task0, params0 = build(_scenario(mpc={"gamma": 0.9}), "ddr-sfim")  # alpha_effort = 0
    cost0, plan0 = jax.jit(objective.make_objective(task0))(
        jnp.asarray(u, jnp.float32).reshape(h, 2 * n), _ctx(task0, s, RADARS), params0
    )
    assert "control_effort" not in plan0.terms
    # the other terms do not depend on the effort weight
    for k in plan0.terms:
        np.testing.assert_allclose(float(plan0.terms[k]), float(plan.terms[k]), rtol=1e-6)
    np.testing.assert_allclose(float(cost) - float(cost0), hand, rtol=1e-4)


def test_terms_sum_to_the_total_with_penalties_active():
    # radars 5 m apart (< R2R) and one 100 m under a target (< R2T): all three terms non-zero
    s = _scenario(mpc={"alpha_effort": 1.0})
    task, params = build(s, "ddr-pfim")
    radar = jnp.array([[0.0, 5.0, 0, 0, 0, 0], [0.0, 10.0, 0, 0, 0, 0]])
    u = jnp.full((s.mpc.horizon, 2 * s.n_radars), 3.0)
    cost, plan = jax.jit(objective.make_objective(task))(u, _ctx(task, s, radar), params)
    vals = {k: float(v) for k, v in plan.terms.items()}
    assert vals["radar_radar"] > 0 and vals["radar_target"] > 0 and vals["control_effort"] > 0
    np.testing.assert_allclose(float(cost), sum(vals.values()), rtol=1e-6)


# -- information flags (float64: see test_objective, rank-deficient FIMs) -----------------

X64 = {  # three still radars, a shape used only here (built under x64)
    "name": "x64",
    "n_radars": 3,
    "sigma_w2": 2.0,
    "targets": [[0.0, 0.0, 50.0, 5.0, 0.0, 0.0], [40.0, -30.0, 60.0, 0.0, -4.0, 1.0]],
    "mpc": {"horizon": 3, "rollout": "analytic", "gamma": 0.8},
    "mppi": {"samples": 16, "iterations": 1},
}
STILL = np.array([[150.0, 0, 0, 0, 0, 0], [-120.0, 90.0, 0, 1.0, 0, 0], [20.0, -160.0, 0, 2, 0, 0]])


def _hand_information(task, s, ctx, params, kind):
    """Discounted information term by hand (numpy float64), radars still at STILL."""
    pts = np.asarray(ctx.target_points)  # [H, P, M, 6]
    radar = STILL[:, :3]
    h, m = pts.shape[0], s.n_targets
    c = sensing.noise_constant(s.radar_eq, m)
    sigma_r2 = c * s.mpc.r2t**4
    floor = np.eye(3) * fisher.INFO_FLOOR
    a6 = np.asarray(motion.cv_transition(s.timing.dt_control, 1, np.float64))
    w6 = np.asarray(motion.cv_process_noise(s.timing.dt_control, s.sigma_w2, 1, np.float64))
    info = np.array(ctx.info0, np.float64)
    # jitted, one program each (eagerly, their small ops compile one by one)
    sfim = jax.jit(lambda p: fisher.sfim(radar, p, c))
    sfim_ccr = jax.jit(lambda p: fisher.sfim_ccr(radar, p, sigma_r2))
    out = 0.0
    for t in range(h):
        if kind == "pfim":
            term = 0.0
            for j in range(m):
                jd = np.mean([np.asarray(sfim(p[j : j + 1, :3]))[0]
                              for p in pts[t]], axis=0)  # fmt: skip
                prior = np.linalg.inv(w6 + a6 @ np.linalg.inv(info[j]) @ a6.T)
                info[j] = prior + np.pad(jd, ((0, 3), (0, 3)))
                term += np.linalg.slogdet(info[j] + fisher.INFO_FLOOR * np.eye(6))[1]
        else:
            f = sfim if kind == "sfim" else sfim_ccr
            term = np.mean([sum(np.linalg.slogdet(j3 + floor)[1] for j3 in np.asarray(f(p[:, :3])))
                            for p in pts[t]])  # fmt: skip
        out += s.mpc.gamma**t * -term
    return out


def test_information_flags_switch_one_compiled_objective():
    with jax.enable_x64(True):
        s = scenario_from_dict(X64)
        task, p_sfim = build(s, "ddr-sfim")
        _, p_pfim = build(s, "ddr-pfim")
        _, p_ccr = build(s, "ccr-sfim")
        assert task.a6.dtype == jnp.float64  # built under x64 (shape used only here)
        ctx = jax.jit(lambda: objective.plan_context(  # one program, not op by op
            task, jnp.asarray(STILL), jnp.asarray(s.target_init).ravel(),
            jnp.diag(jnp.linspace(1.0, 6.0, 12))))()  # fmt: skip
        u = jnp.zeros((s.mpc.horizon, 2 * s.n_radars))
        f = jax.jit(lambda p: objective.make_objective(task)(u, ctx, p)[1].terms["information"])
        got = {}
        for name, p in (("sfim", p_sfim), ("pfim", p_pfim), ("ccr", p_ccr)):
            got[name] = float(f(p))
        # the same flags set by hand on the SFIM parameters give the same numbers
        flip = p_sfim._replace(method=p_sfim.method._replace(pfim=jnp.asarray(True)))
        assert float(f(flip)) == got["pfim"]
        flip = p_sfim._replace(method=p_sfim.method._replace(ccr=jnp.asarray(True)),
                               noise=p_ccr.noise)  # fmt: skip
        assert float(f(flip)) == got["ccr"]
        assert f._cache_size() == 1  # one trace serves every method
        hand = {
            "sfim": _hand_information(task, s, ctx, p_sfim, "sfim"),
            "pfim": _hand_information(task, s, ctx, p_pfim, "pfim"),
            "ccr": _hand_information(task, s, ctx, p_ccr, "ccr"),
        }
        assert len({round(v, 3) for v in hand.values()}) == 3  # three different numbers
        for k in hand:  # float64 end to end: only summation order differs
            np.testing.assert_allclose(got[k], hand[k], rtol=1e-10, err_msg=k)


def test_ccr_noise_equals_r2t_variance_under_x64():
    with jax.enable_x64(True):
        s = scenario_from_dict(X64)
        p = task_params(s, parse_method("ccr-sfim"))
        c = sensing.noise_constant(s.radar_eq, s.n_targets)
        assert p.noise.c.dtype == jnp.float64
        assert float(p.noise.c) == c
        np.testing.assert_allclose(float(p.noise.sigma_r2), c * s.mpc.r2t**4, rtol=1e-15)


def test_dataclass_replace_keeps_shape_key_of_numbers():
    # the runner relies on shape_key(dataclasses.replace(...)) for cache hits
    s = _scenario()
    other = dataclasses.replace(s, seed=99, mpc=dataclasses.replace(s.mpc, alpha_r2t=1.0))
    assert shape_key(other) == shape_key(s)
