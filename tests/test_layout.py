"""The package's layering (scripts/check_imports.py): floors in order, no cycles."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
SCRIPT = REPO / "scripts" / "check_imports.py"


def _checker():
    spec = importlib.util.spec_from_file_location("check_imports", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _tree(root: Path, files: dict[str, str]) -> Path:
    pkg = root / "mjx_radar"
    for rel, text in files.items():
        path = pkg / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    for sub in {p.parent for p in pkg.rglob("*.py")}:
        (sub / "__init__.py").touch()
    return pkg


def test_package_layout_is_clean():
    proc = subprocess.run([sys.executable, str(SCRIPT)], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert proc.stdout.strip().endswith("0 problems")


def test_package_has_no_circle():
    """No cycle between modules, imports inside functions counted (within a package too)."""
    problems, summary = _checker().check(REPO / "mjx_radar")
    assert [p for p in problems if "cycle" in p] == []
    assert ", 0 circles," in summary


def test_function_level_circle_is_reported(tmp_path):
    pkg = _tree(
        tmp_path,
        {
            "world/a.py": "from mjx_radar.world import b\n",
            "world/b.py": "def f():\n    from mjx_radar.world import a\n    return a\n",
        },
    )
    problems, summary = _checker().check(pkg)
    assert problems == ["module cycle: mjx_radar.world.a <-> mjx_radar.world.b"]
    assert ", 1 circles," in summary


def test_long_function_is_reported(tmp_path):
    body = "".join(f"    x{i} = {i}\n" for i in range(80))
    pkg = _tree(tmp_path, {"world/a.py": f"def f():\n{body}", "world/b.py": "def g():\n    pass\n"})
    problems, summary = _checker().check(pkg)
    assert problems == ["world.a:f: 81 lines (> 80)"]
    assert "1 functions over 80 lines" in summary


def test_long_function_ceilings_only_shrink():
    checker = _checker()
    assert checker.function_problems({"a:f": 90}, {"a:f": 90}) == []
    assert checker.function_problems({"a:f": 91}, {"a:f": 90}) == [
        "a:f: 91 lines (> 90, its ceiling in LONG_FUNCTIONS)"
    ]
    assert checker.function_problems({}, {"a:f": 90}) == [
        "a:f: fits 80 lines now; remove it from LONG_FUNCTIONS"
    ]
    assert all(n > checker.MAX_FUNCTION_LINES for n in checker.LONG_FUNCTIONS.values())


def test_upward_import_is_reported(tmp_path):
    pkg = _tree(
        tmp_path,
        {
            "io/a.py": "X = 1\n",
            "world/w.py": "from mjx_radar.io.a import X\n",
            # upward, inside a function: still reported
            "scenario/s.py": "def f():\n    from mjx_radar.world import w\n    return w\n",
        },
    )
    checker = _checker()
    problems, _ = checker.check(pkg)
    assert problems == [
        "mjx_radar.scenario.s imports mjx_radar.world.w (floor 4 world > 3 scenario)"
    ]
    assert checker.main([str(pkg)]) == 1


def test_cycles_private_names_and_cli_are_reported(tmp_path):
    pkg = _tree(
        tmp_path,
        {
            "world/a.py": "from mjx_radar.world.b import _hidden\n",
            "world/b.py": "from mjx_radar.world import a\n_hidden = 1\n",
            "task/t.py": "import mjx_radar.cli.main\n",
            "cli/main.py": "\n" * 301,
            "unknown/u.py": "",
            "world/packed.py": "x = [1,\n  2]  # fmt: skip\n",
        },
    )
    problems, _ = _checker().check(pkg)
    text = "\n".join(problems)
    assert "module cycle: mjx_radar.world.a <-> mjx_radar.world.b" in text
    assert "imports private _hidden from mjx_radar.world.b" in text
    assert "mjx_radar.task.t: library module imports mjx_radar.cli.main" in text
    assert "mjx_radar.cli.main: 301 lines (> 300)" in text
    assert "mjx_radar.unknown: package not in FLOORS" in text
    assert "mjx_radar.world.packed: '# fmt: skip' on line(s) 2" in text


def test_clean_synthetic_tree_passes(tmp_path):
    pkg = _tree(
        tmp_path,
        {"io/a.py": "X = 1\n", "world/w.py": "from mjx_radar.io import a\n"},
    )
    assert _checker().main([str(pkg)]) == 0


def test_every_package_is_installed():
    """pyproject's explicit package list names every subpackage (a wheel would lack it)."""
    import tomllib

    listed = set(
        tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"]
    )
    found = {
        ".".join(p.parent.relative_to(REPO).parts)
        for p in (REPO / "mjx_radar").rglob("__init__.py")
        if "__pycache__" not in p.parts
    }
    assert found - listed == set(), (
        f"pyproject.toml [tool.setuptools] packages lacks {found - listed}"
    )


def test_scenario_readers_ceiling_only_shrinks():
    """More readers than the ceiling is refused; fewer asks for the ceiling to come down."""
    check = _checker()
    assert check.reader_problems(10, 10) == []
    assert "> 10" in check.reader_problems(11, 10)[0]
    assert "lower MAX_SCENARIO_READERS (10) to 9" in check.reader_problems(9, 10)[0]
