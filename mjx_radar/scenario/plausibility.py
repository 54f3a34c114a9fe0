"""Cross-field plausibility of a scenario (after every field passed its own rule).

Pure Python (no JAX, no NumPy) so that ``mjx-radar validate`` stays light. Each
failure is a one-line :class:`ScenarioError` naming the fields and the rule.
The rules (docs/scenarios.md, "Plausibility"):

* clocks: ``dt_control = k · dt_filter`` (integer k >= 1), ``steps`` a multiple of k;
* motion resolved by the filter clock: a target's initial speed ``|v| <= 1000 m/s`` and
  its displacement over one filter step ``|v| dt + 1.5 σ_w dt² <= 100 m``
  (``σ_w = sqrt(sigma_w2)``, 3σ acceleration), so consecutive range measurements
  see nearby states (100 m is below the default R2T keep-out of 125 m);
* range noise (SPEC §1): ``K = Pt Gt Gr λ² σ / ((4π)³ L)`` finite and > 0, and the
  range noise std at ``r_ref``, ``σ_R = sqrt(C) r_ref² = c sqrt(M) / (2 sqrt(2) π fc
  10^(snr_db/20))``, in ``[1e-6, 1e6] m``. With ``r_ref`` in ``[1, 1e5] m`` this keeps
  C in ``[1e-32, 1e12] 1/m²`` and the variance ``C d⁴`` for ``d`` in ``[1 m, 3e5 m]``
  inside float32's normal range; below 1e-6 m the noise vanishes below float32
  resolution of a range, above 1e6 m a measurement carries no information in a
  1e5 m scene;
* geometry: a fixed radar start at least ``max(mpc.r2r, 1 m)`` from every other one
  and at least ``max(mpc.r2t, 1 m)`` (3-D) from every target start (the range and
  its Fisher information are undefined at distance 0); with random placement,
  ``mpc.r2t >= 1 m`` unless every target starts >= 1 m above the ground;
* MPPI: the cross-entropy weighting keeps at least one elite sample.
* detection (docs/detection.md): clutter needs ``filter.structure = "per-target"`` (PDA
  per target; the joint filter has no data association) and a range window
  ``clutter_range_min < clutter_range_max``; the expected false alarms per scan and
  radar ``λ = clutter_density · (max − min)`` must fit the per-scan cap:
  ``P(Poisson(λ) > max_false_alarms) <= 1e-6``.
* IMM (``filter.motion = "imm"``, docs/filters.md): needs ``filter.structure =
  "per-target"`` (the modes are per target), ``filter.form = "covariance"`` and no
  clutter (no IMM-PDA).
* tracker (docs/tracking.md): ``tracker.association = "jpda"`` or ``"gnn"`` needs clutter
  (without it the returns are labelled); the enumeration's ``(G + 1)^M`` events (exact
  JPDA, GNN) at most ``MAX_EVENTS``, times ``M!`` for JPDA* at most ``MAX_STAR_WORK``;
  JPDA* needs ``tracker.marginals = "exact"``; the multi-sensor JPDA's radar tuples
  ``(candidates + 1)^N`` at most ``MAX_TUPLES`` and its events ``tuples^M`` at most
  ``MAX_EVENTS``; the MHT (``"mht"``) needs clutter, and its children per radar
  ``hypotheses · (G + 1)^M`` at most ``MAX_CHILDREN``; a registered associator (and
  ``"gnn"``) needs clutter or the managed table (its GNN: no enumeration, no limit).
"""

from __future__ import annotations

import math

from mjx_radar.io.checks import ScenarioError
from mjx_radar.scenario import tracker_checks, tracker_roles
from mjx_radar.scenario.schema import Scenario
from mjx_radar.scenario.schema_tracker import MAX_EVENTS, MAX_STAR_WORK, MAX_TUPLES

