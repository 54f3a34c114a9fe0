"""Which measured figures README.md and docs/ quote, and whether a result file holds them.

The rule (benchmarks/README.md): a *measured figure* is a number (or a range ``a–b``)
followed by a unit of time (``ms``, ``s``, ``min``), memory (``GiB``, ``MiB``, ``GB``),
throughput (``frames/s``) or a speed-up (``1.89x``, ``1.89×``). Inside a generated table
(``<!-- table: ... -->``) it is checked exactly by ``tables.py --check``. Outside one it is
*traced* when each of its numbers occurs among the values of some result file, or when
the phrase is a model or scenario parameter in ``PARAMETERS``. ``benchmarks/untraced.json``
records, per page, how many untraced figures it still holds; the test fails when a page
holds more (README.md and docs/scaling.md hold none).
"""

from __future__ import annotations

import json
import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
NUMBER = r"\d+(?:[.,]\d+)*"
FIGURE = re.compile(
    rf"(?<![\w.]){NUMBER}(?:\s?[–-]\s?{NUMBER})?\s?"
    r"(?:ms|s|min|GiB|MiB|GB|frames/s|[x×](?!\s?\d))(?![\w/])"
)
TABLE = re.compile(r"<!-- table: [^>]*? -->\n.*?<!-- /table -->", re.S)
CODE = re.compile(r"```.*?```|`[^`]*`", re.S)
#: model and scenario parameters and other figures that are not measurements
PARAMETERS = {
    "25 ms", "100 ms", "1.5 s", "0.1 s", "2 s", "0.025 s", "1 s", "10 s", "15 s", "250 ms",
}  # fmt: skip


def pages(repo: Path = REPO) -> list[Path]:
    """README.md and docs/**/*.md, without docs/notes/ (history) and the SPEC copy."""
    docs = [
        p for p in sorted((repo / "docs").rglob("*.md"))
        if "notes" not in p.relative_to(repo / "docs").parts[:1] and p.name != "spec.md"
    ]  # fmt: skip
    return [repo / "README.md", *docs]


def known_values(results: dict[str, dict]) -> set[str]:
    """Every number written in the result files' rows and headlines, as text."""
    out: set[str] = set()
    for r in results.values():
        values = [v for row in r["rows"] for v in row]
        values += list(r.get("headline", {}).values())
        for v in values:
            if isinstance(v, (int, float)) and not isinstance(v, bool):
                out |= {format(v, "g"), str(v)}
            elif isinstance(v, str):
                out |= set(re.findall(NUMBER, v))
    return out


def figures(text: str) -> list[str]:
    """The measured figures of a page outside generated tables and code."""
    text = CODE.sub("", TABLE.sub("", text))
    return [m.group(0) for m in FIGURE.finditer(text)]


def untraced(text: str, values: set[str]) -> list[str]:
    """The figures of ``text`` that no result file holds and no parameter explains."""
    out = []
    for fig in figures(text):
        if " ".join(fig.split()) in PARAMETERS:
            continue
        numbers = re.findall(NUMBER, fig)
        if not all(n in values or n.rstrip("0").rstrip(".") in values for n in numbers):
            out.append(fig)
    return out


def debt(repo: Path = REPO) -> dict[str, int]:
    """``benchmarks/untraced.json``: page -> untraced figures it may still hold."""
    path = repo / "benchmarks" / "untraced.json"
    return json.loads(path.read_text()) if path.exists() else {}
