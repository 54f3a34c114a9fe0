"""Checks the package's layering: floors in one declared order, no cycles, small modules.

Usage: ``python scripts/check_imports.py [PACKAGE_DIR]`` (default: the ``mjx_radar``
folder beside this script's folder); exit 1 with one line per problem.

Every module belongs to one floor of :data:`FLOORS` (its subpackage; the root modules
are named in :data:`ROOT_FLOORS`). A module may import only from its own floor or the
floors below it. Every import counts: top-level ones and those inside functions, ``import
a.b``, ``from a import b`` with b a submodule, relative imports. Reported:

* each upward import (``A imports B (floor i > j)``);
* each cycle (circle) between packages and between modules, every import counted, those
  inside functions too (an import of a package's ``__init__`` is no module edge);
* library modules importing the CLI or ``scripts``;
* private names (``_x``) imported across modules;
* modules over :data:`MAX_LINES` lines, and any ``# fmt: skip`` (code packed by hand to
  stay under the cap: a module that needs it is split instead);
* functions over :data:`MAX_FUNCTION_LINES` lines from ``def`` to their end (docstring
  included), except those of :data:`LONG_FUNCTIONS`, a ceiling list that only shrinks: a
  function there may not grow past its recorded length, and one that fits the rule must
  leave the list.

The summary also counts the modules outside ``scenario/``, ``api/`` and ``cli/`` that take
or read a scenario (:func:`reads_scenario`; the lower floors should take sub-configs);
more than :data:`MAX_SCENARIO_READERS`, a ceiling that only shrinks, is a problem, and
so is fewer (the ceiling comes down with them).

There is no allowance list for imports: a problem is fixed in the code, never excused
here.
"""

from __future__ import annotations

import ast
import re
import sys
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent.parent / "mjx_radar"
MAX_LINES = 300
MAX_FUNCTION_LINES = 80
#: functions still over MAX_FUNCTION_LINES (module:function -> lines): only shrinks
LONG_FUNCTIONS: dict[str, int] = {}
#: modules outside scenario/, api/ and cli/ that take or read a scenario (reads_scenario):
#: a ceiling that only shrinks (the lower floors take the task's tables and world
#: components instead); lower it as modules leave, never raise it
MAX_SCENARIO_READERS = 16
SKIP = re.compile(r"#\s*fmt:\s*(skip|off)")
# lowest floor first; a module imports only from its own floor and the ones below it
FLOORS = [
    "io",  # leaf file helpers: atomic writes, locks, value rules, terrain files, cache folders
    "base",  # root errors.py, precision.py, version.py, registry.py (plug-in registries)
    "scenario",  # schema, rules, TOML and map-file readers, host geometry, bundles
    "world",  # occlusion, terrain, line of sight, obstacle SDF, moving obstacles (JAX)
    "physics",  # MJCF scene, MJX plant, motion models
    "estimation",  # filters, measurement model, Fisher information
    "control",  # MPPI
    "task",  # task, objective, the MPC step
    "env",  # the pure environment (its types: Observation, State, ControlRecord), placement
    "planners",  # the planner contract and its plug-ins (MPPI, hold, registered ones)
    "loop",  # a planner driving the environment: the closed loop (paper Algorithm 1)
    "rundir",  # the result format: run directories written and read
    "engine",  # compiled programs, caches, devices, batching, runner
    "study",  # multi-cell studies
    "viz",  # viewer, renderer, snapshots
    "learning",  # learned policies: features, brax / gymnasium adapters, PPO, policy:DIR
    "api",  # Python API
    "cli",  # command line
    "facade",  # the package root: __init__, __main__, public alias modules
]
# root modules of the base floor; the other root modules are the facade
ROOT_FLOORS = {
    "errors": "base",
    "precision": "base",
    "version": "base",
    "registry": "base",
    "contracts": "base",
    "plugin_errors": "base",
    "batching": "base",
}


