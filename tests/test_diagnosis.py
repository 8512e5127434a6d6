"""Diagnosis proven on recordings with concealed effects.

Every library effect alone and pairs of them, over seeds and both S1 and S2 (with the friction
level off by up to 15 % at the same time), are named right; clean recordings (also with
spikes, heavier or coloured noise) give no effect and nothing unexplained; forms outside the
library give ``unexplained.present`` and no wrongly named effect; fitted parameters stay inside
their physical bounds; a recording with nothing to diagnose says so. The full matrix is marked
slow; the default run keeps a representative case of each kind.
"""
import math
from types import SimpleNamespace

import numpy as np
import pytest

from cyclo_fmu.diagnosis import Diagnoser, DiagnosisError, ljung_box_p, updated_design
from cyclo_fmu.synth import DEFAULT_EFFECTS, SynthSettings, paper_like, synthesize
from model_core import DriveDesign
from model_core.effects import DEFAULT_CANDIDATES, EFFECTS, OPT_IN

LIBRARY = [e for e in DEFAULT_CANDIDATES if e not in ("none", "friction_miscalibrated")]
#: the plan under which each effect is identifiable: a transducer gain error needs back-driven
#: segments (in forward driving it looks like a friction level error)
PLAN = {"torque_sensor_gain": "four_quadrant",
        # the losses through standstill show only where the drive creeps (1-3 r/min) under
        # load: a hoist's lift, creep and lowering; the other plans pass standstill in ms
        "loss_transition": "hoist"}


def as_recording(r):
    return SimpleNamespace(time=r["time_s"], speed_in=r["speed_in_rpm"] * np.pi / 30,
                           torque_in=r["torque_in_Nm"], speed_out=r["speed_out_rpm"] * np.pi / 30,
                           torque_out=r["torque_out_Nm"], temperature=r.get("temperature_C"))


def diagnose(r, mode, design=None, candidates=None):
    return Diagnoser(design, mode, candidates=candidates).fit(as_recording(r)).diagnosis_


def named(d):
    return {e["id"] for e in d.effects} - {"friction_miscalibrated"}


def inside_bounds(d):
    for e in d.effects:
        if e["id"] == "none":
            continue
        for p in EFFECTS[e["id"]].parameters:
            if p.name not in e["parameters"]:     # a shape with fewer (mesh_ripple load law 0)
                continue
            v = e["parameters"][p.name]["value"]
            assert p.lower <= v <= p.upper, (e["id"], p.name, v)


def _closes(d, r, mode):
    """Re-diagnosed with its own updated design: nothing left, at the noise floor, and the
    written design never fits worse than the plain model."""
    fixed, _ = updated_design(DriveDesign(), d)
    again = diagnose(r, mode, fixed)
    assert named(again) == set() and not again.unexplained["present"], \
        ([e["id"] for e in again.effects], again.unexplained["statement"])
    assert again.rmse_before_Nm <= d.rmse_before_Nm
    assert again.rmse_before_Nm < 1.1 * d.rmse_after_Nm + 1e-5


def _single(effect, seed, closure=False):
    mode = "S1" if seed % 2 else "S2"
    r = synthesize(effect, seed, mode, "small", plan=PLAN.get(effect, "full"))
    truth = r["truth"]
    assert effect == "none" or abs(truth["friction_error"]) <= 0.15
    # concealed: the hidden torque is comparable with the transducer noise (0.003 N*m)
    assert truth["extra_torque_rms_Nm"] < 0.02
    # an opt-in effect (model_core.effects.OPT_IN) is found where it is asked for
    d = diagnose(r, mode, candidates=DEFAULT_CANDIDATES + OPT_IN if effect in OPT_IN else None)
    assert d.effect == effect, (d.effect, [(e["id"], round(e["bic"])) for e in d.evidence[:3]])
    assert not d.unexplained["present"], d.unexplained["statement"]
    inside_bounds(d)
    if effect == "loss_transition":
        # its misfit lives where the hoist creeps (1-3 r/min: a fifth of the samples), not
        # over the whole recording: the width is found as hidden, the rmse falls
        assert d.effects[0]["parameters"]["w_c"]["value"] == truth["shape"]
        assert d.rmse_after_Nm < d.rmse_before_Nm
    elif effect != "none":
        assert d.rmse_after_Nm <= 0.5 * d.rmse_before_Nm
        # the friction level is recovered jointly (not mistaken for the effect)
        fr = d.parameters.get("mu_boundary_rel_error")
        err = fr["value"] if (fr and truth["friction_error"]) else 0.0
        # a calibration effect scales the same load-dependent losses as the friction level: a
        # friction error of a few points next to the mesh loss is taken up by k (measured: -2.5
        # points next to dk = 0.003 in S2, forward driving: k 0.00284, the level not named);
        # the closure below checks the two together. The load-loss scale holds the pins' share
        # too (it scales every contact's loss): measured -2.5 points taken up beside s = 1.12
        # (seed 12, S2), the level not named
        tol = 0.03 if effect in ("mesh_loss", "idle_loss_scale", "load_loss_scale") else 0.01
        assert err == pytest.approx(truth["friction_error"], abs=tol)
    else:
        assert d.parameters == {} and d.rmse_after_Nm == d.rmse_before_Nm
        assert d.effects == []
    if closure:
        _closes(d, r, mode)
    return d


