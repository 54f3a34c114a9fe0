"""``mjx_radar.run_study`` and :class:`Study`: a Monte Carlo study from a Python script.

The same study as ``mjx-radar study`` (:mod:`mjx_radar.study.execute`): the same
chunks, files and numbers, resumable (``resume=True``), one writer per directory.
Scenarios may be :class:`~mjx_radar.Scenario` objects made in Python: each is
validated and written to the study directory as TOML (``scenarios/NAME.toml``), like
a scenario file given on the command line.
"""

from __future__ import annotations

import dataclasses
import json
import tempfile
from pathlib import Path

import pandas as pd

from mjx_radar.errors import InputError
from mjx_radar.io.checks import ScenarioError


@dataclasses.dataclass
class Study:
    """A finished study directory.

    Attributes:
        path: the study directory.
        meta: the contents of ``study.json``.
        metrics: long-format table of every scenario x method x trial x step (the
            columns of ``metrics.parquet``).
    """

    path: Path
    meta: dict
    metrics: pd.DataFrame

    @classmethod
    def load(cls, path: str | Path) -> Study:
        """Reads a finished study directory (``InputError`` if it is not one)."""
        path = Path(path)
        if not (path / "study.json").is_file() or not (path / "metrics.parquet").is_file():
            raise InputError(f"study = {str(path)!r}: not a complete study directory")
        meta = json.loads((path / "study.json").read_text())
        return cls(path, meta, pd.read_parquet(path / "metrics.parquet"))

    def summary(self) -> pd.DataFrame:
        """The report's table: one row per scenario and method (``summary.csv``).

        Columns as :func:`mjx_radar.study.metrics.summary`: mean / median / HDI-upper /
        kept-mean position RMSE, PCRLB, lost-trial and lost-step rates and the DDR
        reductions vs stationary and vs CCR in percent.
        """
        from mjx_radar.study import metrics

        return metrics.summary(metrics.per_step(self.metrics), self.metrics)

    def report(self) -> Path:
        """Writes ``summary.csv``, ``report.md`` and the figures (``mjx-radar report``)."""
        from mjx_radar.study.report import write_report

        return write_report(self.path)


def run_study(
    scenarios,
    methods=None,
    trials: int = 500,
    chunk: int = 50,
    out=None,
    steps: int | None = None,
    seed: int | None = None,
    resume: bool = False,
    rollouts: str | None = None,
    progress: bool = True,
    *,
    planners=None,
    plugins=(),
    deterministic: bool | None = None,
) -> Study:
    """Runs (or resumes) a Monte Carlo study and returns it (``mjx-radar study``).

    Args:
        scenarios: scenarios: :class:`~mjx_radar.Scenario` objects, bundled names or TOML
            paths (a single one may be given alone).
        methods: method names (default all of ``mjx_radar.METHODS``); case-insensitive,
            repeats collapsed.
        trials: trials per scenario and method.
        chunk: trials per device per call, and per result file.
        out: the study directory (required).
        steps: filter steps (default each scenario's).
        seed: base seed (default each scenario's).
        resume: continue the study in ``out`` (its settings must match); a finished
            study is returned as it is.
        rollouts: ``"mjx"`` or ``"analytic"`` planner rollouts (default the scenario's).
        progress: show a progress bar on stderr.
        planners: run every planning method with each of these planners
            (``study --planners``): methods ``"METHOD+PLANNER"`` (``mppi`` keeps the name).
        plugins: Python files run first, e.g. to register planners (``--plugin``).
        deterministic: deterministic GPU kernels (``None``, the default: on where JAX has
            not started its GPU backend yet; ``--deterministic`` / ``--no-deterministic``;
            see :func:`mjx_radar.simulate`).

    Raises:
        ScenarioError: an invalid scenario or argument (nothing compiled, nothing written).
        InputError: an unusable ``out`` (not empty without ``resume``, another process
            writing there, settings differing from the study's), or a study too large.

    Example:
        >>> study = mjx_radar.run_study("smoke", methods=["stationary", "ddr-sfim"],
        ...                             trials=4, chunk=2, out="studies/s")  # doctest: +SKIP
        >>> study.summary()[["scenario", "method", "median_rmse_pos"]]  # doctest: +SKIP
    """
    from mjx_radar.api.run_case import load_plugins
    from mjx_radar.study import execute

    if out is None:
        raise ScenarioError("out: the study directory is required")
    items = _items(scenarios)
    _check_numbers(trials, chunk, steps, seed, deterministic)
    load_plugins(plugins)
    methods = _methods(methods, planners)
    if rollouts not in (None, "mjx", "analytic"):
        raise ScenarioError(f"rollouts = {rollouts!r}: must be one of mjx, analytic")
    with tempfile.TemporaryDirectory(prefix="mjx_radar_study_") as tmp:
        opts = execute.StudyOptions(
            scenarios=_scenario_files(items, Path(tmp)),
            methods=methods,
            trials=trials,
            steps=steps,
            seed=seed,
            chunk=chunk,
            rollouts=rollouts,
            out=Path(out),
            resume=resume,
            precision=_precision(),
            progress=progress,
            deterministic=deterministic,
        )
        execute.run_study(opts)
    return Study.load(out)


