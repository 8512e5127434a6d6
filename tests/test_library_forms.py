"""Library forms with physical scaling (issue 18, item 3): a drag whose exponent reaches 2
(windage, turbulent churning) and a Stribeck decay whose shape runs from Tustin's exponential
(delta = 1) to the Gaussian (delta = 2). Each is one formula (model_core.effects) that the
synthesiser hides, the diagnosis names with its shape, the design carries and both FMUs
evaluate (the native FMU's C is compared with it in test_native_fmu)."""
from types import SimpleNamespace

import numpy as np
import pytest

from cyclo_fmu.diagnosis import Diagnoser, updated_design
from cyclo_fmu.synth import synthesize
from model_core import DriveDesign
from model_core.design import ExtraPhysics, design_from_toml, design_to_toml
from model_core.errors import CycloidInputError


def as_recording(r):
    return SimpleNamespace(time=r["time_s"], speed_in=r["speed_in_rpm"] * np.pi / 30,
                           torque_in=r["torque_in_Nm"], speed_out=r["speed_out_rpm"] * np.pi / 30,
                           torque_out=r["torque_out_Nm"], temperature=r.get("temperature_C"))


def test_stribeck_shape_closed_forms():
    """At w = w_s the decay is exp(-1) for every delta; below it the exponential (delta = 1)
    lies under the Gaussian, above it over it; odd in w."""
    w = np.array([-30.0, 15.0, 30.0, 60.0])
    t = {d: ExtraPhysics(stribeck_torque=0.02, stribeck_speed=30.0,
                         stribeck_exponent=d).steady_torque(w) for d in (1.0, 2.0)}
    for d in (1.0, 2.0):
        assert t[d][2] == pytest.approx(0.02 * np.exp(-1.0)) and t[d][0] == -t[d][2]
    assert t[1.0][1] < t[2.0][1] and t[1.0][3] > t[2.0][3]
    assert t[1.0][3] == pytest.approx(0.02 * np.exp(-2.0))
    assert t[2.0][3] == pytest.approx(0.02 * np.exp(-4.0))


def test_stribeck_exponent_in_the_design_file_and_its_bounds():
    d = DriveDesign(extra=ExtraPhysics(stribeck_torque=0.01, stribeck_exponent=1.0))
    assert design_from_toml(design_to_toml(d)) == d
    with pytest.raises(CycloidInputError, match="extra.stribeck_exponent"):
        DriveDesign(extra=ExtraPhysics(stribeck_exponent=0.5))


@pytest.mark.parametrize("effect, values, shape, key, expect", [
    ("low_speed_friction", {"T_stribeck": 0.025}, (30.0, 1.0), "delta", 1.0),
    ("low_speed_friction", {"T_stribeck": 0.025}, (40.0, 2.0), "delta", 2.0),
    ("load_independent_loss", {"T_drag": 0.006}, 2.0, "p", 2.0),
    ("load_independent_loss", {"T_drag": 0.008}, 1.5, "p", 1.5)])
def test_named_with_their_shape_and_closed(effect, values, shape, key, expect):
    """Hidden by the synthesiser at a shape of the new range, named with that shape and
    size, nothing left; the written design carries the shape and closes the recording."""
    r = synthesize(effect, 81, "S1", "small", effect_values=values, shape=shape)
    d = Diagnoser(None, "S1").fit(as_recording(r)).diagnosis_
    assert [e["id"] for e in d.effects] == [effect] and not d.unexplained["present"]
    p = d.effects[0]["parameters"]
    assert p[key]["value"] == expect
    (name, v), = values.items()
    assert p[name]["value"] == pytest.approx(v, rel=0.1)
    fixed, _ = updated_design(DriveDesign(), d)
    ex = fixed.extra
    if effect == "low_speed_friction":
        assert (ex.stribeck_speed, ex.stribeck_exponent) == shape
    else:
        assert ex.drag_exponent == shape
    again = Diagnoser(fixed, "S1").fit(as_recording(r)).diagnosis_
    assert again.effects == [] and not again.unexplained["present"]


@pytest.mark.parametrize("seed, kw", [(91, {}), (93, {"temperature_rise": 0.0}),
                                      (94, {"plan": "four_quadrant"})])
