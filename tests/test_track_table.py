"""Track management's pure pieces (issue 35): multilateration, births, M-of-N, association.

References: closed forms (a known point from noiseless ranges), a Monte Carlo spread
of the least-squares fit against its linearised covariance, and a plain Python state
machine of the M-of-N life cycle on random hit sequences.
"""

import functools

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_radar.estimation.sensor import measurement
from mjx_radar.estimation.tracks import multilateration, track_birth, track_table, track_update

RADARS = np.array([[-300.0, -200, 0], [250, -300, 0], [300, 250, 0], [-250, 300, 0]])
TARGETS = np.array([[-150.0, 480, 55], [-50, 495, 63], [50, 510, 71], [150, 525, 79]])


def test_trilaterate_recovers_a_known_point_and_its_mirror_choice():
    trilaterate = jax.jit(multilateration.trilaterate)  # one program for every call
    with jax.enable_x64(True):
        p = jnp.asarray(RADARS[:3])
        for t in TARGETS:
            r = np.linalg.norm(t - RADARS[:3], axis=1)
            x, ok = trilaterate(p, jnp.asarray(r))
            assert bool(ok)
            np.testing.assert_allclose(np.asarray(x), t, atol=1e-8)  # the upper solution
        # inconsistent ranges (no intersection) and collinear radars are refused
        _, ok = trilaterate(p, jnp.asarray([10.0, 10.0, 10.0]))
        assert not bool(ok)
        line = jnp.asarray([[0.0, 0, 0], [100, 0, 0], [200, 0, 0]])
        _, ok = trilaterate(line, jnp.asarray([150.0, 120, 150]))
        assert not bool(ok)


@pytest.mark.slow  # a vmapped float64 Gauss-Newton (~1 min on a shared CPU)
def test_gauss_newton_covariance_matches_monte_carlo():
    """4 ranges with noise: the spread of the fit matches ``Λ⁻¹`` (linearised geometry)."""
    model = measurement.make_model("range")
    rng = np.random.default_rng(0)
    t = TARGETS[2]
    z0 = 2 * np.linalg.norm(t - RADARS, axis=1)[:, None]
    var = np.full((4, 1), 4.0)  # 2 m std round trip: 1 m one-way
    trials = 4000
    zs = z0[None] + np.sqrt(var)[None] * rng.normal(size=(trials, 4, 1))
    with jax.enable_x64(True):

        def fit(z):
            x, p, chi2 = multilateration.gauss_newton(
                model,
                jnp.asarray(t + 3.0),
                jnp.asarray(RADARS),
                z,
                jnp.asarray(var),
                jnp.ones(4, bool),
                60.0,
                1e12,
                iters=6,
            )
            return x, p, chi2

        zall = jnp.asarray(np.concatenate([z0[None], zs]))
        xs, ps, chi2 = (np.asarray(a) for a in jax.jit(jax.vmap(fit))(zall))
        # noiseless ranges: the point itself, chi2 = 0
        x0, p0, c0 = xs[0], ps[0], chi2[0]
        xs, chi2 = xs[1:], chi2[1:]
    np.testing.assert_allclose(np.asarray(x0), t, atol=1e-6)
    assert float(c0) < 1e-12
    emp = np.cov(np.asarray(xs).T)
    lin = np.asarray(p0)
    # 4000 draws: a variance estimate's relative std is sqrt(2/4000) = 2.2%; the fit is
    # mildly nonlinear in z (sigma_z ~ 7 m at 71 m height), so allow 10%
    np.testing.assert_allclose(np.diag(emp), np.diag(lin), rtol=0.10)
    corr = lambda c: c / np.sqrt(np.outer(np.diag(c), np.diag(c)))  # noqa: E731
    np.testing.assert_allclose(corr(emp), corr(lin), atol=0.05)
    # with 4 ranges and 3 unknowns, chi2 is chi-square with 1 dof: mean 1
    assert abs(float(np.mean(chi2)) - 1.0) < 0.1


@pytest.mark.slow  # compiles the birth fit (~1 min on a shared CPU)
def test_births_find_every_drone_once_without_ghosts():
    model = measurement.make_model("range")
    z = 2 * np.linalg.norm(TARGETS[None] - RADARS[:, None], axis=-1)[..., None]  # [N, M, 1]
    s = track_birth.BirthSettings(max_births=6, birth_radars=4, height_std=1e4)
    rv = jnp.full(z.shape, 1.0)
    free = jnp.ones(z.shape[:2], bool)
    births = jax.jit(
        lambda z, free, avoid: track_birth.births(
            model, z, free, rv, jnp.asarray(RADARS), 6.63, s, avoid
        )
    )
    nobody = (jnp.zeros((1, 3)), jnp.eye(3)[None], jnp.zeros(1, bool))
    mean, cov, ok = births(jnp.asarray(z, jnp.float32), free, nobody)
    assert np.asarray(ok).tolist() == [True] * 4 + [False] * 2
    got = np.asarray(mean)[:4, :3]
    d = np.linalg.norm(got[:, None] - TARGETS[None], axis=-1)
    assert sorted(d.argmin(1).tolist()) == [0, 1, 2, 3]
    assert d.min(1).max() < 0.05  # float32 at 500 m
    np.testing.assert_array_equal(np.asarray(mean)[:4, 3:], 0.0)  # velocity: zero mean
    np.testing.assert_allclose(np.asarray(cov)[:4, 3, 3], s.speed_std**2)
    # returns already explained by tracks start nothing; a live track there blocks it
    near = (jnp.asarray(TARGETS[1:2], jnp.float32), 4.0 * jnp.eye(3)[None], jnp.ones(1, bool))
    _, _, ok = births(jnp.asarray(z, jnp.float32), free.at[:, 0].set(False), near)
    assert int(np.sum(ok)) == 2  # drone 0's returns taken, drone 1 already tracked


