"""The bench's named scenarios run as written in every master (fmpy's SSP master, the lean
master ``run_fmus`` behind ``run_bench`` and the CLI, libcosim), and the output inertia is
integrated, not differentiated: the signals agree between 1 ms and 0.25 ms steps."""
import subprocess
import sys

import numpy as np
import pytest

from cyclo_fmu.bench import (RPM_PER_RAD_S, Sensors, build_ssp, run_bench, run_ssp, scenario)
from model_core import DriveDesign, operating_point, rig

IDEAL = Sensors(ideal=True)
#: the reversal's regulator goes to -40 Hz: -2400 r/min synchronous on the two-pole motor;
#: the issue's acceptance: below -1500 r/min
REVERSE_RPM = -1500.0
#: load step: relative tolerance of the output torque levels (issue acceptance: 5 %)
LEVEL_TOL = 0.05
#: 1 ms against 0.25 ms: 2 % of the peak output torque (issue acceptance)
AGREE = 0.02
#: s around a setpoint step of the schedules and around a reversal of the input shaft left out
#: of the 1 ms / 0.25 ms comparison (3-5 samples each): at a setpoint step the regulator's ramp
#: starts abruptly, and at a reversal the
#: reducer switches from back-driven to driven (its efficiency, and the output inertia the motor
#: feels, jump by a factor of about 1/(eta eta')) at an instant resolved to one step, and the
#: motor settles on its Kloss slope (time constant ~5 ms)
SWITCH = 10e-3


def _means(t, y, t0, t1):
    sel = (t > t0) & (t <= t1)
    return float(np.mean(y[sel]))


@pytest.fixture(scope="module")
def ssp_runs(fmu_dir, tmp_path_factory):
    """reversal and loadstep in fmpy's own SSP master, from the SSP file alone."""
    d = tmp_path_factory.mktemp("ssp")
    out = {}
    for name in ("reversal", "loadstep"):
        sc = scenario(name)
        out[name] = run_ssp(build_ssp(d / f"{name}.ssp", fmu_dir, sc, IDEAL), sc.stop_time)
    return out


def test_reversal_reverses_and_back_drives_in_fmpys_ssp_master(ssp_runs):
    r = ssp_runs["reversal"]
    t = r["time"]
    n_in = r["n_in.y"]
    assert n_in.min() < REVERSE_RPM
    assert _means(t, n_in, 7.5, 8.0) < REVERSE_RPM              # and stays reversed
    # back-drive: while the regulator slows the shaft down (positive speed), the flywheel on
    # the output pushes power into the reducer and the reducer pushes power into the motor
    p_in = r["drive.tau_in"] * r["motor.w"]                      # into the reducer at the input
    p_out = -r["drive.torque_out"] * r["drive.w_out"]            # into the reducer at the output
    sel = (t > 3.3) & (t < 4.3)
    assert np.all(r["motor.w"][sel] > 0)
    assert np.all(p_in[sel] < 0) and np.all(p_out[sel] > 0)
    # the reducer's losses are what is missing, and never negative
    loss = p_in + p_out
    assert np.all(loss[sel] > 0)
    assert np.all(r["drive.P_loss"][sel] > 0)


def test_loadstep_reaches_its_levels_in_fmpys_ssp_master(ssp_runs):
    r = ssp_runs["loadstep"]
    t, T_out = r["time"], r["t_out.y"]
    for (t0, t1), level in (((2.0, 3.0), 2.0), ((5.0, 6.0), 7.0)):   # scenario: '0 2; 3 7'
        assert _means(t, T_out, t0, t1) == pytest.approx(level, rel=LEVEL_TOL)


def test_runup_reaches_speed(fmu_dir):
    run = run_bench(scenario("runup"), fmu_dir, sensors=IDEAL)
    t, n = run.recording["time_s"], run.recording["speed_in_rpm"]
    n_end = _means(t, n, 3.5, 4.0)
    # 50 Hz on the two-pole motor: 3000 r/min synchronous, 2800 r/min at its rated 0.85 N*m;
    # the 5 N*m brake needs ~0.5 N*m at the input: between rated and synchronous speed
    assert 2800 < n_end < 3000
    assert abs(_means(t, n, 3.0, 3.5) - n_end) < 0.002 * n_end      # steady


