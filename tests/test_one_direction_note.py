"""A transducer's zero (offset or drift) named in a recording where the driving shaft turns one
way only comes with a note: a loss of the same course (constant, or following time or
temperature, opposing the motion) reads the same there, and runs in both directions separate
them (the zero keeps its sign when the motion reverses, the loss changes it)."""
import numpy as np

from cyclo_fmu.diagnosis import Diagnoser
from cyclo_fmu.diagnosis.result import _one_direction
from test_joint_shapes import _recording


def test_one_direction_ignores_a_standstill_s_noise():
    w = np.r_[np.linspace(5, 300, 50), np.full(5, -0.5), np.linspace(300, 5, 50)]
    assert _one_direction(w)                       # |w| < 1 rad/s is a standstill
    assert _one_direction(-w)
    assert not _one_direction(np.r_[w, -w])        # a reversal
    assert not _one_direction(np.zeros(10))        # never moving: no direction at all


def test_a_zero_offset_in_a_forward_recording_says_what_reads_the_same():
    d = Diagnoser(None, "S1").fit(_recording("m03_offset_stribeck_500")).diagnosis_
    assert "torque_sensor_offset" in {e["id"] for e in d.effects}
    assert any(n.startswith("torque_sensor_offset: the driving shaft turns one way only")
               for n in d.notes)
