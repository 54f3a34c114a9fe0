"""The viewer's controls (:mod:`mjx_radar.viz.view.viewer`): per-trial time sliders, play /
pause, and the trial dropdown with the few lines of JavaScript that swap the sliders."""

from __future__ import annotations

import numpy as np

# The trial dropdown: show that trial's slider, point play at its frames, go to its
# first frame. plotly.js runs the button's own restyle (metrics curves) first.
TRIAL_JS = """
var gd = document.getElementById('{plot_id}');
gd.on('plotly_buttonclicked', function (e) {
  if (!e.menu || e.menu.name !== 'trial') return;
  var i = e.active, n = gd.layout.sliders.length, upd = {};
  for (var j = 0; j < n; j++) upd['sliders[' + j + '].visible'] = (j === i);
  var play = gd.layout.updatemenus[0].buttons[0].args;
  upd['updatemenus[0].buttons[0].args'] = ['trial' + i, play[1]];
  Plotly.relayout(gd, upd).then(function () {
    Plotly.animate(gd, ['t' + i + ':0'], {mode: 'immediate', frame: {duration: 0, redraw: true},
                   transition: {duration: 0}});
  });
});
"""


def slider(t: int, times: np.ndarray, visible: bool) -> dict:
    """The time slider of trial position ``t``: one step per frame ``t{t}:{i}`` at ``times``."""
    steps = [
        dict(
            method="animate",
            label=f"{s:.2f}",
            args=[
                [f"t{t}:{i}"],
                {
                    "mode": "immediate",
                    "frame": {"duration": 0, "redraw": True},
                    "transition": {"duration": 0},
                },
            ],
        )
        for i, s in enumerate(times)
    ]
    return dict(
        active=0,
        steps=steps,
        visible=visible,
        x=0.05,
        len=0.9,
        y=0.02,
        currentvalue={"prefix": "t = ", "suffix": " s"},
        pad={"t": 30},
    )


def menus(trials, ids, metric_idx: list[list[int]]) -> list[dict]:
    """Play / pause and the trial dropdown (its restyle shows trial j's ``metric_idx[j]``)."""
    play = dict(
        label="play",
        method="animate",
        args=[
            "trial0",
            {
                "frame": {"duration": 80, "redraw": True},
                "fromcurrent": True,
                "transition": {"duration": 0},
                "mode": "immediate",
            },
        ],
    )
    pause = dict(
        label="pause",
        method="animate",
        args=[
            [None],
            {
                "frame": {"duration": 0, "redraw": False},
                "mode": "immediate",
                "transition": {"duration": 0},
            },
        ],
    )
    menus = [
        dict(
            type="buttons",
            direction="left",
            x=0.05,
            y=0.0,
            xanchor="right",
            yanchor="top",
            pad={"t": 40},
            buttons=[play, pause],
        )
    ]
    everything = sorted(i for idx in metric_idx for i in idx)
    buttons = [
        dict(
            label=f"trial {ids[t]}",
            method="restyle",
            args=[{"visible": [i in metric_idx[j] for i in everything]}, everything],
        )
        for j, t in enumerate(trials)
    ]
    menus.append(
        dict(
            name="trial",
            type="dropdown",
            active=0,
            x=0.0,
            y=1.0,
            xanchor="left",
            buttons=buttons,
            showactive=True,
        )
    )
    return menus