@pytest.mark.slow  # compiles the birth fit (~1 min on a shared CPU)
def test_range_azimuth_birth_from_one_radar():
    model = measurement.make_model("range-azimuth")
    radar = np.array([[10.0, -20.0, 0.0]])
    t = np.array([[200.0, 150.0, 60.0]])
    z = np.asarray(model.predict(jnp.asarray(radar), jnp.asarray(t)))  # [1, 1, 2]
    s = track_birth.BirthSettings(max_births=1, birth_radars=1, height=60.0)
    mean, cov, ok = jax.jit(
        lambda z: track_birth.births(
            model, z, jnp.ones((1, 1), bool), jnp.full((1, 1, 2), 1e-4), jnp.asarray(radar), 9.21, s
        )
    )(jnp.asarray(z))
    assert bool(ok[0])
    np.testing.assert_allclose(np.asarray(mean)[0, :3], t[0], atol=0.05)
    assert float(cov[0, 2, 2]) < s.height_std**2 + 1.0  # height: the prior's spread at most


@jax.jit  # one program for every case (suite time: eager ops compile one by one)
def _one_track():
    return track_table.insert(
        track_table.empty(1, 2), jnp.zeros((1, 6)), jnp.eye(6)[None], jnp.ones(1, bool)
    )


@pytest.mark.parametrize("m,n", [(2, 3), (3, 5), (4, 4)])
def test_m_of_n_confirmation_and_deletion_match_a_python_reference(m, n):
    rules = track_table.LifeRules(confirm_m=m, confirm_n=n, delete_misses=4, delete_cov=1e9)
    rng = np.random.default_rng(m * 10 + n)
    steps = 60
    hits = rng.uniform(size=steps) < 0.6
    hits[:5], hits[30:36] = True, False  # a confirmation, then a deletion by misses
    born = {t for t in range(steps) if t % 15 == 7}

    def scan(table, x):
        t, h = x
        table = track_table.maintain(table, jnp.reshape(h, (1,)), rules)
        ok = jnp.reshape((table.status[0] == 0) & jnp.isin(t, jnp.asarray(sorted(born))), (1,))
        table = track_table.insert(table, jnp.zeros((1, 6)), jnp.eye(6)[None], ok)
        return table, table.status[0]

    table = _one_track()
    # scan t: maintain with hit[t], then a birth at t if the slot is empty
    _, status = jax.lax.scan(scan, table, (jnp.arange(steps), jnp.asarray(hits)))
    ref, st, hist, miss, age = [], 1, [1], 0, 1
    for t in range(steps):  # same order as the scan: maintain, then birth
        if st:
            hist, miss, age = (hist + [int(hits[t])])[-n:], 0 if hits[t] else miss + 1, age + 1
            if st == 1 and sum(hist) >= m:
                st = 2
            if (st == 1 and age >= n) or (st == 2 and miss >= 4):
                st = 0
        elif t in born:
            st, hist, miss, age = 1, [1], 0, 1
        ref.append(st)
    assert np.asarray(status).tolist() == ref
    assert 2 in ref and 0 in ref  # the sequence exercised confirmation and deletion


@pytest.mark.parametrize("vanish", [0, 2, 3])
def test_vanish_misses_deletes_a_track_no_radar_sees(vanish):
    # two confirmed tracks miss every scan (delete_misses 6); slot 0 keeps one radar in
    # its gate (a drone behind a neighbour's return), slot 1 has none (the drone is gone):
    # only slot 1 goes after `vanish` misses, slot 0 after delete_misses, as before
    rules = track_table.LifeRules(2, 3, 6, 1e9, vanish)
    table = jax.jit(track_table.empty, static_argnums=(0, 1))(2, 4)
    ones = np.ones((2, 6), np.float32)
    table = jax.jit(track_table.insert)(table, ones, np.stack([np.eye(6)] * 2), np.ones(2, bool))
    table = table._replace(status=np.full(2, track_table.CONFIRMED, np.int32))
    table = table._replace(gated=np.array([[True, False, False, False], [False] * 4]))
    step = jax.jit(track_table.maintain, static_argnums=2)
    gone = []
    for _ in range(8):
        table = step(table, np.zeros(2, bool), rules)
        gone.append(np.asarray(table.status == track_table.EMPTY).tolist())
    first = [next(t + 1 for t in range(8) if g[t]) for g in zip(*gone, strict=True)]
    assert first == [6, vanish or 6]  # misses counted after each scan's maintain


