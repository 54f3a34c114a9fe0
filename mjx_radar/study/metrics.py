"""Summary statistics of a Monte Carlo study (SPEC §9, issue 13, docs/statistics.md).

All functions take the long-format metrics table of ``mjx-radar study`` /
``mjx-radar run`` (columns ``scenario, method, trial, step, time_s, rmse_pos,
rmse_state, crlb_pos`` and, in studies with the lost-track detector, ``lost``)
and return plain pandas / numpy objects. Without a ``lost`` column (older
studies) every lost-track statistic is NaN ("not recorded"), never a guess.

Definitions (T trials, K steps of one scenario and method):

* **mean RMSE per step**: mean over the T trials of the per-step RMSE. A single
  lost trial (e.g. a CCR filter locked on the z-mirror, 1e6 m) dominates it.
* **median per step**: median over the T trials.
* **90% HDI per step**: the narrowest interval holding 90% of the T per-step
  RMSE values (as ``arviz.hdi`` 0.x: of the sorted values ``x``, the window
  ``[x_i, x_{i + floor(0.9 T)}]`` of least width). Robust while fewer than ~10% of
  the trials are lost at that step.
* **kept mean per step**: mean over the trials never flagged lost in any step.
* **lost-track rates**: trial rate = fraction of trials lost at any step ("ever
  lost"); step rate = fraction of (trial, step) pairs flagged lost.
* **RMS RMSE vs bound per step**: ``sqrt(mean_T rmse_pos²)`` vs
  ``sqrt(mean_T crlb_pos²)`` (``crlb_pos² = mean_m tr[J_m⁻¹]_pos``): both are
  square roots of mean squared errors, the only clean comparison with the PCRLB
  (:func:`mjx_radar.estimation.information.pcrlb.rmse_vs_bound`).
* One number per scenario and method: the mean over the K steps of each per-step
  statistic (``mean_rmse_pos``, ``median_rmse_pos``, ``hdi_hi_pos``, ``kept_rmse_pos``).
* **GOSPA, OSPA** (docs/tracking_metrics.md): means over trials and steps of the
  per-step values and GOSPA parts; **label switches / broken tracks per trial**: the
  mean over trials of each trial's number of events.
* **Reduction** of a DDR-MPPI method vs a baseline (stationary; the CCR-MPPI
  method with the same information kind):
  ``100 (1 - value_DDR / value_baseline)`` percent (positive = DDR is better), on
  the median (``red_median_*``), on the HDI upper end (``red_hdi_*``), and on the
  kept mean over the trials kept by *both* methods (``red_kept_*``, paired by
  trial index: common random numbers give both the same truth and noise). The
  reduction of the plain mean (``red_mean_*``) is kept in ``summary.csv`` for
  comparison with older reports only.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from mjx_radar.study.lost import (  # noqa: F401 -- importable from here as before
    lost_by_trial,
    lost_counts,
    lost_counts_by_cell,
)
from mjx_radar.task.method import METHODS

HDI_PROB = 0.9
_VALUES = ("rmse_pos", "rmse_state", "crlb_pos")
#: multi-target columns (docs/tracking_metrics.md): per-step means; NaN in older studies
SET_VALUES = ("gospa", "gospa_localisation", "gospa_missed", "gospa_false", "ospa")
EVENTS = ("label_switches", "broken_tracks")  # per-step event counts: summed per trial
STATS = ("mean", "median", "hdi", "kept")
#: summary column of each statistic a reduction is computed on
STAT_COLUMN = {
    "mean": "mean_rmse_pos",
    "median": "median_rmse_pos",
    "hdi": "hdi_hi_pos",
    "kept": "kept_rmse_pos",
}


def hdi(samples: np.ndarray, prob: float = HDI_PROB) -> np.ndarray:
    """Highest density interval over the first axis (arviz 0.x's ``hdi``, computed here).

    Of the T sorted values ``x`` of a column, the window ``[x_i, x_{i + floor(prob T)}]``
    of least width (the first on ties; NaN values sort last and, as in arviz, a column
    with NaN may give a NaN bound). Computed without arviz, whose signature changed
    (``hdi_prob`` in 0.x, ``prob`` in 1.x), with the same numbers as arviz 0.x.

    Args:
        samples: [T] or [T, K] values (trials first), T >= 1.
        prob: probability mass of the interval, in (0, 1].

    Returns:
        [2] ``(low, high)`` for 1-D input, else [K, 2].
    """
    x = np.asarray(samples, np.float64)
    if x.ndim == 0 or x.shape[0] == 0:
        raise ValueError("hdi: no values (at least one trial is needed)")
    flat = x.reshape(x.shape[0], -1)
    return np.stack([_hdi_column(flat[:, k], prob) for k in range(flat.shape[1])]).reshape(
        (2,) if x.ndim == 1 else (-1, 2)
    )


def _hdi_column(values: np.ndarray, prob: float) -> np.ndarray:
    v = np.sort(values)
    width_idx = int(np.floor(prob * v.size))
    widths = np.subtract(v[width_idx:], v[: v.size - width_idx], dtype=np.float64)
    i = int(np.argmin(widths))
    return np.array([v[i], v[i + width_idx]])


def ecdf(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Empirical CDF as a right-continuous step function.

    Args:
        values: [n] samples (any shape; flattened; NaN dropped).

    Returns:
        ``(x [u], F [u])``: the u distinct sorted values and ``F(x) = #{v <= x} / n``.
    """
    v = np.sort(np.asarray(values, np.float64).reshape(-1))
    v = v[~np.isnan(v)]
    x = np.unique(v)
    return x, np.searchsorted(v, x, side="right") / max(len(v), 1)


def kept_mean(values: np.ndarray, ever_lost: np.ndarray) -> np.ndarray:
    """Per-step mean over the trials never lost.

    Args:
        values: [T, K] per-trial, per-step values.
        ever_lost: [T] bool.

    Returns:
        [K] means over the kept trials (NaN when every trial was lost).
    """
    keep = ~np.asarray(ever_lost, bool)
    v = np.asarray(values, np.float64)[keep]
    return v.mean(axis=0) if len(v) else np.full(v.shape[1], np.nan)


def _wide(g: pd.DataFrame, column: str) -> pd.DataFrame:
    """[T, K] table (trials x steps) of one column of one scenario and method."""
    return g.pivot(index="trial", columns="step", values=column)


def _lost_wide(g: pd.DataFrame) -> pd.DataFrame | None:
    """[T, K] bool lost flags, or None when the study has no ``lost`` column."""
    if "lost" not in g.columns:
        return None
    return _wide(g, "lost").fillna(0).astype(float) > 0.5


def per_step(frame: pd.DataFrame, prob: float = HDI_PROB) -> pd.DataFrame:
    """Per-step statistics over trials for every scenario and method.

    Args:
        frame: long-format metrics table.
        prob: HDI probability.

    Returns:
        One row per (scenario, method, step): ``time_s``; ``rmse_pos``, ``rmse_state``,
        ``crlb_pos`` (means over trials); ``median_pos``; ``hdi_pos_lo/hi``,
        ``hdi_state_lo/hi``; ``rms_pos`` and ``crlb_rms`` (square roots of the means of
        squares); ``kept_pos`` (mean over never-lost trials), ``lost_frac`` (trials lost
        at this step), ``ever_lost_frac`` (trials lost at this or an earlier step); the
        last three NaN without a ``lost`` column; the means over trials of
        :data:`SET_VALUES` and :data:`EVENTS` (NaN in studies without them).
    """
    rows = []
    for (scen, meth), g in frame.groupby(["scenario", "method"], observed=True, sort=False):
        wide = {c: _wide(g, c) for c in _VALUES}
        steps = wide["rmse_pos"].columns.to_numpy()
        out = pd.DataFrame({"scenario": scen, "method": meth, "step": steps})
        out["time_s"] = g.groupby("step")["time_s"].first().loc[steps].to_numpy()
        for c in _VALUES:
            out[c] = wide[c].mean(axis=0).to_numpy()
        pos = wide["rmse_pos"].to_numpy()
        out["median_pos"] = np.median(pos, axis=0)
        for c, tag in (("rmse_pos", "pos"), ("rmse_state", "state")):
            band = hdi(wide[c].to_numpy(), prob)
            out[f"hdi_{tag}_lo"], out[f"hdi_{tag}_hi"] = band[:, 0], band[:, 1]
        out["rms_pos"] = np.sqrt(np.mean(pos**2, axis=0))
        out["crlb_rms"] = np.sqrt(np.mean(wide["crlb_pos"].to_numpy() ** 2, axis=0))
        lost = _lost_wide(g)
        if lost is None:
            out["kept_pos"] = out["lost_frac"] = out["ever_lost_frac"] = np.nan
        else:
            lost = lost.loc[wide["rmse_pos"].index, steps].to_numpy()
            out["kept_pos"] = kept_mean(pos, lost.any(axis=1))
            out["lost_frac"] = lost.mean(axis=0)
            out["ever_lost_frac"] = np.logical_or.accumulate(lost, axis=1).mean(axis=0)
        for c in SET_VALUES + EVENTS:
            out[c] = _wide(g, c).mean(axis=0).to_numpy() if c in g.columns else np.nan
        rows.append(out)
    return pd.concat(rows, ignore_index=True)


def baselines(method: str) -> dict[str, str]:
    """Baselines of a DDR-MPPI method: ``{"stationary": ..., "ccr": ...}``; {} otherwise."""
    m = METHODS.get(str(method))
    if m is None or m.noise != "ddr" or not m.plans:
        return {}
    out = {"stationary": next(b.name for b in METHODS.values() if not b.plans)}
    ccr = [b.name for b in METHODS.values() if b.noise == "ccr" and b.info == m.info]
    if ccr:
        out["ccr"] = ccr[0]
    return out


def paired_kept(frame: pd.DataFrame, name: str, a: str, b: str) -> tuple[float, float, int]:
    """Means of ``rmse_pos`` over steps and the trials kept by both methods ``a`` and ``b``
    in the rows of the scenario called ``name``.

    Returns:
        ``(mean_a, mean_b, n_common)``; NaNs and 0 without a ``lost`` column or when
        no trial is kept by both.
    """
    sub = frame[frame["scenario"] == name]
    ga, gb = sub[sub["method"] == a], sub[sub["method"] == b]
    la, lb = _lost_wide(ga), _lost_wide(gb)
    if la is None or lb is None or ga.empty or gb.empty:
        return float("nan"), float("nan"), 0
    kept = la.index[~la.any(axis=1)].intersection(lb.index[~lb.any(axis=1)])
    if len(kept) == 0:
        return float("nan"), float("nan"), 0
    ma = _wide(ga, "rmse_pos").loc[kept].to_numpy().mean()
    mb = _wide(gb, "rmse_pos").loc[kept].to_numpy().mean()
    return float(ma), float(mb), len(kept)


def summary(steps: pd.DataFrame, frame: pd.DataFrame | None = None) -> pd.DataFrame:
    """One row per (scenario, method) with means over steps, lost rates and DDR reductions.

    Args:
        steps: output of :func:`per_step`.
        frame: the metrics table; needed for the paired kept-mean reductions (without
            it ``red_kept_*`` compares each method's own kept mean, unpaired).

    Returns:
        Columns ``scenario, method, mean_rmse_pos, median_rmse_pos, hdi_hi_pos,
        kept_rmse_pos, mean_rmse_state, hdi_hi_state, mean_crlb_pos, rms_rmse_pos,
        rms_crlb_pos, lost_trial_rate, lost_step_rate``, ``mean_gospa``,
        ``mean_gospa_{localisation,missed,false}``, ``mean_ospa`` (means over trials and
        steps), ``label_switches_per_trial``, ``broken_tracks_per_trial`` (NaN in studies
        without them) and, for DDR-MPPI methods,
        ``red_{mean,median,hdi,kept}_vs_{stationary,ccr}`` in percent (NaN when the
        baseline is not in the study, for other methods, or without lost flags for
        ``kept``) and ``n_kept_vs_{stationary,ccr}`` (trials kept by both).
    """
    g = steps.groupby(["scenario", "method"], observed=True, sort=False)
    agg = g.agg(
        mean_rmse_pos=("rmse_pos", "mean"),
        median_rmse_pos=("median_pos", "mean"),
        hdi_hi_pos=("hdi_pos_hi", "mean"),
        kept_rmse_pos=("kept_pos", "mean"),
        mean_rmse_state=("rmse_state", "mean"),
        hdi_hi_state=("hdi_state_hi", "mean"),
        mean_crlb_pos=("crlb_pos", "mean"),
        rms_rmse_pos=("rms_pos", lambda x: float(np.sqrt(np.mean(np.square(x))))),
        rms_crlb_pos=("crlb_rms", lambda x: float(np.sqrt(np.mean(np.square(x))))),
        lost_trial_rate=("ever_lost_frac", "last"),
        lost_step_rate=("lost_frac", "mean"),
        **{f"mean_{c}": (c, "mean") for c in SET_VALUES},
        **{f"{c}_per_trial": (c, lambda x: float(x.sum(min_count=1))) for c in EVENTS},
    ).reset_index()
    for tag in ("stationary", "ccr"):
        for stat in STATS:
            agg[f"red_{stat}_vs_{tag}"] = np.nan
        agg[f"n_kept_vs_{tag}"] = 0
    index = {(str(r["scenario"]), str(r["method"])): i for i, r in agg.iterrows()}
    for i, r in agg.iterrows():
        name = r["scenario"]  # the scenario's name (a column of the table)
        for tag, base in baselines(r["method"]).items():
            j = index.get((str(name), base))
            if j is None:
                continue
            for stat in ("mean", "median", "hdi", "kept"):
                col = STAT_COLUMN[stat]
                agg.loc[i, f"red_{stat}_vs_{tag}"] = reduction(agg.loc[i, col], agg.loc[j, col])
            if frame is not None:
                ma, mb, n = paired_kept(frame, name, str(r["method"]), base)
                agg.loc[i, f"red_kept_vs_{tag}"] = reduction(ma, mb)
                agg.loc[i, f"n_kept_vs_{tag}"] = n
    return agg


def reduction(value: float, baseline: float) -> float:
    """Percent reduction ``100 (1 - value / baseline)`` (NaN for a zero or NaN baseline)."""
    if not baseline or np.isnan(baseline) or np.isnan(value):
        return float("nan")
    return float(100.0 * (1.0 - value / baseline))
