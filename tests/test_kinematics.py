"""Table 1 speed ratios (with the erratum i_S1 = +z1) and the Willis equation."""
import numpy as np
import pytest

from model_core import MODES, shaft_speeds, speed_ratio
from model_core.kinematics import parse_mode, reverse_mode

Z1 = 15
I0 = 14 / 15


@pytest.mark.parametrize("mode, expected", [
    ("12", I0), ("21", 1 / I0), ("1S", 1 / Z1), ("S1", Z1), ("2S", 1 / (1 - Z1)), ("S2", 1 - Z1)])
def test_table1_ratios(mode, expected):
    assert speed_ratio(mode, Z1) == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize("mode", MODES)
def test_willis_and_held_shaft(mode):
    w = shaft_speeds(mode, 123.4, Z1)
    a, b, h = parse_mode(mode)
    assert w[a] == pytest.approx(123.4)
    assert w[h] == 0
    assert w["1"] - I0 * w["2"] - (1 - I0) * w["S"] == pytest.approx(0, abs=1e-12)


def test_reverse_ratio_is_reciprocal():
    for mode in MODES:
        assert speed_ratio(mode, Z1) * speed_ratio(reverse_mode(mode), Z1) == pytest.approx(1)


def test_speeds_vectorised():
    w = shaft_speeds("S1", np.array([1.0, -2.0]), Z1)
    np.testing.assert_allclose(w["1"], [1 / Z1, -2 / Z1])