def module_name(path: Path, root: Path) -> str:
    parts = list(path.relative_to(root.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def floor_of(mod: str, pkg: str, subpackages: set[str]) -> str:
    parts = mod.split(".")
    if len(parts) == 1:
        return "facade"
    if parts[1] in subpackages:
        return parts[1]
    return ROOT_FLOORS.get(parts[1], "facade")


def _resolve(name: str, modules: set[str]) -> str | None:
    """The longest known module that ``name`` (a dotted path) starts with."""
    parts = name.split(".")
    for k in range(len(parts), 0, -1):
        cand = ".".join(parts[:k])
        if cand in modules:
            return cand
    return None


def imports(path: Path, mod: str, pkg: str, modules: set[str]) -> list[tuple[str, list[str], bool]]:
    """``(imported module, names, inside a function)`` of every import of the package."""
    out: list[tuple[str, list[str], bool]] = []
    is_pkg = path.name == "__init__.py"
    tree = ast.parse(path.read_text())
    deferred = {
        id(inner)
        for node in ast.walk(tree)
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.Lambda)
        for inner in ast.walk(node)
    }
    for node in ast.walk(tree):
        lazy = id(node) in deferred
        if isinstance(node, ast.Import):
            for a in node.names:
                if a.name.split(".")[0] in (pkg, "scripts"):
                    out.append((_resolve(a.name, modules) or a.name, [], lazy))
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = mod.split(".")
                anchor = anchor[: len(anchor) - node.level + (1 if is_pkg else 0)]
                base = ".".join(anchor + ([base] if base else []))
            if base.split(".")[0] not in (pkg, "scripts"):
                continue
            for a in node.names:
                sub = f"{base}.{a.name}"
                if sub in modules:  # "from pkg.x import y" with y a module
                    out.append((sub, [], lazy))
                else:
                    out.append((_resolve(base, modules) or base, [a.name], lazy))
    return out


def long_functions(tree: ast.AST, mod: str) -> dict[str, int]:
    """``{"module:function": lines}`` of the functions over :data:`MAX_FUNCTION_LINES`."""
    return {
        f"{mod}:{node.name}": node.end_lineno - node.lineno + 1
        for node in ast.walk(tree)
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef)
        and node.end_lineno - node.lineno + 1 > MAX_FUNCTION_LINES
    }


def reads_scenario(tree: ast.AST) -> bool:
    """Whether a module takes or reads a scenario: an argument, name or attribute called
    ``scenario``, or an import of ``Scenario``."""
    for node in ast.walk(tree):
        if isinstance(node, ast.arg) and node.arg == "scenario":
            return True
        if isinstance(node, ast.Name) and node.id == "scenario":
            return True
        if isinstance(node, ast.Attribute) and node.attr == "scenario":
            return True
        if isinstance(node, ast.ImportFrom) and any(a.name == "Scenario" for a in node.names):
            return True
    return False


def reader_problems(found: int, ceiling: int) -> list[str]:
    """The scenario readers over their ceiling, or fewer: then the ceiling must come down."""
    if found > ceiling:
        return [f"{found} scenario readers outside scenario/ api/ cli/ (> {ceiling}, the ceiling)"]
    if found < ceiling:
        return [f"{found} scenario readers now; lower MAX_SCENARIO_READERS ({ceiling}) to {found}"]
    return []


def function_problems(found: dict[str, int], ceiling: dict[str, int]) -> list[str]:
    """Functions over the rule and not in ``ceiling``, grown past it, or listed but fit."""
    out = []
    for name, n in sorted(found.items()):
        cap = ceiling.get(name)
        if cap is None:
            out.append(f"{name}: {n} lines (> {MAX_FUNCTION_LINES})")
        elif n > cap:
            out.append(f"{name}: {n} lines (> {cap}, its ceiling in LONG_FUNCTIONS)")
    out += [
        f"{name}: fits {MAX_FUNCTION_LINES} lines now; remove it from LONG_FUNCTIONS"
        for name in sorted(set(ceiling) - set(found))
    ]
    return out


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one node (Tarjan), sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    comps: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(graph[v]):
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

    sys.setrecursionlimit(max(10000, sys.getrecursionlimit()))
    for v in sorted(graph):
        if v not in index:
            visit(v)
    return sorted(comps)