@pytest.mark.parametrize("effect", list(DEFAULT_CANDIDATES) + list(OPT_IN))
def test_names_the_hidden_effect(effect):
    _single(effect, 11 if effect != "viscosity_drift" else 12)


@pytest.mark.slow
@pytest.mark.parametrize("effect", list(DEFAULT_CANDIDATES) + list(OPT_IN))
@pytest.mark.parametrize("seed", [12, 13, 14])
def test_names_the_hidden_effect_over_seeds(effect, seed):
    _single(effect, seed, closure=True)


PAIRS = [("load_independent_loss", "thermal_drift"), ("torque_sensor_offset", "inertia"),
         ("load_independent_loss", "mesh_ripple"), ("low_speed_friction", "inertia"),
         ("viscosity_drift", "torque_sensor_offset"), ("thermal_drift", "mesh_ripple")]


def _pair(pair, seed, mode, closure=False):
    r = synthesize(list(pair), seed, mode, "small")
    d = diagnose(r, mode)
    assert named(d) == set(pair), ([e["id"] for e in d.effects], d.unexplained["statement"])
    assert not d.unexplained["present"], d.unexplained["statement"]
    inside_bounds(d)
    # each effect carries its share of the residual, largest first
    rms = [e["explained_rms_Nm"] for e in d.effects]
    assert rms == sorted(rms, reverse=True) and min(rms) > 0
    if closure:
        _closes(d, r, mode)
    return d, r


@pytest.mark.parametrize("pair, mode", [(PAIRS[0], "S1"), (PAIRS[1], "S2"), (PAIRS[2], "S1"),
                                        (PAIRS[3], "S2")])
def test_names_both_effects_of_a_pair(pair, mode):
    _pair(pair, 21, mode)


#: re-diagnosed with its own updated design, the viscosity drift and offset of seed 23 leave
#: 0.52 mN*m of structure that a friction level 1.4 % off (not named, 0.48 mN*m) mostly
#: explains: at the reporting floor, a remainder and a sub-floor library effect cannot be told
#: apart (docs/explanation/diagnosis.md, "Tried and dropped: a sub-floor library effect")
AT_FLOOR = {(PAIRS[4], 23)}


@pytest.mark.slow
@pytest.mark.parametrize("pair", PAIRS)
@pytest.mark.parametrize("seed, mode", [(22, "S1"), (23, "S2")])
def test_names_both_effects_of_a_pair_over_seeds(pair, seed, mode, request):
    if (pair, seed) in AT_FLOOR:
        request.applymarker(pytest.mark.xfail(
            reason="closure leaves 0.52 mN*m at the 0.5 mN*m floor that a sub-floor friction "
                   "level mostly explains", strict=False))
    _pair(pair, seed, mode, closure=True)


def test_pair_parameters_are_recovered():
    d, r = _pair(("torque_sensor_offset", "inertia"), 24, "S1")
    got = {e["id"]: e["parameters"] for e in d.effects}
    assert got["inertia"]["J"]["value"] == pytest.approx(DEFAULT_EFFECTS["inertia"][0]["J"], rel=0.1)
    off = got["torque_sensor_offset"]["offset"]
    assert off["ci95"][0] < DEFAULT_EFFECTS["torque_sensor_offset"][0]["offset"] < off["ci95"][1]


# -- clean recordings: nothing named, nothing unexplained ---------------------------------
def _clean(seed, mode, **kw):
    r = synthesize("none", seed, mode, "small", **kw)
    return r


def _with_spikes(r, seed, n=10, size=0.5):
    rng = np.random.default_rng(seed)
    idx = rng.choice(len(r["time_s"]), n, replace=False)
    r["torque_in_Nm"] = r["torque_in_Nm"].copy()
    r["torque_in_Nm"][idx] += size * rng.choice([-1, 1], n)
    return r


def _coloured(r, seed, sigma=0.004, rho=0.95):
    """AR(1) noise (correlation time about 20 samples) added to the input torque."""
    from scipy.signal import lfilter
    rng = np.random.default_rng(seed)
    e = rng.standard_normal(len(r["time_s"])) * sigma * np.sqrt(1 - rho ** 2)
    r["torque_in_Nm"] = r["torque_in_Nm"] + lfilter([1], [1, -rho], e)
    return r


@pytest.mark.parametrize("case", ["plain", "spikes", "heavy", "coloured"])
def test_clean_recordings_give_nothing(case):
    mode = "S1" if case in ("plain", "heavy") else "S2"
    if case == "heavy":
        r = _clean(41, mode, settings=SynthSettings(torque_noise=0.012))
    else:
        r = _clean(41, mode)
    if case == "spikes":
        r = _with_spikes(r, 41)
    if case == "coloured":
        r = _coloured(r, 41)
    d = diagnose(r, mode)
    assert d.effects == [] and d.effect == "none", [e["id"] for e in d.effects]
    assert not d.unexplained["present"], d.unexplained["statement"]
    if case == "spikes":
        assert d.excluded_blocks >= 1 and d.unexplained["bursts"]["tied"] == []


