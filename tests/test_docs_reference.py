"""README.md and docs/ are reference, not a journal: no line names a session, a lent host,
an issue number or a work date (history: CHANGELOG.md and docs/notes/)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
JOURNAL = re.compile(
    r"\bsessions?\b|\bissues? #?\d+|#\d{2,}\b|\b20\d\d-\d\d(-\d\d)?\b|\blent\b", re.I
)


def reference_pages() -> list[Path]:
    docs = [p for p in sorted((REPO / "docs").rglob("*.md"))
            if p.relative_to(REPO / "docs").parts[0] != "notes"]  # fmt: skip
    return [REPO / "README.md", *docs]


@pytest.mark.parametrize("page", reference_pages(), ids=lambda p: str(p.relative_to(REPO)))
def test_no_journal_in_reference_pages(page):
    hits = [
        f"{page.relative_to(REPO)}:{i}: {line.strip()[:80]}"
        for i, line in enumerate(page.read_text().splitlines(), 1)
        if JOURNAL.search(line)
    ]
    assert hits == [], "\n".join(hits)


def test_the_pattern_catches_a_journal_line():
    for line in ("the fourteenth session", "issue 37", "on 2026-11-27", "the lent H100 host"):
        assert JOURNAL.search(line), line
    assert not JOURNAL.search("a silent failure; the talent of 25 ms steps")


def test_readme_is_a_short_guide():
    readme = (REPO / "README.md").read_text()
    assert len(readme.splitlines()) <= 200
    assert len((REPO / "docs" / "scaling.md").read_text().splitlines()) <= 400
    assert (REPO / "CHANGELOG.md").read_text().startswith("# Changelog")
