"""The loop closes through the bench (issue 19 item 7): the bench replays a recording (the motor
follows its measured input speed, a load machine applies its measured output torque), the
transducer FMUs carry the input torque transducer's offset and gain a diagnosis found, and the
co-simulation with the diagnosis's design_updated.toml reproduces the recording to its noise
floor, while the design the diagnosis started from does not."""
import json
import math
from dataclasses import replace

import numpy as np
import pytest

from model_core import DriveDesign, design_to_toml
from cyclo_fmu.bench import Sensors, bench_parameters, Scenario
from cyclo_fmu.bench_replay import (VERIFY_TOLERANCE, noise_floor, replay_parameters,
                                    replay_recording, verify_recording)
from cyclo_fmu.io import load_recording
from cyclo_fmu.synth import synthesize, write_synth

TWIN_TOL = 1e-9       # native against Python, as tests/test_native_rig.py
#: output over input speed in S1 (model_core.kinematics)
RATIO = float(__import__("model_core.kinematics", fromlist=["x"]).shaft_speeds(
    "S1", 1.0, DriveDesign().z1)["1"])


@pytest.fixture(scope="module")
def sets(fmu_dir, tmp_path_factory):
    """The session's Python set and a native set (the paper's drive)."""
    from cyclo_fmu.fmu_build import RIG_NATIVE, build_any
    d = tmp_path_factory.mktemp("replay_native")
    for name in RIG_NATIVE + ("CycloidDriveNative",):
        build_any(name, d)
    return fmu_dir, d


@pytest.fixture(scope="module")
def short(tmp_path_factory):
    """A 12 s recording of the fast synthesiser (drag hidden) and its checked form."""
    path = tmp_path_factory.mktemp("replay_rec") / "drag.csv"
    write_synth(path, synthesize("load_independent_loss", 3, "S1", duration=12.0))
    rec, mode, _ = load_recording(path, "S1")
    return path, rec, mode


