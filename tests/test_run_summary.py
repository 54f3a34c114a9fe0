"""`mjx-radar run`'s summary: a short line by default, the other figures with --verbose."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np

from mjx_radar.cli import run_output
from mjx_radar.cli.run_args import add_arguments
from mjx_radar.scenario.reader import load_scenario


def _res():
    # two trials x three steps, values chosen so that every mean is exact in float
    rmse = np.array([[1.0, 2.0, 3.0], [3.0, 4.0, 5.0]])  # mean 3.0, final step 4.0
    res = {
        "rmse_pos": rmse, "crlb_pos": np.full((2, 3), 1.5), "compile_s": 9.96, "sim_s": 2.04,
        "lost": np.array([[False, False, True], [False, False, False]]), "control_hz": 25.0,
        "gospa": np.full((2, 3), 7.25), "gospa_localisation": np.full((2, 3), 1.0),
        "gospa_missed": np.full((2, 3), 2.0), "gospa_false": np.zeros((2, 3)),
        "ospa": np.full((2, 3), 3.5), "label_switches": np.array([1, 0]),
        "broken_tracks": np.array([0, 2]),
    }  # fmt: skip
    return res


def test_default_summary_is_one_short_line(capsys):
    s = load_scenario("smoke")
    run_output.summary(s, SimpleNamespace(trials=2, verbose=False), _res(), Path("runs/x"))
    out = capsys.readouterr().out.splitlines()
    assert out == [
        "mean position RMSE 3.000 m (PCRLB 1.500 m); 1 of 2 trial(s) lost track; "
        "compile 10.0 s, simulation 2.0 s; results in runs/x"
    ]
    assert "GOSPA" not in out[0] and "control rate" not in out[0]


def test_verbose_adds_the_other_figures(capsys):
    s = load_scenario("smoke")
    run_output.summary(s, SimpleNamespace(trials=2, verbose=True), _res(), Path("runs/x"))
    short, detail = capsys.readouterr().out.splitlines()
    assert short.startswith("mean position RMSE 3.000 m")
    assert detail.startswith("final-step RMSE 4.000 m; control rate 25.0 Hz for the batch of 2")
    assert "mean GOSPA 7.250 m" in detail and "OSPA 3.500 m" in detail
    assert "1 label switch(es), 2 broken track(s)" in detail


def test_verbose_is_a_run_option():
    import argparse

    p = argparse.ArgumentParser()
    add_arguments(p)
    assert p.parse_args(["smoke", "--verbose"]).verbose
    assert p.parse_args(["smoke", "-v"]).verbose
    assert not p.parse_args(["smoke"]).verbose
