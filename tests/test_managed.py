"""The managed tracker in the loop (issue 35): its options, the metrics' view, the env.

The track table's pure pieces are tested in tests/test_track_table.py.
"""

import importlib.util
import sys
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_radar.env import environment, managed
from mjx_radar.errors import ScenarioError
from mjx_radar.estimation.tracks import track_table
from mjx_radar.scenario.reader import load_scenario

MANAGED = {"management": "managed", "max_tracks": 6}
STUDIES = Path(__file__).parents[1] / "benchmarks" / "studies"
PER_TARGET = {"structure": "per-target", "ground_prior": True}


def _study(script: str):
    """The study script ``benchmarks/studies/SCRIPT.py`` as a module (the folder on
    ``sys.path`` while it loads, for its imports of its neighbours)."""
    sys.path.insert(0, str(STUDIES))
    try:
        spec = importlib.util.spec_from_file_location(script, STUDIES / f"{script}.py")
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
    finally:
        sys.path.remove(str(STUDIES))
    return mod


def test_tracker_table_defaults_and_rules():
    sc = load_scenario("paper_3r4t")
    assert sc.tracker.management == "known" and sc.tracker.max_tracks == 16
    ok = sc.replace(tracker=MANAGED, filter=PER_TARGET)
    assert ok.tracker.radars_needed(3, 1) == (3, 3)
    with pytest.raises(ScenarioError, match=r"^tracker.management = \"managed\": needs filter"):
        sc.replace(tracker=MANAGED)  # the joint filter
    with pytest.raises(
        ScenarioError, match=r"^tracker.confirm_m = 6: must be <= tracker.confirm_n"
    ):
        sc.replace(tracker={**MANAGED, "confirm_m": 6}, filter=PER_TARGET)
    with pytest.raises(ScenarioError, match=r"tracker.birth_radars = 4: must be <= n_radars = 3"):
        sc.replace(tracker={**MANAGED, "birth_radars": 4}, filter=PER_TARGET)
    with pytest.raises(ScenarioError, match=r"n_radars >= 3"):
        load_scenario("smoke").replace(tracker=MANAGED, filter=PER_TARGET)
    with pytest.raises(ScenarioError, match="tracker.max_tracks"):
        sc.replace(tracker={"max_tracks": 0})


def test_vanish_misses_reaches_the_tables_rules():
    """``[tracker] vanish_misses`` is read into the life-cycle rules of the managed table
    (the rule itself: tests/test_track_table.py), and a bad value is one line."""
    sc = load_scenario("paper_3r4t")
    with pytest.raises(ScenarioError, match=r"^tracker.vanish_misses = -1: .*\[0, 100000\]"):
        sc.replace(tracker={**MANAGED, "vanish_misses": -1}, filter=PER_TARGET)
    for v in (0, 3):
        cfg = sc.replace(tracker={**MANAGED, "vanish_misses": v}, filter=PER_TARGET).tracker
        rules = managed.life_rules(cfg)
        assert (rules.vanish_misses, rules.delete_misses) == (v, cfg.delete_misses)


def test_truth_view_assigns_confirmed_tracks_greedily():
    truth = jnp.array([[0.0, 0, 50, 1, 0, 0], [100, 0, 50, 0, 1, 0], [300, 0, 50, 0, 0, 0]])
    present = jnp.array([True, True, True])
    means = jnp.array([[98.0, 0, 50, 0, 0, 0], [3, 0, 50, 0, 0, 0], [0, 0, 50, 0, 0, 0]])
    view = track_table.TrackView(
        means,
        jnp.broadcast_to(jnp.eye(6), (3, 6, 6)),
        jnp.ones(3),
        jnp.array([True, True, False]),  # the exact track at drone 0 is not confirmed
        jnp.zeros((1, 3), bool),
    )
    mean, cov = jax.jit(managed.truth_view)(truth, present, view, 50.0)
    got = np.asarray(mean).reshape(3, 6)
    np.testing.assert_allclose(got[0], means[1])  # nearest confirmed
    np.testing.assert_allclose(got[1], means[0])
    np.testing.assert_allclose(got[2], np.asarray(truth[2]) + [managed.CUTOFF_M, 0, 0, 0, 0, 0])
    assert float(cov[12, 12]) == managed.CUTOFF_M**2


