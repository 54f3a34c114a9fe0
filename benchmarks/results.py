"""Benchmark result files: ``benchmarks/results/<id>.json`` (format: benchmarks/README.md).

A result file holds one measurement: what was measured, the exact command, the hardware
as a product name, the software versions, the date and the figures as a table
(``columns``, ``rows``). The docs' tables are written from these files by
``benchmarks/tables.py``; nobody retypes a figure.

    from benchmarks.results import write_result   # or: sys.path + ``from results import``
    write_result("mppi_call", "One MPPI call, paper settings", "python benchmarks/...",
                 "NVIDIA H200", ["method", "median [ms]"], [["ddr-sfim", 2.6]])
"""

from __future__ import annotations

import datetime
import json
import os
import platform
import re
import subprocess
import tempfile
from pathlib import Path

RESULTS = Path(__file__).resolve().parent / "results"
REQUIRED = ("id", "title", "command", "hardware", "software", "date", "columns", "rows")
SOFTWARE = ("mjx_radar", "commit", "jax", "jaxlib", "mujoco", "python")
ID = re.compile(r"^[a-z0-9_]+$")
DATE = re.compile(r"^\d{4}-\d{2}-\d{2}$")


def problems(result: dict, name: str | None = None) -> list[str]:
    """What is wrong with one result file's content (empty when it is well formed)."""
    out = [f"missing key {k!r}" for k in REQUIRED if k not in result]
    if out:
        return out
    if not ID.match(str(result["id"])) or (name is not None and result["id"] != name):
        out.append(f"id {result['id']!r} must be the file's name ([a-z0-9_]+)")
    if not DATE.match(str(result["date"])):
        out.append(f"date {result['date']!r} is not YYYY-MM-DD")
    missing = [k for k in SOFTWARE if k not in result["software"]]
    if missing:
        out.append(f"software lacks {missing} (null where unknown)")
    if not isinstance(result["command"], (str, list)) or not result["command"]:
        out.append("command must be a non-empty string or list of strings")
    width = len(result["columns"])
    for i, row in enumerate(result["rows"]):
        if len(row) != width:
            out.append(f"row {i} has {len(row)} values, columns has {width}")
    headline = result.get("headline")
    if headline is not None and set(headline) != {"what", "figure"}:
        out.append("headline must have exactly the keys 'what' and 'figure'")
    return out


def load(ident: str, root: Path = RESULTS) -> dict:
    """The result file ``root/<ident>.json`` (raises ``ValueError`` naming its problems)."""
    path = root / f"{ident}.json"
    result = json.loads(path.read_text())
    bad = problems(result, ident)
    if bad:
        raise ValueError(f"{path}: " + "; ".join(bad))
    return result


def load_all(root: Path = RESULTS) -> dict[str, dict]:
    """Every result file under ``root``, by id."""
    return {p.stem: load(p.stem, root) for p in sorted(root.glob("*.json"))}


def software() -> dict:
    """The versions of the running process (and the repository's commit)."""
    from importlib import metadata

    from mjx_radar.version import __version__ as package_version

    def version(name):
        try:
            return metadata.version(name)
        except metadata.PackageNotFoundError:
            return None

    try:
        commit = subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"],
            capture_output=True,
            text=True,
            cwd=RESULTS.parent,
            check=True,
        ).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        commit = None
    return {
        "mjx_radar": version("mjx_radar") or package_version,  # a checkout on the path
        "commit": commit,
        "jax": version("jax"),
        "jaxlib": version("jaxlib"),
        "mujoco": version("mujoco"),
        "python": platform.python_version(),
    }


def write_result(
    ident, title, command, hardware, columns, rows, notes=None, headline=None, root: Path = RESULTS
) -> Path:
    """Write ``root/<ident>.json`` atomically, with this process's software and today's date."""
    result = {
        "id": ident,
        "title": title,
        "command": command,
        "hardware": hardware,
        "software": software(),
        "date": datetime.date.today().isoformat(),
        "columns": list(columns),
        "rows": [list(r) for r in rows],
    }
    if notes:
        result["notes"] = notes
    if headline:
        result["headline"] = headline
    bad = problems(result, ident)
    if bad:
        raise ValueError("; ".join(bad))
    root.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=root, suffix=".tmp")
    with os.fdopen(fd, "w") as f:
        json.dump(result, f, indent=2, ensure_ascii=False)
        f.write("\n")
    os.replace(tmp, root / f"{ident}.json")
    return root / f"{ident}.json"
