"""benchmarks/bench_suite.py: the suite's compile profile, summed by file and test."""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent


def _bench():
    spec = importlib.util.spec_from_file_location("bench_suite", REPO / "benchmarks/bench_suite.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_summary_sums_per_file_and_ranks_tests(tmp_path):
    rows = [
        {"id": "tests/test_a.py::x", "wall": 10.0, "xla_n": 300, "xla_s": 8.0},
        {"id": "tests/test_a.py::y", "wall": 2.5, "xla_n": 1, "xla_s": 2.0, "trace_s": 0.5},
        {"id": "tests/test_b.py::z", "wall": 20.0, "xla_n": 2, "xla_s": 15.0},
    ]
    path = tmp_path / "p.jsonl"
    path.write_text("".join(json.dumps(r) + "\n" for r in rows))
    text = _bench().summarise(path, top=5)
    lines = text.splitlines()
    assert lines[0].startswith("3 tests: wall 32 s") and "303 compilations 25 s" in lines[0]
    files = lines[3:5]  # the slowest file first
    assert files[0].split() == ["20.0", "2", "15.0", "tests/test_b.py"]
    assert files[1].split() == ["12.5", "301", "10.0", "tests/test_a.py"]
    assert lines[-1].split()[-1] == "tests/test_a.py::y"


def test_summary_gives_each_workers_busy_time_and_span(tmp_path):
    rows = [
        {"id": "tests/test_a.py::x", "wall": 10.0, "worker": "gw0", "start": 100.0},
        {"id": "tests/test_a.py::y", "wall": 5.0, "worker": "gw0", "start": 130.0},
        {"id": "tests/test_b.py::z", "wall": 20.0, "worker": "gw1", "start": 101.0},
    ]  # gw0 idles 20 s between its tests: span 35 s, busy 15 s
    path = tmp_path / "p.jsonl"
    path.write_text("".join(json.dumps(r) + "\n" for r in rows))
    lines = _bench().summarise(path, top=5).splitlines()
    assert lines[1:3] == [
        "worker gw0: 2 tests, busy 15 s, first start +0 s, last end +35 s",
        "worker gw1: 1 tests, busy 20 s, first start +1 s, last end +21 s",
    ]


def test_summary_lists_the_closed_loop_programs_by_key(tmp_path):
    prog = {"key": "k1", "scenario": "smoke", "batch": 2, "kind": "sfim", "planner": "mppi"}
    rows = [
        {"id": "tests/test_a.py::x", "wall": 30.0,
         "programs": [prog | {"source": "traced", "trace_lower_s": 5.0, "xla_compile_s": 20.0}]},
        {"id": "tests/test_b.py::z", "wall": 3.0,
         "programs": [prog | {"source": "export cache", "trace_lower_s": 0.5,
                              "xla_compile_s": 1.5}]},
    ]  # fmt: skip
    path = tmp_path / "p.jsonl"
    path.write_text("".join(json.dumps(r) + "\n" for r in rows))
    lines = _bench().summarise(path, top=5).splitlines()
    assert lines[-2] == "1 closed-loop programs, 2 uses:"
    assert lines[-1] == (
        "   27.0 s  k1 smoke batch 2 kind sfim planner mppi: test_a.py::x (traced); "
        "test_b.py::z (export cache)"
    )


def test_records_the_compilations_of_a_test(tmp_path):
    """The suite's ``--compile-profile`` option, on one test that compiles 5 programs."""
    out = tmp_path / "p.jsonl"
    test = "tests/test_gospa.py::test_metrics_settings_are_host_only"
    cmd = [sys.executable, "-m", "pytest", "-q", "-n", "0", "-p", "no:cacheprovider", test]
    proc = subprocess.run([*cmd, f"--compile-profile={out}"], cwd=REPO, capture_output=True,
                          text=True, timeout=300)  # fmt: skip
    assert proc.returncode == 0, proc.stdout[-2000:]
    (rec,) = [json.loads(line) for line in out.read_text().splitlines()]
    assert rec["id"] == test and rec["xla_n"] >= 1 and rec["worker"] == "main", rec
    assert 0 < rec["xla_s"] <= rec["wall"], rec
    assert "programs" not in rec  # no closed loop in this test
