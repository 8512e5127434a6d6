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
#: 1 ms against 0.25 ms: 2 % of each signal's peak (issue acceptance), on the common time grid
#: with no time shift
AGREE = 0.02
#: s after a corner of a prescribed input (a schedule's setpoint step) left out of the
#: comparison: one 1-ms step (the one sample in which the coarse run has not yet seen the step)
CORNER = 1e-3
#: a numerical oscillation: the torque minus its moving mean over OSC_WINDOW (s; the train's
#: fastest physical time constant is the motor's ~5 ms on its Kloss slope) changing sign more
#: than OSC_CROSSINGS times in OSC_SPAN after a corner or in the last second, counting a
#: crossing only when the residual swings beyond OSC_LEVEL of the peak torque
OSC_WINDOW = 9e-3
OSC_SPAN = 0.3
OSC_LEVEL = 0.002
OSC_CROSSINGS = 2
STEPS = (1e-3, 2.5e-4)


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


@pytest.fixture(scope="module", params=[("reversal", "physical"), ("loadstep", "physical"),
                                        ("reversal", "paper")], ids="-".join)
def both_steps(request, fmu_dir):
    """A scenario at 1 ms and at 0.25 ms (ideal sensors), in a profile."""
    name, profile = request.param
    sc = scenario(name)
    design = DriveDesign(profile=profile,
                         losses="load_dependent" if profile == "paper" else "all")
    return sc, {h: run_bench(sc, fmu_dir, sensors=IDEAL, step=h, design=design).recording
                for h in STEPS}


def _corners(sc):
    """Times of the setpoint steps of the scenario's schedules (prescribed inputs)."""
    out = []
    for text in (sc.frequency_schedule, sc.torque_schedule):
        out += [t for t, _ in rig.parse_schedule(text)] if text else []
    return sorted(set(out))


def test_step_size_does_not_change_the_signals(both_steps):
    """1 ms against 0.25 ms on the 1 ms grid, no time shift: both torques and both speeds
    within 2 % of their peaks, except the one sample after a setpoint step."""
    sc, runs = both_steps
    c, f = runs[1e-3], runs[2.5e-4]
    t = c["time_s"]
    k = np.searchsorted(f["time_s"], t - 1e-9)
    assert np.allclose(f["time_s"][k], t, atol=1e-9)          # the common grid
    keep = np.ones(t.size, bool)
    for tc in _corners(sc):
        keep &= ~((t > tc + 1e-9) & (t <= tc + CORNER + 1e-9))
    assert keep.sum() >= t.size - len(_corners(sc))
    for col in ("torque_out_Nm", "torque_in_Nm", "speed_in_rpm", "speed_out_rpm"):
        peak = float(np.max(np.abs(f[col])))
        diff = np.abs(c[col] - f[col][k])[keep]
        assert diff.max() <= AGREE * peak, (col, float(diff.max()), float(t[keep][diff.argmax()]),
                                            peak)


def _crossings(r, level):
    """Sign changes of r with hysteresis: r must swing beyond +-level to count."""
    n, state = 0, 0
    for v in r:
        s_ = 1 if v > level else -1 if v < -level else 0
        if s_ and state and s_ != state:
            n += 1
        if s_:
            state = s_
    return n


def test_no_oscillation_at_the_step_rate(both_steps):
    """After every setpoint step and in the last second, the torques minus their 9 ms moving
    mean do not oscillate, at 1 ms nor at 0.25 ms: a numerical oscillation has a period of a
    few communication steps and shows as many sign changes of that residual."""
    sc, runs = both_steps
    for h, rec in runs.items():
        t = rec["time_s"]
        m = int(round(OSC_WINDOW / h)) | 1
        spans = [(tc, tc + OSC_SPAN) for tc in _corners(sc)] + [(sc.stop_time - 1.0,
                                                                   sc.stop_time)]
        for col in ("torque_out_Nm", "torque_in_Nm"):
            y = rec[col]
            peak = float(np.max(np.abs(y)))
            r = y - np.convolve(y, np.ones(m) / m, mode="same")
            for t0, t1 in spans:
                sel = (t > t0 + OSC_WINDOW / 2) & (t < t1 - OSC_WINDOW / 2)
                n = _crossings(r[sel], OSC_LEVEL * peak)
                assert n <= OSC_CROSSINGS, (h, col, t0, n)


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


def test_the_profile_reaches_the_reducer(fmu_dir):
    """The design's profile is a parameter of the reducer FMU: a run in the paper profile has
    the paper profile's steady efficiency, not the default's."""
    import dataclasses
    sc = dataclasses.replace(scenario("runup"), name="short", duration=3.0, hold=3.0, settle=2.0)
    eta = {}
    for profile, losses in (("paper", "load_dependent"), ("physical", "all")):
        design = DriveDesign(profile=profile, losses=losses)
        (w,) = run_bench(sc, fmu_dir, sensors=IDEAL, design=design).windows
        assert abs(w["eta"] - w["eta_core"]) < 0.002, profile
        eta[profile] = w["eta"]
    assert abs(eta["paper"] - eta["physical"]) > 0.01


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
    # settle = 0.9 s the windows hold the tail of the ramp's transient and 20 ms fails the check
    # (mean speeds 3.9 r/min apart)
    sc = Scenario("quick", mode="S1", f_first=30, f_last=50, f_count=2, T_first=3.0, T_last=8.0,
                  T_count=2, hold=2.5, settle=1.8)
    h, report = converged_step(fmu_dir, sc, candidates=(STEADY_STEP,))
    assert h >= STEADY_STEP, report
    transient = Scenario("quick", mode="S1", f_first=30, f_last=50, f_count=2, T_first=3.0,
                         T_last=8.0, T_count=2, hold=2.0, settle=0.9)
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
