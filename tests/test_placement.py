"""Initial conditions of a trial: radar placement and the initial estimate (SPEC §3, §4)."""

import dataclasses
import functools
import itertools

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_radar.engine.run_spec import run_spec
from mjx_radar.env import placement
from mjx_radar.env.streams import trial_streams
from mjx_radar.errors import InputError
from mjx_radar.scenario.reader import scenario_from_dict
from mjx_radar.task.method import METHODS
from mjx_radar.task.params import shape_key, task_params

RAW = {
    "name": "place",
    "n_radars": 4,
    "seed": 7,
    "placement_half_width": 300.0,
    "targets": [[0.0, 0.0, 55.0, 20.0, 10.0, 0.0], [80.0, -40.0, 70.0, 0.0, 5.0, 0.0]],
    "mpc": {"r2t": 125.0, "r2r": 40.0},
}
TRIALS = 1000


def _scenario(**over):
    raw = dict(RAW)
    for k, v in over.items():
        raw[k] = raw.get(k, {}) | v if isinstance(v, dict) else v
    return scenario_from_dict(raw)


@functools.partial(jax.jit, static_argnums=0)
def _place_batch(shape, params, trials):
    def one(t):
        layout = placement.shape_layout(shape)
        return placement.place_radars(layout, params, trial_streams(params.seed, t).placement)

    return jax.vmap(one)(trials)


def _place(s, method="stationary", seed=None, trials=TRIALS):
    """Placements of trials 0..trials-1 (trials <= TRIALS): the first of TRIALS trials,
    so that one compiled program per shape serves every trial count (trial t's draws
    are its own streams', whatever the batch)."""
    states, ok = _place_batch(shape_key(s), task_params(s, METHODS[method], seed),
                              jnp.arange(TRIALS))  # fmt: skip
    return np.asarray(states)[:trials], np.asarray(ok)[:trials]


def test_random_placement_respects_box_and_keep_outs():
    s = _scenario()
    states, ok = _place(s)
    assert states.shape == (TRIALS, 4, 6) and ok.all()
    w = s.placement_half_width
    xy = states[..., :2]
    assert np.all(np.abs(xy) <= w)
    assert np.all(states[..., 2] == 0.0)  # on the ground
    assert np.all(states[..., 4:] == 0.0)  # at rest
    th = states[..., 3]
    assert np.all((th > -np.pi) & (th <= np.float32(np.pi)))
    # float32 positions of <= 300 m: distances good to ~1e-4 m
    tgt = np.asarray(s.target_init)[:, :3]
    p3 = states[..., :3].astype(np.float64)
    d_rt = np.linalg.norm(p3[:, :, None] - tgt[None, None], axis=-1)
    assert d_rt.min() >= s.mpc.r2t - 1e-3
    for i, j in itertools.combinations(range(4), 2):
        assert np.linalg.norm(p3[:, i] - p3[:, j], axis=-1).min() >= s.mpc.r2r - 1e-3
    # the draws do fill the box (uniform): each quadrant holds ~1/4 of the radars
    quad = np.mean((xy[..., 0] > 0) & (xy[..., 1] > 0))
    assert 0.2 < quad < 0.3
    assert np.unique(th).size > 0.99 * th.size  # headings drawn, not a constant


def test_keep_outs_are_runtime_numbers():
    # a wider radar-radar keep-out changes the placement without a new shape
    s, wide = _scenario(), _scenario(mpc={"r2r": 150.0})
    assert shape_key(s) == shape_key(wide)
    states, ok = _place(wide, trials=200)
    assert ok.all()
    p = states[..., :2].astype(np.float64)
    d = min(np.linalg.norm(p[:, i] - p[:, j], axis=-1).min()
            for i, j in itertools.combinations(range(4), 2))  # fmt: skip
    assert d >= 150.0 - 1e-3


def test_fixed_starts_are_used_verbatim():
    fixed = [[200.0, 0.0, 0.5], [-200.0, 10.0, -3.0], [0.0, 250.0, 3.1], [0.0, -250.0, 0.0]]
    s = _scenario(radars=fixed)
    states, ok = _place(s, trials=5)
    assert ok.all()
    want = np.asarray(fixed, np.float32)
    for st in states:  # every trial: the same, the file's numbers
        np.testing.assert_array_equal(st[:, [0, 1, 3]], want)
        np.testing.assert_array_equal(st[:, [2, 4, 5]], 0.0)
    # a fixed start inside the radar-target keep-out is reported, not moved
    # (validation rejects such a file; the flag is the closed loop's second line of defence)
    bad = dataclasses.replace(s, radar_init=((100.0, 0.0, 0.0),) + s.radar_init[1:])
    states, ok = _place(bad, trials=2)
    assert not ok.any()
    np.testing.assert_array_equal(states[0, 0, :2], [100.0, 0.0])


