"""A self-contained copy of a scenario file: the TOML plus its mesh, map, track and terrain files.

``mjx-radar run --out DIR`` writes ``DIR/scenario.toml`` and copies every mesh the
scenario names into ``DIR/meshes/``, rewriting the mesh paths of the copy relative
to ``DIR`` (mesh paths are resolved relative to the scenario file's folder), so the
run directory can be moved or archived and ``load_scenario(DIR/scenario.toml)``
still finds its meshes. Map files (``[buildings]``, ``[occupancy]``, docs/maps.md), track
CSVs (``[[target_motion]]``) and the ``[terrain]`` height field go to ``DIR/maps/``,
``DIR/tracks/`` and ``DIR/terrain/`` the same way. A scenario without meshes is copied
verbatim (comments kept); with meshes the ``path = ...`` lines are rewritten in place when
that reproduces the intended table, else the copy is re-serialised (comments lost).
"""

from __future__ import annotations

import json
import math
import re
import shutil
import tomllib
from pathlib import Path

from mjx_radar.io.atomic import atomic_write

_PATH_LINE = re.compile(r"""^(\s*path\s*=\s*)("(?:[^"\\]|\\.)*"|'[^']*')(\s*(?:#.*)?)$""")


def bundle_scenario(src: Path, out_dir: Path) -> list[Path]:
    """Writes ``out_dir/scenario.toml`` (and ``out_dir/meshes/*``) from scenario ``src``.

    Args:
        src: the scenario file (already validated).
        out_dir: the run directory.

    Returns:
        The files written, the scenario copy last (each written atomically).
    """
    src, out_dir = Path(src), Path(out_dir)
    text = src.read_text()
    raw = tomllib.loads(text)
    obstacles = raw.get("obstacles", [])
    meshes = [(o, "meshes") for o in obstacles if isinstance(o, dict) and o.get("kind") == "mesh"]
    motions = raw.get("target_motion", [])  # track CSVs travel like meshes (into tracks/)
    meshes += [(t, "tracks") for t in motions if isinstance(t, dict) and t.get("model") == "track"]
    terrain = raw.get("terrain")
    if isinstance(terrain, dict) and isinstance(terrain.get("path"), str):
        meshes.append((terrain, "terrain"))  # the height field travels the same way
    written: list[Path] = []
    if meshes:
        mapping: dict[str, str] = {}  # path as written in src -> path relative to out_dir
        copied: dict[Path, str] = {}  # resolved source file -> relative copy
        for o, folder in meshes:
            given = str(o["path"])
            source = (src.parent / given).resolve()
            if source not in copied:
                rel = _free_name(out_dir, source.name, set(copied.values()), folder)
                dest = out_dir / rel
                atomic_write(dest, lambda tmp, s=source: shutil.copyfile(s, tmp))
                written.append(dest)
                copied[source] = rel
            mapping[given] = copied[source]
            o["path"] = copied[source]
    else:
        mapping = {}
    written += _bundle_maps(src, out_dir, raw, mapping)
    if mapping:
        text = _rewrite_paths(text, mapping, raw)
    dest = out_dir / "scenario.toml"
    atomic_write(dest, lambda tmp: Path(tmp).write_text(text))
    return written + [dest]


def _bundle_maps(src: Path, out_dir: Path, raw: dict, mapping: dict[str, str]) -> list[Path]:
    """Copies the ``[buildings]`` / ``[occupancy]`` map files into ``out_dir/maps/``.

    A GeoJSON file goes to ``maps/NAME``; an occupancy YAML and its image to
    ``maps/STEM/`` (the image keeps its path relative to the YAML). ``mapping`` and
    ``raw`` get the new relative paths.
    """
    from mjx_radar.scenario.maps import map_files

    written: list[Path] = []
    for table in ("buildings", "occupancy"):
        if not isinstance(raw.get(table), dict):
            continue
        given = str(raw[table]["path"])
        files = map_files({table: raw[table]}, src.parent)
        folder = "maps" if table == "buildings" else f"maps/{files[0].stem}"
        for k, source in enumerate(files):
            name = source.name if k == 0 else source.relative_to(files[0].parent).as_posix()
            rel = f"{folder}/{name}"
            atomic_write(out_dir / rel, lambda tmp, s=source: shutil.copyfile(s, tmp))
            written.append(out_dir / rel)
            if k == 0:
                mapping[given] = rel
                raw[table]["path"] = rel
    return written


def _free_name(out_dir: Path, name: str, taken: set[str], folder: str = "meshes") -> str:
    stem, suffix = Path(name).stem, Path(name).suffix
    rel, i = f"{folder}/{name}", 1
    while rel in taken:
        rel, i = f"{folder}/{stem}_{i}{suffix}", i + 1
    return rel


def _rewrite_paths(text: str, mapping: dict[str, str], expected: dict) -> str:
    """``text`` with mesh ``path = ...`` lines rewritten; re-serialised if that fails."""
    lines = []
    for line in text.splitlines(keepends=True):
        body = line.rstrip("\r\n")
        match = _PATH_LINE.match(body)
        if match:
            value = tomllib.loads(f"v = {match.group(2)}")["v"]
            if value in mapping:
                body = match.group(1) + json.dumps(mapping[value]) + match.group(3)
                line = body + line[len(line.rstrip("\r\n")) :]
        lines.append(line)
    rewritten = "".join(lines)
    try:
        if tomllib.loads(rewritten) == expected:
            return rewritten
    except tomllib.TOMLDecodeError:
        pass
    return dumps(expected)


def dumps(table: dict) -> str:
    """Minimal TOML writer for a parsed scenario (scalars, arrays, tables, arrays of tables)."""
    out: list[str] = []
    _table(out, table, [])
    return "\n".join(out) + "\n"


def _table(out: list[str], table: dict, prefix: list[str]) -> None:
    subtables = []
    for key, value in table.items():
        if isinstance(value, dict):
            subtables.append((key, value, False))
        elif isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
            subtables.append((key, value, True))
        else:
            out.append(f"{_key(key)} = {_value(value)}")
    for key, value, is_array in subtables:
        name = ".".join(_key(k) for k in [*prefix, key])
        for sub in value if is_array else [value]:
            out.extend(["", f"[[{name}]]" if is_array else f"[{name}]"])
            _table(out, sub, [*prefix, key])


def _key(key: str) -> str:
    return key if re.fullmatch(r"[A-Za-z0-9_-]+", key) else json.dumps(key)


def _value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return repr(v) if math.isfinite(v) else ("nan" if math.isnan(v) else f"{v:+}"[:4])
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{_key(k)} = {_value(x)}" for k, x in v.items()) + "}"
    raise TypeError(f"cannot write {type(v).__name__} to TOML")