def _items(scenarios) -> list:
    """The scenarios as a list (a single one may be given alone); at least one."""
    items = (
        [scenarios]
        if isinstance(scenarios, str | Path) or hasattr(scenarios, "name")
        else list(scenarios)
    )
    if not items:
        raise ScenarioError("scenarios: must name at least one scenario")
    return items


def _check_numbers(trials, chunk, steps, seed, deterministic) -> None:
    """``trials``, ``chunk``, ``steps``, ``seed`` and ``deterministic`` in range (one line)."""
    for name, value, hi in (("trials", trials, 10**6), ("chunk", chunk, 10**6)):
        if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= hi:
            raise ScenarioError(f"{name} = {value!r}: must be an integer in [1, {hi}]")
    for name, value, lo, hi in (("steps", steps, 1, 10**7), ("seed", seed, 0, 2**31 - 1)):
        if value is not None and (
            isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi
        ):
            raise ScenarioError(f"{name} = {value!r}: must be an integer in [{lo}, {hi}] or None")
    if deterministic is not None and not isinstance(deterministic, bool):
        raise ScenarioError(f"deterministic = {deterministic!r}: must be True, False or None")


def _methods(methods, planners) -> list:
    """The study's method names: ``methods`` (default all) normalised, each planning one
    with each of ``planners`` (``METHOD+PLANNER``); ``ScenarioError`` for a bad name."""
    from mjx_radar.planners import PLANNERS
    from mjx_radar.task.method import METHODS, normalise_methods, with_planners

    try:
        methods = normalise_methods(
            list(METHODS) if methods is None else _listed(methods, "methods")
        )
        if planners is not None:
            planners = _listed(planners, "planners")
            if not planners:
                raise ValueError("planners: empty list; give one or more planner names")
            for name in planners:
                PLANNERS.get(name)
            methods = with_planners(methods, planners)
    except ValueError as err:
        raise ScenarioError(str(err)) from None
    return methods


def _scenario_files(items, tmp: Path) -> list[str]:
    """The scenarios as TOML paths; one made in Python validated, then written to ``tmp``."""
    from mjx_radar.scenario.edit import validate

    files = []
    for item in items:
        if isinstance(item, str | Path):
            files.append(str(item))
        else:  # a Scenario made in Python: validated, then a TOML file like any other
            s = validate(item)
            path = tmp / f"{s.name}.toml"
            s.to_toml(path)
            files.append(str(path))
    return files


def _listed(value, field: str) -> list:
    """A list of names: a single string is one name, never its letters."""
    if isinstance(value, str):
        return [value]
    try:
        return list(value)
    except TypeError:
        raise ValueError(f"{field} = {value!r}: must be a name or a list of names") from None


def _precision() -> str:
    import jax

    return "float64" if jax.config.jax_enable_x64 else "float32"
