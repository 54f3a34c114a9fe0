"""Markdown reference of every scenario field, generated from the config metadata.

``docs/scenarios.md`` embeds :func:`fields_markdown` between the markers
``<!-- fields:begin -->`` and ``<!-- fields:end -->``; a test keeps them in sync.
Regenerate with ``python -m mjx_radar.scenario.doc docs/scenarios.md``.
"""

from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

from mjx_radar.io.checks import Rows, Rule
from mjx_radar.scenario.reader import EXTRA_KEYS, config_fields, toml_name
from mjx_radar.scenario.schema import Scenario
from mjx_radar.scenario.sections import SECTIONS

BEGIN, END = "<!-- fields:begin -->", "<!-- fields:end -->"


def _default(f: dataclasses.Field) -> str:
    if f.default is not dataclasses.MISSING:
        v = f.default
        if isinstance(v, bool):
            return "true" if v else "false"
        return '""' if v == "" else ("none" if v == () else repr(v).strip("'"))
    return "required"


def _row(key: str, f: dataclasses.Field, r: Rule) -> str:
    unit = r.unit or "-"
    return f"| `{key}` | {_default(f)} | {unit} | {r.describe()} | {_esc(r.doc)} |"


def _esc(text: str) -> str:
    return text.replace("|", "\\|")


def _table(cls: type, prefix: str) -> list[str]:
    lines, tables = [], []
    for f, typ in config_fields(cls):
        key = prefix + toml_name(f)
        if "table" in f.metadata:
            tables.append((key, f, typ))
            continue
        r = f.metadata["rule"]
        if isinstance(r, Rows):
            count = f"{r.count} rows" if r.count else "1 to 1000 rows"
            cols = "; ".join(f"{n}: {c.describe()} {c.unit}".rstrip() for n, c in r.columns)
            lines.append(
                f"| `{key}` | {_default(f)} | rows | {count} of [{r.names}]; {cols} | {r.doc} |"
            )
        else:
            lines.append(_row(key, f, r))
    for key, f, typ in tables:
        lines += ["", f"### `[{key}]` — {f.metadata['table']}", "", *_HEAD, *_table(typ, "")]
    return lines


_HEAD = ["| field | default | unit | allowed | meaning |", "|---|---|---|---|---|"]


def fields_markdown() -> str:
    """The field reference: one Markdown table per TOML table."""
    lines = ["### Top level", "", *_HEAD]
    lines += [f"| `{k}` | {d} | - | - | {doc} |" for k, (d, doc) in EXTRA_KEYS.items()]
    lines += _table(Scenario, "")
    for section in SECTIONS:  # the optional tables with a field table
        if section.title is not None:
            lines += ["", section.title, "", *_HEAD, *section.doc_rows]
            lines += _table(section.dataclass, "")
    return "\n".join([BEGIN, *lines, END]) + "\n"


def sync(path: Path) -> bool:
    """Rewrites the generated part of ``path``; returns True if it changed."""
    text = path.read_text()
    head, rest = text.split(BEGIN, 1)
    _, tail = rest.split(END + "\n", 1)
    new = head + fields_markdown() + tail
    path.write_text(new)
    return new != text


if __name__ == "__main__":
    sync(Path(sys.argv[1]))
