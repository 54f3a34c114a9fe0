"""Method names on the command line: any case, each once (issue 26).

``study --methods stationary,stationary`` used to simulate both and then end in
``ValueError: Index contains duplicate entries, cannot reshape``; ``DDR-SFIM`` was
refused by ``run`` (argparse choices) but not recognised by ``study``. Names are now
matched case-insensitively to the canonical name, and a repeated name counts once (in
the order of its first appearance), for ``run --method`` and ``study --methods`` alike.
"""

from __future__ import annotations

import argparse
import json

import pytest

from mjx_radar.cli.args import method_list, method_name
from mjx_radar.cli.main import build_parser, main
from mjx_radar.errors import InputError
from mjx_radar.study import driver


@pytest.mark.parametrize(
    "text, expected",
    [
        ("stationary,stationary", ["stationary"]),
        ("DDR-SFIM", ["ddr-sfim"]),
        ("ddr-sfim, DDR-SFIM ,Stationary,ddr-sfim", ["ddr-sfim", "stationary"]),
        ("ccr-pfim,,stationary,", ["ccr-pfim", "stationary"]),
    ],
)
def test_method_list_canonical_each_once(text, expected):
    assert method_list(text) == expected


@pytest.mark.parametrize("text", ["greedy", "ddr_sfim", "stationary,nope", ",", ""])
def test_method_list_refuses_unknown_or_empty(text):
    with pytest.raises(argparse.ArgumentTypeError):
        method_list(text)


def test_run_method_any_case():
    assert method_name(" CCR-PFIM ") == "ccr-pfim"
    args = build_parser().parse_args(["run", "smoke", "--method", "DDR-SFIM"])
    assert args.method == "ddr-sfim"
    args = build_parser().parse_args(["study", "smoke", "--methods", "Stationary,STATIONARY",
                                      "--out", "x"])  # fmt: skip
    assert args.methods == ["stationary"]


@pytest.mark.parametrize(
    "argv",
    [["run", "smoke", "--method", "greedy"], ["study", "smoke", "--methods", "stationary,greedy"]],
)
def test_unknown_method_one_line(argv, tmp_path, capsys):
    assert main([*argv, "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "'greedy' is not one of stationary" in err, err
    assert not (tmp_path / "o").exists()


def test_library_refuses_repeated_methods():
    """A caller that bypasses the command line (the Python API) gets one line too."""
    with pytest.raises(InputError, match="'stationary' given twice"):
        driver.load_scenarios(["smoke"], ["stationary", "stationary"], 2, 8, 0, 2, "analytic")
    with pytest.raises(InputError, match="'DDR-SFIM' is not one of"):
        driver.load_scenarios(["smoke"], ["DDR-SFIM"], 2, 8, 0, 2, "analytic")


def test_study_with_repeated_methods_completes(tmp_path, capsys):
    out = tmp_path / "study"
    argv = ["study", "smoke", "--methods", "stationary,STATIONARY,stationary"]
    argv += ["--rollouts", "analytic", "--steps", "8", "--trials", "2", "--chunk", "2"]
    argv += ["--out", str(out)]
    assert main(argv) == 0, capsys.readouterr().err
    meta = json.loads((out / "study.json").read_text())
    assert meta["methods"] == ["stationary"]
    assert [p.name for p in (out / "chunks").iterdir()] == ["smoke__stationary__0-1.parquet"]
