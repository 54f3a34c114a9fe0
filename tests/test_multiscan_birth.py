"""Multi-scan births (``[tracker] birth_scans``): the CV fit, the packing, a ghost scene.

References: the weighted least-squares line through the seeds (numpy, float64), a
hand-made conflict graph of seeds, and a seeded two-wave-like scene in which one-scan
births confirm a ghost (the tracker alone, fixed radars, four drones flying straight).
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_radar.errors import ScenarioError
from mjx_radar.estimation.tracks import multiscan_birth as msb
from mjx_radar.physics import motion
from mjx_radar.scenario.reader import load_scenario

DT = 0.025


def _spd(rng, scale):
    a = rng.normal(size=(3, 3))
    return scale * (a @ a.T / 3 + 0.3 * np.eye(3))


def _ls_reference(xs, ps, sv):
    """numpy float64: ``(θ [6], Λ⁻¹ [6, 6], J_min)`` of the CV line through ``xs [S, 3]``."""
    scans = len(xs)
    t = (np.arange(scans) - (scans - 1)) * DT
    hs = [np.hstack([np.eye(3), t[j] * np.eye(3)]) for j in range(scans)]
    info = sum(h.T @ np.linalg.inv(p) @ h for h, p in zip(hs, ps, strict=True))
    rhs = sum(h.T @ np.linalg.solve(p, x) for h, p, x in zip(hs, ps, xs, strict=True))
    info[3:, 3:] += np.eye(3) / sv**2
    theta = np.linalg.solve(info, rhs)
    res = [x - h @ theta for h, x in zip(hs, xs, strict=True)]
    j_min = sum(e @ np.linalg.solve(p, e) for e, p in zip(res, ps, strict=True))
    return theta, np.linalg.inv(info), j_min + theta[3:] @ theta[3:] / sv**2


def test_cv_fit_over_scans_matches_numpy_least_squares():
    """S scans, one seed each: the candidate is the weighted least-squares CV line.

    Reference: ``min_θ Σ_j (x_j − H_j θ)ᵀ P_j⁻¹ (x_j − H_j θ) + |v|² / σ_v²`` with
    ``θ = [p, v]`` at the last scan, ``H_j = [I, (t_j − t_S) I]``; its minimum is the
    sum of the Kalman innovations ``Σ d²`` that the candidate accumulates (on top of
    the seeds' own χ²). Born at scan S with that state (``birth_scans = S``); vmapped
    over two trials.
    """
    scans, n, sv, trials = 4, 4, 30.0, 2
    rng = np.random.default_rng(5)
    p0, v0 = np.array([10.0, 480.0, 60.0]), np.array([1.0, -22.0, 0.5])
    ps = np.array([[_spd(rng, 4.0) for _ in range(scans)] for _ in range(trials)])
    xs = np.array(
        [
            [
                p0 + v0 * j * DT + np.linalg.cholesky(ps[i, j]) @ rng.normal(size=3)
                for j in range(scans)
            ]
            for i in range(trials)
        ]
    )
    chi2_seed = rng.uniform(0.1, 1.0, (trials, scans))

    def run(s, x, p, c2):
        def body(c, inp):
            xj, pj, cj = inp
            fits = (xj[None], pj[None], cj[None], jnp.zeros((1, n), jnp.int32))
            born, c = msb.step(c, fits + (jnp.ones(1, bool), jnp.ones(1)), f6, s)
            return c, born

        return jax.lax.scan(body, msb.empty(3, n, jnp.float64), (x, p, c2))

    with jax.enable_x64(True):
        f6 = jnp.asarray(motion.cv_transition(DT, 1), jnp.float64)
        args = (jnp.asarray(xs), jnp.asarray(ps), jnp.asarray(chi2_seed))
        grow = msb.MultiScanSettings(scans=scans + 1, capacity=3, max_births=1, speed_std=sv)
        cands, _ = jax.jit(jax.vmap(lambda *a: run(grow, *a)))(*args)
        born_s = grow._replace(scans=scans)
        left, (mean, cov, ok) = jax.jit(jax.vmap(lambda *a: run(born_s, *a)))(*args)
        cands, left, mean, cov, ok = jax.tree_util.tree_map(
            np.asarray, (cands, left, mean, cov, ok)
        )
    assert ok[:, :, 0].tolist() == [[False] * (scans - 1) + [True]] * trials
    assert left.age.max() == 0  # the born candidate left the table
    for i in range(trials):
        theta, p_ls, j_min = _ls_reference(xs[i], ps[i], sv)
        assert cands.age[i, 0] == scans and cands.age[i, 1:].max() == 0
        np.testing.assert_allclose(cands.mean[i, 0], theta, rtol=0, atol=1e-8)
        np.testing.assert_allclose(cands.cov[i, 0], p_ls, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(cands.chi2[i, 0], chi2_seed[i].sum() + j_min, rtol=1e-9)
        assert cands.dof[i, 0] == scans * 1 + 3 * (scans - 1)  # 4 ranges: 1 dof a seed
        np.testing.assert_allclose(mean[i, -1, 0], theta, rtol=0, atol=1e-8)
        np.testing.assert_allclose(cov[i, -1, 0], p_ls, rtol=1e-9, atol=1e-12)


def test_pack_prefers_the_most_disjoint_seeds_over_the_best_fitting_ghost():
    """Two drones seen by 4 radars and a ghost made of one return of each: the one-scan
    greedy (best χ² first) takes the ghost and blocks both drones; the packing takes both."""
    joined = jnp.asarray([[0, 1, 0, 1], [0, 0, 0, 0], [1, 1, 1, 1]], jnp.int32)  # ghost, A, B
    chi2 = jnp.asarray([0.01, 0.5, 0.7])
    good = jnp.ones(3, bool)
    score = 4e4 - chi2
    s = msb.MultiScanSettings(new_per_scan=3, starts=3)
    sel, ok = jax.jit(lambda: msb._greedy(good, score, joined, jnp.argmax(score), 3))()
    assert np.asarray(sel)[np.asarray(ok)].tolist() == [0]  # the ghost alone
    sel, ok = jax.jit(lambda: msb._pack(good, score, chi2, joined, s))()
    assert sorted(np.asarray(sel)[np.asarray(ok)].tolist()) == [1, 2]


def test_chi2_bound_matches_scipy():
    from scipy.stats import chi2

    dof = np.array([1.0, 3.0, 5.0, 9.0, 20.0])
    got = np.asarray(jax.jit(msb.chi2_bound)(jnp.asarray(dof)))
    # Wilson-Hilferty: 3.0% high at 1 dof (11.16 vs 10.83), 1.7% at 3 dof, less above
    np.testing.assert_allclose(got[0], chi2.ppf(0.999, 1), rtol=0.035)
    np.testing.assert_allclose(got[1:], chi2.ppf(0.999, dof[1:]), rtol=0.02)
    assert np.all(got >= chi2.ppf(0.999, dof))  # conservative: never a tighter gate
    assert np.isinf(float(msb.chi2_bound(jnp.asarray(0.0))))


@pytest.mark.parametrize("value", [0, 11, 2.5, "3"])
def test_bad_birth_scans_one_line(value):
    sc = load_scenario("raid_4r8t")
    with pytest.raises(ScenarioError) as err:
        sc.replace(tracker={"management": "managed", "birth_scans": value})
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith("tracker.birth_scans"), msg


def test_birth_scans_in_toml(tmp_path):
    sc = load_scenario("raid_4r8t").replace(
        tracker={"management": "managed", "birth_scans": 3},
        filter={"structure": "per-target", "ground_prior": True},
    )
    sc.to_toml(tmp_path / "s.toml")
    assert "birth_scans = 3" in (tmp_path / "s.toml").read_text()
    assert load_scenario(tmp_path / "s.toml").tracker.birth_scans == 3


def test_birth_scans_one_is_the_default_program():
    from mjx_radar.task.params import shape_key

    sc = load_scenario("raid_4r8t").replace(
        tracker={"management": "managed"},
        filter={"structure": "per-target", "ground_prior": True},
    )
    assert sc.tracker.birth_scans == 1
    assert shape_key(sc.replace(tracker={"birth_scans": 1})) == shape_key(sc)
    assert shape_key(sc.replace(tracker={"birth_scans": 3})) != shape_key(sc)


RADARS = [[-300.0, -200, 0], [250, -300, 1], [300, 250, 2], [-250, 300, 3]]


def _scene(birth_scans, seed, scans):
    """The managed tracker alone on 4 straight drones (raid_4r8t's wave 1), fixed radars:
    ``(confirmed [T, K], track_pos [T, K, 3], truth [T, M, 3])``."""
    from mjx_radar.env import environment
    from mjx_radar.env.scan import Scan

    sc = load_scenario("raid_4r8t")
    targets = np.asarray(sc.target_init, np.float32)[:4]
    sc = sc.replace(
        target_init=targets.tolist(),
        target_motion=(),
        radars=RADARS,
        timing={"steps": 40},
        tracker={"management": "managed", "max_tracks": 8, "birth_scans": birth_scans},
        filter={"structure": "per-target", "ground_prior": True},
    )
    env = environment.make(sc, "stationary")
    ops, model, noise = env._tracker, env.task.measurement, env.params.noise
    rp = jnp.asarray(RADARS, jnp.float32)
    m = len(targets)
    eye, zero = jnp.eye(6 * m), jnp.zeros(6 * m)

    def body(carry, k):
        modes, key = carry
        key, sub = jax.random.split(key)
        pos = jnp.asarray(targets[:, :3]) + (k + 1) * DT * jnp.asarray(targets[:, 3:])
        z = model.sample(sub, rp, pos, noise)
        scan = Scan(None, jnp.int32(0), jnp.int32(0), jnp.int32(0), None, None)
        _, _, modes = ops.predict(zero, eye, modes)
        _, _, modes = ops.update(zero, eye, modes, z, rp, scan)
        view = ops.tracks(modes)
        return (modes, key), (view.exist, view.mean[:, :3], pos)

    run = jax.jit(lambda k: jax.lax.scan(body, (ops.init(zero, eye), k), jnp.arange(scans))[1])
    return (np.asarray(a) for a in run(jax.random.PRNGKey(seed)))


@pytest.mark.slow  # compiles the tracker twice (~40 s on a shared CPU)
def test_multiscan_births_keep_the_ghost_out_of_the_ghost_scene():
    """One-scan births confirm a ghost (a point fitting four returns of different drones,
    160 m above them) that blocks two drones; two- and three-scan births confirm the four drones,
    each within 10 scans, and no track farther than 50 m from a drone (two-scan births:
    from scan 10 on)."""
    scans = 60
    for birth_scans in (1, 2, 3):
        exist, pos, truth = _scene(birth_scans, seed=0, scans=scans)
        d = np.linalg.norm(pos[:, :, None] - truth[:, None], axis=-1)  # [T, K, M]
        ghosts = (exist & (d.min(-1) > 50.0)).sum(1)
        found = np.any(exist[:, :, None] & (d < 50.0), axis=1)  # [T, M]
        if birth_scans == 1:
            assert ghosts[10:].min() >= 1 and not found[-1].all()
        else:  # two scans: one track > 50 m off every drone in 3 of the first 10 scans
            assert ghosts[10 if birth_scans == 2 else 0 :].max() == 0
            assert found[10].all() and found[10:].all()