def test_check_placeable_names_the_fields_when_impossible():
    s = _scenario(placement_half_width=20.0)  # 4 radars 40 m apart do not fit in 40 x 40 m
    with pytest.raises(ValueError) as e:
        placement.check_placeable(s, s.seed, 4)
    msg = str(e.value)
    assert "\n" not in msg
    for field in ("placement_half_width = 20.0", "mpc.r2r = 40.0", "mpc.r2t = 125.0"):
        assert field in msg, msg
    placement.check_placeable(_scenario(), 7, 16)  # feasible: silent
    # the same shape and trial count as the impossible case: the program traced for it is
    # reused with the new numbers (a check baked into the program would raise here)
    placement.check_placeable(_scenario(), s.seed, 4)


def test_initial_estimate_error_has_covariance_p0():
    # Monte Carlo over 4000 trials (one target: 6 dims). The sample variance of
    # N(0, p0) has standard error p0 sqrt(2/n) (1.1 m^2), a covariance p0/sqrt(n)
    # (0.8 m^2), the mean sqrt(p0/n) (0.11 m): bounds at 4 standard errors.
    n, p0 = 4000, 50.0
    s = _scenario(targets=RAW["targets"][:1], p0=p0)
    layout, params = placement.shape_layout(shape_key(s)), task_params(s, METHODS["ddr-sfim"])

    @jax.jit  # one program for both p0 (the parameters are runtime numbers)
    def batch(prm):
        def one(t):
            return placement.initial_conditions(layout, prm, trial_streams(params.seed, t))

        return jax.vmap(one)(jnp.arange(n))

    init = batch(params)
    np.testing.assert_array_equal(init.cov[0], p0 * np.eye(6))
    np.testing.assert_array_equal(init.target_state[0], np.float32(s.target_init))
    err = np.asarray(init.mean, np.float64) - np.asarray(s.target_init).reshape(-1)
    assert np.all(np.abs(err.mean(0)) < 4 * np.sqrt(p0 / n))
    cov = np.cov(err, rowvar=False)
    assert np.all(np.abs(np.diag(cov) - p0) < 4 * p0 * np.sqrt(2 / n)), np.diag(cov)
    off = cov[~np.eye(6, dtype=bool)]
    assert np.all(np.abs(off) < 4 * p0 / np.sqrt(n)), off
    # ... and the error scales with sqrt(p0) (the same normal draws: common random numbers)
    params4 = task_params(_scenario(targets=RAW["targets"][:1], p0=4 * p0), METHODS["ddr-sfim"])
    e4 = np.asarray(batch(params4).mean[3])  # trial 3 with trial_streams(params.seed, 3)
    e1 = np.asarray(init.mean[3])
    tgt = np.asarray(params.target_init).ravel()
    np.testing.assert_allclose(e4 - tgt, 2 * (e1 - tgt), rtol=1e-5, atol=1e-5)


def test_common_random_numbers_across_methods():
    s = _scenario()
    layout = placement.shape_layout(shape_key(s))
    states = {m: _place(s, m, trials=8)[0] for m in METHODS}
    for m in METHODS:
        np.testing.assert_array_equal(states[m], states["stationary"])
    # one program for every method (the parameters are runtime numbers), not op by op
    mean = jax.jit(lambda p: placement.initial_conditions(layout, p, trial_streams(s.seed, 2)).mean)
    means = {m: np.asarray(mean(task_params(s, METHODS[m]))) for m in METHODS}
    for m in METHODS:
        np.testing.assert_array_equal(means[m], means["stationary"])
    # another seed: another placement; another trial: another placement
    other, _ = _place(s, seed=8, trials=8)
    assert not np.array_equal(other, states["stationary"])
    assert not np.array_equal(states["stationary"][0], states["stationary"][1])


