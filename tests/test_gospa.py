"""GOSPA / OSPA and track continuity (issue 35) against Stone Soup's metric generators.

Stone Soup (``stonesoup.metricgenerator.ospametric``) is an independent implementation:
``GOSPAMetric.compute_gospa_metric`` solves the rectangular assignment of the capped
costs with scipy and splits the value into localisation / missed / false exactly as
:mod:`mjx_radar.estimation.tracks.gospa` does, so every part must agree to float64 round-off
(1e-9 relative: sums of a few distances below 100 m). ``OSPAMetric`` assigns on the
capped distances ``min(d, c)`` rather than their p-th powers: the same optimum for
p = 1 (compared to 1e-9), an upper bound of the exact OSPA otherwise (checked as such,
and the exact value against a brute-force minimum over every permutation).
"""

from __future__ import annotations

import datetime
import itertools

import numpy as np
import pytest

from mjx_radar.estimation.tracks import gospa
from mjx_radar.estimation.tracks.continuity import continuity_events

ss = pytest.importorskip("stonesoup.metricgenerator.ospametric")
from stonesoup.types.state import State  # noqa: E402

T0 = datetime.datetime(2026, 1, 1)
RTOL = 1e-9


def _states(points, k=0):
    stamp = T0 + datetime.timedelta(seconds=k)
    return [State(np.asarray(x, float).reshape(-1, 1), timestamp=stamp) for x in points]


def _random_sets(rng, m_max=6, k_max=5, spread=15.0):
    """Padded sets with random masks (0 to all present), estimates near some truths."""
    truth = rng.uniform(0.0, 60.0, (m_max, 3))
    est = truth[rng.integers(0, m_max, k_max)] + rng.normal(0.0, spread, (k_max, 3))
    present = rng.permutation(np.arange(m_max) < rng.integers(0, m_max + 1))
    exists = rng.permutation(np.arange(k_max) < rng.integers(0, k_max + 1))
    return truth, present, est, exists


@pytest.mark.parametrize("order", [1.0, 2.0, 3.0])
def test_gospa_matches_stone_soup_on_random_sets(order):
    rng = np.random.default_rng(int(order))
    cutoff, empties = 30.0, 0
    for _ in range(150):
        truth, present, est, exists = _random_sets(rng)
        got = gospa.set_metrics(truth, present, est, exists, cutoff, order)
        if not (present.any() or exists.any()):  # Stone Soup needs a timestamp
            assert got.gospa == got.ospa == got.localisation == 0.0
            empties += 1
            continue
        ref, _ = ss.GOSPAMetric(c=cutoff, p=order).compute_gospa_metric(
            _states(est[exists]), _states(truth[present])
        )
        v = ref.value
        pairs = {"distance": got.gospa, "localisation": got.localisation}
        for name, mine in (pairs | {"missed": got.missed, "false": got.false}).items():
            assert mine == pytest.approx(v[name], rel=RTOL, abs=1e-9), name
        ospa = ss.OSPAMetric(c=cutoff, p=order).compute_OSPA_distance(
            _states(est[exists]), _states(truth[present])
        )
        if order == 1.0:
            assert got.ospa == pytest.approx(ospa.value, rel=RTOL, abs=1e-9)
        else:  # Stone Soup's assignment is optimal for sum min(d, c), not its p-th powers
            assert got.ospa <= ospa.value + 1e-9
        assert got.ospa == pytest.approx(_ospa_brute(truth[present], est[exists], cutoff, order))
    assert empties >= 1  # both empty: GOSPA = OSPA = 0


def _ospa_brute(x, y, c, p):
    """Schuhmacher et al.'s definition, minimised over every injection (small sets)."""
    if len(x) > len(y):
        x, y = y, x
    m, n = len(x), len(y)
    if n == 0:
        return 0.0
    d = np.minimum(np.linalg.norm(x[:, None] - y[None], axis=-1), c) ** p
    best = min(sum(d[i, s[i]] for i in range(m)) for s in itertools.permutations(range(n), m))
    return ((best + c**p * (n - m)) / n) ** (1 / p)