@pytest.mark.slow
@pytest.mark.parametrize("case", ["plain", "spikes", "heavy", "coloured"])
@pytest.mark.parametrize("seed, mode", [(43, "S1"), (44, "S2"), (45, "S1")])
def test_clean_recordings_give_nothing_over_seeds(case, seed, mode):
    r = _clean(seed, mode, settings=SynthSettings(torque_noise=0.012)) if case == "heavy" \
        else _clean(seed, mode)
    if case == "spikes":
        r = _with_spikes(r, seed)
    if case == "coloured":
        r = _coloured(r, seed)
    d = diagnose(r, mode)
    assert d.effects == [] and not d.unexplained["present"], \
        ([e["id"] for e in d.effects], d.unexplained["statement"])


def test_spikes_do_not_change_the_verdict():
    r = synthesize("load_independent_loss", 42, "S1", "small")
    clean = diagnose(r, "S1")
    spiky = diagnose(_with_spikes(r, 42, n=10, size=2.0), "S1")
    assert spiky.effect == clean.effect == "load_independent_loss"
    a = clean.parameters["T_drag"]["value"]
    assert spiky.parameters["T_drag"]["value"] == pytest.approx(a, rel=0.05)
    assert spiky.excluded_blocks >= 5


# -- physics outside the library: said to be unexplained, not named as a library effect -------
def _load_squared(s):
    """A loss growing with the square of the load (e.g. a mis-sized bearing's load-squared
    friction), sign of the motion."""
    return np.sign(s["w_in"]) * 0.010 * (s["T_in_model"] / 0.8) ** 2


def _speed_times_load(s):
    """A loss growing with speed times load (a viscous loss in a loaded contact)."""
    return np.sign(s["w_in"]) * 0.012 * np.abs(s["w_in"]) / 300 * np.abs(s["T_in_model"]) / 0.8


def _mains(s):
    """Electrical pick-up at a fixed 50 Hz on the torque channel."""
    return 0.004 * np.sin(2 * np.pi * 50 * s["t"])


def _backlash(s):
    """A torque burst at every reversal of the rotation (lost motion taken up: a transient of
    about 30 ms)."""
    w, t = s["w_in"], s["t"]
    out = np.zeros_like(t)
    for i in np.flatnonzero(np.diff(np.sign(w)) != 0):
        out += 0.05 * np.sign(w[min(i + 5, len(w) - 1)]) * np.exp(-((t - t[i]) / 0.03) ** 2)
    return out


@pytest.mark.parametrize("form, seed, mode", [(_load_squared, 31, "S1"),
                                              (_speed_times_load, 32, "S2"),
                                              (_mains, 35, "S1"), (_backlash, 91, "S2")])
def test_forms_outside_the_library_are_unexplained(form, seed, mode):
    r = synthesize("none", seed, mode, "small", added_torque=form)
    d = diagnose(r, mode)
    assert d.unexplained["present"], d.unexplained
    assert d.unexplained["statement"]
    # no library effect is named for it (the friction level is exact here)
    assert d.effects == [], [e["id"] for e in d.effects]


@pytest.mark.slow
@pytest.mark.parametrize("form", [_load_squared, _speed_times_load, _mains, _backlash])
@pytest.mark.parametrize("seed, mode", [(36, "S2"), (37, "S1")])
def test_forms_outside_the_library_over_seeds(form, seed, mode):
    r = synthesize("none", seed, mode, "small", added_torque=form)
    d = diagnose(r, mode)
    assert d.unexplained["present"] and d.effects == []


@pytest.mark.parametrize("hidden, form, seed, mode", [
    ("load_independent_loss", _mains, 36, "S1"), ("inertia", _load_squared, 74, "S2"),
    ("torque_sensor_offset", _speed_times_load, 75, "S1")])
def test_a_library_effect_next_to_an_unknown_one(hidden, form, seed, mode):
    """The library effect is named, the rest is said to be unexplained; a steady library
    term that the unknown steady loss could hold (a drag) is withdrawn, and a warm-up term
    that a steady function of the operating point explains as well (the plan visits its
    operating points in time order) is not named, rather than either absorbing the unknown."""
    r = synthesize(hidden, seed, mode, "small", added_torque=form)
    d = diagnose(r, mode)
    assert named(d) == {hidden}, [e["id"] for e in d.effects]
    assert d.unexplained["present"], d.unexplained
    if form is _mains:
        assert "50.00 Hz" in d.unexplained["statement"]
    else:
        assert "operating point" in d.unexplained["statement"]


@pytest.mark.slow
@pytest.mark.parametrize("triple, seed, mode", [
    (("load_independent_loss", "inertia", "torque_sensor_offset"), 71, "S1"),
    (("low_speed_friction", "thermal_drift", "mesh_ripple"), 72, "S2")])
