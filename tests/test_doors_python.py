"""What differs between the Pythons we admit: arviz 0.x / 1.x (the HDI is computed here)
and JAX 0.10 / 0.11 (exported programs' locations, engine.locations)."""

from __future__ import annotations

import inspect
import warnings

import numpy as np
import pytest

from mjx_radar.engine import locations
from mjx_radar.study.metrics import hdi


def _arviz_hdi(x, prob):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        import arviz as az
    key = "hdi_prob" if "hdi_prob" in inspect.signature(az.hdi).parameters else "prob"
    return np.asarray(az.hdi(x, **{key: prob}))


@pytest.mark.parametrize("seed", range(5))
def test_hdi_equals_arviz_whichever_version(seed):
    pytest.importorskip("arviz")
    rng = np.random.default_rng(seed)
    for t in (1, 2, 7, 50, 501):
        x = rng.lognormal(size=t)
        if seed % 2:
            x = np.round(x, 1)  # ties: the first narrowest window, as arviz
        for prob in (0.5, 0.9, 0.94):
            np.testing.assert_array_equal(hdi(x, prob), _arviz_hdi(x, prob))


def test_hdi_columns_and_definition():
    x = np.array([[5.0, 1.0], [1.0, 2.0], [2.0, 3.0], [3.0, 100.0], [4.0, 4.0]])
    # 5 values, prob 0.5: windows [x_i, x_{i+2}] of the sorted column, the narrowest
    np.testing.assert_array_equal(hdi(x, 0.5), [[1.0, 3.0], [1.0, 3.0]])
    with pytest.raises(ValueError, match="no values"):
        hdi(np.zeros((0, 2)))


def test_callsites_collapse_to_their_callee():
    text = (
        '#loc1 = loc("a.py":1:1)\n#loc2 = loc("b.py":2:2)\n'
        "#loc3 = loc(callsite(#loc1 at #loc2))\n#loc4 = loc(callsite(#loc3 at #loc2))\n"
        "%0 = op loc(callsite(#loc4 at #loc1))\n"
    )
    out = locations.collapse(text)
    assert "callsite" not in out
    assert "#loc3 = loc(#loc1)" in out and "#loc4 = loc(#loc1)" in out
    assert "%0 = op loc(#loc1)" in out
    assert locations.collapse("#loc1 = loc(unknown)\n") == "#loc1 = loc(unknown)\n"


def test_function_calls_lose_their_location():
    """A call's location would become a parent frame of every operation XLA inlines."""
    text = (
        '#loc1 = loc("a.py":1:1)\n    %3 = call @f(%2) : (tensor<f32>) -> tensor<f32> loc(#loc1)\n'
        "    %4:2 = func.call @g(%3) : (tensor<f32>) -> (tensor<f32>, tensor<f32>) loc(#loc1)\n"
        "    %5 = stablehlo.add %3, %3 : tensor<f32> loc(#loc1)\n"
    )
    out = locations.collapse(text)
    assert out.count("loc(unknown)") == 2 and "stablehlo.add %3, %3 : tensor<f32> loc(#loc1)" in out
