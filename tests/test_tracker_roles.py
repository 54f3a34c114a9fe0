"""The tracker's roles (scenario.tracker_roles): each option picks a role, and a
combination the composed tracker would not read (silently ignored before) is one line
naming the field and what is allowed."""

from __future__ import annotations

import pytest

import mjx_radar
from mjx_radar.io.checks import ScenarioError
from mjx_radar.scenario.reader import load_scenario
from mjx_radar.scenario.tracker_roles import Roles, composed, roles

PER_TARGET = {"structure": "per-target"}


@pytest.fixture(scope="module")
def smoke():
    return load_scenario("smoke")


@pytest.fixture(scope="module")
def clutter():
    return load_scenario("clutter_3r4t")


def test_roles_of_the_options(smoke, clutter):
    assert roles(smoke) == Roles("ckf", None, "known", None) and composed(smoke) == "ckf"
    bank = smoke.replace(filter=PER_TARGET)
    assert composed(bank) == "bank" and composed(bank.replace(filter={"form": "sqrt"})) == "bank"
    imm = bank.replace(filter={"motion": "imm"})
    assert roles(imm).form == "imm" and composed(imm) == "imm"
    assert roles(clutter) == Roles("bank", "pda", "known", None) and composed(clutter) == "pda"
    for assoc in ("jpda", "gnn", "mht"):
        assert composed(clutter.replace(tracker={"association": assoc})) == assoc
    managed = clutter.replace(tracker={"management": "managed"})
    assert roles(managed) == Roles("bank", "pda", "managed", None)
    assert composed(managed) == "managed"


@pytest.mark.parametrize(
    ("name", "filt", "tracker", "start"),
    [  # each combination ran before, one of its options ignored
        ("smoke", {**PER_TARGET, "tracker": "ckf"}, {}, 'filter.tracker = "ckf": the options'),
        ("smoke", {"tracker": "bank"}, {}, 'filter.tracker = "bank": the options compose "ckf"'),
        ("smoke", {**PER_TARGET, "tracker": "imm"}, {}, 'filter.tracker = "imm"'),
        ("smoke", {**PER_TARGET, "tracker": "pda"}, {}, 'filter.tracker = "pda"'),
        ("smoke", {**PER_TARGET, "tracker": "mht"}, {}, 'filter.tracker = "mht"'),
        ("clutter_3r4t", {"tracker": "bank"}, {}, 'filter.tracker = "bank"'),
        ("clutter_3r4t", {"tracker": "gnn"}, {"association": "jpda"}, 'filter.tracker = "gnn"'),
        ("smoke", {"imm_turn_rate": 0.3}, {}, "filter.imm_turn_rate = 0.3: read only with filt"),
        ("smoke", {}, {"max_tracks": 8}, "tracker.max_tracks = 8: read only with tracker.man"),
        ("smoke", {}, {"candidates": 3}, "tracker.candidates = 3: read only with tracker.assoc"),
        ("clutter_3r4t", {}, {"marginals": "lbp"}, 'tracker.marginals = "lbp": read only with'),
        ("clutter_3r4t", {}, {"association": "gnn", "hypotheses": 8}, "tracker.hypotheses = 8"),
        ("clutter_3r4t", {}, {"association": "jpda", "tuples": 4}, "tracker.tuples = 4"),
        (
            "clutter_3r4t",
            {},
            {"association": "mht", "lbp_iterations": 5},
            "tracker.lbp_iterations = 5",
        ),
        ("raid_4r8t", {}, {"birth_scans": 2}, "tracker.birth_scans = 2: read only with"),
        (
            "clutter_3r4t",
            {},
            {"management": "managed", "association": "mht"},
            'tracker.association = "mht": the managed tracker takes "pda", "gnn", "jpda" or',
        ),
        (
            "clutter_3r4t",
            {},
            {"management": "managed", "association": "jpda"},
            'tracker.marginals = "exact": the managed tracker\'s JPDA takes "lbp"',
        ),
        (
            "raid_4r8t",
            PER_TARGET,
            {"management": "managed", "association": "gnn", "candidates": 3},
            'tracker.candidates = 3: read only with tracker.management = "known"',
        ),
    ],
)
def test_an_ignored_option_is_one_line(name, filt, tracker, start):
    with pytest.raises(ScenarioError) as err:
        load_scenario(name).replace(filter=filt, tracker=tracker)
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith(start), msg


def test_options_the_roles_read_are_kept(smoke, clutter):
    assert smoke.replace(filter={**PER_TARGET, "motion": "imm", "imm_turn_rate": 0.3})
    assert smoke.replace(filter={**PER_TARGET, "tracker": "bank"})  # named as composed
    assert clutter.replace(tracker={"association": "jpda", "marginals": "lbp", "lbp_iterations": 5})
    assert clutter.replace(tracker={"association": "gnn", "candidates": 3})
    assert clutter.replace(tracker={"management": "managed", "max_tracks": 8})
    assert clutter.replace(tracker={"management": "managed", "birth_scans": 2})


def test_a_registered_tracker_replaces_the_roles(smoke):
    """A whole tracker of its own may read any option: none is refused for it."""
    mjx_radar.register_tracker("roles_mine", lambda task, params: None)
    try:
        s = smoke.replace(filter={"tracker": "roles_mine", "imm_turn_rate": 0.3})
        assert roles(s).plugin == "roles_mine" and composed(s) == "roles_mine"
    finally:
        mjx_radar.unregister_tracker("roles_mine")