def test_three_effects_at_once(triple, seed, mode):
    d = diagnose(synthesize(list(triple), seed, mode, "small"), mode)
    assert named(d) == set(triple) and not d.unexplained["present"]


@pytest.mark.parametrize("form", ["drag_sqrt", "viscous"])
def test_other_drag_laws_are_a_drag(form):
    """A drag with another speed law (n^0.5, or purely viscous n^1) is still a drag: the
    exponent is the effect's shape, written to the design."""
    p = {"drag_sqrt": 0.5, "viscous": 1.0}[form]
    r = synthesize("none", 64, "S2", "small", added_torque=lambda s: np.sign(s["w_in"]) * 0.012
                   * (np.abs(s["w_in"]) / 300) ** p)
    d = diagnose(r, "S2")
    assert named(d) == {"load_independent_loss"} and not d.unexplained["present"]
    assert d.effects[0]["parameters"]["p"]["value"] == pytest.approx(p)
    fixed, _ = updated_design(DriveDesign(), d)
    assert fixed.extra.drag_exponent == pytest.approx(p)


def test_a_drag_of_another_shape_is_named_with_a_remainder():
    """A churning drag that saturates with speed (tanh(w/80 rad/s), 12 mN*m at full speed) has
    no exponent of the library's law: the drag is named (beside the generic basis it still
    explains more than twins of the recording show, or it explains DOMINANCE times more than
    the basis adds) and what its shape misses is reported unexplained."""
    r = synthesize("none", 64, "S1", "small",
                   added_torque=lambda s: 0.012 * np.tanh(s["w_in"] / 80.0))
    d = diagnose(r, "S1")
    assert named(d) == {"load_independent_loss"}, (d.effects, d.unexplained["statement"])
    assert d.rmse_after_Nm < 0.5 * d.rmse_before_Nm
    assert d.unexplained["present"], d.unexplained["statement"]


def test_output_shaft_order_is_the_mesh_ripple():
    """Ripple once per turn of the driven shaft (runout of the output flange, an eccentric pin
    circle), 8 mN*m, written by hand here (not the registry's basis): an order of the output
    speed (1/15 of the input in S1), which the library's mesh_ripple holds since it carries
    1x and 2x of both shafts. Named so, at its amplitude and phase (A sin(k theta + 0.3) =
    A cos 0.3 sin + A sin 0.3 cos), and no order is left over as unexplained."""
    from model_core.kinematics import speed_ratio
    k = 1.0 / abs(speed_ratio("S1", DriveDesign().z1))
    r = synthesize("none", 65, "S1", "small",
                   added_torque=lambda s: 0.008 * np.sin(k * s["theta_in"] + 0.3))
    d = diagnose(r, "S1")
    assert named(d) == {"mesh_ripple"} and not d.unexplained["present"], \
        d.unexplained["statement"]
    p = {n: v["value"] for n, v in d.effects[0]["parameters"].items()}
    assert np.hypot(p["Ao1_sin"], p["Ao1_cos"]) == pytest.approx(0.008, rel=0.05)
    assert np.arctan2(p["Ao1_cos"], p["Ao1_sin"]) == pytest.approx(0.3, abs=0.05)
    assert d.unexplained["orders"] == {} and d.unexplained["peaks_Hz_Nm"] == []


def test_effect_sizes_are_reported_where_the_fit_cannot_see_them():
    """A roller-pass ripple is mostly averaged out of the 10 ms means the fit runs on, so its
    drop-one figure is small; ``torque_rms_Nm`` is the RMS of its fitted torque at sample
    level, sqrt(sum A^2/2) of the hidden amplitudes. A friction level relinearised (replayed
    at the corrected level) explains what it explained at the design's own level, not the
    ~zero left in the second analysis."""
    r = synthesize("mesh_ripple", 66, "S1", "small")
    d = diagnose(r, "S1")
    (e,) = [x for x in d.effects if x["id"] == "mesh_ripple"]
    v = EFFECTS["mesh_ripple"].synth_default[0]
    assert e["torque_rms_Nm"] == pytest.approx(np.sqrt(sum(a * a for a in v.values()) / 2),
                                               rel=0.15)
    r = synthesize("none", 67, "S2", "small", friction_error=0.15)
    d = diagnose(r, "S2")
    assert d.effect == "friction_miscalibrated", [x["id"] for x in d.effects]
    assert d.effects[0]["explained_rms_Nm"] > 0.5 * d.rmse_before_Nm


def test_a_delayed_torque_channel_is_a_transient_at_the_steps():
    """The input torque recorded 20 ms late (a filter or a data-acquisition skew): the blocks
    after every load step are excluded as spikes, in bursts longer than the quasi-static
    replay's own (STEP_TRANSIENT_BLOCKS), and the mismatch is reported, not "nothing
    structured"; on time, nothing."""
    r = dict(synthesize("none", 68, "S1", "small", plan="one_speed"))
    assert not diagnose(r, "S1").unexplained["present"]
    fs = 1.0 / np.median(np.diff(r["time_s"]))
    lag = int(round(0.020 * fs))
    r["torque_in_Nm"] = np.concatenate([np.repeat(r["torque_in_Nm"][:1], lag),
                                        r["torque_in_Nm"][:-lag]])
    d = diagnose(r, "S1")
    assert d.unexplained["present"], d.unexplained["statement"]
    assert "load or speed steps" in d.unexplained["statement"]
    assert d.unexplained["rms_Nm"] > 0


