"""The generic basis's groups for physics the library lacks (issue 18): a hysteresis that
remembers the direction of the last load change, and a loss while the speed changes.

A recording synthesised with the repository's synthesiser plus a transducer hysteresis (a Dahl
state driven by the output torque: not the play operator the diagnosis uses) is reported as
unexplained and follows the load-change direction; one plus a loss sign(w) c |dw/dt| follows
the acceleration against the motion. Neither is named a library effect (an offset, an inertia).
The clean twins of both plans report nothing.
"""
from types import SimpleNamespace

import numpy as np
import pytest

from cyclo_fmu.diagnosis import Diagnoser
from cyclo_fmu.diagnosis.residual import (GROUP_READING, PLAY_RANGE_SHARE, generic_basis,
                                          noise_width, play_state, play_width)
from cyclo_fmu.synth import synthesize


def as_recording(r):
    return SimpleNamespace(time=r["time_s"], speed_in=r["speed_in_rpm"] * np.pi / 30,
                           torque_in=r["torque_in_Nm"], speed_out=r["speed_out_rpm"] * np.pi / 30,
                           torque_out=r["torque_out_Nm"], temperature=r.get("temperature_C"))


def dahl(T, T0):
    """Dahl's hysteresis state (Dahl 1968) driven by the output torque T [N*m]: dh/dT =
    (sgn(dT) - h) / T0 along |dT|, h in [-1, 1]; it moves towards the direction of the load
    change over a change of about T0 and keeps its value while the load is held."""
    dT = np.diff(T, prepend=T[0])
    h = np.empty(len(T))
    x = 0.0
    for i, d in enumerate(dT.tolist()):
        x += (np.sign(d) - x) * min(abs(d) / T0, 1.0)
        h[i] = x
    return h


#: [rad/s^2] the synthesiser's speed ramps (1500 r/min per s)
RAMP_ALPHA = 1500.0 * np.pi / 30

FORMS = {
    # a torque transducer's hysteresis of 6 mN*m (0.06 % of a 10 N*m range: the datasheets'
    # 0.05-0.1 %), switching branch over 0.3 N*m of output torque
    "hysteresis": lambda s: 0.006 * dahl(s["tau_out"], 0.3),
    # a loss against the motion of 6 mN*m at the ramps' acceleration (a slipping coupling)
    "acceleration loss": lambda s: np.sign(s["w_in"]) * 0.006 / RAMP_ALPHA * np.abs(
        s["alpha_in"]),
    "none": None,
}
GROUP = {"hysteresis": "load-change direction",
         "acceleration loss": "acceleration against the motion"}


def _diagnose(form, seed, mode, plan):
    r = synthesize("none", seed, mode, "small", added_torque=FORMS[form], plan=plan)
    return r, Diagnoser(None, mode).fit(as_recording(r)).diagnosis_


def test_the_play_state_keeps_the_direction_of_the_last_change():
    """+1 while rising beyond the width 2 r, -1 while falling; through a hold whose wander
    stays within the play the play's output holds and the state stays on its branch (it moves
    inside the play linearly, as a Prandtl-Ishlinskii hysteron does); 0 before the first
    change; a partial reversal by r lies half way."""
    r = 0.1
    x = np.concatenate([np.linspace(0, 1, 50), np.full(20, 1.0) + 0.05 * np.sin(np.arange(20)),
                        np.linspace(1, 0, 50), np.full(10, 0.0), [0.1]])
    s = play_state(x, r)
    assert s[0] == 0.0
    assert np.allclose(s[12:50], 1.0)              # rising
    assert np.all(s[50:70] >= -1e-12)             # held: the wander (0.1 < 2 r) keeps the branch
    assert np.allclose(s[110:130], -1.0)           # fallen, held
    assert s[-1] == pytest.approx(0.0)            # back up by r: half way between the branches
    assert np.all(np.abs(s) <= 1.0 + 1e-12)


def test_widths_come_from_the_measurement():
    """The play's half width is PLAY_RANGE_SHARE of the load's range where that exceeds the
    noise rule; the noise rule reads white noise of sigma as sigma (to the MAD's accuracy)
    and does not take a ramp for noise."""
    rng = np.random.default_rng(3)
    t = np.arange(20000) * 0.01
    x = 0.02 * rng.standard_normal(len(t))
    assert noise_width(x, 0.01, sigmas=1.0) == pytest.approx(0.02, rel=0.05)
    ramp = x + 0.05 * t           # a steady ramp (5e-4 per block) adds no noise
    assert noise_width(ramp, 0.01, sigmas=1.0) == pytest.approx(0.02, rel=0.05)
    steps = np.where((t // 10) % 2 == 0, 2.0, 7.0) + x
    assert play_width(steps, 0.01) == pytest.approx(PLAY_RANGE_SHARE * 5.0, rel=0.05)


def test_the_new_columns_avoid_the_library_signatures():
    """No new column is a constant (the offset) or proportional to dw/dt (an inertia): the
    acceleration group is even in the acceleration or saturates; every group has a reading.
    (A plan of held speeds with ramps between them; in a plan that never holds its speed, a
    loss at a level while the speed changes is an offset: no column can tell them apart.)"""
    rng = np.random.default_rng(4)
    n = 3000
    t = np.arange(n) * 0.01
    w = np.interp(t, [0, 5, 6, 12, 13, 18, 20, 30], [100, 100, 250, 250, 150, 150, 300, 300])
    a = np.gradient(w, t) + rng.standard_normal(n)
    T = 4 + 2 * np.sin(0.3 * t) + 0.01 * rng.standard_normal(n)
    G, groups = generic_basis({"t": t, "w_in": w, "T_out": T, "alpha": a})
    assert set(groups) <= set(GROUP_READING)
    for name in ("load-change direction", "acceleration against the motion"):
        X = G[:, [i for i, g in enumerate(groups) if g == name]]
        for lib in (np.ones(n), a):
            c = np.linalg.lstsq(X, lib, rcond=None)[0]
            resid = lib - X @ c
            assert np.linalg.norm(resid) > 0.3 * np.linalg.norm(lib)


@pytest.mark.parametrize("form, seed, mode, plan", [
    ("hysteresis", 51, "S1", "full"),
    ("acceleration loss", 54, "S2", "four_quadrant")])
def test_physics_outside_the_library_follows_its_group(form, seed, mode, plan):
    """Nothing of the library named; a remainder beyond its twins, of the hidden torque's size
    (the play's state stands for the Dahl state within a fifth of its RMS), whose largest part
    follows the group of its physics, read as that physics in the statement."""
    r, D = _diagnose(form, seed, mode, plan)
    u = D.unexplained
    truth = r["truth"]["extra_torque_rms_Nm"]
    assert [e["id"] for e in D.effects] == []
    assert u["present"] and u["claims"]["structure"]["p_value"] < u["false_alarm_rate"]
    best = max(u["follows"], key=u["follows"].get)
    assert best == GROUP[form]
    assert 0.7 * truth <= u["follows"][best] <= 1.3 * truth
    assert GROUP_READING[best] in u["statement"]


@pytest.mark.parametrize("seed, mode, plan", [(53, "S1", "full"), (52, "S2", "four_quadrant")])
def test_clean_twins_of_the_plans_report_nothing(seed, mode, plan):
    _, D = _diagnose("none", seed, mode, plan)
    assert D.effects == [] and not D.unexplained["present"]
