"""Figures and tables of a finished study directory (``mjx-radar report DIR``).

The command line part lives in :mod:`mjx_radar.cli.report`; this module is the
library behind it (:func:`write_report`). Writes, per scenario ``S`` (statistics
as defined in :mod:`mjx_radar.study.metrics` and docs/statistics.md)::

    DIR/figures/S_rmse.png        median (solid) and mean (dotted) position RMSE vs
                                  time with the 90% HDI band, all methods; the RMS
                                  PCRLB of the DDR-MPPI methods dashed
    DIR/figures/S_rmse_mppi.png   the same without the stationary baseline
    DIR/figures/S_ecdf.png        ECDF of position RMSE over trials x steps
    DIR/summary.csv               one row per scenario and method (study_metrics.summary)
    DIR/report.md                 tables and the figures (relative links), with the
                                  statistic each reduction is computed on
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

from mjx_radar.errors import InputError
from mjx_radar.study import metrics as study_metrics

COLORS = {
    "stationary": "tab:gray",
    "ccr-sfim": "tab:blue",
    "ccr-pfim": "tab:cyan",
    "ddr-sfim": "tab:red",
    "ddr-pfim": "tab:orange",
}
HEADLINE = "paper: 38–74% (mean RMSE), 33–79% (HDI upper end)"


def write_report(d: Path) -> Path:
    """Writes ``summary.csv``, ``report.md`` and the figures of study directory ``d``.

    Raises:
        InputError: ``d`` is not a complete study directory.

    Returns:
        The path of ``report.md``.
    """
    from mjx_radar.rundir.results import atomic_write

    d = Path(d)
    if not (d / "study.json").is_file() or not (d / "metrics.parquet").is_file():
        hint = "; finish it with study --resume" if (d / "manifest.json").is_file() else ""
        raise InputError(f"DIR = {str(d)!r}: not a complete study directory (no study.json){hint}")
    meta = json.loads((d / "study.json").read_text())
    frame = pd.read_parquet(d / "metrics.parquet")
    steps = study_metrics.per_step(frame)
    table = study_metrics.summary(steps, frame)
    atomic_write(d / "summary.csv", lambda tmp: table.to_csv(tmp, index=False))
    lines = [f"# Monte Carlo study: {', '.join(meta['scenarios'])}", ""]
    lines += [
        f"{meta['trials']} trials per method, seed {_one(meta['seed'])}, "
        f"steps {_one(meta['steps'])}, "
        f"devices `{meta['devices']}`, wall {meta['wall_s']:.1f} s. Command: "
        f"`{meta['command']}`.",
        "",
        *_legend("lost" in frame.columns),
        "",
    ]
    for scen in steps["scenario"].astype(str).unique():
        lines += [f"## {scen}", ""]
        lines += _table(table[table["scenario"].astype(str) == scen])
        lines += _set_table(table[table["scenario"].astype(str) == scen], meta, scen)
        for name, title in _figures(d, scen, steps, frame):
            lines += ["", f"![{title}](figures/{name})"]
        lines.append("")
    atomic_write(d / "report.md", lambda tmp: Path(tmp).write_text("\n".join(lines)))
    return d / "report.md"


def _legend(has_lost: bool) -> list[str]:
    """The statistics and which reduction uses which (docs/statistics.md)."""
    out = [
        "Statistics of the per-step position RMSE over trials, each averaged over steps [m]: "
        "**mean**; **median**; **HDI upper**: upper end of the 90% highest density interval; "
        "**kept mean**: mean over the trials never flagged lost; **lost trials**: fraction "
        "of trials lost at any step; **lost steps**: fraction of (trial, step) pairs lost "
        "(lost = non-finite or non-PD filter, estimate nearer a target's z-mirror than its "
        "truth for ≥ 1 s, or error > max(5·sqrt(tr P_pos), 50 m)). **RMS RMSE** and "
        "**RMS PCRLB**: sqrt of the mean over trials and steps of rmse_pos² and of the "
        "bound's position trace (the clean comparison with the bound).",
        "",
        "Reductions of a DDR-MPPI method vs a baseline, 100·(1 − DDR/baseline) % "
        "(positive: DDR better); the CCR baseline has the same information kind "
        "(ddr-sfim vs ccr-sfim, ddr-pfim vs ccr-pfim). **red. median** uses the median; "
        "**red. kept** the mean over the trials kept by *both* methods (paired by trial); "
        "**red. HDI** the HDI upper end. The reduction of the plain mean is not shown: a "
        "few lost trials dominate it (it stays in summary.csv as red_mean_*). "
        f"Compare with the {HEADLINE}.",
    ]
    if not has_lost:
        out += [
            "",
            "This study predates the lost-track flags (no `lost` column): lost rates, kept "
            "means and kept reductions are not recorded (–).",
        ]
    return out


def _one(per_scenario: dict):
    """The common value of a per-scenario dict, else the dict."""
    values = set(per_scenario.values())
    return values.pop() if len(values) == 1 else per_scenario


def _pct(v: float) -> str:
    return "–" if np.isnan(v) else f"{v:+.1f}%"


def _num(v: float) -> str:
    return "–" if np.isnan(v) else f"{v:.3f}"


def _rate(v: float) -> str:
    return "–" if np.isnan(v) else f"{100 * v:.1f}%"


def _table(t: pd.DataFrame) -> list[str]:
    head = (
        "| method | mean [m] | median [m] | HDI upper [m] | kept mean [m] | lost trials "
        "| lost steps | RMS RMSE [m] | RMS PCRLB [m] | red. median vs stationary "
        "| red. kept vs stationary | red. HDI vs stationary | red. median vs CCR "
        "| red. kept vs CCR | red. HDI vs CCR |"
    )
    rows = [head, "|" + "---|" * 15]
    for r in t.itertuples():
        vals = [r.mean_rmse_pos, r.median_rmse_pos, r.hdi_hi_pos, r.kept_rmse_pos]
        rows.append(
            f"| {r.method} | "
            + " | ".join(_num(v) for v in vals)
            + f" | {_rate(r.lost_trial_rate)} | {_rate(r.lost_step_rate)} "
            f"| {_num(r.rms_rmse_pos)} | {_num(r.rms_crlb_pos)} | "
            + " | ".join(
                _pct(getattr(r, f"red_{stat}_vs_{tag}"))
                for tag in ("stationary", "ccr")
                for stat in ("median", "kept", "hdi")
            )
            + " |"
        )
    return rows + ["", f"Headline of the {HEADLINE}; the numbers above are this study's own."]


def _set_table(t: pd.DataFrame, meta: dict, scen: str) -> list[str]:
    """GOSPA / OSPA and track continuity (absent: a study without these columns)."""
    if t["mean_gospa"].isna().all():
        return []
    cfg = meta.get("gospa", {}).get(scen)
    with_c = f" (c = {cfg['cutoff']:g} m, p = {cfg['order']:g})" if cfg else ""
    rows = [
        "",
        f"Multi-target metrics{with_c}, means over trials and steps; GOSPA's parts in "
        "m^p; switches and breaks per trial (docs/tracking_metrics.md):",
        "",
        "| method | GOSPA [m] | localisation | missed | false | OSPA [m] "
        "| label switches / trial | broken tracks / trial |",
        "|" + "---|" * 8,
    ]
    for r in t.itertuples():
        vals = [r.mean_gospa, r.mean_gospa_localisation, r.mean_gospa_missed]
        vals += [r.mean_gospa_false, r.mean_ospa]
        vals += [r.label_switches_per_trial, r.broken_tracks_per_trial]
        rows.append(f"| {r.method} | " + " | ".join(_num(v) for v in vals) + " |")
    return rows


def _figures(d: Path, scen: str, steps: pd.DataFrame, frame: pd.DataFrame) -> list:
    """Writes the three figures of one scenario; returns ``[(file name, title)]``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from mjx_radar.rundir.results import atomic_write

    out = []
    sub = steps[steps["scenario"].astype(str) == scen]
    for suffix, keep in (("rmse", None), ("rmse_mppi", "stationary")):
        fig, ax = plt.subplots(figsize=(8, 4.5))
        for meth, g in sub.groupby("method", observed=True, sort=False):
            if meth == keep:
                continue
            c = COLORS.get(str(meth))
            ax.plot(g["time_s"], g["median_pos"], color=c, label=f"{meth} median")
            ax.plot(g["time_s"], g["rmse_pos"], ":", color=c, lw=0.8, label=f"{meth} mean")
            ax.fill_between(g["time_s"], g["hdi_pos_lo"], g["hdi_pos_hi"], color=c, alpha=0.2)
            if study_metrics.baselines(str(meth)):  # DDR-MPPI methods
                ax.plot(g["time_s"], g["crlb_rms"], "--", color=c, label=f"{meth} RMS PCRLB")
        which = "all methods" if keep is None else "MPPI methods"
        ax.set(xlabel="time [s]", ylabel="position RMSE [m]", yscale="log")
        ax.set_title(f"{scen}: median and mean position RMSE, 90% HDI band ({which})")
        ax.grid(True, alpha=0.3)
        if ax.lines:
            ax.legend(fontsize=8, ncol=2)
        else:
            ax.text(0.5, 0.5, "no MPPI method in this study", ha="center", transform=ax.transAxes)
        out.append((_save(fig, d / "figures" / f"{scen}_{suffix}.png", atomic_write), which))
        plt.close(fig)
    fig, ax = plt.subplots(figsize=(6, 4.5))
    rows = frame[frame["scenario"].astype(str) == scen]
    for meth, g in rows.groupby("method", observed=True, sort=False):
        x, f = study_metrics.ecdf(g["rmse_pos"].to_numpy())
        ax.step(x, f, where="post", color=COLORS.get(str(meth)), label=str(meth))
    ax.set(xlabel="position RMSE [m]", ylabel="ECDF over trials × steps", ylim=(0, 1.02))
    ax.set_title(f"{scen}: ECDF of position RMSE")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    out.append((_save(fig, d / "figures" / f"{scen}_ecdf.png", atomic_write), "ECDF"))
    plt.close(fig)
    return out


def _save(fig, path: Path, atomic_write) -> str:
    fig.tight_layout()
    atomic_write(path, lambda tmp: fig.savefig(tmp, dpi=120, format="png"))
    return path.name


# Compatibility until cli/main.py's COMMANDS["report"] names mjx_radar.cli.report: the
# parser builder needs add_arguments/main here. Delete both then.