# -- closure: the updated design explains the recording ------------------------------------
@pytest.mark.parametrize("hidden, mode", [("load_independent_loss", "S1"),
                                          (["torque_sensor_offset", "inertia"], "S2"),
                                          ("thermal_drift", "S1"), ("friction_miscalibrated", "S2")])
def test_updated_design_leaves_nothing(hidden, mode):
    r = synthesize(hidden, 51, mode, "small")
    d = diagnose(r, mode)
    fixed, notes = updated_design(DriveDesign(), d)
    again = diagnose(r, mode, fixed)
    assert again.effects == [] or all(
        e["explained_rms_Nm"] < 0.2 * min(x["explained_rms_Nm"] for x in d.effects)
        for e in again.effects), [(e["id"], e["explained_rms_Nm"]) for e in again.effects]
    assert not again.unexplained["present"]
    # never worse than the plain model, and at the noise floor
    assert again.rmse_before_Nm <= d.rmse_before_Nm
    assert again.rmse_before_Nm < 1.1 * d.rmse_after_Nm


def test_temperature_form_is_written_as_fitted():
    """A warm-up with a temperature column is fitted per 10 K and written that way."""
    r = synthesize("thermal_drift", 52, "S1", "small", temperature_rise=30.0,
                   effect_values={"loss_change": 0.04})
    d = diagnose(r, "S1")
    assert named(d) == {"thermal_drift"}
    e = d.effects[0]
    assert e["form"].startswith("per 10 K") and "tau" not in e["parameters"]
    # the linear law (the exponential one's limit theta -> infinity) is chosen for it
    assert "theta" not in e["parameters"] and e["form"] == "per 10 K of the temperature column"
    assert e["parameters"]["loss_change"]["value"] == pytest.approx(0.04, rel=0.15)
    fixed, _ = updated_design(DriveDesign(), d)
    assert fixed.extra.thermal_loss_per_10K == pytest.approx(e["parameters"]["loss_change"]["value"])
    assert fixed.extra.thermal_loss_change == 0.0 and fixed.extra.thermal_T_scale == 0.0
    again = diagnose(r, "S1", fixed)
    assert named(again) == set() and not again.unexplained["present"]


@pytest.mark.parametrize("theta", [10.0, 40.0])
def test_a_warm_up_exponential_in_temperature_is_named_with_its_scale(theta):
    """A warm-up whose losses follow the temperature as a viscosity does, c (theta/10 K)(1 -
    exp(-dT/theta)) (model_core.thermal.loss_temperature_law), the temperature rising 30 K:
    the diagnosis chooses theta on its grid (linear, 10, 20, 40, 80 K) by BIC and held-out
    error, with c (the change per 10 K at the column's first value) within its size, and
    writes both; the design it writes leaves nothing (the replay evaluates the same law)."""
    from model_core.effects import TemperatureScale
    r = synthesize("thermal_drift", 53, "S1", "small", temperature_rise=30.0,
                   temperature_tau=40.0, shape=TemperatureScale(theta),
                   effect_values={"loss_change": -0.2})
    d = diagnose(r, "S1")
    assert named(d) == {"thermal_drift"}
    e = d.effects[0]
    assert e["parameters"]["theta"] == {"value": theta, "unit": "K", "ci95": None}
    assert e["form"] == f"per 10 K of the temperature column, exponential law (theta {theta:g} K)"
    assert e["parameters"]["loss_change"]["value"] == pytest.approx(-0.2, rel=0.15)
    fixed, _ = updated_design(DriveDesign(), d)
    assert fixed.extra.thermal_T_scale == theta
    again = diagnose(r, "S1", fixed)
    assert named(again) == set() and not again.unexplained["present"]


# -- what cannot be told apart, and nothing to diagnose -------------------------------------
def test_says_when_the_data_cannot_tell_effects_apart():
    """One speed, one direction, no run-up: an offset, a drag and a Stribeck torque are all
    constants. The diagnosis must say so and name the run that would separate them."""
    r = synthesize("torque_sensor_offset", 3, "S1", "small", plan="one_speed")
    keep = r["time_s"] > 5.0
    r = {k: (v[keep] if k != "truth" else v) for k, v in r.items()}
    d = diagnose(r, "S1")
    # the idle-loss scale (the model's own bearing, seal and grease laws, a constant at one
    # speed) is one of the constants too
    assert d.effect in ("torque_sensor_offset", "load_independent_loss", "low_speed_friction",
                        "idle_loss_scale")
    alike = set(d.indistinguishable_from + [d.effect])
    assert "torque_sensor_offset" in alike
    assert alike & {"load_independent_loss", "idle_loss_scale"}
    assert "both directions" in d.suggested_test
    full = diagnose(synthesize("torque_sensor_offset", 3, "S1", "small"), "S1")
    assert full.effect == "torque_sensor_offset" and full.indistinguishable_from == []