def test_a_run_in_is_named_as_such_and_closes(seed, kw):
    """Load-dependent losses 15 % above the model at the start, settling over 1e4 rad of the
    driving shaft (no temperature change; with a flat temperature column too): named
    ``run_in`` (not a transducer drift, not a warm-up), its size and distance found, nothing
    left; the updated design closes the recording."""
    r = synthesize("run_in", seed, "S1", "small", **kw)
    d = Diagnoser(None, "S1").fit(as_recording(r)).diagnosis_
    assert [e["id"] for e in d.effects] == ["run_in"], [e["id"] for e in d.effects]
    p = d.effects[0]["parameters"]
    assert p["loss_excess"]["value"] == pytest.approx(0.15, rel=0.1)
    assert p["s0"]["value"] == 1e4 and not d.unexplained["present"]
    fixed, _ = updated_design(DriveDesign(), d)
    assert fixed.extra.run_in_distance == 1e4
    again = Diagnoser(fixed, "S1").fit(as_recording(r)).diagnosis_
    assert again.effects == [] and not again.unexplained["present"]


def _run_fmu(fmu, change, s0, w, tau, n=5):
    """tau_in, the load-dependent losses' power PL1+..+PL6 and P_loss of the Python FMU held
    at (w, tau) for n steps of 0.1 s, the grease held at the design's temperature (with the
    heat balance the run-in's extra heat would warm it and change the gear's own losses)."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave
    md = read_model_description(fmu)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    f = FMU2Slave(guid=md.guid, unzipDirectory=extract(fmu),
                  modelIdentifier=md.coSimulation.modelIdentifier, instanceName="i")
    f.instantiate()
    f.setupExperiment(startTime=0.0)
    f.enterInitializationMode()
    f.setReal([vr["run_in_change"], vr["run_in_distance"], vr["w_in"], vr["tau_out"]],
              [change, s0, w, tau])
    f.setBoolean([vr["use_T_oil_input"]], [True])
    f.exitInitializationMode()
    names = ["tau_in", "PL1", "PL2", "PL3", "PL5", "PL6", "PL_support", "PL_seal", "PL_churn",
             "P_loss"]
    vals = []
    for k in range(n):
        f.doStep(currentCommunicationPoint=0.1 * k, communicationStepSize=0.1)
        vals.append(f.getReal([vr[x] for x in names]))
    f.terminate()
    f.freeInstance()
    v = np.array(vals)
    return v[:, 0], v[:, 1:6].sum(1), v[:, 6:9].sum(1), v[:, 9]


def test_run_in_in_the_fmu_decays_with_the_distance_run(fmu):
    """Held at one operating point, the Python FMU's run-in adds c exp(-|w| t / s0) of the
    gear's load-dependent loss torque (PL1+..+PL6)/w_in, not of its whole loss torque (the
    idle losses of bearings, seals and churning do not run in); the added loss power is
    exactly that (energy balance); with no load there is nothing to run in."""
    c, s0, w = 0.2, 50.0, 100.0
    dist = w * 0.1 * np.arange(1, 6)
    ratio = float(__import__("model_core").shaft_speeds("S1", 1.0, 15)["1"])
    excess = {}
    for tau in (-8.0, -4.0):
        gear, P_load, P_idle, P_loss = _run_fmu(fmu, 0.0, s0, w, tau)
        run, P_load_c, _, P_loss_c = _run_fmu(fmu, c, s0, w, tau)
        assert P_load_c == pytest.approx(P_load, rel=1e-12)   # the gear's own losses held
        T_load = P_load / w
        loss_in = gear + tau * ratio                         # less the lossless torque
        assert np.all(P_idle > 0) and np.all(T_load > 0)
        assert np.all(T_load < loss_in)                      # the idle part left out
        assert run - gear == pytest.approx(c * np.exp(-dist / s0) * T_load, rel=1e-9)
        # the run-in's torque is loss: P_loss grows by c exp(-d/s0) (PL1+..+PL6)
        assert P_loss_c - P_loss == pytest.approx(c * np.exp(-dist / s0) * P_load, rel=1e-9)
        excess[tau] = (run - gear) / P_load
    # in proportion to the load-dependent losses at either load
    assert excess[-8.0] == pytest.approx(excess[-4.0], rel=1e-9)
    # no load: the idle losses (here 4.3 W of 5.2 W) are untouched; what runs in is the
    # friction of the torque the driven shaft's own drag puts through the gear, and only that
    gear, P_load, P_idle, P_loss = _run_fmu(fmu, 0.0, s0, w, 0.0)
    run, _, _, _ = _run_fmu(fmu, c, s0, w, 0.0)
    assert np.all(P_idle > 2.0 * P_load) and np.all(P_load > 0)
    assert P_load + P_idle == pytest.approx(P_loss, rel=1e-9)     # no mesh loss calibrated
    assert run - gear == pytest.approx(c * np.exp(-dist / s0) * (gear - P_idle / w), rel=1e-9)


@pytest.mark.parametrize("seed, plan", [(61, "full"), (65, "one_speed")])
def test_a_ripple_growing_with_the_load_is_named_as_such(seed, plan):
    """Ripple at 1x and the roller pass whose amplitude is in proportion to the load
    (4.5 and 6 mN*m at 10 N*m): named ``mesh_ripple`` at its load law 1 (amplitude a + b |T|)
    with its amplitudes (not "shaft orders remain"), and the updated design closes the
    recording. ``load_ripple``, the id of the earlier separate entry, is an alias."""
    r = synthesize("load_ripple", seed, "S1", "small", plan=plan)
    d = Diagnoser(None, "S1").fit(as_recording(r)).diagnosis_
    assert [e["id"] for e in d.effects] == ["mesh_ripple"] and not d.unexplained["present"]
    assert d.effects[0]["parameters"]["load_law"]["value"] == 1.0
    p = {k: v["value"] for k, v in d.effects[0]["parameters"].items()}
    # at one speed the three loads separate a from b poorly: the 1x amplitude b comes out 12-16 %
    # low (0.0038 for 0.0045; the separate load_ripple entry of earlier versions: 12 % without
    # a beside it), the roller-pass one 16 % high at an interval of +-50 % (0.0070 for 0.006)
    tol = 0.15 if plan == "full" else 0.2
    assert np.hypot(p["B1_sin"], p["B1_cos"]) == pytest.approx(np.hypot(0.004, 0.002), rel=tol)
    assert np.hypot(p["Bz_sin"], p["Bz_cos"]) == pytest.approx(0.006, rel=tol)
    fixed, _ = updated_design(DriveDesign(), d)
    assert fixed.extra.ripple_roller_load == pytest.approx(0.006, rel=tol)
    again = Diagnoser(fixed, "S1").fit(as_recording(r)).diagnosis_
    assert again.effects == [] and not again.unexplained["present"]


def test_load_ripple_closed_form():
    """At a held load the ripple's amplitude is in proportion to |tau_out|, zero at no load."""
    ex = ExtraPhysics(ripple_roller_load=0.006, ripple_roller_load_phase=0.3)
    th = np.linspace(0, 2 * np.pi, 721)
    for T in (0.0, 5.0, -10.0):
        amp = np.max(np.abs(ex.load_ripple_torque(th, 14.0, T)))
        assert amp == pytest.approx(0.006 * abs(T) / 10.0, abs=1e-6)


@pytest.mark.slow
@pytest.mark.parametrize("effect, shape, key, expect", [
    ("run_in", 1e4, "s0", 1e4), ("low_speed_friction", (30.0, 1.0), "delta", 1.0)])
def test_hidden_through_the_bench_fmus(effect, shape, key, expect):
    """The synthesiser's bench engine hides the effect in the reducer FMU's parameters (an SSP
    co-simulation of motor, reducer, brake and transducers); the diagnosis names it with its
    shape and size."""
    r = synthesize(effect, 5, "S1", "small", engine="bench", shape=shape, friction_error=0.0)
    d = Diagnoser(None, "S1").fit(as_recording(r)).diagnosis_
    assert [e["id"] for e in d.effects] == [effect] and not d.unexplained["present"]
    assert d.effects[0]["parameters"][key]["value"] == expect
