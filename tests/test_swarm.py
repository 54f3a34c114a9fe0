"""Swarm scenarios (issue 15): the bundled files validate and the generator is deterministic."""

import subprocess
import sys
from pathlib import Path

import pytest

from mjx_radar.env import placement
from mjx_radar.scenario.reader import load_scenario

ROOT = Path(__file__).resolve().parent.parent
SIZES = (8, 16, 32)


@pytest.mark.parametrize("n", SIZES)
def test_swarm_file_validates(n):
    s = load_scenario(ROOT / "scenarios" / f"swarm_{n}r{n}t.toml")
    assert (s.name, s.n_radars, s.n_targets) == (f"swarm_{n}r{n}t", n, n)
    assert not s.radar_init  # radars placed per trial by the rejection rule
    w = s.placement_half_width
    for x, y, z, vx, vy, vz in s.target_init:
        assert max(abs(x), abs(y)) <= 0.6 * w + 0.01 and 40.0 <= z <= 80.0
        assert 10.0 - 0.02 <= (vx**2 + vy**2) ** 0.5 <= 25.0 + 0.02 and vz == 0.0
    placement.check_placeable(s, s.seed, 2)  # raises ValueError if rejection fails


def test_generator_reproduces_bundled_files_byte_for_byte(tmp_path):
    """Same arguments -> same bytes, and the committed files are the generator's output."""
    for n in SIZES:
        out = tmp_path / f"{n}.toml"
        cmd = [sys.executable, str(ROOT / "scripts" / "make_swarm.py")]
        cmd += ["--radars", str(n), "--targets", str(n), "--seed", "0", "--out", str(out)]
        subprocess.run(cmd, check=True, capture_output=True)
        assert out.read_bytes() == (ROOT / "scenarios" / f"swarm_{n}r{n}t.toml").read_bytes()


def test_generator_seed_changes_layout_and_rejects_bad_input(tmp_path):
    script = str(ROOT / "scripts" / "make_swarm.py")
    outs = []
    for seed in (1, 1, 2):
        out = tmp_path / f"s{len(outs)}.toml"
        cmd = [sys.executable, script, "--radars", "3", "--targets", "5", "--seed", str(seed)]
        subprocess.run(cmd + ["--out", str(out)], check=True, capture_output=True)
        outs.append(out.read_bytes())
    assert outs[0] == outs[1] != outs[2]
    bad = subprocess.run(
        [sys.executable, script, "--radars", "0", "--targets", "3"], capture_output=True, text=True
    )
    assert bad.returncode == 2 and "--radars must be in [1, 1000], got 0" in bad.stderr