def check(root: Path) -> tuple[list[str], str]:
    """``(problems, summary line)`` of the package in folder ``root``."""
    root = Path(root).resolve()
    pkg = root.name
    files = {module_name(p, root): p for p in sorted(root.rglob("*.py"))}
    modules = set(files)
    subpackages = {p.parent.name for p in root.glob("*/__init__.py")}
    problems: list[str] = []
    unknown = sorted(subpackages - set(FLOORS))
    problems += [f"{pkg}.{s}: package not in FLOORS" for s in unknown]
    rank = {f: i for i, f in enumerate(FLOORS, start=1)}  # as numbered in docs
    graph: dict[str, set[str]] = {m: set() for m in files}
    pgraph: dict[str, set[str]] = {}
    n_imports = 0
    long: dict[str, int] = {}
    readers = 0  # modules outside scenario/, api/, cli/ that take or read a scenario
    for mod, path in files.items():
        text = path.read_text()
        tree = ast.parse(text)
        long |= long_functions(tree, mod.split(".", 1)[-1])
        outside = floor_of(mod, pkg, subpackages) not in ("scenario", "api", "cli")
        readers += outside and reads_scenario(tree)
        n = len(text.splitlines())
        if n > MAX_LINES:
            problems.append(f"{mod}: {n} lines (> {MAX_LINES})")
        skips = [i for i, line in enumerate(text.splitlines(), 1) if SKIP.search(line)]
        if skips:
            problems.append(f"{mod}: '# fmt: skip' on line(s) {', '.join(map(str, skips))}")
        here = floor_of(mod, pkg, subpackages)
        lib = here not in ("cli", "facade")
        seen: set[str] = set()
        for target, names, _lazy in imports(path, mod, pkg, modules):
            n_imports += 1
            if target.split(".")[0] == "scripts":
                problems.append(f"{mod}: imports {target} (scripts are not part of the package)")
                continue
            if target not in modules:
                problems.append(f"{mod}: imports {target}, not a module of {pkg}")
                continue
            there = floor_of(target, pkg, subpackages)
            # a module edge: every import, those inside functions too
            if target != mod and files[target].name != "__init__.py":
                graph[mod].add(target)
            if there != here:
                pgraph.setdefault(here, set()).add(there)
                pgraph.setdefault(there, set())
            if rank.get(there, -1) > rank.get(here, -1) and target not in seen:
                seen.add(target)
                problems.append(
                    f"{mod} imports {target} (floor {rank.get(there)} {there} > "
                    f"{rank.get(here)} {here})"
                )
            if lib and there == "cli":
                problems.append(f"{mod}: library module imports {target}")
            private = [x for x in names if x.startswith("_") and not x.startswith("__")]
            if private and target != mod:
                problems.append(f"{mod}: imports private {', '.join(private)} from {target}")
    ceiling = LONG_FUNCTIONS if root == PACKAGE else {}  # the list is the package's
    problems += function_problems(long, ceiling)
    if root == PACKAGE:
        problems += reader_problems(readers, MAX_SCENARIO_READERS)
    problems += [f"package cycle: {' <-> '.join(c)}" for c in cycles(pgraph)]
    circles = cycles(graph)
    problems += [f"module cycle: {' <-> '.join(c)}" for c in circles]
    edges = sum(map(len, graph.values()))
    summary = (
        f"{len(files)} modules in {len(FLOORS)} floors, {n_imports} imports "
        f"({edges} module edges), {len(circles)} circles, {len(long)} functions over "
        f"{MAX_FUNCTION_LINES} lines, {readers} scenario readers outside scenario/ api/ cli/, "
        f"{len(problems)} problems"
    )
    return problems, summary


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    root = Path(argv[0]) if argv else PACKAGE
    problems, summary = check(root)
    for p in problems:
        print(p)
    print(summary)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