def test_deletion_by_covariance_bound_and_labels():
    # (inputs built in numpy: every eager jnp op would compile a program of its own)
    rules = track_table.LifeRules(delete_cov=100.0)
    table = jax.jit(track_table.empty, static_argnums=(0, 1))(3, 2)
    covs = np.stack([np.eye(6), 50.0 * np.eye(6), np.eye(6)]).astype(np.float32)
    ones = np.ones((3, 6), np.float32)
    insert = jax.jit(track_table.insert)
    table = insert(table, ones, covs, np.array([True, True, False]))
    assert np.asarray(table.label).tolist() == [0, 1, -1]
    table = jax.jit(track_table.maintain, static_argnums=2)(table, np.ones(3, bool), rules)
    assert np.asarray(table.status).tolist() == [1, 0, 0]  # tr P_pos = 150 > 100: gone
    table = insert(table, ones[:2], covs[:2], np.array([True, True]))
    assert np.asarray(table.label).tolist() == [0, 2, 3]  # labels never reused
    # more births than free slots: the extra ones are dropped
    table = insert(table, ones[:1], covs[:1], np.array([True]))
    assert np.asarray(table.label).tolist() == [0, 2, 3] and int(table.next_label) == 4


@pytest.mark.slow  # ~20 s compile on a shared CPU
def test_ownership_two_tracks_on_one_return():
    """Two tracks gate the same return: only the likelier one sees the radar."""
    k, n, ell = 2, 1, 2
    nll = jnp.array([[[1.0, jnp.inf]], [[2.0, jnp.inf]]])  # [K, N, L]

    def associate(means, covs, on, zs, valid, radar_pos):
        return means, covs, nll

    table = track_table.insert(
        track_table.empty(k, n),
        jnp.zeros((2, 6)),
        jnp.eye(6)[None].repeat(2, 0),
        jnp.ones(2, bool),
    )
    zs, valid = jnp.zeros((n, ell, 1)), jnp.ones((n, ell), bool)
    table, hit, explained = track_update.update(table, zs, valid, jnp.zeros((1, 3)), associate, 1)
    assert np.asarray(hit).tolist() == [True, False]
    assert np.asarray(explained).tolist() == [[True, False]]  # return 1 stays free


def test_sorted_scans_hide_the_truth_order():
    zs = jnp.array([[[30.0], [10.0], [20.0]]])
    valid = jnp.array([[True, False, True]])
    z, v = jax.jit(track_update.sorted_scans)(zs, valid)
    assert np.asarray(z)[0, :, 0].tolist() == [20.0, 30.0, 10.0]
    assert np.asarray(v).tolist() == [[True, True, False]]


def test_births_may_share_a_claimed_return_with_birth_shared():
    """A drone one of whose returns a live track claims (not free) is born only with
    ``shared >= 1``; at the noiseless point (closed form), from all four returns; a seed
    holding two claimed returns needs ``shared >= 2``."""
    model = measurement.make_model("range")
    two = TARGETS[[0, 3]]  # 300 m apart: no return of one joins the other's gate
    z = jnp.asarray(2 * np.linalg.norm(two[None] - RADARS[:, None], axis=-1)[..., None])
    rv = jnp.full(z.shape, 1.0)
    valid = jnp.ones(z.shape[:2], bool)
    pos = jnp.asarray(RADARS)

    @functools.partial(jax.jit, static_argnums=1)
    def fits(free, shared):
        out = []
        for s in shared:
            bs = track_birth.BirthSettings(birth_radars=4, height_std=1e4, shared=s)
            x, _, _, joined, good, _ = track_birth.fit_seeds(
                model, z, free, rv, pos, 6.63, bs, None, valid
            )
            out.append((x, joined, good))
        return out

    def born(x, joined, good):  # the drones with a good seed at the point, all 4 returns
        x, joined, good = (np.asarray(a) for a in (x, joined, good))
        d = np.linalg.norm(x[:, None] - two[None], axis=-1)  # [C, 2]
        at = good[:, None] & (d < 0.05) & np.all(joined >= 0, axis=1)[:, None]  # float32
        return at.any(0).tolist()

    one_held = valid.at[0, 1].set(False)  # drone 1's return at radar 0 claimed by a track
    r0, r1 = fits(one_held, (0, 1))
    assert born(*r0) == [True, False] and born(*r1) == [True, True]
    x, joined, good = (np.asarray(a) for a in r1)
    at1 = good & (np.linalg.norm(x - two[1], axis=-1) < 0.05)
    assert np.all(joined[at1, 0] == 1)  # with the claimed return of radar 0
    two_held = one_held.at[2, 1].set(False)
    r1, r2 = fits(two_held, (1, 2))
    assert born(*r1) == [True, False] and born(*r2) == [True, True]
    with pytest.raises(ValueError, match="valid"):
        track_birth.fit_seeds(
            model, z, one_held, rv, pos, 6.63, track_birth.BirthSettings(shared=1), None
        )
