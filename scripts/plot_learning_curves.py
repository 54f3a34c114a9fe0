"""Learning curves of trained policies (``DIR/curve.csv`` of ``train_policy.py``).

    python scripts/plot_learning_curves.py "penalty 0.02=runs/pD" "then 1.0=runs/pF" \
        --out docs/img/learning_curves.png [--title T]

Each argument is ``LABEL=PATH`` (a policy directory or a ``curve.csv``). Two panels over
env steps (control periods, all parallel environments): the evaluation's mean position
RMSE per period, and the keep-out penalty per episode (unscaled, log scale).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def read_curve(path):
    """A ``curve.csv`` (given, or inside a policy directory) as a DataFrame."""
    import pandas as pd

    path = Path(path)
    return pd.read_csv(path / "curve.csv" if path.is_dir() else path)


def plot(curves: dict, out, title: str | None = None) -> Path:
    """Writes the two-panel figure of ``{label: DataFrame}`` to ``out``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 3.8), constrained_layout=True)
    for label, c in curves.items():
        steps = c["steps"] / 1e6
        a.plot(steps, c["rmse_pos"], label=label)
        b.plot(steps, c["penalty"].clip(lower=1.0), label=label)
    a.set(xlabel="env steps [M]", ylabel="eval mean RMSE per period [m]", ylim=(0, None))
    b.set(xlabel="env steps [M]", ylabel="keep-out penalty per episode", yscale="log")
    a.grid(alpha=0.3)
    b.grid(alpha=0.3)
    a.legend(fontsize=8)
    if title:
        fig.suptitle(title)
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("curves", nargs="+", metavar="LABEL=PATH")
    p.add_argument("--out", required=True, help="the PNG to write")
    p.add_argument("--title", default=None)
    args = p.parse_args(argv)
    curves = {}
    for item in args.curves:
        label, sep, path = item.rpartition("=")
        if not sep or not label:
            print(f"error: {item!r}: give LABEL=PATH", file=sys.stderr)
            return 2
        try:
            curves[label] = read_curve(path)
        except (OSError, ValueError) as err:
            print(f"error: {path}: {err}", file=sys.stderr)
            return 2
        missing = {"steps", "rmse_pos", "penalty"} - set(curves[label].columns)
        if missing:
            print(f"error: {path}: no column {sorted(missing)[0]!r}", file=sys.stderr)
            return 2
    print(plot(curves, args.out, args.title))
    return 0


if __name__ == "__main__":
    sys.exit(main())
