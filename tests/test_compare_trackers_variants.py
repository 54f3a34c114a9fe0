"""The variant names of benchmarks/studies/compare_trackers.py:
``NAME[-settleStoK][-missQ][-gateN][-assocA][-ground][-consensusS][-altH]``
become the scenario tables they say (docs/tracking.md), and malformed names are refused."""

import importlib.util
import sys
from pathlib import Path

import pytest

import mjx_radar

STUDIES = Path(__file__).resolve().parents[1] / "benchmarks" / "studies"


@pytest.fixture(scope="module")
def ct():
    sys.path.insert(0, str(STUDIES.parent))  # compare_trackers imports benchmarks/results.py
    spec = importlib.util.spec_from_file_location(
        "compare_trackers_script", STUDIES / "compare_trackers.py"
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def clutter():
    return mjx_radar.load_scenario("clutter_3r4t")


def test_suffixes_set_the_gate_and_the_association_term(ct, clutter):
    s = ct.variant(clutter, "mht-jpda-256-gate4-assoc10")
    assert (s.tracker.association, s.tracker.hypotheses, s.tracker.branch_scans) == ("mht", 256, 1)
    assert s.detection.gate_probability == pytest.approx(0.9999, abs=1e-15)
    assert s.mpc.alpha_assoc == 10.0
    assert s.name == "clutter_3r4t_mht_jpda_256_gate4_assoc10"
    plain = ct.variant(clutter, "mht-jpda-256")
    assert plain.detection.gate_probability == clutter.detection.gate_probability == 0.99
    assert plain.mpc.alpha_assoc == 0.0


def test_settle_suffix_keeps_the_variants_tracker(ct, clutter):
    s = ct.variant(clutter, "mht-jpda-1024-settle40to64-gate4")
    t = s.tracker
    assert (t.hypotheses, t.branch_scans, t.merge_screen) == (1024, 1, 2)
    assert (t.settle_scans, t.settled_hypotheses) == (40, 64)
    assert s.detection.gate_probability == pytest.approx(0.9999, abs=1e-15)
    s = ct.variant(clutter, "mht-jpda-1024-settle40to64-miss0.5-assoc10")
    assert (s.tracker.settle_scans, s.tracker.miss_noise, s.mpc.alpha_assoc) == (40, 0.5, 10.0)


def test_ground_and_consensus_suffixes(ct, clutter):
    s = ct.variant(clutter, "mht-jpda-1024-settle100to64-gate4-assoc10-ground-consensus2.5")
    t = s.tracker
    assert (t.hypotheses, t.settle_scans, t.estimate, t.consensus_scale) == (
        1024,
        100,
        "consensus",
        2.5,
    )
    assert s.filter.ground_prior and s.mpc.alpha_assoc == 10.0
    assert s.name.endswith("_assoc10_ground_consensus2p5")
    plain = ct.variant(clutter, "mht-jpda")
    assert not plain.filter.ground_prior and plain.tracker.estimate == "best"
    alt = ct.variant(clutter, "mht-jpda-ground-consensus5-alt40")
    assert (alt.tracker.height_std, alt.tracker.birth_height) == (40.0, 60.0)
    assert plain.tracker.height_std == 0.0


def test_the_gate_keeps_the_variants_own_detection_edits(ct, clutter):
    s = ct.variant(clutter, "known-gate6")  # known: the labelled scans (no clutter)
    assert s.detection.clutter_density == 0.0
    assert s.detection.gate_probability == pytest.approx(0.999999, abs=1e-15)


@pytest.mark.parametrize(
    ("name", "known"),
    [
        ("mht-jpda-gate6", True),
        ("jpda-gate4-assoc30", True),
        ("mht-jpda-512", True),
        ("mht-jpda-gate", False),
        ("mht-jpda-gate7", False),  # beyond the scenario's largest gate, 0.999999
        ("jpda-assoc", False),
        ("mht-jpda-gatex", False),
        ("nope-gate4", False),
        ("jpda-assoc1x", False),
        ("jpda-assoc10-gate4", False),  # the order is -gateN, then -assocA
        ("mht-jpda-1024-settle40to64-gate4-assoc10", True),
        ("mht-jpda-settle40", False),
        ("mht-jpda-settle40to0", False),
        ("mht-jpda-settlextoy", False),
        ("mht-jpda-gate4-settle40to64", False),  # -settle comes first
        ("mht-jpda-settle40to64-miss0.5-gate4", True),
        ("mht-jpda-miss2", True),
        ("mht-jpda-missx", False),
        ("mht-jpda-miss", False),
        ("mht-jpda-miss0.5-settle40to64", False),  # -settle before -miss
        ("mht-jpda-1024-settle100to64-gate4-assoc10-ground-consensus5", True),
        ("mht-jpda-ground", True),
        ("mht-jpda-consensus2.5", True),
        ("mht-jpda-ground-assoc10", False),  # -ground after -assocA
        ("mht-jpda-groundx", False),
        ("mht-jpda-consensus0", False),
        ("mht-jpda-consensus", False),
        ("mht-jpda-consensus5-ground", False),  # -ground before -consensusS
        ("mht-jpda-1024-settle200to64-gate4-assoc10-ground-consensus5-alt40", True),
        ("mht-jpda-alt0", False),
        ("mht-jpda-alt40-ground", False),  # -altH comes last
    ],
)
def test_known_variant(ct, name, known):
    assert ct.known_variant(name) is known