def test_gain_error_is_not_taken_for_friction_in_forward_driving():
    """Forward driving only (no back-driven segment): a transducer gain error scales the whole
    input torque. Under the physical profile the friction level's sensitivity is not
    proportional to load (Stribeck pin law, load-independent drag), so the gain's signature
    fits the residual better than any friction level, but telling them apart that way rests on
    the model's friction law; only back-driven segments (the losses change side, a gain error
    does not) separate them independently of it. The diagnosis therefore does not name a
    gain error here; it must not report a friction level as the explanation, and must say that
    a gain error explains the data, and which run separates them."""
    r = synthesize("torque_sensor_gain", 11, "S1", "small")   # no back-driven segment
    d = diagnose(r, "S1")
    assert "torque_sensor_gain" not in named(d)
    if d.effect == "friction_miscalibrated" or d.calibration:
        assert "torque_sensor_gain" in d.indistinguishable_from
    else:     # the friction level cannot hold it: what is left is said to be unexplained
        assert d.unexplained["present"]
    assert any("gain error" in n and "back-driven" in n for n in d.notes), d.notes
    # what the physical profile says: the gain's column fits better than the friction level's
    bic = {e["id"]: e["bic"] for e in d.evidence}
    assert bic["torque_sensor_gain"] < bic["friction_miscalibrated"] - 10


@pytest.mark.parametrize("what", ["standstill", "short"])
def test_nothing_to_diagnose_is_said(what):
    r = synthesize("none", 5, "S1", "tiny")
    rec = as_recording(r)
    if what == "standstill":
        rec.speed_in = rec.speed_in * 0
        rec.speed_out = rec.speed_out * 0
    else:
        for k in ("time", "speed_in", "torque_in", "speed_out", "torque_out"):
            setattr(rec, k, getattr(rec, k)[:500])
    with pytest.raises(DiagnosisError, match="nothing to diagnose"):
        Diagnoser(mode="S1").fit(rec)


@pytest.mark.parametrize("mode", ["S1", "S2"])
def test_paper_like_case(mode):
    d = diagnose(paper_like(mode, 7), mode)
    assert d.effect == "load_independent_loss"
    assert d.zeta_d_before > 0.015
    assert abs(d.zeta_d_after) < 0.005
    assert "grows with speed" in d.located["statement"]
    assert "does not scale with load" in d.located["statement"]
    # as the paper found: at a given speed the mismatch weighs most at light load (low power)
    assert "larger at light load" in d.located["statement"]


def test_whiteness_test_separates_noise_from_structure():
    rng = np.random.default_rng(0)
    noise = rng.standard_normal(5000)
    assert ljung_box_p(noise) > 0.01
    assert ljung_box_p(noise + 3 * np.sin(np.arange(5000) / 50)) < 1e-6


def test_locates_ripple_at_shaft_orders():
    d = diagnose(synthesize("mesh_ripple", 4, "S1", "small"), "S1")
    assert named(d) == {"mesh_ripple"}
    clean = diagnose(synthesize("none", 4, "S1", "small"), "S1")
    assert clean.located["orders"] == {}


@pytest.mark.parametrize("effect, mode", [("load_independent_loss", "S1"), ("inertia", "S2"),
                                          ("friction_miscalibrated", "S1"), ("none", "S2")])
def test_names_the_effect_hidden_in_the_fmu_dir(fmu_dir, effect, mode):
    """The same proof through the bench's co-simulated FMUs (motor, reducer with the hidden
    physics switched on, brake, transducers), not only the vectorised replay."""
    r = synthesize(effect, 3, mode, "tiny", engine="bench", fmu_dir=fmu_dir)
    d = diagnose(r, mode)
    assert d.effect == effect
    if effect == "loss_transition":
        # its misfit lives where the hoist creeps (1-3 r/min: a fifth of the samples), not
        # over the whole recording: the width is found as hidden, the rmse falls
        assert d.effects[0]["parameters"]["w_c"]["value"] == truth["shape"]
        assert d.rmse_after_Nm < d.rmse_before_Nm
    elif effect != "none":
        assert d.rmse_after_Nm <= 0.5 * d.rmse_before_Nm