SPEED_OF_LIGHT = 299792458.0  # c [m/s] (same as estimation.sensor.sensing)
MAX_SPEED = 1e3  # initial target speed [m/s]
MAX_STEP = 100.0  # target displacement per filter step [m]
SIGMA_R_RANGE = (1e-6, 1e6)  # range noise std at r_ref [m]
MIN_DISTANCE = 1.0  # radar-target and radar-radar start distance [m]


def check_scenario(s: Scenario) -> None:
    """Raises :class:`ScenarioError` on the first implausible combination of fields."""
    _check_clocks(s)
    _check_motion(s)
    _check_noise(s)
    _check_geometry(s)
    _check_detection(s)
    _check_imm(s)
    tracker_checks.check(s)  # first: the managed table's own refusal names its associators
    _check_tracker(s)
    tracker_roles.check(s)
    if s.mppi.samples * (1 - s.mppi.elite_threshold) < 1 and s.mppi.weighting == "ce":
        raise ScenarioError(
            f"mppi.elite_threshold = {s.mppi.elite_threshold}: leaves no elite sample out of "
            f"mppi.samples = {s.mppi.samples}; need samples * (1 - threshold) >= 1"
        )


def _check_clocks(s: Scenario) -> None:
    t = s.timing
    ratio = t.dt_control / t.dt_filter
    if ratio < 1 - 1e-9 or abs(ratio - round(ratio)) > 1e-6:
        raise ScenarioError(
            f"timing.dt_control = {t.dt_control}: must be an integer multiple (>= 1) of "
            f"timing.dt_filter = {t.dt_filter}"
        )
    if t.steps % t.control_every:
        raise ScenarioError(
            f"timing.steps = {t.steps}: must be a multiple of dt_control/dt_filter = "
            f"{t.control_every}"
        )


def _check_motion(s: Scenario) -> None:
    dt = s.timing.dt_filter
    for i, row in enumerate(s.target_init):
        speed = math.hypot(*row[3:6])
        if speed > MAX_SPEED:
            raise ScenarioError(
                f"targets[{i}] speed |v| = {speed:.6g} m/s: must be <= {MAX_SPEED:g} m/s"
            )
        step = speed * dt + 1.5 * math.sqrt(s.sigma_w2) * dt**2
        if step > MAX_STEP:
            raise ScenarioError(
                f"timing.dt_filter = {dt}: targets[{i}] moves {step:.6g} m per filter step "
                f"(|v| dt + 1.5 sqrt(sigma_w2) dt^2); must be <= {MAX_STEP:g} m, lower dt_filter"
            )


def noise_std_at_r_ref(s: Scenario) -> float:
    """``σ_R = sqrt(C) r_ref²`` [m] in float64 (``inf``/``nan`` if not representable)."""
    p = s.radar_eq
    c2 = SPEED_OF_LIGHT**2
    try:
        snr = 10.0 ** (p.snr_db / 10.0)
        return math.sqrt(c2 * s.n_targets / (8.0 * math.pi**2 * p.fc**2 * snr))
    except (OverflowError, ZeroDivisionError):
        return math.inf


def radar_constant(s: Scenario) -> float:
    """``K = Pt Gt Gr λ² σ / ((4π)³ L)`` [W m⁴] in float64 (``inf`` if it overflows)."""
    p = s.radar_eq
    try:
        lam = SPEED_OF_LIGHT / p.fc
        return p.power_tx * p.gain_tx * p.gain_rx * lam**2 * p.rcs / ((4.0 * math.pi) ** 3 * p.loss)
    except OverflowError:  # e.g. fc = 1e-253: lambda^2 beyond float64
        return math.inf


