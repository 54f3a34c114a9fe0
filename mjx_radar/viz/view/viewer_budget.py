"""What one viewer file holds (docs/viewer.md): the frames, trials and MPPI samples that fit
the HTML size budget, and :class:`ViewInfo`, the record of what the file leaves out."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from mjx_radar.errors import InputError
from mjx_radar.viz.view.viewer_traces import frame_traces

MAX_FRAMES = 150


MAX_SAMPLES = 32


MAX_TRIALS = 8  # trials in one file by default (each adds its frames)


SIZE_BUDGET = 14e6  # bytes: defaults fit this (plotly.js itself is about 4.8 MB)


PLOTLY_JS = 4.9e6


@dataclasses.dataclass(frozen=True)
class ViewInfo:
    """What :func:`view` wrote and what it left out."""

    path: Path | None
    trials: tuple[int, ...]  # trial positions shown
    trials_run: int  # trials in the run directory
    steps: int  # filter steps K of the run
    frames: int  # frames per trial
    stride: int  # every stride-th filter step
    samples: int  # MPPI samples drawn per frame
    samples_kept: int  # MPPI samples in the run directory per control step
    bytes: int = 0
    terrain: str = ""  # the terrain nodes drawn, if any

    def dropped(self) -> str:
        """One line: what the file leaves out of the run directory."""
        parts = [f"{self.frames} of {self.steps} steps (every {self.stride})"]
        if len(self.trials) < self.trials_run:
            parts.append(f"{len(self.trials)} of {self.trials_run} trials (--trial)")
        parts.append(f"{self.samples} of {self.samples_kept} kept MPPI samples per frame")
        if self.terrain:
            parts.append(self.terrain)
        return "; ".join(parts)


def frame_steps(steps: int, max_frames: int) -> np.ndarray:
    """0-based filter steps of the frames: every k-th, ending at the last; ``<= max_frames``."""
    stride = math.ceil(steps / max_frames)
    return np.arange(steps - 1, -1, -stride)[::-1]


def trial_list(trial, n: int) -> tuple[int, ...] | None:
    if trial is None:
        return None
    ids = [trial] if isinstance(trial, int | np.integer) else list(trial)
    bad = [
        t
        for t in ids
        if isinstance(t, bool) or not isinstance(t, int | np.integer) or not 0 <= t < n
    ]
    if not ids or bad:
        raise InputError(f"--trial = {bad[0] if bad else trial!r}: must be in [0, {n - 1}]")
    return tuple(dict.fromkeys(int(t) for t in ids))


def fit_budget(tr, ks, plan, trials: int, samples: int | None, n_trials: int | None):
    """``(trials, samples)`` whose estimated HTML size fits :data:`SIZE_BUDGET`.

    Only what the caller left as ``None`` is lowered: samples first (32, 16, 8), then
    the number of trials (at least one).
    """
    visible = np.ones((tr.radar.shape[1], tr.target.shape[1]), bool)  # the size: the same
    frame = frame_traces(tr, ks[-1], 1, plan, visible)
    fixed = sum(a.nbytes for d in frame for a in (d["x"], d["y"], d["z"])) - frame[6]["x"].nbytes
    per_sample = frame[6]["x"].nbytes * 13 / 4  # x, y, z float32 and the weight per point

    def size(t, s):
        return PLOTLY_JS + 1.15 * t * len(ks) * ((fixed + s * per_sample) * 4 / 3 + 2000)

    s = min(MAX_SAMPLES, tr.sample_xy.shape[1]) if samples is None else samples
    t = min(trials, MAX_TRIALS) if n_trials is None else n_trials
    while samples is None and s > 8 and size(t, s) > SIZE_BUDGET:
        s //= 2
    while n_trials is None and t > 1 and size(t, s) > SIZE_BUDGET:
        t -= 1
    return t, s