def test_each_radar_takes_its_first_admissible_candidate():
    """Against a sequential numpy reference on the same candidate draws (float64
    distances): radar i takes the first of its ``CANDIDATES`` draws >= R2T from every
    target and >= R2R from radars 0..i-1. Keep-outs wide enough that both reject often.
    The radars are a loop in the program, not N unrolled copies: the traced placement has
    as many operations for 32 radars as for 6 (a 32-radar placement compiled for 6 s)."""
    s = _scenario(n_radars=6, mpc={"r2r": 150.0})
    params = task_params(s, METHODS["stationary"], None)
    states, ok = _place(s, trials=200)
    n, w, c = s.n_radars, s.placement_half_width, placement.CANDIDATES
    targets = np.asarray(params.target_init, np.float64)[:, :3]
    firsts = []
    for t in range(200):
        k_xy, _ = jax.random.split(trial_streams(params.seed, t).placement)
        cand = np.asarray(jax.random.uniform(k_xy, (n, c, 2), minval=-w, maxval=w))
        cand3 = np.concatenate([cand, np.zeros((n, c, 1), cand.dtype)], -1).astype(np.float64)
        placed, all_ok = [], True
        for i in range(n):
            good = np.linalg.norm(cand3[i][:, None] - targets[None], axis=-1).min(-1) >= s.mpc.r2t
            for p in placed:
                good &= np.linalg.norm(cand3[i] - p, axis=-1) >= s.mpc.r2r
            first = int(np.argmax(good))
            firsts.append(first)
            placed.append(cand3[i, first])
            all_ok &= bool(good[first])
        np.testing.assert_array_equal(states[t, :, :3], np.asarray(placed, np.float32))
        assert ok[t] == all_ok
    assert np.mean(np.asarray(firsts) > 0) > 0.3  # the keep-outs rejected candidates

    def eqns(radars):
        big = _scenario(n_radars=radars, placement_half_width=3000.0)
        key = trial_streams(7, 0).placement
        jaxpr = jax.make_jaxpr(
            lambda p: placement.place_radars(placement.shape_layout(shape_key(big)), p, key)
        )(task_params(big, METHODS["stationary"], None))
        return len(jaxpr.eqns)

    assert eqns(32) == eqns(6)


def test_cached_check_loads_its_program_and_says_the_same(tmp_path, monkeypatch):
    """engine.placement_cache: the check's program kept on disk (a warm process neither
    traces nor lowers it) gives the same verdicts and messages as the traced one."""
    from mjx_radar.engine import compile_cache, executable_cache, placement_cache

    monkeypatch.setattr(compile_cache, "_DIR", [tmp_path])  # a private program folder
    bad = _scenario(placement_half_width=20.0)

    def check_both():
        placement_cache._program.cache_clear()  # as a new process: nothing in memory
        with pytest.raises(InputError) as cached:  # the user's error: one line, exit 2
            placement_cache.check_placeable(run_spec(bad), bad.seed, 4)
        with pytest.raises(ValueError) as traced:
            placement.check_placeable(bad, bad.seed, 4)
        assert str(cached.value) == str(traced.value)
        placement_cache.check_placeable(run_spec(_scenario()), 7, 16)  # feasible: silent

    check_both()  # XLA compiles the flat programs (no other test does): both written
    assert len(list((tmp_path / "programs").glob("place-*.bin"))) == 2  # 4 -> 8, and 16

    def no_compile(lowered):
        raise AssertionError("compiled although the executables are on disk")

    monkeypatch.setattr(executable_cache, "compile_lowered", no_compile)
    check_both()


def test_cached_check_runs_on_this_process_device(tmp_path, monkeypatch):
    """Under ``jax.distributed`` ``jax.devices()[0]`` is process 0's device: the check's
    program must be loaded and run on this process's own (a distributed study's process 1
    loaded it onto process 0's device and could not read the verdict)."""
    from mjx_radar.engine import compile_cache, placement_cache

    monkeypatch.setattr(compile_cache, "_DIR", [tmp_path])

    def foreign(*_, **__):
        raise AssertionError("jax.devices()[0]: process 0's device under jax.distributed")

    for _ in range(2):  # compiled (or loaded from JAX's cache), then loaded if written
        placement_cache._program.cache_clear()
        with monkeypatch.context() as m:
            m.setattr(jax, "devices", foreign)
            placement_cache.check_placeable(run_spec(_scenario()), 7, 16)