def _check_noise(s: Scenario) -> None:
    k = radar_constant(s)
    if not (math.isfinite(k) and k > 0.0):
        raise ScenarioError(
            f"radar_equation: radar constant K = Pt Gt Gr lambda^2 rcs / ((4 pi)^3 L) = {k:.3g} "
            "W m^4 is not a finite number > 0; adjust power_tx, gain_tx, gain_rx, rcs, loss, fc"
        )
    noise = k / s.radar_eq.r_ref**4 / 10.0 ** (s.radar_eq.snr_db / 10.0)
    if not (math.isfinite(noise) and noise > 0.0):
        raise ScenarioError(
            f"radar_equation: noise power K / r_ref^4 / 10^(snr_db/10) = {noise:.3g} W is not a "
            "finite number > 0; adjust power_tx, gains, rcs, loss, r_ref or snr_db"
        )
    sigma = noise_std_at_r_ref(s)
    lo, hi = SIGMA_R_RANGE
    if not (math.isfinite(sigma) and lo <= sigma <= hi):
        raise ScenarioError(
            f"radar_equation: range noise std at r_ref, sqrt(C) r_ref^2 = {sigma:.3g} m (fc = "
            f"{s.radar_eq.fc:g} Hz, snr_db = {s.radar_eq.snr_db:g}, {s.n_targets} targets); "
            f"must be in [{lo:g}, {hi:g}] m"
        )


def _dist(a, b) -> float:
    return math.dist(a, b)


def _check_geometry(s: Scenario) -> None:
    r2t, r2r = s.mpc.r2t, s.mpc.r2r
    radars = [(x, y, 0.0) for x, y, _ in s.radar_init]
    for i, a in enumerate(radars):
        for j in range(i + 1, len(radars)):
            d = _dist(a[:2], radars[j][:2])
            if d < max(r2r, MIN_DISTANCE):
                raise ScenarioError(
                    f"radars[{i}] and radars[{j}] start {d:.3g} m apart; need >= mpc.r2r = "
                    f"{r2r} m and >= {MIN_DISTANCE:g} m"
                )
        for m, t in enumerate(s.target_init):
            d = _dist(a, t[:3])
            if d < max(r2t, MIN_DISTANCE):
                raise ScenarioError(
                    f"targets[{m}] starts {d:.3g} m from radars[{i}]; need >= mpc.r2t = {r2t} m "
                    f"and >= {MIN_DISTANCE:g} m (the range is undefined at 0)"
                )
    if not radars and r2t < MIN_DISTANCE:
        low = min(range(s.n_targets), key=lambda m: s.target_init[m][2])
        z = s.target_init[low][2]
        if z < MIN_DISTANCE:
            raise ScenarioError(
                f"mpc.r2t = {r2t}: with random radar placement a radar may start within "
                f"{MIN_DISTANCE:g} m of targets[{low}] (z = {z} m); need mpc.r2t >= "
                f"{MIN_DISTANCE:g} m"
            )


CLUTTER_TAIL = 1e-6  # largest allowed probability of more false alarms than the cap


def poisson_tail(lam: float, cap: int) -> float:
    """``P(Poisson(lam) > cap)`` (pure Python, summed in log space)."""
    if lam <= 0.0:
        return 0.0
    cdf = sum(math.exp(k * math.log(lam) - lam - math.lgamma(k + 1)) for k in range(cap + 1))
    return max(0.0, 1.0 - cdf)


def _check_detection(s: Scenario) -> None:
    d = s.detection
    if not d.clutter:
        return
    if s.filter.structure != "per-target":
        raise ScenarioError(
            f"detection.clutter_density = {d.clutter_density}: clutter needs "
            f'filter.structure = "per-target" (PDA per target); the joint filter has no '
            f"data association"
        )
    width = d.clutter_range_max - d.clutter_range_min
    if width <= 0.0:
        raise ScenarioError(
            f"detection.clutter_range_max = {d.clutter_range_max}: must exceed "
            f"detection.clutter_range_min = {d.clutter_range_min}"
        )
    lam = d.clutter_density * width
    tail = poisson_tail(lam, d.max_false_alarms)
    if tail > CLUTTER_TAIL:
        raise ScenarioError(
            f"detection.clutter_density = {d.clutter_density}: {lam:.3g} expected false alarms "
            f"per scan and radar exceed the per-scan cap detection.max_false_alarms = "
            f"{d.max_false_alarms} (P(more) = {tail:.2g} > {CLUTTER_TAIL:g}); raise the cap "
            f"or lower the density"
        )
    if s.filter.form != "covariance":
        raise ScenarioError(
            f'filter.form = "{s.filter.form}": clutter (PDA) runs in the covariance form only; '
            f'use filter.form = "covariance" or detection.clutter_density = 0'
        )


