"""Library effects are named only where they stand beside the proposed closed form.

A loss outside the library that grows with the load (here speed x load, a share of the
transmitted power) is taken up in part by the friction level, a free scale of the model's own
load-dependent losses. The discovery stage models the remainder; the named effects are then
decided again with that form in the design (``Diagnoser._decide_beside_form``). The
synthesised reducer has its friction exactly as designed, so the friction level must not be
claimed off; an effect that is really there (an inertia) stays named beside the form."""
import math

import numpy as np
import pytest

from cyclo_fmu.diagnosis import Diagnoser
from cyclo_fmu.diagnosis.discover import removed_share
from cyclo_fmu.synth import SynthSettings, synthesize
from test_discover import as_recording


def speed_times_load(c):
    """c (N*m) sgn(w) |w|/300 rad/s |tau_out|/10 N*m: c at 300 rad/s and 10 N*m."""
    return lambda s: c * np.sign(s["w_in"]) * np.abs(s["w_in"]) / 300 * np.abs(
        s["tau_out"]) / 10


def _block_noise():
    s = SynthSettings()
    return s.torque_noise / math.sqrt(0.01 * s.sample_rate)


def test_a_speed_load_loss_is_not_named_as_the_friction_level():
    r = synthesize("none", 61, "S1", "small", added_torque=speed_times_load(0.036),
                   plan="full", friction_error=0.0)
    d = Diagnoser(None, "S1").fit(as_recording(r)).diagnosis_
    assert "friction_miscalibrated" not in [e["id"] for e in d.effects]
    assert d.calibration == {}, d.calibration           # the true friction is the model's
    assert "friction_miscalibrated" in d.withdrawn
    p = d.unexplained["proposed"]
    assert d.unexplained["present"] and p and p["formula"]
    (term,) = p["design_terms"]
    assert (term["speed_exponent"], term["load_exponent"]) == (1.0, 1.0)
    assert term["coefficient_Nm"] == pytest.approx(0.036, rel=0.1)
    assert removed_share(p["heldout_rms_before_Nm"], p["heldout_rms_after_Nm"],
                         _block_noise()) >= 0.7, p
    assert "friction_miscalibrated" not in p["library_change"]


def test_an_effect_that_is_there_stays_named_beside_the_form():
    r = synthesize("inertia", 66, "S2", "small", added_torque=speed_times_load(0.03),
                   plan="full", friction_error=0.0)
    d = Diagnoser(None, "S2").fit(as_recording(r)).diagnosis_
    assert [e["id"] for e in d.effects] == ["inertia"]
    assert d.unexplained["proposed"]["formula"]

