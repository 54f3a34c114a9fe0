"""Summary statistics of a Monte Carlo study (SPEC §9).

All functions take the long-format metrics table of ``mjx-radar study`` /
``mjx-radar run`` (columns ``scenario, method, trial, step, time_s, rmse_pos,
rmse_state, crlb_pos``) and return plain pandas / numpy objects.

Definitions:

* **mean RMSE per step**: mean over the T trials of the per-step RMSE.
* **90% HDI per step**: the narrowest interval holding 90% of the T per-step
  RMSE values (``arviz.hdi``: of the sorted values ``x``, the window
  ``[x_i, x_{i + floor(0.9 T)}]`` of least width).
* **HDI upper end** (one number per scenario and method): the mean over the K
  steps of the per-step HDI upper bound.
* **ECDF**: over all T x K (trial, step) values of one scenario and method.
* **Reduction** of a DDR-MPPI method vs a baseline:
  ``100 (1 - value_DDR / value_baseline)`` percent (positive = DDR is better).
"""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd

HDI_PROB = 0.9
#: DDR-MPPI method -> the CCR-MPPI method with the same information kind.
CCR_OF = {"ddr-sfim": "ccr-sfim", "ddr-pfim": "ccr-pfim"}


def hdi(samples: np.ndarray, prob: float = HDI_PROB) -> np.ndarray:
    """Highest density interval over the first axis.

    Args:
        samples: [T] or [T, K] values (trials first).
        prob: probability mass of the interval.

    Returns:
        [2] ``(low, high)`` for 1-D input, else [K, 2].
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # arviz 0.2x announces its refactor on import
        import arviz as az

    x = np.asarray(samples, np.float64)
    if x.ndim == 1:
        return np.asarray(az.hdi(x, hdi_prob=prob))
    # arviz reads an n-d array as (chain, draw, *shape): one chain, T draws, K variables.
    return np.asarray(az.hdi(x.reshape(1, x.shape[0], -1), hdi_prob=prob)).reshape(-1, 2)


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


def per_step(frame: pd.DataFrame, prob: float = HDI_PROB) -> pd.DataFrame:
    """Per-step statistics over trials for every scenario and method.

    Args:
        frame: long-format metrics table.
        prob: HDI probability.

    Returns:
        One row per (scenario, method, step): ``time_s``, ``rmse_pos``, ``rmse_state``,
        ``crlb_pos`` (means over trials), ``hdi_pos_lo/hi``, ``hdi_state_lo/hi``.
    """
    rows = []
    for (scen, meth), g in frame.groupby(["scenario", "method"], observed=True, sort=False):
        wide = {c: g.pivot(index="trial", columns="step", values=c) for c in _VALUES}
        steps = wide["rmse_pos"].columns.to_numpy()
        out = pd.DataFrame({"scenario": scen, "method": meth, "step": steps})
        out["time_s"] = g.groupby("step")["time_s"].first().loc[steps].to_numpy()
        for c in _VALUES:
            out[c] = wide[c].mean(axis=0).to_numpy()
        for c, tag in (("rmse_pos", "pos"), ("rmse_state", "state")):
            band = hdi(wide[c].to_numpy(), prob)
            out[f"hdi_{tag}_lo"], out[f"hdi_{tag}_hi"] = band[:, 0], band[:, 1]
        rows.append(out)
    return pd.concat(rows, ignore_index=True)


_VALUES = ("rmse_pos", "rmse_state", "crlb_pos")


def summary(steps: pd.DataFrame) -> pd.DataFrame:
    """One row per (scenario, method) with means over steps and the DDR reductions.

    Args:
        steps: output of :func:`per_step`.

    Returns:
        Columns ``scenario, method, mean_rmse_pos, hdi_hi_pos, mean_rmse_state,
        hdi_hi_state, mean_crlb_pos`` and, for DDR methods, ``red_mean_vs_stationary,
        red_hdi_vs_stationary, red_mean_vs_ccr, red_hdi_vs_ccr`` in percent (NaN when
        the baseline is not in the study or for non-DDR methods).
    """
    agg = steps.groupby(["scenario", "method"], observed=True, sort=False).agg(
        mean_rmse_pos=("rmse_pos", "mean"),
        hdi_hi_pos=("hdi_pos_hi", "mean"),
        mean_rmse_state=("rmse_state", "mean"),
        hdi_hi_state=("hdi_state_hi", "mean"),
        mean_crlb_pos=("crlb_pos", "mean"),
    )
    agg = agg.reset_index()
    for tag in ("stationary", "ccr"):
        agg[f"red_mean_vs_{tag}"] = agg[f"red_hdi_vs_{tag}"] = np.nan
    index = {(r.scenario, r.method): i for i, r in agg.iterrows()}
    for i, r in agg.iterrows():
        if r.method not in CCR_OF:
            continue
        for base, tag in (("stationary", "stationary"), (CCR_OF[r.method], "ccr")):
            j = index.get((r.scenario, base))
            if j is None:
                continue
            agg.loc[i, f"red_mean_vs_{tag}"] = reduction(r.mean_rmse_pos, agg.mean_rmse_pos[j])
            agg.loc[i, f"red_hdi_vs_{tag}"] = reduction(r.hdi_hi_pos, agg.hdi_hi_pos[j])
    return agg


def reduction(value: float, baseline: float) -> float:
    """Percent reduction ``100 (1 - value / baseline)``."""
    return float(100.0 * (1.0 - value / baseline)) if baseline else float("nan")
