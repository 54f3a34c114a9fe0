"""Benchmarks as data (benchmarks/README.md): result files, the docs' generated tables,
and every measured figure in README.md and docs/ traced to a result file."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "benchmarks"))
import figures  # noqa: E402
import results  # noqa: E402
import tables  # noqa: E402


def test_every_result_file_is_well_formed():
    files = sorted(results.RESULTS.glob("*.json"))
    assert files
    for path in files:
        assert results.problems(json.loads(path.read_text()), path.stem) == [], path


def test_a_malformed_result_file_is_named():
    bad = {"id": "x", "title": "t", "command": "c", "hardware": "h", "date": "27.11.2026",
           "software": {"jax": None}, "columns": ["a", "b"], "rows": [[1]]}  # fmt: skip
    found = " ".join(results.problems(bad, "x"))
    assert "date" in found and "software lacks" in found and "row 0 has 1 values" in found


def test_tables_agree_with_their_files():
    assert tables.stale() == []


def test_a_changed_figure_makes_the_table_stale(tmp_path):
    (tmp_path / "docs").mkdir()
    root = tmp_path / "results"
    results.write_result("demo", "t", "python x.py", "2-core CPU", ["n", "s"], [[1, 0.5]],
                         root=root)  # fmt: skip
    body = tables.render("demo", results.load_all(root))
    doc = f"# x\n<!-- table: demo -->\n{body}<!-- /table -->\n"
    (tmp_path / "README.md").write_text(doc)
    assert tables.stale(tmp_path, root) == []
    (tmp_path / "README.md").write_text(doc.replace("| 1 | 0.5 |", "| 1 | 0.4 |"))
    assert tables.stale(tmp_path, root) == ["README.md: table demo"]
    assert "| 1 | 0.5 |" in tables.fill(doc.replace("0.5 |", "0.4 |"), results.load_all(root))


def test_the_figure_scan_finds_measured_figures_only():
    text = "took 12.9 s (compile 9.5–10.1 s), 1.89x faster, 17.84 GiB; `--steps 600 12 s`"
    assert figures.figures(text) == ["12.9 s", "9.5–10.1 s", "1.89x", "17.84 GiB"]
    assert figures.untraced(text, {"12.9", "9.5", "10.1", "1.89"}) == ["17.84 GiB"]
    assert figures.untraced("a step of 25 ms", set()) == []


@pytest.mark.parametrize("page", figures.pages(), ids=lambda p: str(p.relative_to(REPO)))
def test_every_figure_traces_to_a_result_file(page):
    values = figures.known_values(results.load_all())
    left = figures.untraced(page.read_text(), values)
    allowed = figures.debt().get(str(page.relative_to(REPO)), 0)
    assert len(left) <= allowed, (
        f"{len(left)} measured figures not in benchmarks/results/ (allowed {allowed}): {left}"
    )