def test_the_bench_hides_a_gain_error_in_its_transducer_and_refuses_replay_only_effects(
        fmu_dir):
    """A transducer gain error goes into the bench's input torque transducer (it went into
    the reducer's replay-only fields, which the FMUs do not carry, so the bench hid nothing);
    effects the FMUs cannot carry are refused, naming the effect."""
    from model_core.errors import CycloidInputError
    g = EFFECTS["torque_sensor_gain"].synth_default[0]["gain_error"]
    r = synthesize("torque_sensor_gain", 3, "S1", "tiny", engine="bench", fmu_dir=fmu_dir,
                   friction_error=0.0)
    r0 = synthesize("none", 3, "S1", "tiny", engine="bench", fmu_dir=fmu_dir,
                    friction_error=0.0)
    loaded = np.abs(r0["torque_in_Nm"]) > 0.1
    ratio = np.median(r["torque_in_Nm"][loaded] / r0["torque_in_Nm"][loaded])
    assert ratio == pytest.approx(1 + g, abs=0.002)
    for effect in ("viscosity_drift",):     # the transducer FMU carries a zero drift
        with pytest.raises(CycloidInputError, match=effect):
            synthesize(effect, 3, "S1", "tiny", engine="bench", fmu_dir=fmu_dir)


def test_fixed_frequency_told_from_a_shaft_order_that_shares_it():
    """A fixed frequency persists while the speed moves; a shaft order moves with it. 50 Hz
    pick-up at 200 Hz sampling, in a test plan that holds 600 r/min (whose fifth order is
    50 Hz) in every quarter, is found from the stretches at the other speeds; the fifth order
    itself (phase-locked to the shaft) is never taken for a fixed frequency."""
    from cyclo_fmu.diagnosis import residual as R
    fs, hold = 200.0, 6.0
    rpm = np.tile([600.0, 1600.0, 2000.0, 2800.0, 1200.0], 4)      # 20 holds of 6 s
    t = np.arange(int(rpm.size * hold * fs)) / fs
    w = np.repeat(rpm, int(hold * fs)) * np.pi / 30
    theta = np.cumsum(w) / fs
    noise = np.random.default_rng(5).normal(0.0, 0.003, t.size)
    order5 = 0.003 * np.sin(5 * theta)
    mains = 0.003 * np.sin(2 * np.pi * 50.0 * t)
    peaks = R.spectral_peaks(noise + mains + order5, 1 / fs, speed=w, orders=[1, 2, 3, 5, 10])
    assert [round(f) for f, _ in peaks] == [50]
    assert peaks[0][1] == pytest.approx(0.003, rel=0.15)
    # an order ten times larger, whose leakage in the segments that span a speed step reaches
    # past the excluded band, is still no fixed frequency
    for scale in (1.0, 10.0, 33.0):
        assert R.spectral_peaks(noise + scale * order5, 1 / fs, speed=w,
                                orders=[1, 2, 3, 5, 10]) == []
    # without the speed, the order at speeds held in every quarter stands as fixed peaks
    # (50 Hz at 600 r/min; 33.3 Hz at 2000 and 2800 r/min, 66.7 Hz at 1600, folded at 200 Hz)
    found = sorted(f for f, _ in R.spectral_peaks(noise + order5, 1 / fs))
    assert np.allclose(found, [100 / 3, 50.0, 200 / 3], atol=0.5)   # (0.5 Hz bins)


def test_orders_swept_fast_are_no_fixed_frequency():
    """Orders of a speed ramping at 200 r/min/s (the 21st and 42nd sweep 70 and 140 Hz/s) leave
    no fixed-frequency peak; 50 Hz pick-up on top of them is found."""
    from cyclo_fmu.diagnosis import residual as R
    fs = 1000.0
    t = np.arange(120_000) / fs
    rpm = 300 + 1200 * (1 - np.abs(2 * ((t / 12) % 1) - 1))
    w = rpm * np.pi / 30
    theta = np.cumsum(w) / fs
    x = (np.random.default_rng(1).normal(0.0, 0.003, t.size) + 0.03 * np.sin(42 * theta)
         + 0.03 * np.sin(21 * theta))
    orders = [1, 2, 3, 21, 42]
    assert R.spectral_peaks(x, 1 / fs, speed=w, orders=orders) == []
    peaks = R.spectral_peaks(x + 0.003 * np.sin(2 * np.pi * 50 * t), 1 / fs, speed=w,
                             orders=orders)
    assert [round(f) for f, _ in peaks] == [50]
    assert peaks[0][1] == pytest.approx(0.003, rel=0.15)


def test_coloured_noise_is_no_fixed_frequency():
    """Red noise (AR(1), 0.1 s correlation time at 200 Hz: flat below about 1.6 Hz, then
    falling) has no narrow peak, though the edge of its low-frequency plateau stands more than
    four times over the median of the +-5 Hz around it; a 7 Hz line of 3 mN*m on the same
    noise is found, with its amplitude."""
    from scipy.signal import lfilter
    from cyclo_fmu.diagnosis import residual as R
    fs = 200.0
    t = np.arange(int(300 * fs)) / fs
    a = 0.95
    red = 0.004 * lfilter([np.sqrt(1 - a * a)], [1, -a],
                          np.random.default_rng(7).normal(size=t.size))
    assert R.spectral_peaks(red, 1 / fs) == []
    peaks = R.spectral_peaks(red + 0.003 * np.sin(2 * np.pi * 7.0 * t), 1 / fs)
    assert [round(f) for f, _ in peaks] == [7]
    assert peaks[0][1] == pytest.approx(0.003, rel=0.2)


