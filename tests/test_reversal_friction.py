"""The standstill (Stribeck) friction through a speed reversal: its sign passes through zero
over a transition width w_r (pre-sliding; model_core.friction.reversal_sign, tanh(w/w_r), the
sharp sign at w_r = 0), a shape parameter of ``low_speed_friction`` that the diagnosis refines
once the effect is selected, that the design carries (``extra.stribeck_transition``) and that
the core, both FMUs (test_native_fmu: native = Python through a slow reversal) and the
synthesiser evaluate from one formula."""
from types import SimpleNamespace

import numpy as np
import pytest

from cyclo_fmu.diagnosis import Diagnoser, updated_design
from cyclo_fmu.synth import synthesize
from model_core import DriveDesign
from model_core.design import ExtraPhysics, design_from_toml, design_to_toml
from model_core.effects import EFFECTS, STRIBECK_TRANSITIONS
from model_core.errors import CycloidInputError
from model_core.friction import reversal_sign

W = np.concatenate([-np.logspace(-4, 3, 60)[::-1], [0.0], np.logspace(-4, 3, 60)])


def test_reversal_sign_is_the_sharp_sign_in_the_limit_and_odd():
    """tanh(w/w_r) -> sign(w) as w_r -> 0 (pointwise, for w != 0), exactly sign(w) at 0; odd
    in w, bounded by 1, tanh(1) at w = w_r; a negative or undefined width is refused."""
    assert np.array_equal(reversal_sign(W, 0.0), np.sign(W))
    nonzero = W != 0
    gaps = [np.max(np.abs(reversal_sign(W, r) - np.sign(W))[np.abs(W) > 1e-2])
            for r in (1e-1, 1e-2, 1e-3, 1e-4)]
    assert all(b < a for a, b in zip(gaps, gaps[1:])) and gaps[-1] < 1e-12
    for r in (0.0, 0.5, 2.0, 40.0):
        s = reversal_sign(W, r)
        np.testing.assert_array_equal(s, -reversal_sign(-W, r))
        assert np.all(np.abs(s) <= 1.0) and np.all(s[nonzero] * W[nonzero] > 0)
    assert reversal_sign(1.5, 1.5) == pytest.approx(np.tanh(1.0), rel=1e-15)
    for bad in (-1.0, float("nan")):
        with pytest.raises(ValueError, match="w_r"):
            reversal_sign(W, bad)


@pytest.mark.parametrize("w_r", [0.0, 0.3, 2.0, 25.0])
@pytest.mark.parametrize("delta", [1.0, 1.5, 2.0])
def test_the_friction_torque_dissipates_at_any_width(w_r, delta):
    """T(w) w >= 0 everywhere (the friction never feeds power), T odd, |T| <= T_s, and at
    |w| >> w_r the width changes nothing (the Stribeck decay alone)."""
    ex = ExtraPhysics(stribeck_torque=0.02, stribeck_speed=30.0, stribeck_exponent=delta,
                      stribeck_transition=w_r)
    t = ex.steady_torque(W)
    assert np.all(t * W >= 0.0) and np.all(np.abs(t) <= 0.02)
    np.testing.assert_array_equal(t, -ex.steady_torque(-W))
    far = np.abs(W) > 30 * w_r
    sharp = ExtraPhysics(stribeck_torque=0.02, stribeck_speed=30.0, stribeck_exponent=delta)
    np.testing.assert_allclose(t[far], sharp.steady_torque(W[far]), rtol=1e-12, atol=1e-300)


def test_the_sharp_sign_is_the_formula_as_before():
    """w_r = 0 (the default) is sgn(w) exp(-(|w|/w_s)^delta) to the last bit, for the
    coarse grid the diagnosis selects on and for a design without the field."""
    s = {"w_in": W}
    eff = EFFECTS["low_speed_friction"]
    for w_s, delta, w_r in eff.shape:
        assert w_r == 0.0
        np.testing.assert_array_equal(eff.basis(s, (w_s, delta, w_r))[:, 0],
                                      np.sign(W) * np.exp(-(np.abs(W) / w_s) ** delta))
    assert ExtraPhysics().stribeck_transition == 0.0
    fine = eff.shapes(s, around=eff.shape[0])
    assert set(STRIBECK_TRANSITIONS) >= {0.0} and set(eff.shape) < set(fine)
    assert {r for _, _, r in fine} == set(STRIBECK_TRANSITIONS)


def test_the_replay_evaluates_the_same_formula():
    """The diagnosis's replay of a design (effects.extra_torque) is the FMUs' steady torque
    (ExtraPhysics.steady_torque) to the last bit, width included: a design written by a
    diagnosis closes its recording only if the replay carries the width it was fitted with."""
    from model_core.effects import extra_torque
    ex = ExtraPhysics(stribeck_torque=0.02, stribeck_speed=30.0, stribeck_exponent=1.5,
                      stribeck_transition=2.0, drag_torque=0.01, drag_exponent=0.5)
    t = np.linspace(0.0, 1.0, len(W))
    got = extra_torque(ex, {"t": t, "w_in": W})
    np.testing.assert_array_equal(got, ex.steady_torque(W))
    inside = np.abs(W) < 2.0
    assert np.all(np.abs(got[inside]) < np.abs(
        ExtraPhysics(stribeck_torque=0.02, stribeck_speed=30.0, stribeck_exponent=1.5,
                     drag_torque=0.01, drag_exponent=0.5).steady_torque(W[inside])) + 1e-300)


