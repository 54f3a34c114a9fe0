"""The legend of the viewer and the live view: one entry (and group) per layer.

A click on an entry toggles exactly that layer (``groupclick = "togglegroup"`` with one
group per trace name). The MPPI samples' entry is a one-colour stand-in sharing their
group (plotly.js cannot draw the legend icon of a ``scatter3d`` line coloured by an array:
"Invalid color specifier" on the console); no "blocked lines of sight" entry where
nothing can block one.
"""

from __future__ import annotations


def sample_legend(lo) -> dict:
    """The "MPPI samples" legend entry: a one-point trace of one colour in their group.

    plotly.js draws the legend icon of a ``scatter3d`` line coloured by an array with a
    colour it cannot parse ("Invalid color specifier" on the console), so the samples layer
    has no entry of its own; :func:`legend_per_layer` makes a click here toggle both. Its
    data: one point at the ground's corner ``lo`` (plotly lists no trace without data).
    """
    return dict(
        type="scatter3d",
        mode="lines",
        name="MPPI samples",
        hoverinfo="skip",
        line={"color": "rgb(204,71,120)", "width": 2},  # Plasma's middle
        x=[float(lo[0])],
        y=[float(lo[1])],
        z=[0.0],
    )


def legend_per_layer(fig) -> dict:
    """One legend group per name (the samples and their entry share one), so a click on an
    entry toggles exactly that layer; returns the ``legend`` layout to use."""
    fig.for_each_trace(lambda d: d.update(legendgroup=d.name))
    return {"groupclick": "togglegroup", "tracegroupgap": 0}


def hide_blocked_entry(fig, occluders: bool) -> None:
    """No "blocked lines of sight" legend entry where nothing can block one (``occluders``:
    :func:`mjx_radar.viz.view.viewer_los.has_occluders` of the scene)."""
    if not occluders:
        fig.update_traces(showlegend=False, selector={"name": "blocked lines of sight"})