def test_empty_and_one_sided_sets():
    c, p = 50.0, 1.0
    truth, est = np.zeros((3, 3)), np.ones((2, 3))
    none3, none2 = np.zeros(3, bool), np.zeros(2, bool)
    out = gospa.set_metrics(truth, none3, est, none2, c, p)
    assert out.gospa == out.ospa == 0.0 and (out.assignment == -1).all()
    out = gospa.set_metrics(truth, ~none3, est, none2, c, p)  # 3 missed
    assert (out.gospa, out.missed, out.false, out.ospa) == (75.0, 75.0, 0.0, 50.0)
    out = gospa.set_metrics(truth, none3, est, ~none2, c, p)  # 2 false
    assert (out.gospa, out.missed, out.false, out.ospa) == (50.0, 0.0, 50.0, 50.0)
    # K = 0 estimate slots and M = 0 truths (static shapes)
    out = gospa.set_metrics(truth, ~none3, np.zeros((0, 3)), np.zeros(0, bool), c, p)
    assert out.gospa == 75.0 and out.assignment.shape == (3,)
    out = gospa.set_metrics(np.zeros((0, 3)), np.zeros(0, bool), est, ~none2, c, 2.0)
    assert out.gospa == pytest.approx(np.sqrt(2 * c**2 / 2)) and out.ospa == c


def test_cutoff_pairs_count_as_missed_and_false():
    """A pair farther apart than c is no assignment: c^p/2 missed + c^p/2 false."""
    truth, est = np.zeros((1, 3)), np.array([[0.0, 0.0, 80.0]])
    one = np.ones(1, bool)
    out = gospa.set_metrics(truth, one, est, one, 50.0, 2.0)
    assert out.assignment[0] == -1 and out.localisation == 0.0
    assert out.missed == out.false == 1250.0 and out.gospa == pytest.approx(50.0)
    assert out.ospa == pytest.approx(50.0)


def test_solvers_agree_and_batch_axes_are_kept():
    """Identity shortcut, enumeration and scipy: one optimum; leading axes kept."""
    rng = np.random.default_rng(3)
    cost = rng.uniform(0.0, 1.0, (400, 5, 5))
    cost[:100] = np.where(np.eye(5, dtype=bool), 0.0, cost[:100])  # identity optimal
    perm = gospa.assign(cost)
    ref = np.stack([_lsa(c) for c in cost])
    np.testing.assert_allclose(_total(cost, perm), _total(cost, ref), rtol=1e-12)
    assert (np.sort(perm, axis=1) == np.arange(5)).all()  # permutations
    big = rng.uniform(0.0, 1.0, (50, 9, 9))  # beyond ENUMERATE_MAX: scipy
    perm = gospa.assign(big)
    ref = np.stack([_lsa(c) for c in big])
    np.testing.assert_allclose(_total(big, perm), _total(big, ref), rtol=1e-12)
    truth = rng.uniform(0, 40, (2, 3, 8, 3))
    est = truth + rng.normal(0, 4, truth.shape)
    mask = np.ones((2, 3, 8), bool)
    out = gospa.set_metrics(truth, mask, est, mask, 30.0)
    assert out.gospa.shape == (2, 3) and out.assignment.shape == (2, 3, 8)
    flat = gospa.set_metrics(truth[1, 2], mask[1, 2], est[1, 2], mask[1, 2], 30.0)
    assert flat.gospa == pytest.approx(out.gospa[1, 2], rel=1e-12)


def _total(cost, perm):
    return np.take_along_axis(cost, perm[:, :, None], axis=2).sum((1, 2))


def _lsa(c):
    from scipy.optimize import linear_sum_assignment

    return linear_sum_assignment(c)[1]


@pytest.mark.parametrize("cutoff,order", [(0.0, 1.0), (-1.0, 1.0), (np.inf, 1.0), (5.0, 0.5)])
def test_bad_cutoff_or_order_is_one_line(cutoff, order):
    with pytest.raises(ValueError, match="must be a finite number"):
        gospa.set_metrics(np.zeros((1, 3)), [True], np.zeros((1, 3)), [True], cutoff, order)


