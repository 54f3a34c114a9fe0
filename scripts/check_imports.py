"""Checks the package's import graph: no cycles, no library module importing the CLI or
scripts, no private name imported across modules, every module at most 300 lines.

Usage: ``python scripts/check_imports.py`` (exit 1 with one line per problem).
Imports inside functions count too (a lazy import still ties two modules together).
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent / "mjx_radar"
MAX_LINES = 300
# Deliberate upward edges, each a lazy import inside a method (not part of the layering):
# Scenario.replace / Scenario.to_toml delegate to the validating reader of io.
UPWARD = {("mjx_radar.config", "mjx_radar.io.scenario_edit")}


def module_name(path: Path) -> str:
    rel = path.relative_to(ROOT.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def imports(path: Path, modules: set[str]) -> list[tuple[str, list[str]]]:
    """``(imported module, names)`` of every mjx_radar import in the file."""
    out = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            out += [(a.name, []) for a in node.names if a.name.startswith("mjx_radar")]
        elif isinstance(node, ast.ImportFrom) and (node.module or "").startswith("mjx_radar"):
            for a in node.names:
                sub = f"{node.module}.{a.name}"
                if sub in modules:  # "from mjx_radar.x import y" with y a module
                    out.append((sub, []))
                else:
                    out.append((node.module, [a.name]))
    return out


def main() -> int:
    files = {module_name(p): p for p in ROOT.rglob("*.py")}
    modules = set(files)
    graph: dict[str, set[str]] = {m: set() for m in files}
    problems = []
    for mod, path in files.items():
        n = len(path.read_text().splitlines())
        if n > MAX_LINES:
            problems.append(f"{mod}: {n} lines (> {MAX_LINES})")
        for target, names in imports(path, modules):
            if target not in modules:
                continue
            if target != mod and not files[target].name == "__init__.py":
                if (mod, target) not in UPWARD:
                    graph[mod].add(target)
            lib = not mod.startswith("mjx_radar.cli") and mod != "mjx_radar.__main__"
            if lib and target.startswith("mjx_radar.cli"):
                problems.append(f"{mod}: library module imports {target}")
            private = [x for x in names if x.startswith("_") and not x.startswith("__")]
            if private and target != mod:
                problems.append(f"{mod}: imports private {', '.join(private)} from {target}")
    # cycles (Tarjan's strongly connected components)
    index, low, stack, on, comps, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                comps.append(sorted(comp))

    sys.setrecursionlimit(10000)
    for v in graph:
        if v not in index:
            visit(v)
    problems += [f"import cycle: {' <-> '.join(c)}" for c in comps]
    for p in problems:
        print(p)
    print(
        f"{len(files)} modules, {sum(map(len, graph.values()))} imports, {len(problems)} problems"
    )
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
