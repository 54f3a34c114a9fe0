"""``mjx-radar validate``'s summary names what each scenario adds to the flat open world,
and the progress bar's clock restarts when the simulation starts (not counting compiling)."""

from __future__ import annotations

import importlib
import io

import pytest

cli_main = importlib.import_module("mjx_radar.cli.main")


@pytest.mark.parametrize(
    "name, words",
    [
        ("smoke", ["flat open ground, no obstacles"]),
        ("hills_4r4t", ["terrain 1600 x 1600 m (hills.png)"]),
        ("clutter_3r4t", ["detection swerling1 with clutter"]),
        ("town_4r4t", ["52 obstacles", "2 moving obstacles"]),
        ("mixed_6r4t", ["2 fixed radar sites"]),
    ],
)
def test_validate_summary(name, words, capsys):
    assert cli_main.main(["validate", name]) == 0
    out = capsys.readouterr().out
    assert out.startswith(f"ok: {name}: ") and all(w in out for w in words), out
    assert "0 obstacles" not in out


def test_bar_phase_restarts_the_clock():
    from tqdm import tqdm

    from mjx_radar.api.simulate import bar_phase

    with tqdm(total=10, file=io.StringIO()) as bar:
        phase = bar_phase(bar)
        phase("compiling")
        assert bar.desc.startswith("compiling")
        bar.start_t -= 100.0  # 100 s of compiling
        phase("simulating")
        assert bar.desc.startswith("simulating") and bar.n == 0 and bar.total == 10
        assert bar._time() - bar.start_t < 5.0  # the rate no longer counts the compile
