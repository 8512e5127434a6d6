"""The losses through standstill (pre-sliding): the model's loss torque times tanh(|w|/w_c)
(model_core.friction.loss_transition, design field extra.loss_transition), one formula in the
replay, both FMUs, the synthesiser and the diagnosis's ``loss_transition`` effect."""
from dataclasses import replace

import numpy as np
import pytest

from model_core import DriveDesign
from model_core.design import validate_design
from model_core.errors import CycloidInputError
from model_core.friction import loss_transition
from model_core.lossmap import replay_input_torque

W = np.array([-30.0, -1.0, -0.2, -0.05, -1e-3, 0.0, 1e-3, 0.05, 0.1, 0.2, 1.0, 30.0])


def _with(w_c):
    d = DriveDesign()
    return replace(d, extra=replace(d.extra, loss_transition=w_c))


def test_share_limits():
    """0 <= s <= 1, even in w, increasing in |w|, tanh(1) at |w| = w_c; w_c = 0 is the model
    (s = 1 everywhere); w_c -> 0 tends to it away from standstill."""
    s = loss_transition(W, 0.1)
    assert np.all((s >= 0) & (s <= 1))
    assert np.array_equal(s, loss_transition(-W, 0.1))
    assert np.all(np.diff(s[W >= 0]) >= 0)
    assert loss_transition(0.1, 0.1) == pytest.approx(np.tanh(1.0), rel=1e-15)
    assert np.array_equal(loss_transition(W, 0.0), np.ones_like(W))
    far = W[np.abs(W) >= 1e-3]
    assert np.all(loss_transition(far, 1e-6) == 1.0)


@pytest.mark.parametrize("tau_out", [-5.0, 5.0, -0.5])
def test_replay_keeps_the_loss_sign_and_the_model_away_from_standstill(tau_out):
    """The loss torque with the transition is s times the model's: never of the other sign
    (what dissipates still dissipates: loss * w >= 0 where the model's does), never larger;
    equal to the model's (to the bit) where tanh saturates (|w| >= 20 w_c); w_c = 0 is the
    model to the bit."""
    t = np.full(W.shape, tau_out)
    T0, L0 = replay_input_torque(DriveDesign(), "S1", W, t)
    T1, L1 = replay_input_torque(_with(0.1), "S1", W, t)
    Tz, Lz = replay_input_torque(_with(0.0), "S1", W, t)
    assert np.array_equal(Tz, T0)
    assert np.all(L1 * L0 >= 0) and np.all(np.abs(L1) <= np.abs(L0))
    assert np.all(L1 * W >= np.minimum(L0 * W, 0.0))
    far = np.abs(W) >= 2.0
    assert np.array_equal(T1[far], T0[far])
    np.testing.assert_allclose(L1, loss_transition(W, 0.1) * L0, rtol=1e-12, atol=1e-15)
    assert L1[W == 0.0] == 0.0


@pytest.mark.parametrize("bad", [-0.1, float("nan"), float("inf")])
def test_bad_width_names_the_field(bad):
    with pytest.raises(CycloidInputError, match="extra.loss_transition"):
        validate_design(_with(bad))


@pytest.mark.parametrize("seed, mode", [(3, "S1"), (4, "S2")])
def test_a_clean_hoist_names_nothing(seed, mode):
    """A hoist lifting and lowering payloads at creeping speeds from 1.5 r/min (synth plan
    'hoist') with the model's own losses: nothing named, nothing unexplained (the effect that
    is hidden, named and closed: tests/test_diagnosis.py, tests/test_bench_replay.py)."""
    from cyclo_fmu.diagnosis import Diagnoser
    from cyclo_fmu.synth import synthesize
    from types import SimpleNamespace
    r = synthesize("none", seed, mode, duration=40.0, plan="hoist", friction_error=0.0)
    rec = SimpleNamespace(time=r["time_s"], speed_in=r["speed_in_rpm"] * np.pi / 30,
                          torque_in=r["torque_in_Nm"], speed_out=r["speed_out_rpm"] * np.pi / 30,
                          torque_out=r["torque_out_Nm"], temperature=None)
    from model_core.effects import DEFAULT_CANDIDATES, OPT_IN
    for cands in (None, DEFAULT_CANDIDATES + OPT_IN):     # by default, and asked for
        d = Diagnoser(DriveDesign(), mode, candidates=cands).fit(rec).diagnosis_
        assert d.effects == [] and not d.unexplained["present"], d.unexplained["statement"]
