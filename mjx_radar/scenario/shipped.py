"""Data files shipped with the package: bundled scenarios, terrain, maps and meshes.

``mjx_radar.bundled_path("terrain/hills.png")`` is the installed file's path (from a
wheel or a source checkout), to name in a :class:`~mjx_radar.scenario.schema.Terrain`
or a scenario made in Python.
"""

from __future__ import annotations

from pathlib import Path

from mjx_radar.io.checks import ScenarioError, show


def bundled_files() -> list[str]:
    """Every shipped data file, relative to the bundled folder (``"maps/town.geojson"``)."""
    from mjx_radar.scenario.reader import bundled_dir

    root = bundled_dir()
    return sorted(
        p.relative_to(root).as_posix()
        for p in root.rglob("*")
        if p.is_file() and p.suffix not in (".py", ".pyc")
    )


def bundled_path(relative: str) -> Path:
    """The absolute path of a shipped data file (``"terrain/hills.png"``, ``"smoke.toml"``).

    Raises:
        ScenarioError: not a relative path to a shipped file (one line listing its folders).
    """
    from mjx_radar.scenario.reader import bundled_dir

    if not isinstance(relative, str) or not relative:
        raise ScenarioError(f"bundled_path = {show(relative)}: must be a relative file path")
    root = bundled_dir().resolve()
    path = (root / relative).resolve()
    if not path.is_relative_to(root) or not path.is_file() or path.suffix in (".py", ".pyc"):
        folders = sorted({f.split("/")[0] + "/" for f in bundled_files() if "/" in f})
        raise ScenarioError(
            f"bundled_path = {relative!r}: no such bundled file; see "
            f"mjx_radar.bundled_files() (*.toml, {', '.join(folders)})"
        )
    return path