def _tube_error(coarse, fine, t_c, t_f, h, skip=()):
    """Largest distance of each coarse sample from the fine signal within +-h around it: a
    recorded torque passes two connections (motor -> reducer -> transducer), each one
    communication step late in a Jacobi master, so a jump may move by two coarse steps; an
    oscillation may not."""
    err = 0.0
    for k in range(len(t_c)):
        if any(abs(t_c[k] - ts) < SWITCH for ts in skip):
            continue
        sel = np.abs(t_f - t_c[k]) <= h + 1e-12
        err = max(err, float(np.min(np.abs(fine[sel] - coarse[k]))))
    return err


@pytest.mark.parametrize("name", ["reversal", "loadstep"])
def test_step_size_does_not_change_the_signals(fmu_dir, name):
    sc = scenario(name)
    runs = {h: run_bench(sc, fmu_dir, sensors=IDEAL, step=h).recording for h in (1e-3, 2.5e-4)}
    c, f = runs[1e-3], runs[2.5e-4]
    peak = float(np.max(np.abs(f["torque_out_Nm"])))
    for col in ("torque_out_Nm", "torque_in_Nm"):
        scale = peak if col == "torque_out_Nm" else float(np.max(np.abs(f[col])))
        n_f = f["speed_in_rpm"]
        flips = list(f["time_s"][1:][np.diff(np.sign(n_f)) != 0])
        for text in (sc.frequency_schedule, sc.torque_schedule):
            flips += [t for t, _ in rig.parse_schedule(text)] if text else []
        err = _tube_error(c[col], f[col], c["time_s"], f["time_s"], 2e-3, flips)
        assert err < AGREE * scale, (col, err, scale)
    # no oscillation at the communication rate: the 1 ms output torque minus its 21-sample
    # moving mean stays within 1 % of the peak away from the schedule's steps and reversals
    T = c["torque_out_Nm"]
    smooth = np.convolve(T, np.ones(21) / 21, mode="same")
    n = c["speed_out_rpm"]
    quiet = np.ones_like(T, bool)
    for k in np.flatnonzero((np.abs(np.diff(T)) > 0.05 * peak) | (np.diff(np.sign(n)) != 0)):
        quiet[max(0, k - 30):k + 30] = False
    quiet[:30] = quiet[-30:] = False
    assert np.max(np.abs(T - smooth)[quiet]) < 0.01 * peak


def test_design_with_a_string_parameter_runs(fmu_dir, tmp_path):
    """ring_rollers = 'needle' reaches the reducer FMU: the steady efficiency is the core's
    for the needle design, not the plain one."""
    import dataclasses
    needle = dataclasses.replace(DriveDesign(), ring_rollers="needle")
    sc = dataclasses.replace(scenario("runup"), name="short", duration=3.0, hold=3.0, settle=2.0)
    run = run_bench(sc, fmu_dir, tmp_path, IDEAL, design=needle)
    (w,) = run.windows
    assert abs(w["eta"] - w["eta_core"]) < 0.002
    plain = operating_point(DriveDesign(), "S1", w["speed_in_rpm"] / RPM_PER_RAD_S,
                            w["torque_in_Nm"])
    assert abs(float(plain.eta) - w["eta_core"]) > 0.005         # the parameter matters
    # fmpy's SSP master cannot set it: a clear error naming the parameter
    with pytest.raises(ValueError, match="drive.ring_rollers"):
        run_ssp(tmp_path / "TestBench.ssp", 0.01)