@pytest.mark.slow  # compiles the closed loop with births (~3 min on a shared CPU)
def test_managed_env_tracks_unknown_drones():
    """Fixed radars, 2 drones, stationary: both found, planner sees K slots, never M."""
    sc = load_scenario("raid_4r8t")
    sc = sc.replace(
        target_init=sc.target_init[:2],
        target_motion=(),
        radars=[
            [-300.0, -200.0, 0.0],
            [250.0, -300.0, 1.0],
            [300.0, 250.0, 2.0],
            [-250.0, 300.0, 3.0],
        ],
        timing={"steps": 40},
        tracker=MANAGED,
        filter=PER_TARGET,
    )
    env = environment.make(sc, "stationary")
    assert env.n_tracks == 6 and env.observation_size == 6 * 4 + 6 * 6 + 21 * 6 + 6 + 4 * 6
    state = jax.jit(env.reset)(env.trial_key(0, 0))
    assert state.obs.mean.shape == (36,) and float(jnp.sum(state.obs.target_weight)) == 0.0
    assert env.observation_vector(state.obs).shape == (env.observation_size,)
    step = jax.jit(env.transition)
    for _ in range(env.episode_length):
        state, rec = step(state, jnp.zeros((4, 2)))
    assert rec.track_pos.shape == (env.every, 6, 3) and rec.present.shape == (env.every, 2)
    exist = np.asarray(rec.track_exist[-1])
    assert exist.sum() == 2  # the two drones, no ghost
    truth = np.asarray(rec.target[-1, :, :3])
    pos = np.asarray(rec.track_pos[-1])[exist]
    d = np.linalg.norm(pos[:, None] - truth[None], axis=-1)
    assert sorted(d.argmin(1).tolist()) == [0, 1] and d.min(1).max() < 30.0
    np.testing.assert_array_equal(np.asarray(state.obs.target_weight) > 0, exist)
    assert np.isfinite(float(state.reward)) and float(rec.rmse_pos[-1]) < 30.0


def test_script_gospa_matches_brute_force():
    """benchmarks/studies/run_raid_managed.py's GOSPA (α = 2) against every assignment, by hand."""
    import itertools

    mod = _study("run_raid_managed")
    rng = np.random.default_rng(3)
    c, p = 20.0, 2.0
    for _ in range(30):
        x = rng.uniform(0, 60, (4, 3))
        y = rng.uniform(0, 60, (5, 3))
        px, ey = rng.uniform(size=4) < 0.8, rng.uniform(size=5) < 0.7
        xs, ys = x[px], y[ey]
        best = np.inf
        small, big = (xs, ys) if len(xs) <= len(ys) else (ys, xs)
        for perm in itertools.permutations(range(len(big)), len(small)):
            cost, k = 0.0, 0
            for i, j in enumerate(perm):  # pairs beyond c: a miss and a false track
                d = np.linalg.norm(small[i] - big[j])
                cost, k = (cost + d**p, k + 1) if d < c else (cost, k)
            best = min(best, cost + c**p / 2 * (len(xs) + len(ys) - 2 * k))
        g = mod.gospa(x, px, y, ey, c, p)
        np.testing.assert_allclose(g[0], best ** (1 / p), rtol=1e-9)


def test_script_mirror_folded_gospa():
    """run_raid_managed.py's mirror-folded truth: a drone 30 m below the radars' plane and a
    track at its mirror image are 60 m apart (beyond c: a miss and a false track), and
    nothing apart once folded; a drone above is left as it is."""
    mod = _study("run_raid_managed")
    truth = np.array([[10.0, -20.0, -30.0], [5.0, 7.0, 40.0]])
    est = np.array([[10.0, -20.0, 30.0], [5.0, 7.0, 40.0]])
    both = np.ones(2, bool)
    c = 50.0
    np.testing.assert_allclose(mod.gospa(truth, both, est, both, c)[0], c, rtol=1e-12)
    folded = mod.mirror_folded(truth)
    np.testing.assert_array_equal(folded, est)
    assert mod.gospa(folded, both, est, both, c) == (0.0, 0.0, 0, 0)


