"""``mjx_radar.simulate``: the closed loop from a Python script, as a ``Run``.

The one run use case of ``mjx-radar run`` (:mod:`mjx_radar.api.run_case`): the same
options, defaults, checks and compiled program, so a fixed seed gives the same numbers
from either.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from mjx_radar.api.run import Run
from mjx_radar.errors import InputError


def simulate(
    scenario,
    method: str = "ddr-sfim",
    trials=1,
    steps: int | None = None,
    seed: int | None = None,
    progress: bool = True,
    cache: bool = True,
    view: bool = False,
    view_port: int | None = None,
    *,
    linger: float | None = None,
    planner: str | None = None,
    rollouts: str | None = None,
    association: str | None = None,
    precision: str = "float32",
    deterministic: bool | None = None,
    cache_dir: str | Path | None = None,
    plugins=(),
    gospa_cutoff: float | None = None,
    gospa_order: float | None = None,
    masks: bool = False,
) -> Run:
    """Runs the closed loop (``mjx-radar run``) and returns the :class:`Run`.

    Args:
        scenario: a :class:`~mjx_radar.Scenario`, a bundled scenario name or a TOML path.
        method: ``"stationary"``, ``"ccr-sfim"``, ``"ccr-pfim"``, ``"ddr-sfim"`` or
            ``"ddr-pfim"`` (case-insensitive), or ``"METHOD+PLANNER"``.
        trials: a count T (trials ``0..T-1``; default 1) or explicit trial indices (common
            random numbers: trial i is the same world for every method).
        steps: filter steps (default the scenario's ``timing.steps``); a multiple of
            ``dt_control / dt_filter``.
        seed: base seed (default the scenario's).
        progress: show a progress bar on stderr.
        cache: use the persistent compilation cache (as the command line does).
        view: a live 3-D view while it simulates (``run --view``, docs/viewer.md; URL on
            stderr), served after the run (replayed from the start) for ``linger`` seconds.
        view_port: its port on 127.0.0.1 (default 8765; 0: any free one; implies ``view``).
        linger: with the view, seconds it stays after the run (``run --view-linger``):
            ``None`` (default): until Ctrl-C (``KeyboardInterrupt``, caught: the run is
            still returned); 0: it stops when the run ends.
        planner: a registered planner moving the radars instead of the method's own
            (``run --planner``; :func:`mjx_radar.register_planner`).
        rollouts: ``"mjx"`` or ``"analytic"`` planner rollouts (``run --rollouts``;
            default the scenario's).
        association: ``"pda"``, ``"jpda"``, ``"gnn"``, ``"mht"`` or a registered one: the
            scenario's ``[tracker] association`` (``run --association``; docs/tracking.md).
        precision: ``"float32"`` or ``"float64"`` (x64 mode for this run; ``--precision``).
        deterministic: deterministic GPU kernels (:mod:`mjx_radar.engine.determinism`):
            ``None`` (default) on where JAX's GPU backend has not started, else as the
            process has; ``True`` / ``False`` as asked (``InputError`` where the running
            backend differs); ``run.meta["deterministic"]`` says what the run had.
        cache_dir: the persistent compilation cache's folder (``--cache-dir``).
        plugins: Python files run first, e.g. to register planners (``--plugin``).
        gospa_cutoff, gospa_order: GOSPA / OSPA cutoff c [m] and order p
            (``--gospa-cutoff``, ``--gospa-order``; default the scenario's ``[metrics]``).
        masks: also record every radar-drone pair's line of sight and detection per
            filter step (``--masks``): ``Run.trajectories``' ``visible`` and ``detected``
            ``[trial, step, radar, target]`` (a program of its own; off by default).

    Returns:
        The run (not saved; :meth:`Run.save` writes it).

    Raises:
        ScenarioError: an invalid scenario or option (one line, as a TOML file or the
            command line gives); nothing is compiled.
        InputError: unplaceable radars, not enough memory, a bad or busy ``view_port``.

    Example:
        >>> import mjx_radar
        >>> run = mjx_radar.simulate("smoke", trials=2, steps=40)  # doctest: +SKIP
        >>> run.metrics.groupby("step")["rmse_pos"].mean().tail(1)  # doctest: +SKIP
    """
    from mjx_radar.api import run_case

    given = locals()  # the run's options, by their names in RUN_DEFAULTS
    req = run_case.request(scenario, **{k: given[k] for k in run_case.RUN_DEFAULTS})
    check_linger(linger)
    return _simulate(req, progress, (view or view_port is not None, view_port, linger))


def check_linger(linger) -> None:
    """``linger``: None or seconds >= 0 (one-line :class:`InputError` otherwise)."""
    if linger is not None and (
        isinstance(linger, bool) or not isinstance(linger, int | float) or not 0 <= linger < 1e9
    ):
        raise InputError(f"linger = {linger!r}: must be None or seconds >= 0")


def bar_phase(bar):
    """The runner's ``phase`` callback for a tqdm bar: the phase as its description, and
    the bar's clock restarted when simulating starts (its rate and time left leave out
    the compilation)."""

    def phase(name: str) -> None:
        bar.set_description_str(name)
        if name == "simulating":
            bar.reset(total=bar.total)

    return phase


def _simulate(req, progress: bool, view=(False, None, 0)) -> Run:
    from tqdm import tqdm

    from mjx_radar.api import run_case
    from mjx_radar.rundir import results
    from mjx_radar.rundir.writer import TRAJECTORY_KEYS, run_meta
    from mjx_radar.viz.live_view import live as live_view
    from mjx_radar.viz.scene import scene_of

    s, ids, steps, method = req.scenario, req.trials, req.steps, req.method.name
    live = live_view.start(scene_of(s), ids, steps, view[1], "view_port") if view[0] else None
    try:
        with tqdm(
            total=steps, unit="step", desc="closed loop", file=sys.stderr, disable=not progress
        ) as bar:
            res = run_case.execute(req, bar.update, bar_phase(bar), live)
    except BaseException:
        if live is not None:
            live.close()
        raise
    if live is not None:
        live.linger(view[2])
    time_s = s.timing.dt_filter * np.arange(1, steps + 1)
    frame = results.metrics_frame(s.name, method, ids, time_s, res)
    arrays = {k: np.asarray(res[k]) for k in TRAJECTORY_KEYS if k in res}
    arrays["time_s"] = time_s
    meta = run_meta(
        run_case.run_header(s),
        method,
        req.seed,
        ids,
        steps,
        res,
        precision=req.precision,
        deterministic=bool(res.get("deterministic", False)),
    )
    return Run(s, method, req.seed, ids, steps, frame, arrays, meta, None, res)