def test_libcosim_runs_the_loadstep(fmu_dir, tmp_path):
    pytest.importorskip("libcosimpy")
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver
    sc = scenario("loadstep")
    ssp = build_ssp(tmp_path / "TestBench.ssp", fmu_dir, sc, IDEAL)
    log_output_level(CosimLogLevel.ERROR)
    ex = CosimExecution.from_ssp_file(ssp_path=str(ssp), step_size=1_000_000)
    idx = {i.name.decode(): i.index for i in ex.slave_infos()}
    obs = CosimObserver.create_last_value()
    ex.add_observer(obs)
    ref = {v.name.decode(): v.reference for v in ex.slave_variables(idx["t_out"])}["y"]
    for t_end, level in ((2.9, 2.0), (5.9, 7.0)):
        ex.simulate_until(target_time=int(round(t_end * 1e9)))
        assert obs.last_real_values(idx["t_out"], [ref])[0] == pytest.approx(level, rel=LEVEL_TOL)


def test_cli_reversal_recording(tmp_path):
    r = subprocess.run([sys.executable, "-m", "cyclo_fmu.cli", "bench", "--mode", "S1",
                        "--scenario", "reversal", "--out", str(tmp_path)], capture_output=True,
                       text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    data = np.genfromtxt(tmp_path / "recording_S1_reversal.csv", delimiter=",", names=True)
    assert data["speed_in_rpm"].min() < REVERSE_RPM


def test_steady_step_passes_the_convergence_check(fmu_dir):
    """The step the bench uses for steady scenarios (STEADY_STEP, chosen on the paper scenario)
    passes the same check on a shorter steady series: window efficiencies within
    STEP_ETA_TOL and mean speeds within STEP_SPEED_TOL of the 1 ms run."""
    from cyclo_fmu.bench import STEADY_STEP, Scenario, converged_step
    # steady: the windows start 1.8 s into each slot (the 30 -> 50 Hz ramp takes 0.8 s); with
    # settle = 1.2 s the windows hold the tail of the ramp's transient and 20 ms fails the check
    sc = Scenario("quick", mode="S1", f_first=30, f_last=50, f_count=2, T_first=3.0, T_last=8.0,
                  T_count=2, hold=2.5, settle=1.8)
    h, report = converged_step(fmu_dir, sc, candidates=(STEADY_STEP,))
    assert h >= STEADY_STEP, report
    transient = Scenario("quick", mode="S1", f_first=30, f_last=50, f_count=2, T_first=3.0,
                         T_last=8.0, T_count=2, hold=2.0, settle=1.2)
    h, report = converged_step(fmu_dir, transient, candidates=(STEADY_STEP,))
    assert h < STEADY_STEP, report           # the check can fail


def _run_with_tty_stderr(argv):
    """Run the CLI with stderr on a pseudo-terminal; returns (exit code, stderr text)."""
    import os
    import pty
    import fcntl
    import struct
    import termios
    master, slave = pty.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 100, 0, 0))   # 100 columns
    p = subprocess.Popen([sys.executable, "-m", "cyclo_fmu.cli"] + argv, stdout=subprocess.PIPE,
                         stderr=slave)
    os.close(slave)
    chunks = []
    while True:
        try:
            data = os.read(master, 4096)
        except OSError:
            break
        if not data:
            break
        chunks.append(data)
    p.wait(timeout=600)
    os.close(master)
    return p.returncode, b"".join(chunks).decode(errors="replace")


def test_bench_progress_bar_on_a_terminal_only(tmp_path):
    argv = ["bench", "--scenario", "runup", "--step", "steady", "--out", str(tmp_path / "a")]
    rc, err = _run_with_tty_stderr(argv)
    assert rc == 0 and "bench" in err and "step" in err          # tqdm's bar
    rc, err = _run_with_tty_stderr(argv[:-1] + [str(tmp_path / "b"), "--quiet"])
    assert rc == 0 and err == ""
    r = subprocess.run([sys.executable, "-m", "cyclo_fmu.cli"] + argv[:-1] + [str(tmp_path / "c")],
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0 and r.stderr == ""                   # not a terminal: no bar