def test_friction_error_next_to_a_drift_is_kept_in_the_fit():
    """A 15 % friction error next to a strong viscosity drift (S2, 200 Hz): the friction level
    can be stood in for by the smooth generic basis, but withdrawing it left its error to the
    drift term (named at a ninth of its size, the fit worse than the plain model's). Kept, the
    fit improves on the plain model, the drift is named at a size of the right order and
    nothing is left unexplained."""
    settings = SynthSettings(sample_rate=200.0, torque_noise=0.0057, bandwidth=80.0)
    r = synthesize({"viscosity_drift": ({"ln_viscosity_change": -1.36}, 300.0)}, 838449, "S2",
                   "small", settings=settings, friction_error=0.146)
    d = diagnose(r, "S2")
    assert d.rmse_after_Nm < 0.7 * d.rmse_before_Nm
    assert named(d) == {"viscosity_drift"}
    drift = next(e for e in d.effects if e["id"] == "viscosity_drift")
    # on a 2-minute recording a drift of 300 s and one of 600 s differ only by their size
    # (both nearly linear over it: look-alikes on the time-constant grid); what the recording
    # determines is the change it saw, ln nu at its end: c (1 - exp(-t_end/tau)), the truth's
    # -1.36 (1 - exp(-120/300)) = -0.45, of the right size within a third
    p = drift["parameters"]
    t_end = float(r["time_s"][-1] - r["time_s"][0])
    seen = p["ln_viscosity_change"]["value"] * (1 - math.exp(-t_end / p["tau"]["value"]))
    assert seen == pytest.approx(-1.36 * (1 - math.exp(-t_end / 300.0)), rel=1 / 3)
    assert d.calibration["mu_boundary_rel_error"]["value"] == pytest.approx(0.146, abs=0.05)
    assert not d.unexplained["present"]


def test_a_drift_set_aside_is_offered_for_what_remains():
    """A viscosity drift in a plan that does not return to its operating points late enough is
    set aside (a steady function of the operating point explains the same change over time);
    the mismatch it leaves is reported as unexplained, and the drift is offered as what it
    could be, next to the note naming the run that would separate them."""
    settings = SynthSettings(sample_rate=500.0, torque_noise=0.00514, bandwidth=200.0)
    r = synthesize({"viscosity_drift": ({"ln_viscosity_change": -0.947}, 300.0)}, 680342, "S2",
                   "small", settings=settings, friction_error=-0.1223)
    d = diagnose(r, "S2")
    # the drift is never lost silently: named, or offered for the mismatch it leaves
    assert "viscosity_drift" in named(d) or (
        d.unexplained["present"] and "viscosity_drift" in d.unexplained["could_include"]
        and any(n.startswith("viscosity_drift not named") for n in d.notes)), d.unexplained
    assert not set(named(d)) - {"viscosity_drift"}


def test_a_warm_up_driven_by_the_loss_power_is_told_from_one_in_time():
    """Without a temperature column a warm-up is first order in time (1 - e^(-t/tau)) or
    follows the housing's lumped heat balance heated by the loss power (tau = R C, the FMUs'
    own: effects.HeatBalanceTau, thermal.housing_path, the heat being the loss with the
    warm-up in it). The plan's power changes with its stairs, so the two differ; the
    diagnosis chooses between them on the same grid of tau by BIC and held-out error, names
    the power-driven one with tau_housing and c per 10 K of the rise, and writes it onto the
    FMUs' heat balance (C = tau/R, a cold start at the operating temperature); the design it
    writes leaves nothing. The warm-up in time stays in time."""
    from model_core import thermal
    from model_core.effects import HeatBalanceTau
    r = synthesize("thermal_drift", 54, "S1", "small", shape=HeatBalanceTau(60.0),
                   effect_values={"loss_change": -0.15}, friction_error=0.0)
    d = diagnose(r, "S1")
    assert named(d) == {"thermal_drift"}
    e = d.effects[0]
    assert e["parameters"]["tau_housing"]["value"] == 60.0 and "tau" not in e["parameters"]
    assert e["form"].startswith("time, the housing's heat balance")
    assert e["parameters"]["loss_change"]["value"] == pytest.approx(-0.15, rel=0.03)
    fixed, _ = updated_design(DriveDesign(), d)
    R = thermal.housing_resistance(fixed)
    assert fixed.housing_heat_capacity == pytest.approx(60.0 / R, rel=1e-12)
    assert fixed.ambient_temperature == fixed.extra.thermal_T_ref == \
        DriveDesign().operating_temperature
    assert fixed.extra.thermal_loss_change == 0.0
    again = diagnose(r, "S1", fixed)
    assert named(again) == set() and not again.unexplained["present"]
    plain = diagnose(synthesize("thermal_drift", 54, "S1", "small", shape=150.0,
                                effect_values={"loss_change": 0.12}, friction_error=0.0), "S1")
    assert named(plain) == {"thermal_drift"}
    assert plain.effects[0]["parameters"]["tau"]["value"] == 150.0
    assert "tau_housing" not in plain.effects[0]["parameters"]
