"""The SSP test bench: steady-state efficiency against the core, energy balance in the
recording, the recording schema, the same numbers in libcosimpy, the CLI."""
import csv
import json
import subprocess
import sys

import numpy as np
import pytest

from cyclo_fmu.bench import (RECORDING_COLUMNS, RPM_PER_RAD_S, Scenario, Sensors, build_ssp,
                             run_bench, run_ssp)
from model_core import rig

QUICK = Scenario("quick", mode="S1", f_first=30, f_last=50, f_count=2, T_first=3.0, T_last=8.0,
                 T_count=2, hold=2.0, settle=1.2)


@pytest.fixture(scope="module")
def quick_run(fmu_dir, tmp_path_factory):
    return run_bench(QUICK, fmu_dir, tmp_path_factory.mktemp("bench"))


def test_steady_state_efficiency_matches_core(quick_run):
    assert len(quick_run.windows) == 4
    for w in quick_run.windows:
        assert abs(w["eta"] - w["eta_core"]) < 0.002, w      # 0.2 percentage point
        assert 0.6 < w["eta"] < 0.8      # the default (physical) profile, S1: 61-79 % (README)


def test_energy_balance_in_recording(quick_run):
    """Measured input minus output power equals the reducer's loss in every steady window."""
    res, sc = quick_run.result, quick_run.scenario
    t = res["time"] + 1e-3
    for k, w in enumerate(quick_run.windows):
        sel = (t > w["t_start_s"]) & (t <= w["t_end_s"])
        loss = float(np.mean(res["drive.P_loss"][sel]))
        assert w["input_power_W"] - w["output_power_W"] == pytest.approx(loss, rel=0.02)


def test_recording_schema_and_units(quick_run, tmp_path):
    from cyclo_fmu.bench import write_recording
    path = write_recording(tmp_path / "rec.csv", quick_run.recording)
    rows = list(csv.reader(path.open()))
    assert rows[0] == RECORDING_COLUMNS
    data = np.array(rows[1:], float)
    assert np.all(np.diff(data[:, 0]) > 0)
    last = data[-100:]
    # S1, 50 Hz, two-pole motor: input near 2800 r/min, output = input / 15 (i_S1 = +z1)
    assert 2600 < last[:, 1].mean() < 3000
    assert last[:, 3].mean() == pytest.approx(last[:, 1].mean() / 15, rel=2e-3)
    assert last[:, 2].mean() > 0 and last[:, 4].mean() > 0


def libcosim_last_values(ssp, stop_time, variables):
    """Run an SSP in libcosim at 1 ms until ``stop_time`` [s]; the last values of
    [(component, variable)]."""
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver
    log_output_level(CosimLogLevel.ERROR)
    ex = CosimExecution.from_ssp_file(ssp_path=str(ssp), step_size=1_000_000)
    idx = {i.name.decode(): i.index for i in ex.slave_infos()}
    obs = CosimObserver.create_last_value()
    ex.add_observer(obs)
    ex.simulate_until(target_time=int(round(stop_time * 1e9)))
    out = []
    for comp, var in variables:
        ref = {v.name.decode(): v.reference for v in ex.slave_variables(idx[comp])}[var]
        out.append(obs.last_real_values(idx[comp], [ref])[0])
    return out


def test_libcosim_runs_the_ssp_with_fmpys_numbers(fmu_dir, tmp_path):
    pytest.importorskip("libcosimpy")
    sc = Scenario("short", mode="S2", f_first=30, f_last=30, f_count=1, T_first=5, T_last=5,
                  T_count=1, hold=1.5, duration=1.5)
    ssp = build_ssp(tmp_path / "TestBench.ssp", fmu_dir, sc, Sensors(ideal=True))
    fm = run_ssp(ssp, 1.5)
    variables = (("drive", "tau_in"), ("drive", "eta"), ("motor", "w"), ("brake", "tau_out"))
    for (comp, var), value in zip(variables, libcosim_last_values(ssp, 1.5, variables)):
        # fmpy's row k holds the values after step k+1; libcosim stopped after 1500 steps
        assert value == pytest.approx(fm[f"{comp}.{var}"][1499], rel=1e-9, abs=1e-12), (comp, var)


def test_kloss_motor():
    m = rig.InductionMotor()
    assert m.torque(m.rated_speed, 50.0) == pytest.approx(m.rated_torque, rel=1e-12)
    w_k = 2 * np.pi * 50 - m.breakdown_slip_speed
    assert m.torque(w_k, 50.0) == pytest.approx(m.breakdown_ratio * m.rated_torque, rel=1e-12)
    # constant flux: the same slip speed gives the same torque at 25 Hz
    assert m.torque(np.pi * 50 - 10.0, 25.0) == pytest.approx(m.torque(2 * np.pi * 50 - 10.0, 50.0))
    assert m.torque(2 * np.pi * 50, 50.0) == 0.0


