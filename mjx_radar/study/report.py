"""``mjx-radar report DIR``: figures and tables of a finished study directory.

Writes, per scenario ``S`` (statistics as defined in :mod:`mjx_radar.study.metrics`)::

    DIR/figures/S_rmse.png        mean position RMSE vs time with the 90% HDI band,
                                  all methods; PCRLB of the DDR methods dashed
    DIR/figures/S_rmse_mppi.png   the same without the stationary baseline
    DIR/figures/S_ecdf.png        ECDF of position RMSE over trials x steps
    DIR/summary.csv               one row per scenario and method (study_metrics.summary)
    DIR/report.md                 tables and the figures (relative links)
"""

from __future__ import annotations

import argparse
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


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("dir", type=Path, metavar="DIR", help="study directory (mjx-radar study)")


def main(args) -> int:
    from mjx_radar.io.results import atomic_write

    d = args.dir
    if not (d / "study.json").is_file() or not (d / "metrics.parquet").is_file():
        hint = "; finish it with study --resume" if (d / "manifest.json").is_file() else ""
        raise InputError(f"DIR = {str(d)!r}: not a complete study directory (no study.json){hint}")
    meta = json.loads((d / "study.json").read_text())
    frame = pd.read_parquet(d / "metrics.parquet")
    steps = study_metrics.per_step(frame)
    table = study_metrics.summary(steps)
    atomic_write(d / "summary.csv", lambda tmp: table.to_csv(tmp, index=False))
    lines = [f"# Monte Carlo study: {', '.join(meta['scenarios'])}", ""]
    lines += [
        f"{meta['trials']} trials per method, seed {_one(meta['seed'])}, "
        f"steps {_one(meta['steps'])}, "
        f"devices `{meta['devices']}`, wall {meta['wall_s']:.1f} s. Command: "
        f"`{meta['command']}`.",
        "",
        "Mean RMSE: mean over trials and steps of the per-step position RMSE [m]. "
        "HDI upper end: mean over steps of the upper bound of the per-step 90% highest "
        "density interval over trials [m]. Reduction of a DDR-MPPI method vs a baseline: "
        "100·(1 − DDR/baseline) % (positive: DDR better); the CCR baseline has the same "
        f"information kind (ddr-sfim vs ccr-sfim, ddr-pfim vs ccr-pfim); {HEADLINE}.",
        "",
    ]
    for scen in steps["scenario"].astype(str).unique():
        lines += [f"## {scen}", ""]
        lines += _table(table[table["scenario"].astype(str) == scen])
        for name, title in _figures(d, scen, steps, frame):
            lines += ["", f"![{title}](figures/{name})"]
        lines.append("")
    atomic_write(d / "report.md", lambda tmp: Path(tmp).write_text("\n".join(lines)))
    print(f"report: {d / 'report.md'}")
    return 0


def _one(per_scenario: dict):
    """The common value of a per-scenario dict, else the dict."""
    values = set(per_scenario.values())
    return values.pop() if len(values) == 1 else per_scenario


def _pct(v: float) -> str:
    return "–" if np.isnan(v) else f"{v:+.1f}%"


def _table(t: pd.DataFrame) -> list[str]:
    head = (
        "| method | mean RMSE pos [m] | HDI upper pos [m] | mean RMSE state | mean PCRLB pos [m] "
        "| mean red. vs stationary | HDI red. vs stationary | mean red. vs CCR | HDI red. vs CCR |"
    )
    rows = [head, "|" + "---|" * 9]
    for r in t.itertuples():
        rows.append(
            f"| {r.method} | {r.mean_rmse_pos:.3f} | {r.hdi_hi_pos:.3f} | {r.mean_rmse_state:.3f} "
            f"| {r.mean_crlb_pos:.3f} | {_pct(r.red_mean_vs_stationary)} "
            f"| {_pct(r.red_hdi_vs_stationary)} | {_pct(r.red_mean_vs_ccr)} "
            f"| {_pct(r.red_hdi_vs_ccr)} |"
        )
    return rows + ["", f"Headline of the {HEADLINE}; the numbers above are this study's own."]


def _figures(d: Path, scen: str, steps: pd.DataFrame, frame: pd.DataFrame) -> list:
    """Writes the three figures of one scenario; returns ``[(file name, title)]``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from mjx_radar.io.results import atomic_write

    out = []
    sub = steps[steps["scenario"].astype(str) == scen]
    for suffix, keep in (("rmse", None), ("rmse_mppi", "stationary")):
        fig, ax = plt.subplots(figsize=(8, 4.5))
        for meth, g in sub.groupby("method", observed=True, sort=False):
            if meth == keep:
                continue
            c = COLORS.get(str(meth))
            ax.plot(g["time_s"], g["rmse_pos"], color=c, label=f"{meth} mean")
            ax.fill_between(g["time_s"], g["hdi_pos_lo"], g["hdi_pos_hi"], color=c, alpha=0.2)
            if str(meth).startswith("ddr"):
                ax.plot(g["time_s"], g["crlb_pos"], "--", color=c, label=f"{meth} PCRLB")
        which = "all methods" if keep is None else "MPPI methods"
        ax.set(xlabel="time [s]", ylabel="position RMSE [m]", yscale="log")
        ax.set_title(f"{scen}: mean position RMSE, 90% HDI band ({which})")
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
