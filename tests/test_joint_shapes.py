"""A candidate effect is judged with the shapes of the effects already selected re-chosen beside
it (``selection.stepwise``).

In a forward-only plan a zero offset and the decay of a Stribeck friction are partly alike: a
Stribeck speed stretched far beyond the true one (150 rad/s for 30) stands in for both at
once. Judged against that stretched shape, the offset explained nothing held out and was not
named; 12 mN*m of Stribeck friction were named for 6, with 1 mN*m left "unexplained". Judged
with the Stribeck's shape re-chosen beside it, the pair is found at its own shapes.

The recording is batch 1's ``m03_offset_stribeck_500`` (``benchmarks/independent/gen.py``,
written without reading the diagnosis): 7 mN*m zero offset + sgn(w) exp(-|w|/30 rad/s), 6 mN*m
RMS, speed stairs 300-1600 r/min forward at 500 Hz.
"""
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from cyclo_fmu.diagnosis import Diagnoser

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks" / "independent"))
import gen  # noqa: E402


def _recording(case_id):
    case = next(c for c in gen.CASES if c["id"] == case_id)
    data, truth = gen.build(case)
    return SimpleNamespace(time=data["time_s"], speed_in=data["speed_in_rpm"] * np.pi / 30,
                           torque_in=data["torque_in_Nm"], torque_out=data["torque_out_Nm"],
                           speed_out=data["speed_out_rpm"] * np.pi / 30, temperature=None)


def test_an_offset_beside_a_stribeck_friction_is_named_at_both_shapes():
    d = Diagnoser(None, "S1").fit(_recording("m03_offset_stribeck_500")).diagnosis_
    named = {e["id"]: e for e in d.effects}
    assert set(named) == {"torque_sensor_offset", "low_speed_friction"}
    off = named["torque_sensor_offset"]["parameters"]["offset"]
    assert abs(off["value"] - 7e-3) < 0.5e-3          # the hidden 7 mN*m
    st = named["low_speed_friction"]["parameters"]
    # the hidden decay is Tustin's exponential (delta 1) at 30 rad/s, both on the grid
    assert st["w_s"]["value"] == 30.0 and st["delta"]["value"] == 1.0
    assert not d.unexplained["present"], d.unexplained["statement"]


def test_a_coulomb_plus_viscous_drag_is_the_drag_alone():
    """The same joint re-choice lets a second effect follow what one effect's single shape
    misses. A lip seal's Coulomb drag plus a viscous drag, sgn(w) (1 + |w|/150 rad/s), is a
    sum of two of the drag's own power laws (p = 0 and 1) with the same sign: the twins judge
    every claim beside such a mix at any two shapes of the grid (``twins.mixes``), so a
    Stribeck decay at 150 rad/s that bends the single power law is not named beside it
    (batch 1's ``l03_coulomb_viscous_500``, 12 mN*m RMS, catman dialect)."""
    d = Diagnoser(None, "S1").fit(_recording("l03_coulomb_viscous_500")).diagnosis_
    assert [e["id"] for e in d.effects] == ["load_independent_loss"]
    assert not d.unexplained["present"], d.unexplained["statement"]
