"""A burst is judged against the residual *before* its events (a transient follows its event).

Batch 2's ``x05_backlash_rev_800`` (``benchmarks/independent/gen2.py``, written without
reading the diagnosis) hides a ring-out at every speed reversal: 150 mN*m peak, 12 Hz,
decaying in 80 ms, over 0.5 s. Judged against flanks on both sides of the events, the ring's
own tail (still above the noise 0.1-0.3 s after the reversal) stood in the flank after it,
and on ranks its tail counted as much as its head: p = 0.007 at a per-kind rate of 0.25 %,
nothing reported. Against the flank before the events it stands at p = 5e-5.
"""
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from cyclo_fmu.diagnosis import Diagnoser

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks" / "independent"))
import gen2  # noqa: E402


def test_a_ring_out_after_every_speed_reversal_stands_against_the_residual_before():
    case = next(c for c in gen2.CASES if c["id"] == "x05_backlash_rev_800")
    data, _ = gen2.build(case)
    rec = SimpleNamespace(time=data["time_s"], speed_in=data["speed_in_rpm"] * np.pi / 30,
                          torque_in=data["torque_in_Nm"], torque_out=data["torque_out_Nm"],
                          speed_out=data["speed_out_rpm"] * np.pi / 30, temperature=None)
    d = Diagnoser(None, "S1").fit(rec).diagnosis_
    assert not d.effects
    u = d.unexplained
    assert u["present"]
    assert "speed reversals" in u["bursts"]["tied"]
    chk = u["claims"]["bursts"]["speed reversals"]
    assert chk["p_value"] <= chk["false_alarm_rate"]
