"""The ``[tracker]`` table: defaults, selection of the association, one-line refusals."""

import pytest

from mjx_radar.io.checks import ScenarioError
from mjx_radar.scenario.reader import load_scenario
from mjx_radar.scenario.schema_tracker import TrackerConfig
from mjx_radar.scenario.tracker_roles import composed
from mjx_radar.task.params import shape_key


@pytest.fixture(scope="module")
def clutter():
    return load_scenario("clutter_3r4t")


def test_default_is_todays_pda(clutter):
    assert TrackerConfig().association == "pda"
    assert composed(clutter) == "pda"
    assert composed(load_scenario("smoke")) != "pda"  # no clutter: the bank or the CKF


@pytest.mark.parametrize("assoc", ["jpda", "gnn"])
def test_association_selects_the_tracker_and_its_program(clutter, assoc):
    s = clutter.replace(tracker={"association": assoc})
    assert composed(s) == assoc
    assert shape_key(s) != shape_key(clutter)  # a program of its own
    assert composed(s.replace(filter={"tracker": assoc})) == assoc  # named as composed
    with pytest.raises(ScenarioError) as err:  # a name the options do not compose
        s.replace(filter={"tracker": "pda"})
    assert str(err.value).startswith(f'filter.tracker = "pda": the options compose "{assoc}"')


def test_tracker_table_in_toml_and_through_the_cli(clutter, tmp_path):
    from mjx_radar.cli.main import main

    s = clutter.replace(tracker={"association": "jpda", "marginals": "lbp", "lbp_iterations": 7})
    path = tmp_path / "c.toml"
    s.to_toml(path)
    assert "[tracker]" in path.read_text()
    back = load_scenario(path)
    assert back.tracker == s.tracker and composed(back) == "jpda"
    assert main(["validate", str(path)]) == 0
    path.write_text(path.read_text().replace('association = "jpda"', 'association = "pmbm"'))
    assert main(["validate", str(path)]) == 2


@pytest.mark.parametrize(
    ("table", "start"),
    [
        ({"association": "pmbm"}, "tracker.association"),
        ({"marginals": "mc"}, "tracker.marginals"),
        ({"candidates": 0}, "tracker.candidates"),
        ({"lbp_iterations": 0}, "tracker.lbp_iterations"),
        ({"jpda_star": "yes"}, "tracker.jpda_star"),
        ({"association": "jpda", "candidates": 16}, "tracker.candidates = 16"),
        ({"association": "jpda", "marginals": "lbp", "jpda_star": True}, "tracker.jpda_star"),
        ({"association": "gnn", "jpda_star": True}, "tracker.jpda_star"),
        ({"tuples": 1}, "tracker.tuples"),
        ({"association": "jpda", "marginals": "multisensor", "tuples": 64}, "tracker.tuples = 64"),
        (
            {"association": "jpda", "marginals": "multisensor", "candidates": 16},
            "tracker.candidates = 16: (candidates + 1)^N",
        ),
        ({"bogus": 1}, "tracker.bogus"),
    ],
)
def test_bad_tracker_fields_give_one_line(clutter, table, start):
    with pytest.raises(ScenarioError) as err:
        clutter.replace(tracker=table)
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith(start), msg


def test_multisensor_is_a_program_of_its_own(clutter):
    s = clutter.replace(tracker={"association": "jpda"})
    ms = s.replace(tracker={"marginals": "multisensor"})
    assert composed(ms) == "jpda" and ms.tracker.tuples == 8
    assert shape_key(ms) != shape_key(s)
    assert shape_key(ms.replace(tracker={"tuples": 6})) != shape_key(ms)


def test_joint_association_needs_clutter():
    with pytest.raises(ScenarioError, match='tracker.association = "jpda": needs clutter'):
        load_scenario("smoke").replace(tracker={"association": "jpda"})
    # 17^4 events refused above; LBP has no enumeration: it reads no candidates setting
    s = load_scenario("clutter_3r4t")
    assert s.replace(tracker={"association": "jpda", "marginals": "lbp", "lbp_iterations": 9})
    with pytest.raises(ScenarioError, match="^tracker.candidates = 16: read only with tracker"):
        s.replace(tracker={"association": "jpda", "marginals": "lbp", "candidates": 16})


def test_run_option_association_sets_the_table():
    """``simulate(association=)`` and ``run --association`` (one request, no compile)."""
    from mjx_radar.api import run_case

    req = run_case.request("clutter_3r4t", association="gnn")
    assert req.scenario.tracker.association == "gnn" and composed(req.scenario) == "gnn"
    with pytest.raises(ScenarioError, match="^--association: tracker.association"):
        run_case.request("clutter_3r4t", cli=True, association="pmbm")