def test_the_replay_follows_the_recording_on_its_time_base(sets, short):
    py_dir, _ = sets
    _, rec, mode = short
    rp = replay_recording(rec, mode, py_dir, DriveDesign(), Sensors(ideal=True), "python")
    sim = rp.simulated
    assert np.array_equal(sim["time_s"], rec.time)
    # the load machine applies the measured output torque: with ideal transducers the output
    # torque reading is that torque (the reducer's output torque is its load, J_out = 0)
    assert np.max(np.abs(sim["torque_out_Nm"] - rec.torque_out)) < 1e-12
    # the speed loop (first order, 1 ms) follows the measured speed, its setpoint advanced by
    # the loop's time: no lag; the 10 ms means agree within a tenth of the ramps' 1500 (r/min)/s
    # times the loop's time, plus the noise
    m = 10
    d = (rec.speed_in * 30 / math.pi - sim["speed_in_rpm"])[:len(rec.time) // m * m]
    assert np.max(np.abs(d.reshape(-1, m).mean(1))) < 1.0
    # the output speed is the input's times the kinematic ratio (S1: 1/z1)
    assert np.allclose(sim["speed_out_rpm"], sim["speed_in_rpm"] * RATIO, atol=1e-9)


def test_native_and_python_replays_are_twins(sets, short):
    """Speed and torque control, the transducers' offset, gain and zero drift from the design:
    the C components equal their Python slaves."""
    py_dir, na_dir = sets
    _, rec, mode = short
    design = DriveDesign()
    design = replace(design, extra=replace(design.extra, torque_in_offset=0.004,
                                           torque_in_gain_error=0.01))
    design = replace(design, extra=replace(design.extra, torque_in_zero_drift=0.01,
                                           torque_in_zero_tau=3.0))
    out = []
    for d, fmus in ((py_dir, "python"), (na_dir, "native")):
        # the native reducer carries the paper's drive: its design check compares the reducer
        # fields only, the transducer fields are the bench's
        out.append(replay_recording(rec, mode, d, design, Sensors(seed=4), fmus).simulated)
    for k in out[0]:
        scale = np.maximum(1.0, np.abs(out[0][k]))
        assert np.max(np.abs(out[0][k] - out[1][k]) / scale) <= TWIN_TOL, k


def test_the_bench_reads_the_diagnosed_offset_and_gain(sets, short):
    """design_updated.toml's [extra] torque_in_offset, torque_in_gain_error and
    torque_in_zero_drift/_tau (where the diagnosis writes them, model_core.effects._apply_offset,
    _apply_gain, _apply_zero_drift) become the input torque transducer's offset, gain and zero
    drift: the reading is (1 + g) T + offset + drift (model_core.effects.reading_model), on top
    of the bench's own sensor errors."""
    py_dir, _ = sets
    _, rec, mode = short
    base = DriveDesign()
    g, off = 0.02, 0.006
    fixed = replace(base, extra=replace(base.extra, torque_in_offset=off,
                                        torque_in_gain_error=g))
    drifting = replace(fixed, extra=replace(fixed.extra, torque_in_zero_drift=0.01,
                                            torque_in_zero_tau=3.0))
    p = bench_parameters(Scenario("x"), Sensors(torque_in_offset=0.001,
                                                torque_in_gain_error=0.01), fixed)
    assert p["t_in.offset"] == pytest.approx(0.007)
    assert p["t_in.gain_error"] == pytest.approx(1.01 * 1.02 - 1)
    assert p["t_out.offset"] == 0.0 and p["t_out.gain_error"] == 0.0
    quiet = Sensors(torque_noise=0.0, torque_resolution=0.0, speed_noise=0.0,
                    speed_resolution=0.0)
    a = replay_recording(rec, mode, py_dir, base, quiet, "python").simulated["torque_in_Nm"]
    b = replay_recording(rec, mode, py_dir, fixed, quiet, "python").simulated["torque_in_Nm"]
    assert np.allclose(b, (1 + g) * a + off, rtol=0, atol=1e-12)
    # and the zero's drift in time form: 0.01 (1 - exp(-t/3 s)) from the recording's start
    c = replay_recording(rec, mode, py_dir, drifting, quiet, "python").simulated["torque_in_Nm"]
    t = rec.time - rec.time[0]
    assert np.allclose(c - b, 0.01 * (1 - np.exp(-t / 3.0)), rtol=0, atol=1e-12)


def test_transducer_gain_error_has_bounds(sets, capfd):
    from fmpy import read_model_description
    py_dir, na_dir = sets
    for d, name in ((py_dir, "TorqueTransducer"), (na_dir, "TorqueTransducerNative")):
        v = {x.name: x for x in read_model_description(str(d / f"{name}.fmu")).modelVariables}
        assert (float(v["gain_error"].min), float(v["gain_error"].max)) == (-0.5, 0.5)
        assert v["offset"].unit == "N.m" and v["gain_error"].unit == "1"
    # a gain error beyond its bound is refused by the native front (fmi2Error, named)
    from cyclo_fmu.bench import run_fmus
    p = replay_parameters("S1", 0.01, Sensors(torque_in_gain_error=0.6), None, "native")
    with pytest.raises(Exception, match="failed with status 3"):
        run_fmus(na_dir, p, 0.01, 1e-3, fmus="native",
                 signals={"motor.w_set": np.full(11, 100.0), "brake.T_set": np.full(11, 1.0)})
    assert "gain_error = 0.6 outside its declared range [-0.5, 0.5]" in capfd.readouterr().out


def test_a_temperature_the_reducer_cannot_take_is_refused_by_name(sets, short):
    """A temperature column becomes the reducer's grease temperature: one out of the FMUs'
    range (here a column in K read as degC) is refused before the run, naming the column."""
    import dataclasses
    from cyclo_fmu.recordings import RecordingError
    py_dir, _ = sets
    _, rec, mode = short
    hot = dataclasses.replace(rec, temperature=np.full(len(rec.time), 313.15))
    with pytest.raises(RecordingError, match="temperature_C: 313.15 degC"):
        replay_recording(hot, mode, py_dir, DriveDesign(), Sensors(ideal=True), "python")


def test_an_uneven_recording_is_run_on_its_median_step(sets):
    """A logger's dropped sample (a gap) and jitter: the run is on the median step, the result
    interpolated back onto the recording's own times."""
    from cyclo_fmu.recordings import recording_from_arrays
    py_dir, _ = sets
    t = np.arange(6000) * 1e-3
    t = np.delete(t, [1000, 3000])
    n = np.where(t < 3, 1500.0, 2000.0)
    T_out = np.full_like(t, 4.0) * np.sign(RATIO)    # delivered to the load
    rec = recording_from_arrays(t, n, np.full_like(t, 0.3), n * RATIO, T_out)
    rp = replay_recording(rec, "S1", py_dir, DriveDesign(), Sensors(ideal=True), "python")
    assert rp.resampled and np.array_equal(rp.simulated["time_s"], t)
    assert np.allclose(rp.simulated["torque_out_Nm"], T_out, atol=1e-9)


def test_an_mdf4_recording_replays_and_verifies_like_its_csv(sets, short, tmp_path):
    """The same reader as diagnose: MDF4 channels with their own names and units (N*mm, rad/s)
    give the replay and the verdict of the CSV."""
    asammdf = pytest.importorskip("asammdf")
    py_dir, _ = sets
    path, rec, mode = short
    t = rec.time
    mdf = asammdf.MDF(version="4.10")
    mdf.append([asammdf.Signal(rec.speed_in * 30 / math.pi, t, name="n_in", unit="rpm"),
                asammdf.Signal(rec.torque_in * 1e3, t, name="T_in", unit="N·mm"),
                asammdf.Signal(rec.speed_out, t, name="n_out", unit="rad/s"),
                asammdf.Signal(rec.torque_out, t, name="T_out", unit="Nm")])
    p = tmp_path / "run.mf4"
    mdf.save(p, overwrite=True)
    mdf.close()
    rec4, mode4, _ = load_recording(p, "auto")
    a, _ = verify_recording(rec, mode, py_dir, DriveDesign(), "python")
    b, _ = verify_recording(rec4, mode4, py_dir, DriveDesign(), "python")
    assert mode4 == mode and b["blocks"] == a["blocks"]
    assert b["ratio_to_noise_floor"] == pytest.approx(a["ratio_to_noise_floor"], rel=1e-6)


def test_noise_floor_of_white_noise_is_sigma_over_sqrt_m():
    rng = np.random.default_rng(1)
    x = 0.003 * rng.standard_normal(200_000)
    assert noise_floor(x, 10) == pytest.approx(0.003 / math.sqrt(10), rel=0.02)


def _closure(effect, sets, tmp_path, duration=20.0, plan="full", engine="bench",
             calibrate=False, seed=2, design=None, **synth):
    """Synthesise (the hidden effect in the bench's FMUs), diagnose against the default design
    (or ``design``), write design_updated.toml, verify both designs through the bench (Python
    set)."""
    from cyclo_fmu.sweep.batch import diagnose_recording
    from model_core import design_from_toml
    py_dir, _ = sets
    base = design or DriveDesign()
    rec = synthesize(effect, seed, "S1", duration=duration, plan=plan, engine=engine,
                     fmu_dir=py_dir, design=base, **synth)
    path = tmp_path / f"{effect}.csv"
    write_synth(path, rec)
    r, mode, checks = load_recording(path, "S1")
    from model_core.effects import OPT_IN
    d, _ = diagnose_recording(r, mode, checks, base, calibrate=calibrate,
                              with_effects=(effect,) if effect in OPT_IN else ())
    fixed, notes = d.updated
    toml = tmp_path / "design_updated.toml"
    toml.write_text(design_to_toml(fixed) + "".join(f"# {n}\n" for n in notes))
    updated = design_from_toml(toml)
    good, _ = verify_recording(r, mode, py_dir, updated, "python")
    bad, _ = verify_recording(r, mode, py_dir, base, "python")
    return good, bad, d


def _native_closes(r, mode, fixed, sets, folder):
    """The native reducer FMU built for the updated design ``fixed`` (its start values the
    bench checks) reproduces recording ``r`` to its noise floor, and its replay is the Python
    FMU's twin (``TWIN_TOL``)."""
    from cyclo_fmu.fmu_build import RIG_NATIVE, build_any
    folder.mkdir()
    for name in RIG_NATIVE:
        build_any(name, folder)
    build_any("CycloidDriveNative", folder, fixed)
    gn, rpn = verify_recording(r, mode, folder, fixed, "native")
    gp, rpp = verify_recording(r, mode, sets[0], fixed, "python")
    assert gn["reproduces_to_noise_floor"]
    for k in rpp.simulated:
        scale = np.maximum(1.0, np.abs(rpp.simulated[k]))
        assert np.max(np.abs(rpn.simulated[k] - rpp.simulated[k]) / scale) <= TWIN_TOL, k


def _assert_closes(good, bad, bad_min=2.5):
    # the tolerance VERIFY_TOLERANCE (1.2, bench_replay: what a reproduction to the noise
    # floor may leave); measured ratios 0.88-1.17 on these recordings (Stribeck 1.17, inertia
    # 1.14, the rest 0.88-1.09; run-in 1.01, load ripple 0.93, the temperature-driven
    # viscosity 1.01)
    assert good["reproduces_to_noise_floor"], good
    assert good["ratio_to_noise_floor"] <= VERIFY_TOLERANCE
    assert abs(good["torque_in_residual_mean_Nm"]) < 0.5 * good["noise_floor_Nm"]
    # the default design leaves the effect: several times the noise floor
    assert not bad["reproduces_to_noise_floor"] and bad["ratio_to_noise_floor"] > bad_min


def test_closure_sensor_offset(sets, tmp_path):
    """The default suite's closure: a transducer zero offset (6 mN*m) hidden in the bench's
    input torque transducer FMU, diagnosed, reproduced by the bench from design_updated.toml."""
    good, bad, d = _closure("torque_sensor_offset", sets, tmp_path)
    assert "torque_sensor_offset" in [e["id"] for e in d.effects]
    _assert_closes(good, bad)


@pytest.mark.slow
@pytest.mark.parametrize("effect, kw", [
    ("load_independent_loss", {}),
    ("friction_miscalibrated", {}),
    ("mesh_loss", {"calibrate": True}),
    ("idle_loss_scale", {"calibrate": True}),
    # a gain error is told from the friction level only back-driven (the diagnosis's rule):
    # the four-quadrant plan needs a load machine that drives the output, which the engine
    # bench's felt brake is not; the fast engine's recording, verified through the bench
    ("torque_sensor_gain", {"plan": "four_quadrant", "engine": "fast", "duration": 40.0}),
    # the warm-up in time form (extra.thermal_loss_change, thermal_tau: the reducer FMUs carry
    # it, their losses held at T_oil_start: one warm-up, not also through the heat balance)
    ("thermal_drift", {"duration": 120.0}),
    # the load-dependent losses settling with the distance run (extra.run_in_change,
    # run_in_distance; measured 1.01, the default design 9.24; named 0.1498 at 1e4 rad for the
    # hidden 0.15 at 1e4 rad)
    ("run_in", {"duration": 60.0}),
    # the reducer FMU's dynamic extra physics: J dw/dt (the speed setpoint's noise matters:
    # bench_replay.SPEED_SMOOTHING; the least margin: 1.14 of the noise floor on 30 s, 1.23 on
    # 20 s, where the ramps' corners weigh more and J is fitted from fewer of them)
    ("inertia", {"duration": 30.0}),
    ("mesh_ripple", {}),
    ("low_speed_friction", {}),
    # the input transducer's zero drifting as it warms (time form: the transducer FMU's
    # zero_drift, zero_drift_tau from [extra] torque_in_zero_drift, torque_in_zero_tau)
    ("torque_sensor_drift", {"duration": 120.0}),
])
def test_closure_through_the_bench(sets, tmp_path, effect, kw):
    good, bad, d = _closure(effect, sets, tmp_path, **kw)
    _assert_closes(good, bad)


#: no constant ripple at 1x and the roller pass (the synthesiser's default values)
_NO_RIPPLE_DEFAULT = {"A1_sin": 0.0, "A1_cos": 0.0, "Az_sin": 0.0, "Az_cos": 0.0}


@pytest.mark.parametrize("values, field, native", [
    # 2x of the driving shaft, growing with the load (13 mN*m at 10 N*m): measured 1.05 of
    # the noise floor with design_updated.toml, 4.43 with the default design
    ({"B2_sin": 0.012, "B2_cos": 0.005}, "ripple_2x_load", False),
    # 1x of the driven shaft (its runout), growing with the load: 1.00 against 4.84; the
    # native reducer built for design_updated.toml (build --design) gives the same bench
    pytest.param({"Bo1_sin": -0.008, "Bo1_cos": 0.010}, "ripple_out_1x_load", True,
                 marks=pytest.mark.slow)])
def test_closure_shaft_order_ripple(sets, tmp_path, values, field, native):
    """A load-scaled ripple at a shaft order beyond 1x and the roller pass, hidden in the
    bench's reducer FMU (its parameters ripple_2x_load, ripple_out_1x_load and phases),
    diagnosed as ``mesh_ripple``: design_updated.toml carries it, and the bench with it
    reproduces the recording to its noise floor, the default design does not."""
    good, bad, d = _closure("mesh_ripple", sets, tmp_path,
                            effect_values=dict(_NO_RIPPLE_DEFAULT, **values), shape=1.0)
    assert [e["id"] for e in d.effects] == ["mesh_ripple"]
    fixed, _ = d.updated
    s_, c_ = values.values()
    assert getattr(fixed.extra, field) == pytest.approx(math.hypot(s_, c_), rel=0.1)
    _assert_closes(good, bad, bad_min=2.0)
    if native:
        r, mode, _ = load_recording(tmp_path / "mesh_ripple.csv", "S1")
        _native_closes(r, mode, fixed, sets, tmp_path / "native_updated")


@pytest.mark.slow
def test_closure_load_ripple(sets, tmp_path):
    """A ripple growing with the load (extra.ripple_*_load): measured 0.93 of the noise floor
    with design_updated.toml, 2.30 with the default design (the synthesiser's ripple is small
    at the plan's light loads)."""
    good, bad, d = _closure("load_ripple", sets, tmp_path)
    # named by its id since the two entries merged (load_ripple is an alias)
    assert "mesh_ripple" in [e["id"] for e in d.effects]
    _assert_closes(good, bad, bad_min=2.0)


@pytest.mark.parametrize("duration, tau, measured", [
    (20.0, 10.0, "slope -0.0247 1/K, 1.01 of the noise floor against 2.55"),
    pytest.param(60.0, 30.0, "slope -0.0239 1/K, 1.01 against 2.48", marks=pytest.mark.slow)])
def test_closure_temperature_driven_warm_up(sets, tmp_path, duration, tau, measured):
    """A warm-up driven by a measured temperature: the reducer FMU's grease follows a
    temperature rising 14 K from the operating temperature (time constant ``tau``; the
    recording's temperature column), its true lubricant thinning at d ln(nu)/dT = -0.025 1/K
    (the default grease: -0.058). The diagnosis (model held at the operating temperature) names
    the viscosity drift per 10 K, design_updated.toml carries it as the lubricant's Walther line
    (nu_100 rewritten), and the bench, its grease fed the recording's temperature column
    (T_oil_in), reproduces the recording to its noise floor; the default lubricant at the same
    temperatures does not (``measured``). The friction level is held right (friction_error 0):
    with a random 4 % friction error the diagnosis named the viscosity drift alone and the
    closure left 1.6 of the noise floor."""
    good, bad, d = _closure("viscosity_drift", sets, tmp_path, duration=duration,
                            temperature_rise=14.0, shape=tau, friction_error=0.0,
                            effect_values={"ln_viscosity_change": -0.25})
    e = {x["id"]: x for x in d.effects}
    assert list(e) == ["viscosity_drift"]
    slope = e["viscosity_drift"]["parameters"]["ln_viscosity_change"]["value"] / 10.0
    # the true slope within the diagnosis's linearisation in ln(nu) (about 5 % over 0.35 of
    # ln(nu)), far from the default grease's
    assert slope == pytest.approx(-0.025, rel=0.08)
    fixed, _ = d.updated
    from model_core import thermal
    assert thermal.viscosity_slope(fixed) == pytest.approx(slope, rel=1e-3)
    assert any("temperature column" in n for n in good["notes"])
    _assert_closes(good, bad, bad_min=2.0)


@pytest.mark.parametrize("duration, tau, measured", [
    (20.0, 10.0, "c 0.1195 (CI 0.1191-0.1199), 1.01 of the noise floor against 15.3"),
    pytest.param(60.0, 30.0, "c 0.1196, 1.01 against 14.7", marks=pytest.mark.slow)])
def test_closure_warm_up_per_10K(sets, tmp_path, duration, tau, measured):
    """A warm-up found as "the losses change per 10 K": the reducer FMU's losses grow by 12 %
    per 10 K of its grease temperature (extra.thermal_loss_per_10K), the grease following a
    temperature rising 14 K from the operating temperature (time constant ``tau``; the
    recording's temperature column, T_oil_in), its losses held at T_oil_start (one warm-up).
    The diagnosis names the warm-up per 10 K of the column; design_updated.toml carries it with
    the column's first value as thermal_T_ref, and the bench (the grease fed the column)
    reproduces the recording to its noise floor; the default design does not (``measured``)."""
    good, bad, d = _closure("thermal_drift", sets, tmp_path, duration=duration,
                            temperature_rise=14.0, shape=tau, friction_error=0.0,
                            effect_values={"loss_change": 0.12})
    e = {x["id"]: x for x in d.effects}
    assert "thermal_drift" in e and e["thermal_drift"]["form"].startswith("per 10 K")
    c = e["thermal_drift"]["parameters"]["loss_change"]["value"]
    ci = e["thermal_drift"]["parameters"]["loss_change"]["ci95"]
    # the true 0.12: the model is held at the operating temperature in the diagnosis and in
    # the FMUs alike (one warm-up), so nothing of the grease's own temperature physics mixes in
    assert c == pytest.approx(0.12, rel=0.02), ci
    fixed, _ = d.updated
    assert fixed.extra.thermal_loss_per_10K == pytest.approx(c, rel=1e-9)
    # the reference is the column's first value (the design's operating temperature, 0.05 K
    # noise), carried to the FMUs
    assert fixed.extra.thermal_T_ref == pytest.approx(DriveDesign().operating_temperature,
                                                      abs=0.3)
    assert fixed.extra.thermal_loss_change == 0.0
    _assert_closes(good, bad, bad_min=2.0)


@pytest.mark.parametrize("native", [False, pytest.param(True, marks=pytest.mark.slow)])
def test_closure_warm_up_exponential_in_temperature(sets, tmp_path, native):
    """A warm-up that levels off as the grease warms, as a loss following the lubricant's
    viscosity does: the reducer FMU's losses change by c (theta/10 K)(1 - exp(-(T_oil -
    T_ref)/theta)), c = -0.25 per 10 K at the reference and theta = 20 K
    (extra.thermal_T_scale; model_core.thermal.loss_temperature_law), the grease following a
    temperature rising 30 K from the operating temperature with an 8 s time constant (the
    recording's temperature column, T_oil_in): the losses fall by 39 % where the linear law
    would make 75 %. The diagnosis chooses the law's shape on its grid (THETA_GRID: linear, 10,
    20, 40, 80 K) by BIC and held-out error, names the warm-up per 10 K with theta = 20 K;
    design_updated.toml carries thermal_T_scale, and the bench reproduces the recording to its
    noise floor through the Python and the native reducer FMU alike (equal to 1e-9); the
    default design does not, nor does the same design with the linear law (``measured``:
    the docs' table, docs/explanation/thermal.md)."""
    from model_core.effects import TemperatureScale
    good, bad, d = _closure("thermal_drift", sets, tmp_path, duration=20.0,
                            temperature_rise=30.0, temperature_tau=8.0,
                            shape=TemperatureScale(20.0), friction_error=0.0,
                            effect_values={"loss_change": -0.25})
    e = {x["id"]: x for x in d.effects}
    assert list(e) == ["thermal_drift"] and e["thermal_drift"]["form"].startswith("per 10 K")
    par = e["thermal_drift"]["parameters"]
    assert par["theta"]["value"] == 20.0 and par["theta"]["unit"] == "K"
    assert par["loss_change"]["value"] == pytest.approx(-0.25, rel=0.03), par
    fixed, _ = d.updated
    assert fixed.extra.thermal_T_scale == 20.0
    assert fixed.extra.thermal_loss_per_10K == pytest.approx(par["loss_change"]["value"],
                                                             rel=1e-9)
    _assert_closes(good, bad, bad_min=2.0)
    # the linear law at the same c leaves the curvature: not a reproduction
    r, mode, _ = load_recording(tmp_path / "thermal_drift.csv", "S1")
    linear, _ = verify_recording(r, mode, sets[0], replace(
        fixed, extra=replace(fixed.extra, thermal_T_scale=0.0)), "python")
    assert not linear["reproduces_to_noise_floor"]
    if not native:
        return
    # the native reducer FMU carries the law (parameter thermal_T_scale)
    _native_closes(r, mode, fixed, sets, tmp_path / "native_updated")


@pytest.mark.parametrize("native", [False, pytest.param(True, marks=pytest.mark.slow)])
def test_closure_warm_up_driven_by_the_loss_power(sets, tmp_path, native):
    """A warm-up with no temperature column whose temperature is the housing's, heated by the
    loss: the reducer FMU's losses change by c = -0.2 per 10 K of its grease temperature T_oil
    (extra.thermal_loss_per_10K), which its own lumped heat balance integrates from a cold
    start (ambient = T_oil_start = 40 degC, tau = R C = 60 s; its loss, warm-up included,
    heats it), under the plan's changing power (40 s). The diagnosis chooses the power-driven
    form (tau_housing 60 s) over the first order in time on the same grid, its columns
    re-linearised at the fitted size (the heat with the warm-up in it), and writes it onto the
    FMUs' heat balance (C = tau/R, the ambient at the operating temperature); the bench
    replay, the grease following the heat balance, reproduces the recording to its noise
    floor through the Python and the native reducer FMU alike (equal to 1e-9), the default
    design does not (measured: c -0.2001, 1.013 against 10.4 of the noise floor)."""
    from model_core import thermal
    from model_core.effects import HeatBalanceTau
    good, bad, d = _closure("thermal_drift", sets, tmp_path, duration=40.0,
                            shape=HeatBalanceTau(60.0), friction_error=0.0,
                            effect_values={"loss_change": -0.2})
    e = {x["id"]: x for x in d.effects}
    assert list(e) == ["thermal_drift"]
    par = e["thermal_drift"]["parameters"]
    assert par["tau_housing"]["value"] == 60.0
    assert par["loss_change"]["value"] == pytest.approx(-0.2, rel=0.02), par
    fixed, _ = d.updated
    assert fixed.extra.thermal_loss_per_10K == pytest.approx(par["loss_change"]["value"],
                                                             rel=1e-9)
    assert thermal.housing_time_constant(fixed) == pytest.approx(60.0, rel=1e-12)
    assert any("heat balance" in n for n in good["notes"])
    _assert_closes(good, bad, bad_min=2.0)
    if not native:
        return
    r, mode, _ = load_recording(tmp_path / "thermal_drift.csv", "S1")
    _native_closes(r, mode, fixed, sets, tmp_path / "native_updated")


@pytest.mark.parametrize("native", [False, pytest.param(True, marks=pytest.mark.slow)])
def test_closure_loss_transition_through_standstill(sets, tmp_path, native):
    """The losses building up through standstill (pre-sliding): a hoist lifting and lowering
    payloads of 2 and 5 N*m at creeping speeds from 1.5 r/min up (synth plan 'hoist', the fast
    engine: the bench's load is a brake, not a payload), its whole loss torque times
    tanh(|w_in|/0.1 rad/s) (friction.loss_transition). The diagnosis names ``loss_transition``
    at w_c = 0.1 rad/s with a share near 1 (the speed reading's noise, 0.5 r/min, biases it:
    tanh is concave there), design_updated.toml carries extra.loss_transition = 0.1 rad/s,
    and the bench with it reproduces the recording to its noise floor through the Python and
    the native reducer FMU alike (equal to 1e-9); the default design does not. The speed is
    read by an encoder-grade transducer (0.1 r/min of noise): the bench replays at the
    measured speed, and a reading as noisy as the transition is wide (0.5 r/min, 0.05 rad/s,
    the synthesiser's default) leaves the replay's tanh(|w|/w_c) off near standstill
    (measured: 1.34 of the noise floor with the updated design against 3.02, the misfit below
    2 r/min; with 0.1 r/min 1.08 against 2.95)."""
    from cyclo_fmu.synth import SynthSettings
    good, bad, d = _closure("loss_transition", sets, tmp_path, duration=40.0, plan="hoist",
                            engine="fast", friction_error=0.0, seed=3,
                            settings=SynthSettings(speed_noise=0.1))
    e = {x["id"]: x for x in d.effects}
    assert list(e) == ["loss_transition"]
    par = e["loss_transition"]["parameters"]
    assert par["w_c"]["value"] == 0.1
    assert 0.9 <= par["share"]["value"] <= 1.15, par
    fixed, _ = d.updated
    assert fixed.extra.loss_transition == 0.1
    _assert_closes(good, bad, bad_min=2.0)
    if not native:
        return
    r, mode, _ = load_recording(tmp_path / "loss_transition.csv", "S1")
    _native_closes(r, mode, fixed, sets, tmp_path / "native_updated")


@pytest.mark.slow
@pytest.mark.parametrize("duration, tau, measured", [
    (20.0, 10.0, "c 0.00999 (CI 0.00994-0.01004), 1.01 of the noise floor against 9.18"),
    (60.0, 30.0, "c 0.00997 (CI 0.00995-0.01000), 1.01 against 9.14")])
def test_closure_zero_drift_per_10K(sets, tmp_path, duration, tau, measured):
    """The input torque transducer's zero drifting with temperature: +10 mN*m per 10 K of its
    temperature input (the reducer's T_oil, fed a temperature rising 14 K from the operating
    temperature, time constant ``tau``; the recording's temperature column) in the bench's
    transducer FMU. The diagnosis names the zero drift per 10 K of the column;
    design_updated.toml carries it as torque_in_zero_per_10K with the column's first value as
    torque_in_zero_T_ref, and the bench (the transducer's temperature = the reducer's T_oil =
    the column) reproduces the recording to its noise floor; the design the diagnosis started
    from does not (``measured``: c, its CI, the ratios to the noise floor).

    The paper profile, whose losses do not depend on the grease temperature; the physical
    profile is the next test."""
    good, bad, d = _closure("torque_sensor_drift", sets, tmp_path, duration=duration,
                            temperature_rise=14.0, shape=tau, friction_error=0.0,
                            effect_values={"offset_change": 0.010},
                            design=DriveDesign(profile="paper"))
    e = {x["id"]: x for x in d.effects}
    assert list(e) == ["torque_sensor_drift"]
    assert e["torque_sensor_drift"]["form"].startswith("per 10 K")
    c = e["torque_sensor_drift"]["parameters"]["offset_change"]["value"]
    lo, hi = e["torque_sensor_drift"]["parameters"]["offset_change"]["ci95"]
    assert lo <= 0.010 <= hi and c == pytest.approx(0.010, rel=0.02), (c, lo, hi)
    fixed, _ = d.updated
    assert fixed.extra.torque_in_zero_per_10K == pytest.approx(c, rel=1e-9)
    assert fixed.extra.torque_in_zero_drift == 0.0
    # the reference is the column's first value (the operating temperature, 0.05 K noise)
    assert fixed.extra.torque_in_zero_T_ref == pytest.approx(
        DriveDesign().operating_temperature, abs=0.3)
    assert any("zero drifts with it" in n for n in good["notes"])
    _assert_closes(good, bad, bad_min=2.0)


@pytest.mark.slow
def test_closure_zero_drift_per_10K_physical_profile(sets, tmp_path):
    """As above in the physical profile, whose reducer warms with the column too (its grease
    thins at -0.058 1/K): the diagnosis, its model held at the operating temperature, names
    that viscosity drift beside the zero drift, and both together close. Measured: c 0.009995
    (CI 0.00994-0.01005), ln(nu) -0.544 per 10 K; 1.06 of the noise floor (2.0 needed for
    the design the diagnosis started from). Linearised at the
    design's viscosity (before the drift was evaluated at its fitted size) the pair left 1.23
    and c 0.0093."""
    good, bad, d = _closure("torque_sensor_drift", sets, tmp_path, duration=20.0,
                            temperature_rise=14.0, shape=10.0, friction_error=0.0,
                            effect_values={"offset_change": 0.010}, design=DriveDesign())
    e = {x["id"]: x for x in d.effects}
    assert set(e) == {"torque_sensor_drift", "viscosity_drift"}
    c = e["torque_sensor_drift"]["parameters"]["offset_change"]
    assert c["ci95"][0] <= 0.010 <= c["ci95"][1] and c["value"] == pytest.approx(0.010, rel=0.02)
    # the grease's own thinning (Walther's line): a straight line per 10 K over the 14 K rise
    # has a slope between the curve's slopes at its ends (-0.584 and -0.483 per 10 K)
    from model_core.thermal import viscosity_slope
    T0 = DriveDesign().operating_temperature
    v = e["viscosity_drift"]["parameters"]["ln_viscosity_change"]["value"]
    assert 10 * viscosity_slope(DriveDesign(), T0) < v < 10 * viscosity_slope(DriveDesign(),
                                                                              T0 + 14.0), v
    _assert_closes(good, bad, bad_min=2.0)

def test_the_bench_reads_the_zero_drift_per_10K(sets, short):
    """design_updated.toml's [extra] torque_in_zero_per_10K and torque_in_zero_T_ref become the
    input torque transducer's zero_per_10K and zero_T_ref, and the recording's temperature
    column reaches its temperature input through the reducer (T_oil_in -> T_oil -> t_in): the
    reading moves by c (T - T_ref)/10 K at every sample (closed form), as the diagnosis's
    replay has it (model_core.effects.reading_model, the same formula), in the Python and the
    native set alike. Without a temperature column the transducer reads at the reducer's heat
    balance temperature (T_oil_start at the start)."""
    import dataclasses

    from model_core.effects import reading_model
    py_dir, na_dir = sets
    _, rec, mode = short
    T_col = 40.0 + 6.0 * np.sin(rec.time / 2.0)           # degC, 34-46
    warm = dataclasses.replace(rec, temperature=T_col)
    base = DriveDesign()
    c, T_ref = 0.02, 310.0
    drifting = replace(base, extra=replace(base.extra, torque_in_zero_per_10K=c,
                                           torque_in_zero_T_ref=T_ref))
    p = bench_parameters(Scenario("x"), Sensors(), drifting)
    assert (p["t_in.zero_per_10K"], p["t_in.zero_T_ref"]) == (c, T_ref)
    assert p["t_out.zero_per_10K"] == 0.0
    quiet = Sensors(torque_noise=0.0, torque_resolution=0.0, speed_noise=0.0,
                    speed_resolution=0.0)
    a = replay_recording(warm, mode, py_dir, base, quiet, "python").simulated["torque_in_Nm"]
    out = [replay_recording(warm, mode, d, drifting, quiet, f).simulated["torque_in_Nm"]
           for d, f in ((py_dir, "python"), (na_dir, "native"))]
    closed = c * (T_col + 273.15 - T_ref) / 10.0
    assert np.ptp(closed) > 0.02                             # 24 mN*m of drift
    assert np.allclose(out[0] - a, closed, rtol=0, atol=1e-12)
    assert np.allclose(out[1], out[0], rtol=0, atol=TWIN_TOL)
    assert np.allclose(reading_model(drifting.extra, a, {"temperature": T_col}), out[0],
                       rtol=0, atol=1e-12)
    # no temperature column: the transducer at the reducer's T_oil from its heat balance
    cold = replay_recording(rec, mode, py_dir, drifting, quiet, "python")
    ref = replay_recording(rec, mode, py_dir, base, quiet, "python").simulated["torque_in_Nm"]
    first = (cold.simulated["torque_in_Nm"] - ref)[0]
    assert first == pytest.approx(c * (base.operating_temperature - T_ref) / 10.0, abs=1e-9)
    assert any("zero drift per 10 K with it" in n for n in cold.notes)


def test_cli_bench_replay_and_verify(sets, short, tmp_path, capsys):
    """bench --scenario FILE (with --columns/--units as diagnose) and verify: exit 1 when the
    design does not reproduce the recording, one-line errors (exit 2) for bad input."""
    from cyclo_fmu.cli import main
    path, rec, _ = short
    # the recording in another dialect: semicolons, decimal commas, torque in N*mm, renamed
    text = path.read_text().splitlines()
    rows = ["t;n1;T1;n2;T2"] + [";".join(x.replace(".", ",") if i != 2 else
                                         str(float(x) * 1e3).replace(".", ",")
                                         for i, x in enumerate(line.split(",")))
                                for line in text[1:]]
    other = tmp_path / "other.csv"
    other.write_text("\n".join(rows) + "\n")
    cols = "time_s=t,speed_in_rpm=n1,torque_in_Nm=T1,speed_out_rpm=n2,torque_out_Nm=T2"
    out = tmp_path / "b"
    assert main(["bench", "--scenario", str(other), "--columns", cols, "--units",
                 "torque_in_Nm=N*mm", "--fmus", "python", "--out", str(out), "--quiet"]) == 0
    sim = np.genfromtxt(out / "recording_S1_replay.csv", delimiter=",", names=True)
    assert np.allclose(sim["time_s"], rec.time)
    capsys.readouterr()
    code = main(["verify", str(path), "--mode", "S1", "--fmus", "python", "--json"])
    res = json.loads(capsys.readouterr().out)
    assert code == 1 and not res["reproduces_to_noise_floor"] and res["blocks"] == 1200
    # diagnose --verify: the updated design through the bench (native FMUs) closes the loop
    assert main(["diagnose", str(path), "--mode", "S1", "--verify", "--json"]) == 0
    v = json.loads(capsys.readouterr().out)["verify"]
    assert v["reproduces_to_noise_floor"] and v["ratio_to_noise_floor"] <= VERIFY_TOLERANCE
    assert main(["bench", "--scenario", str(tmp_path / "missing.csv")]) == 2
    assert main(["bench", "--scenario", "paper", "--columns", cols]) == 2
    assert "scenario" in capsys.readouterr().err