def _check_imm(s: Scenario) -> None:
    f = s.filter
    if f.motion != "imm":
        return
    if f.structure != "per-target":
        raise ScenarioError(
            f'filter.motion = "imm": needs filter.structure = "per-target" (an IMM per '
            f'target), got "{f.structure}"'
        )
    if f.form != "covariance":
        raise ScenarioError(
            f'filter.motion = "imm": runs in the covariance form only; got filter.form = "{f.form}"'
        )
    if s.detection.clutter:
        raise ScenarioError(
            f'filter.motion = "imm": not with clutter (no IMM-PDA); set '
            f"detection.clutter_density = 0 (got {s.detection.clutter_density})"
        )


def _check_tracker(s: Scenario) -> None:
    t, m = s.tracker, s.n_targets
    managed = tracker_roles.roles(s).management == "managed"
    if t.association == "pda" or (t.association in tracker_roles.TABLE_ASSOCIATORS and managed):
        return  # the track table's own (jpda: lbp, tracker_checks): any K, no enumeration
    if tracker_roles.registered_associator(t.association):  # a plug-in: it drives the
        if not s.detection.clutter and not managed:
            raise ScenarioError(  # bank on cluttered scans, the track table on any
                f'tracker.association = "{t.association}": needs clutter '
                f'(detection.clutter_density > 0) or tracker.management = "managed"; '
                f"without them the returns are labelled"
            )
        return
    if not s.detection.clutter:
        raise ScenarioError(
            f'tracker.association = "{t.association}": needs clutter (detection.clutter_density '
            f'> 0); without it the returns are labelled: use tracker.association = "pda"'
        )
    if t.association == "jpda" and t.marginals == "multisensor":
        _check_multisensor(t, s.n_radars, m)
    exact = t.association in ("gnn", "mht") or t.marginals == "exact"
    events = (t.candidates + 1) ** m
    if exact and events > MAX_EVENTS:
        raise ScenarioError(
            f"tracker.candidates = {t.candidates}: (candidates + 1)^M = {events} joint events "
            f"for M = {m} targets exceed {MAX_EVENTS}; lower it, or use "
            f'tracker.marginals = "lbp" (jpda)'
        )
    if t.association == "mht":
        tracker_checks.check_mht(t, m)
    if t.jpda_star and (t.association != "jpda" or t.marginals != "exact"):
        raise ScenarioError(
            f'tracker.jpda_star = true: needs tracker.association = "jpda" and '
            f'tracker.marginals = "exact" (got "{t.association}", "{t.marginals}")'
        )
    if t.jpda_star and events * math.factorial(m) > MAX_STAR_WORK:
        raise ScenarioError(
            f"tracker.jpda_star = true: (candidates + 1)^M x M! = {events * math.factorial(m)} "
            f"for M = {m} targets exceeds {MAX_STAR_WORK}; lower tracker.candidates"
        )


def _check_multisensor(t, n: int, m: int) -> None:
    tuples, events = (t.candidates + 1) ** n, t.tuples**m
    if tuples > MAX_TUPLES:
        raise ScenarioError(
            f"tracker.candidates = {t.candidates}: (candidates + 1)^N = {tuples} radar tuples "
            f"for N = {n} radars exceed {MAX_TUPLES}; lower it"
        )
    if events > MAX_EVENTS:
        raise ScenarioError(
            f"tracker.tuples = {t.tuples}: tuples^M = {events} joint events for M = {m} "
            f"targets exceed {MAX_EVENTS}; lower it"
        )