def test_schedules():
    s = rig.parse_schedule("0 20; 3 30", "frequency_schedule")
    assert rig.schedule_value(s, 2.9) == 20 and rig.schedule_value(s, 3.0) == 30
    with pytest.raises(ValueError, match="frequency_schedule"):
        rig.parse_schedule("0 20; 1", "frequency_schedule")
    with pytest.raises(ValueError, match="increase"):
        rig.parse_schedule("2 20; 1 30")
    # every frequency meets every load
    pairs = {(rig.series_value(t, 20, 50, 4, 3.0, 4), rig.series_value(t, 3, 8, 4, 3.0))
             for t in np.arange(0.5, 48, 3.0)}
    assert len(pairs) == 16


def test_cli_bench_runup(tmp_path):
    r = subprocess.run([sys.executable, "-m", "cyclo_fmu.cli", "bench", "--mode", "S2",
                        "--scenario", "runup", "--out", str(tmp_path), "--plot"],
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    rec = tmp_path / "recording_S2_runup.csv"
    assert rec.exists() and (tmp_path / "efficiency_S2_runup.csv").exists()
    assert (tmp_path / "bench_S2_runup.png").stat().st_size > 10000
    # without --plot: the same results, no figure
    plain = tmp_path / "plain"
    r = subprocess.run([sys.executable, "-m", "cyclo_fmu.cli", "bench", "--mode", "S2",
                        "--scenario", "runup", "--out", str(plain)], capture_output=True,
                       text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    assert not (plain / "bench_S2_runup.png").exists()
    assert (plain / "recording_S2_runup.csv").read_bytes() == rec.read_bytes()
    # the Python slaves instead of the native FMUs: the same recording, byte for byte
    slaves = tmp_path / "slaves"
    r = subprocess.run([sys.executable, "-m", "cyclo_fmu.cli", "bench", "--mode", "S2",
                        "--scenario", "runup", "--out", str(slaves), "--fmus", "python"],
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    assert (slaves / "recording_S2_runup.csv").read_bytes() == rec.read_bytes()
    assert sorted(p.name for p in (slaves / "fmus").iterdir()) == [
        "CycloidDrive.fmu", "FeltBrake.fmu", "InductionMotor.fmu", "SpeedTransducer.fmu",
        "TorqueTransducer.fmu"]
    r = subprocess.run([sys.executable, "-m", "cyclo_fmu.cli", "bench", "--scenario", "nope",
                        "--out", str(tmp_path)], capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1


def test_transducers_switchable(fmu_dir, tmp_path):
    sc = Scenario("short", mode="S1", f_first=30, f_last=30, f_count=1, T_first=5, T_last=5,
                  T_count=1, hold=1.5, duration=1.5)
    spread = {}
    for ideal in (True, False):
        res = run_ssp(build_ssp(tmp_path / f"tb{ideal}.ssp", fmu_dir, sc, Sensors(ideal=ideal)), 1.5)
        err = res["t_in.y"][-300:] - res["drive.tau_in"][-300:]
        spread[ideal] = float(np.std(err))
        if ideal:
            # ideal: the reading is the true value (one step behind through the connection)
            assert abs(float(np.mean(err))) < 1e-3
    # the default transducer noise (0.003 N*m) shows, the ideal one does not
    assert spread[False] > 0.002 and spread[True] < 0.001


def test_bench_runs_an_updated_design(fmu_dir, tmp_path):
    """A design with diagnosed physics (drag) goes to the reducer FMU through the SSV, and the
    bench's steady efficiency matches the core with that physics."""
    from model_core import DriveDesign
    from model_core.design import ExtraPhysics
    d = DriveDesign(extra=ExtraPhysics(drag_torque=0.02))
    sc = Scenario("short", mode="S1", f_first=40, f_last=40, f_count=1, T_first=5, T_last=5,
                  T_count=1, hold=2.0, settle=1.2, duration=2.0)
    run = run_bench(sc, fmu_dir, tmp_path, Sensors(ideal=True), design=d)
    (w,) = run.windows
    assert abs(w["eta"] - w["eta_core"]) < 0.002
    plain = run_bench(sc, fmu_dir, tmp_path, Sensors(ideal=True))
    assert plain.windows[0]["eta"] - w["eta"] > 0.01       # the drag costs efficiency


# -- scenarios run as written, in every master -------------------------------------------------
@pytest.fixture(scope="module")
def reversal_run(fmu_dir, tmp_path_factory):
    from cyclo_fmu.bench import scenario
    return run_bench(scenario("reversal", "S1"), fmu_dir)


def test_reversal_reverses_and_back_drives(reversal_run):
    """fmpy's SSP master sets the motor's schedule (numbered Real parameters): +40 Hz, then
    -40 Hz; while the regulator decelerates, the output flywheel drives the reducer backwards."""
    rec = reversal_run.recording
    assert rec["speed_in_rpm"].min() < -1500
    assert rec["speed_in_rpm"][rec["time_s"] < 3.0].max() > 1500
    p_in = rec["torque_in_Nm"] * rec["speed_in_rpm"] / RPM_PER_RAD_S   # W, into the reducer
    assert np.count_nonzero(p_in < -1.0) > 100       # power flows from the output to the motor


def test_loadstep_reaches_its_levels(fmu_dir):
    from cyclo_fmu.bench import scenario
    rec = run_bench(scenario("loadstep", "S1"), fmu_dir).recording
    t, T = rec["time_s"], rec["torque_out_Nm"]
    assert np.mean(T[(t > 2.5) & (t < 3.0)]) == pytest.approx(2.0, rel=0.05)
    assert np.mean(T[(t > 5.5) & (t < 6.0)]) == pytest.approx(7.0, rel=0.05)


def test_runup_reaches_speed(fmu_dir):
    """50 Hz with a 5 N*m brake: near the motor's rated 2800 r/min (slip under load)."""
    from cyclo_fmu.bench import scenario
    rec = run_bench(scenario("runup", "S1"), fmu_dir).recording
    n_end = np.mean(rec["speed_in_rpm"][rec["time_s"] > 3.5])
    assert 2700 < n_end < 3000


def test_libcosim_sets_the_schedule(fmu_dir, tmp_path):
    """libcosim applies the per-component parameter sets: the motor reverses there too."""
    pytest.importorskip("libcosimpy")
    sc = Scenario("rev", mode="S1", frequency_schedule="0 40; 0.5 -40", T_first=0.5,
                  T_last=0.5, T_count=1, hold=2.0, duration=2.0)
    ssp = build_ssp(tmp_path / "TestBench.ssp", fmu_dir, sc, Sensors(ideal=True))
    (frequency,) = libcosim_last_values(ssp, 2.0, [("motor", "frequency")])
    assert frequency < -10.0      # reversed, ramping


def test_schedule_given_two_ways_is_an_error():
    with pytest.raises(ValueError, match="more than 8 setpoints"):
        rig.schedule_parameters("motor.", [(float(k), 1.0) for k in range(9)])
    p = rig.schedule_parameters("brake.", rig.parse_schedule("0 2; 3 7"))
    assert p == {"brake.schedule_points": 2, "brake.schedule_time_1": 0.0,
                 "brake.schedule_value_1": 2.0, "brake.schedule_time_2": 3.0,
                 "brake.schedule_value_2": 7.0}


def test_lean_master_gives_fmpys_numbers(fmu_dir, tmp_path):
    """The package's master (cached value references, raw FMI calls) with Jacobi coupling and
    fmpy's SSP master run the same SSP to the same numbers, schedules included."""
    from cyclo_fmu.bench import bench_parameters, run_fmus, scenario
    sc = scenario("loadstep", "S2")
    lean = run_fmus(fmu_dir, bench_parameters(sc, Sensors()), sc.stop_time, coupling="jacobi")
    ref = run_ssp(build_ssp(tmp_path / "TestBench.ssp", fmu_dir, sc), sc.stop_time)
    n = min(len(lean), len(ref))
    for name in lean.dtype.names:
        np.testing.assert_allclose(lean[name][:n], ref[name][:n], rtol=1e-9, atol=1e-9)


def test_gauss_seidel_rows_hold_one_instant(fmu_dir):
    """The default coupling: the reducer's output speed and the transducers' readings in a
    row belong to the motor's speed of the same row (Jacobi: one step behind per connection)."""
    from cyclo_fmu.bench import bench_parameters, run_fmus, scenario
    sc = scenario("runup", "S1")
    r = run_fmus(fmu_dir, bench_parameters(sc, Sensors(ideal=True)), 0.5)
    np.testing.assert_allclose(r["drive.w_out"], r["motor.w"] / 15, rtol=1e-12)
    np.testing.assert_allclose(r["n_in.y"], r["motor.w"] * RPM_PER_RAD_S, rtol=1e-12)
    np.testing.assert_allclose(r["t_in.y"], r["drive.tau_in"], rtol=1e-12)
    with pytest.raises(ValueError, match="coupling"):
        run_fmus(fmu_dir, {}, 0.01, coupling="implicit")


def test_c_loop_and_python_loop_agree(fmu_dir, monkeypatch):
    """run_fmus' C inner loop makes the same calls as its Python fallback: the same rows, bit
    for bit, in both couplings."""
    import cyclo_fmu.bench as bench
    sc = bench.scenario("loadstep", "S1")
    params = bench.bench_parameters(sc, Sensors())
    if bench._c_loop() is None:
        pytest.skip("no C compiler: the Python loop is the only one")
    for coupling in bench.COUPLINGS:
        c = bench.run_fmus(fmu_dir, params, 0.3, coupling=coupling)
        monkeypatch.setitem(bench._LOOP, "fn", None)
        py = bench.run_fmus(fmu_dir, params, 0.3, coupling=coupling)
        monkeypatch.undo()
        for name in c.dtype.names:
            np.testing.assert_array_equal(c[name], py[name], err_msg=f"{coupling} {name}")