def test_the_width_in_the_design_file_and_its_bounds():
    d = DriveDesign(extra=ExtraPhysics(stribeck_torque=0.01, stribeck_transition=1.5))
    assert design_from_toml(design_to_toml(d)) == d
    for bad in (-0.5, float("nan"), float("inf")):
        with pytest.raises(CycloidInputError, match="extra.stribeck_transition"):
            DriveDesign(extra=ExtraPhysics(stribeck_transition=bad))


def as_recording(r):
    return SimpleNamespace(time=r["time_s"], speed_in=r["speed_in_rpm"] * np.pi / 30,
                           torque_in=r["torque_in_Nm"], speed_out=r["speed_out_rpm"] * np.pi / 30,
                           torque_out=r["torque_out_Nm"], temperature=r.get("temperature_C"))


@pytest.mark.slow
@pytest.mark.parametrize("seed, shape, widths", [
    # a width between the grid's 1 and 2 rad/s: one of its neighbours
    (81, (30.0, 2.0, 1.5), (1.0, 2.0)),
    # a sharp reversal stays sharp
    (82, (30.0, 2.0, 0.0), (0.0,))])
def test_a_hidden_width_is_found_and_closes(seed, shape, widths):
    """A four-quadrant recording (speed reversals, back-driving) with a standstill friction
    of 25 mN*m whose sign passes through a reversal over ``shape[2]`` rad/s: named
    low_speed_friction with its Stribeck speed, exponent and a width next to the hidden one,
    nothing unexplained; the updated design carries the width and closes the recording."""
    r = synthesize("low_speed_friction", seed, "S1", "small", plan="four_quadrant",
                   effect_values={"T_stribeck": 0.025}, shape=shape)
    d = Diagnoser(None, "S1").fit(as_recording(r)).diagnosis_
    assert [e["id"] for e in d.effects] == ["low_speed_friction"]
    assert not d.unexplained["present"], d.unexplained["statement"]
    p = d.effects[0]["parameters"]
    assert (p["w_s"]["value"], p["delta"]["value"]) == shape[:2]
    assert p["w_r"]["value"] in widths and p["w_r"]["unit"] == "rad/s"
    assert p["T_stribeck"]["value"] == pytest.approx(0.025, rel=0.05)
    fixed, _ = updated_design(DriveDesign(), d)
    assert fixed.extra.stribeck_transition == p["w_r"]["value"]
    again = Diagnoser(fixed, "S1").fit(as_recording(r)).diagnosis_
    assert again.effects == [] and not again.unexplained["present"]


@pytest.mark.parametrize("rate, bandwidth", [(1000.0, 1000.0), (10000.0, 1000.0),
                                             (200.0, 1000.0), (1000.0, 0.0)])
def test_widened_columns_are_the_whole_columns_to_the_bit(rate, bandwidth):
    """The diagnosis forms a widened Stribeck column (w_r > 0) from its sharp one, evaluating
    the basis and the transducer's low pass only near the reversals
    (problem._Widened): the same numbers, bit for bit, as the whole column through the low
    pass and the masked block means, for any sample rate, with compared samples masked out."""
    from cyclo_fmu.diagnosis.problem import _candidates, masked_means
    from cyclo_fmu.diagnosis.replay import first_order
    rng = np.random.default_rng(3)
    dt, m = 1.0 / rate, max(1, int(round(0.01 * rate)))
    n = 40 * m * 10
    t = np.arange(n) * dt
    # reversals of several rates and a hold at standstill, with speed noise
    w = 120 * np.sin(2 * np.pi * t / 1.7) * np.abs(np.sin(2 * np.pi * t / 5.3)) ** 0.5
    w[(t > 1.0) & (t < 1.3)] = 0.0
    w += rng.normal(0, 0.05, n)
    mask = rng.random(n) > 0.05
    mask[: 3 * m] = False                 # an empty block: its plain mean
    counts = mask.reshape(-1, m).sum(1)
    eff = EFFECTS["low_speed_friction"]
    shapes = eff.shapes({"w_in": w}, around=(30.0, 2.0, 0.0))
    assert any(s[2] > 0 for s in shapes)
    cols, options, _ = _candidates({"w_in": w}, ["low_speed_friction"], True, dt, bandwidth,
                                   mask, m, counts=counts,
                                   refined={"low_speed_friction": shapes})
    for term, B in zip(options["low_speed_friction"], cols):
        whole = masked_means(first_order(eff.basis({"w_in": w}, term.shape), dt, bandwidth),
                             mask, m, counts)
        np.testing.assert_array_equal(B, whole, err_msg=str(term.shape))