def test_script_scenario_with_and_without_the_ground_prior():
    """run_raid_managed.py's ``--ground-prior off`` reaches ``[filter] ground_prior`` of
    both the managed and the known rows; the managed rows take the tracker fields."""
    mod = _study("run_raid_managed")
    opts = ["birth_shared=1", "height_std=60", "height_scans=200"]
    on = mod.scenario_for("managed", 16, 40, opts, 2)
    off = mod.scenario_for("managed", 16, 40, opts, 2, ground_prior=False)
    known = mod.scenario_for("known", 16, 40, (), 1, ground_prior=False)
    assert (on.filter.ground_prior, off.filter.ground_prior, known.filter.ground_prior) == (
        True,
        False,
        False,
    )
    assert (off.tracker.birth_shared, off.tracker.height_scans) == (1, 200)
    # --mpc: an [mpc] field of every row, managed and known alike
    planned = [
        mod.scenario_for(g, 16, 40, o, b, False, ["alpha_assoc=7", "assoc_scale=8"])
        for g, o, b in (("managed", opts, 2), ("known", (), 1))
    ]
    assert [(s.mpc.alpha_assoc, s.mpc.assoc_scale) for s in planned] == [(7.0, 8.0)] * 2
    assert off.mpc.alpha_assoc == 0.0


def test_raid_arrival_scene_score_by_hand():
    """benchmarks/studies/raid_arrival_scene.py's per-scan score on one hand-made scan:
    four drones, a confirmed track 3 m and one 4 m from drones 0 and 1, a confirmed track
    70 m from drone 2 (false; drones 2 and 3 missed), a tentative one 10 m from drone 3."""
    mod = _study("raid_arrival_scene")
    truth = np.array([[0.0, 0, 60], [100, 0, 60], [200, 0, 60], [300, 0, 60]])
    pos = np.array([[3.0, 0, 60], [100, 4, 60], [200, 70, 60], [310, 0, 60]])
    rec = {
        "exist": np.array([[[True, True, True, False]]]),
        "pos": pos[None, None],
        "truth": truth[None, None],
        "status": np.array([[[2, 2, 2, 1]]]),
        "cov": np.broadcast_to(np.diag([4.0, 4.0, 25.0]), (1, 1, 4, 3, 3)),
        "seen": np.array([[[4, 4, 4, 2]]]),
    }
    found, false, gospa, near = mod.score(rec, 50.0)
    assert found[0, 0] == 2 and false[0, 0] == 1
    np.testing.assert_allclose(gospa[0, 0], np.sqrt(9 + 16 + 1250 * 3), rtol=1e-12)
    # drone 2: the 70 m track, confirmed, chi2 70²/4; drone 3: the tentative 10 m track
    np.testing.assert_allclose(near, [[0, 70, 70**2 / 4, 4, 1], [0, 10, 100 / 4, 2, 0]], rtol=1e-12)


@pytest.mark.parametrize(
    ("script", "flag", "item", "message"),
    [
        (script, "--tracker", item, message)
        for script in ("run_raid_managed", "raid_arrival_scene")
        for item, message in (
            ("height_std=-1", "tracker.height_std = -1: must be"),
            ("height_std", "--tracker: KEY=VALUE"),
        )
    ]
    + [
        ("run_raid_managed", "--mpc", "alpha_assoc=-1", "mpc.alpha_assoc = -1"),
        ("run_raid_managed", "--mpc", "alpha_assoc", "--mpc: KEY=VALUE"),
    ],
)
def test_raid_scripts_refuse_a_bad_field_in_one_line(script, flag, item, message, tmp_path, capsys):
    """A bad ``--tracker`` item (run_raid_managed: also ``--mpc``): one line naming it,
    exit 2, nothing written, no run."""
    mod = _study(script)
    out = ["--out", str(tmp_path / "o")] if script == "run_raid_managed" else []
    sys.path.insert(0, str(STUDIES))  # raid_arrival_scene's main imports its neighbours
    try:
        with pytest.raises(SystemExit) as e:
            mod.main([*out, flag, item])
    finally:
        sys.path.remove(str(STUDIES))
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert e.value.code == 2 and message in err and not (tmp_path / "o").exists()


def test_raid_script_asks_for_deterministic_gpu_kernels_before_it_runs(tmp_path, monkeypatch):
    """run_raid_managed.py turns XLA's deterministic GPU kernels on (as ``mjx-radar study``
    does) before its first chunk runs: a seed and a chunk size fix its numbers."""
    mod = _study("run_raid_managed")
    calls = []
    monkeypatch.setattr(mod.determinism, "apply", lambda *a: calls.append("apply") or True)

    def chunk(*_):
        calls.append("chunk")
        raise KeyboardInterrupt  # stop before any work

    monkeypatch.setattr(mod, "run_chunk", chunk)
    argv = ["--out", str(tmp_path / "o"), "--trials", "1", "--chunk", "1", "--steps", "4"]
    with pytest.raises(KeyboardInterrupt):
        mod.main([*argv, "--methods", "stationary", "--management", "known"])
    assert calls == ["apply", "chunk"]