def test_assignments_match_stone_soup_switching_over_time():
    """Stone Soup's switching loss (penalty 1, p = 1) from our truth-to-track assignments:
    1/2 per change to or from "unassigned", 1 per change between two tracks."""
    rng = np.random.default_rng(11)
    steps, m, k, c = 40, 4, 5, 20.0
    truth = np.cumsum(rng.normal(0, 3.0, (steps, m, 3)), axis=0) + 10 * np.arange(m)[:, None]
    slots = np.stack([rng.permutation(k)[:m] if s % 7 == 0 else np.arange(m) for s in range(steps)])
    est = rng.normal(0, 30.0, (steps, k, 3))  # unused slots: far-off false tracks
    for s in range(steps):
        est[s, slots[s]] = truth[s] + rng.normal(0, 4.0 + 10 * (s % 5 == 0), (m, 3))
    present, exists = np.ones((steps, m), bool), np.ones((steps, k), bool)
    out = gospa.set_metrics(truth, present, est, exists, c)
    metric = ss.GOSPAMetric(c=c, p=1, switching_penalty=1.0)
    ids_t = [i for _ in range(steps) for i in range(m)]
    ids_e = [j for _ in range(steps) for j in range(k)]
    states_t = [s for t in range(steps) for s in _states(truth[t], t)]
    states_e = [s for t in range(steps) for s in _states(est[t], t)]
    ref = metric.compute_over_time(states_e, ids_e, states_t, ids_t).value
    hist = np.full(m, -2)  # -2: never assigned yet
    for t in range(steps):
        a = out.assignment[t]
        changed = (hist != -2) & (a != hist)
        want = np.sum(np.where(changed, 0.5 + 0.5 * ((a >= 0) & (hist >= 0)), 0.0))
        assert ref[t].value["switching"] == pytest.approx(want), t
        hist = np.where((hist == -2) & (a < 0), -2, a)
    assert sum(r.value["switching"] for r in ref) > 2  # the test saw switches


def _events(assign, present, exists):
    sw, br = continuity_events(*(np.asarray(x)[None] for x in (assign, present, exists)))
    return sw[0].tolist(), br[0].tolist()


def test_continuity_events_by_hand():
    on2, on3 = np.ones((5, 2), bool), np.ones((5, 3), bool)
    # a swap at step 2: both tracks switch label, both truths' tracks break
    swap = [[0, 1], [0, 1], [1, 0], [1, 0], [1, 0]]
    assert _events(swap, on2, on2) == ([0, 0, 2, 0, 0], [0, 0, 2, 0, 0])
    # truth 1 loses its track at step 1 and regains it at 3: one break, no switch
    lost = [[0, 1], [0, -1], [0, -1], [0, 1], [0, 1]]
    assert _events(lost, on2, on2) == ([0] * 5, [0, 1, 0, 0, 0])
    # track 1 leaves truth 1 (step 1) and later takes truth 2 (step 3): a label switch
    # across the gap, and truth 2's track 2 breaks then
    a = [[0, 1, 2], [0, -1, 2], [0, -1, 2], [0, -1, 1], [0, -1, 1]]
    assert _events(a, on3, on3) == ([0, 0, 0, 1, 0], [0, 1, 0, 1, 0])
    # the same, but track 1 did not exist at step 2: a new track in the slot, no switch
    alive = on3.copy()
    alive[2, 1] = False
    assert _events(a, on3, alive)[0] == [0] * 5
    # a truth that leaves (absent at step 2) breaks nothing
    here = on2.copy()
    here[2:, 1] = False
    assert _events([[0, 1], [0, 1], [0, -1], [0, -1], [0, -1]], here, on2) == ([0] * 5, [0] * 5)


def test_metrics_settings_are_host_only():
    """``[metrics]`` changes neither the compiled shape nor the runtime parameters."""
    import jax

    from mjx_radar.scenario.reader import load_scenario
    from mjx_radar.task.method import parse_method
    from mjx_radar.task.params import shape_key, task_params

    s = load_scenario("smoke")
    other = s.replace(metrics={"gospa_cutoff": 20.0, "gospa_order": 2.0})
    assert other.metrics.gospa_cutoff == 20.0 and shape_key(other) == shape_key(s)
    method = parse_method("ddr-sfim")
    a, b = (jax.tree.leaves(task_params(x, method)) for x in (s, other))
    assert all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))
