"""Write the docs' benchmark tables from ``benchmarks/results/*.json`` (benchmarks/README.md).

A table in README.md or docs/ sits between two marker comments::

    <!-- table: ID -->                     the result file ID: its columns and rows
    <!-- table: headlines: ID1, ID2 -->     one row per file: its headline, hardware, command
    <!-- /table -->

    python benchmarks/tables.py            # rewrite every table from its file
    python benchmarks/tables.py --check    # exit 1 naming each table that differs
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from results import RESULTS, load_all  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
BLOCK = re.compile(r"(<!-- table: (?P<spec>[^>]*?) -->\n)(?P<body>.*?)(<!-- /table -->)", re.S)


def cell(value) -> str:
    """One value as a table cell: numbers as written in the file (``g`` format)."""
    if isinstance(value, bool) or value is None:
        return str(value)
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return format(value, "g")
    return str(value).replace("|", "\\|")


def command_text(result: dict) -> str:
    cmd = result["command"]
    return " && ".join(cmd) if isinstance(cmd, list) else cmd


def source_line(result: dict) -> str:
    """Where a table's figures come from: the command, the hardware and the result file."""
    line = (
        f"Command: `{command_text(result)}`; hardware: {result['hardware']}; "
        f"`benchmarks/results/{result['id']}.json`."
    )
    if result.get("notes"):
        line += f" {result['notes']}"
    return line


def table(columns, rows) -> list[str]:
    lines = ["| " + " | ".join(cell(c) for c in columns) + " |"]
    lines.append("|" + "---|" * len(columns))
    lines += ["| " + " | ".join(cell(v) for v in row) + " |" for row in rows]
    return lines


def render(spec: str, results: dict[str, dict]) -> str:
    """The body of the table with marker ``spec`` (raises ``KeyError`` for an unknown file)."""
    spec = spec.strip()
    if spec.startswith("headlines:"):
        ids = [s.strip() for s in spec.removeprefix("headlines:").split(",") if s.strip()]
        rows = []
        for ident in ids:
            r = results[ident]
            if "headline" not in r:
                raise KeyError(f"{ident} has no headline")
            cmd = r["command"] if isinstance(r["command"], str) else r["command"][0] + " …"
            rows.append([r["headline"]["what"], r["headline"]["figure"], r["hardware"], f"`{cmd}`"])
        return "\n".join(table(["what", "figure", "hardware", "command"], rows)) + "\n"
    r = results[spec]
    lines = [f"**{r['title']}**", "", *table(r["columns"], r["rows"]), "", source_line(r)]
    return "\n".join(lines) + "\n"


def documents(repo: Path = REPO) -> list[Path]:
    return [repo / "README.md", *sorted((repo / "docs").rglob("*.md"))]


def fill(text: str, results: dict[str, dict]) -> str:
    return BLOCK.sub(lambda m: m.group(1) + render(m.group("spec"), results) + m.group(4), text)


def stale(repo: Path = REPO, root: Path = RESULTS) -> list[str]:
    """``PATH: table SPEC`` for every table that differs from what its file renders."""
    results = load_all(root)
    out = []
    for path in documents(repo):
        text = path.read_text()
        for m in BLOCK.finditer(text):
            if m.group("body") != render(m.group("spec"), results):
                out.append(f"{path.relative_to(repo)}: table {m.group('spec').strip()}")
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--check", action="store_true", help="only report tables that differ")
    args = p.parse_args(argv)
    if args.check:
        bad = stale()
        for line in bad:
            print(f"stale: {line} (run python benchmarks/tables.py)")
        return 1 if bad else 0
    results = load_all()
    for path in documents():
        text = path.read_text()
        new = fill(text, results)
        if new != text:
            path.write_text(new)
            print(f"wrote {path.relative_to(REPO)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
