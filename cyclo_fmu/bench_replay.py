"""The bench driven by a recording (``cyclo-fmu bench --scenario RECORDING``) and the check that
a design reproduces that recording through the co-simulation (``cyclo-fmu verify``).

Replay scenario: the bench's components as in every scenario (motor, reducer, brake, the four
transducers), with the motor's regulator in speed control following the recording's measured
input speed (``InductionMotor.speed_control``: a first-order speed loop whose setpoint is the
measured speed's +-2 ms mean, advanced by the loop's time constant) and the brake replaced
by a load machine in torque control applying the measured output torque at the output shaft
(``FeltBrake.torque_control``; the measured torque already holds the output side's inertia,
so the reducer's ``J_out`` is 0). A recording's temperature column becomes the reducer's grease
temperature (its input ``T_oil_in``), and through the bench's connection of the reducer's
``T_oil`` the input torque transducer's temperature (its zero's drift per 10 K); without one the
reducer's heat balance runs from ``T_oil_start``. The lean master (``bench.run_fmus``) feeds the two measured
signals into the FMUs' inputs at every step; the simulated recording has the recording's time
base (a recording sampled unevenly is run on its median step and interpolated back).

The recording is read by the same reader, checks and unit handling as ``diagnose``
(``cyclo_fmu.io.load_recording``: every CSV dialect and MDF4, ``--columns``, ``--units``).

``verify``: the co-simulation with a design (e.g. the ``design_updated.toml`` a diagnosis
wrote: its friction level, ``[calibration]``, ``[extra]`` physics in the reducer FMU and the
input torque transducer's offset, gain and zero drift in the transducer FMU) on the recording's own
inputs, with noise-free transducers; the residual of the input torque on the diagnosis's
10 ms block means against the recording's noise floor at that block length (the transducer
noise from sample-to-sample differences, as the diagnosis estimates it, of the recording and of
the residual: the smaller).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from model_core import DriveDesign
from model_core.kinematics import parse_mode

from .recordings import RecordingError
from .bench import (RPM_PER_RAD_S, Scenario, Sensors, bench_parameters, check_native_design,
                    fmu_set, run_fmus, write_recording)

#: [1] a recording's sampling is even when every step is within this share of the median
#: step (loggers' timestamps jitter by far less than a step; a missing sample is a gap of 100 %)
EVEN_SAMPLING = 1e-3
#: [s] the block length of the comparison: the diagnosis's (its residual statistics use
#: 10 ms means, ``cyclo_fmu.io.AUTO_BLOCK_S``)
BLOCK_S = 0.01
#: [Hz] the transducers' bandwidth in ``verify``: the diagnosis's assumption (``Diagnoser``'s
#: ``bandwidth``), with which it filtered the model it fitted
VERIFY_BANDWIDTH = 1000.0
#: [1] the residual's RMS at most this multiple of the noise floor counts as reproducing the
#: recording to its noise floor. A model that reproduced the recording exactly would leave the
#: transducer's noise alone: a ratio of 1 within 1/sqrt(2 N) for N blocks (under 1 % for a
#: minute of 10 ms blocks). 1.2 lets a structured mismatch of at most sqrt(1.2^2 - 1) = 0.66
#: of the noise remain, below what the diagnosis itself reports (an effect that explains less
#: than the noise-scaled threshold is not named): what is left is not a library effect's size
VERIFY_TOLERANCE = 1.2
#: [s] the replay's speed loop (``InductionMotor.speed_time_constant``), a first-order lag
#: that the setpoint's advance by the same time removes. Assumption: a servo regulator's speed
#: loop (~160 Hz), fast against the bench motor's own ~5 ms
SPEED_TIME_CONSTANT = 1e-3
#: [s] the measured input speed becomes the setpoint as its mean over +-2 ms (zero phase):
#: the speed transducer's noise would otherwise reach the inertia torques J dw/dt (0.5 r/min
#: at 1 kHz is 7 rad/s^2 on 10 ms blocks). Measured on the inertia closure (J = 1.5e-4 kg*m^2
#: hidden, engine bench): a 2 ms loop without advance or mean left 1.40 times the noise floor,
#: with the advance 1.21, with this mean and the 1 ms loop 1.14; +-1 to +-4 ms and 0.5-2 ms
#: loops gave 1.13-1.17 (wider means round the ramps' corners, narrower pass the noise)
SPEED_SMOOTHING = 2e-3
#: [steps] the longest replay in one run: the lean master keeps every connector's value of
#: every step (about 40 doubles), so 2 million steps (33 min at 1 kHz) hold about 0.6 GB. A
#: longer recording is replayed in parts, or read as block means (``load_recording(...,
#: block=0.01)``)
MAX_REPLAY_STEPS = 2_000_000


@dataclass
class Replay:
    """A replay run: the simulated recording (schema columns, edge units, the recording's time
    base), the measured one it was driven by, and the run's details."""

    mode: str
    simulated: dict
    measured: dict
    step: float                       # s, the communication step
    resampled: bool                   # the recording's sampling was uneven
    notes: list = field(default_factory=list)


def _measured(rec) -> dict:
    return {"time_s": np.asarray(rec.time, float),
            "speed_in_rpm": np.asarray(rec.speed_in, float) * RPM_PER_RAD_S,
            "torque_in_Nm": np.asarray(rec.torque_in, float),
            "speed_out_rpm": np.asarray(rec.speed_out, float) * RPM_PER_RAD_S,
            "torque_out_Nm": np.asarray(rec.torque_out, float)}


def replay_parameters(mode: str, duration: float, sensors: Sensors, design: DriveDesign,
                      fmus: str) -> dict:
    """The bench's parameters for a replay: the scenario's (no output inertia: the measured
    torque holds it), the design's, the transducers' (with the design's offset and gain), the
    motor in speed control and the load machine in torque control."""
    p = bench_parameters(Scenario("replay", mode=mode, duration=duration, J_out=0.0), sensors,
                         design, fmus)
    p.update({"motor.speed_control": True, "motor.speed_time_constant": SPEED_TIME_CONSTANT,
              "brake.torque_control": True, "brake.J_out": 0.0, "drive.J_out": 0.0})
    return p


def replay_recording(rec, mode: str, fmu_dir, design: DriveDesign = None,
                     sensors: Sensors = Sensors(), fmus: str = None, progress=False) -> Replay:
    """Drive the bench in ``fmu_dir`` with the checked recording ``rec`` (``Recording``):
    the motor follows its input speed, the load machine applies its output torque. ``mode``
    S1 or S2 (the bench drives the eccentric shaft). Returns a ``Replay``."""
    a, b, _ = parse_mode(mode)
    mode = a + b
    if a != "S":
        raise ValueError(f"mode = {mode!r}: the bench drives the eccentric shaft S (S1 or S2)")
    fmus = fmu_set(fmu_dir, fmus)
    if fmus == "native":
        check_native_design(fmu_dir, design)
    t = np.asarray(rec.time, float)
    dt = np.diff(t)
    step = float(np.median(dt))
    if not (math.isfinite(step) and step > 0):
        raise RecordingError(f"time_s: the recording's median step {step!r} s is not a time "
                             "step")
    even = bool(np.all(np.abs(dt - step) <= EVEN_SAMPLING * step))
    n = len(t) - 1 if even else int(math.floor((t[-1] - t[0]) / step + 1e-9))
    grid = t if even else t[0] + step * np.arange(n + 1)
    w_in = np.asarray(rec.speed_in, float)
    T_out = np.asarray(rec.torque_out, float)
    # the speed loop is a first-order lag of tc: its setpoint is the measured speed tc ahead
    # (interpolated; held at the end), so that the simulated speed follows the measured one
    # without the loop's delay (to first order in tc), and no noisy derivative is fed forward
    tc = SPEED_TIME_CONSTANT
    w_in = np.interp(grid + tc, t, centred_mean(w_in, int(round(SPEED_SMOOTHING / step))))
    if not even:
        T_out = np.interp(grid, t, T_out)
    if n > MAX_REPLAY_STEPS:
        raise RecordingError(f"time_s: the recording has {n + 1} samples at {1e3 * step:.6g} "
                             f"ms, more than one replay runs ({MAX_REPLAY_STEPS} steps): replay "
                             "it in parts or as 10 ms block means")
    if n < 1:
        raise RecordingError("time_s: the recording has fewer than two samples")
    params = replay_parameters(mode, n * step, sensors, design, fmus)
    signals = {"motor.w_set": w_in, "brake.T_set": T_out}
    notes = []
    temperature = getattr(rec, "temperature", None)
    if temperature is not None:
        # the reducer's grease follows the recording's temperature column (its input T_oil_in;
        # the diagnosis's temperature forms are per 10 K of the same column)
        from model_core.design import KELVIN

        from .slaves.cycloid_drive import T_OIL_RANGE
        T_oil = np.interp(grid, t, np.asarray(temperature, float)) + KELVIN
        bad = ~((T_oil > T_OIL_RANGE[0]) & (T_oil < T_OIL_RANGE[1]))
        if bad.any():
            k = int(np.argmax(bad))
            raise RecordingError(f"temperature_C: {float(T_oil[k] - KELVIN):.6g} degC at t = "
                                 f"{grid[k]:.6g} s is not a grease temperature the reducer "
                                 "takes (-100 to 200 degC); a column in K or F needs --units")
        signals["drive.T_oil_in"] = T_oil
        params["drive.use_T_oil_input"] = True
        notes.append("the reducer's grease temperature follows the recording's temperature "
                     "column (T_oil_in)"
                     + (", and the input torque transducer's zero drifts with it (its "
                        "temperature input is the reducer's T_oil)"
                        if params.get("t_in.zero_per_10K") else ""))
    else:
        notes.append("no temperature column: the reducer's grease follows its heat balance "
                     "from T_oil_start"
                     + (", and the input torque transducer's zero drift per 10 K with it"
                        if params.get("t_in.zero_per_10K") else ""))
    res = run_fmus(fmu_dir, params, n * step, step, progress=progress, fmus=fmus,
                   signals=signals)
    sim = {"time_s": grid,
           "speed_in_rpm": np.asarray(res["n_in.y"]), "torque_in_Nm": np.asarray(res["t_in.y"]),
           "speed_out_rpm": np.asarray(res["n_out.y"]),
           "torque_out_Nm": np.asarray(res["t_out.y"])}
    notes.insert(0, f"motor in speed control on the measured input speed, load machine in "
                    f"torque control on the measured output torque; step {1e3 * step:.6g} ms")
    if not even:
        sim = {k: (t if k == "time_s" else np.interp(t, grid, v)) for k, v in sim.items()}
        notes.append("the recording's sampling is uneven: run on its median step and "
                     "interpolated back onto its times")
    return Replay(mode, sim, _measured(rec), step, not even, notes)


def centred_mean(x, half: int):
    """The mean over the 2 half + 1 samples centred on each sample (zero phase; the ends
    repeat the first and last sample)."""
    x = np.asarray(x, float)
    if half < 1 or len(x) < 2:
        return x
    pad = np.concatenate([np.full(half, x[0]), x, np.full(half, x[-1])])
    c = np.concatenate([[0.0], np.cumsum(pad)])
    return (c[2 * half + 1:] - c[:-2 * half - 1]) / (2 * half + 1)


def noise_floor(torque_in, m: int) -> float:
    """The input torque transducer's noise at the level of m-sample means (N*m): the robust
    standard deviation of sample-to-sample differences over sqrt(2 m), the estimate the
    diagnosis uses (white noise: differences carry it twice; slow structure hardly enters)."""
    from .diagnosis.residual import robust_sigma
    return robust_sigma(np.diff(np.asarray(torque_in, float))) / math.sqrt(2 * m)


def _block_means(x, m):
    n = len(x) // m
    return np.asarray(x[:n * m], float).reshape(n, m).mean(1)


def compare(replay: Replay, block: float = BLOCK_S) -> dict:
    """The residual measured - simulated on ``block``-second means (input torque N*m, speeds
    r/min, output torque N*m) against the recording's noise floor."""
    meas, sim = replay.measured, replay.simulated
    t = meas["time_s"]
    dt = float(np.median(np.diff(t)))
    m = max(1, int(round(block / dt)))
    # the noise floor from the recording (as the diagnosis estimates it) and from the residual
    # (the simulated readings are noise-free, so its sample differences carry the recording's
    # noise alone where the model reproduces it): each counts the structure it holds near the
    # Nyquist frequency (a roller-pass ripple at up to 700 Hz) as noise, so the smaller is taken
    full = meas["torque_in_Nm"] - sim["torque_in_Nm"]
    noise = min(noise_floor(meas["torque_in_Nm"], m), noise_floor(full, m))
    from .diagnosis.residual import robust_sigma
    r = _block_means(full, m)
    rms = float(np.sqrt(np.mean(r * r)))
    out = {"blocks": int(len(r)), "block_s": m * dt,
           "torque_in_residual_rms_Nm": rms,
           "torque_in_residual_mean_Nm": float(np.mean(r)),
           "torque_in_residual_robust_sigma_Nm": robust_sigma(r),
           "noise_floor_Nm": noise,
           "ratio_to_noise_floor": rms / noise if noise > 0 else float("inf"),
           "tolerance": VERIFY_TOLERANCE}
    for key in ("speed_in_rpm", "speed_out_rpm", "torque_out_Nm"):
        d = _block_means(meas[key] - sim[key], m)
        out[f"{key.rsplit('_', 1)[0]}_residual_rms_{key.rsplit('_', 1)[1]}"] = float(
            np.sqrt(np.mean(d * d)))
    out["reproduces_to_noise_floor"] = bool(out["ratio_to_noise_floor"] <= VERIFY_TOLERANCE)
    return out


def verify_recording(rec, mode: str, fmu_dir, design: DriveDesign = None, fmus: str = None,
                     progress=False) -> dict:
    """Co-simulate the bench with ``design`` on the recording's own inputs (noise-free
    transducers at the diagnosis's bandwidth, the design's offset and gain) and compare
    (``compare``). Returns the comparison with the replay's notes."""
    sensors = Sensors(torque_noise=0.0, torque_resolution=0.0, speed_noise=0.0,
                      speed_resolution=0.0, bandwidth=VERIFY_BANDWIDTH)
    rp = replay_recording(rec, mode, fmu_dir, design, sensors, fmus, progress)
    out = compare(rp)
    out["mode"] = rp.mode
    out["notes"] = rp.notes
    return out, rp


def write_replay(path, replay: Replay):
    """The simulated recording as CSV (the bench's recording schema)."""
    return write_recording(path, replay.simulated)


def plot_replay(replay: Replay, path, block: float = BLOCK_S):
    """Measured and simulated signals over time, and the input torque's residual on
    ``block``-second means (matplotlib PNG)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    meas, sim = replay.measured, replay.simulated
    t = meas["time_s"]
    fig, axes = plt.subplots(3, 1, figsize=(11, 9), sharex=True)
    for ax, key, label in ((axes[0], "speed_in_rpm", "input speed / (r/min)"),
                           (axes[1], "torque_in_Nm", "input torque / N*m")):
        ax.plot(t, meas[key], lw=0.5, color="0.5", label="recording")
        ax.plot(t, sim[key], lw=0.6, color="C3", label="bench replay")
        ax.set_ylabel(label)
        ax.legend(fontsize=7, loc="upper right")
    axes[0].set_title(f"replay of a recording through the bench, mode {replay.mode}")
    m = max(1, int(round(block / float(np.median(np.diff(t))))))
    r = _block_means(meas["torque_in_Nm"] - sim["torque_in_Nm"], m)
    tb = _block_means(t, m)
    noise = noise_floor(meas["torque_in_Nm"], m)
    axes[2].plot(tb, 1e3 * r, lw=0.5, color="C0")
    for s in (-1, 1):
        axes[2].axhline(1e3 * s * noise, color="k", ls="--", lw=0.8)
    axes[2].set(xlabel="time / s", ylabel=f"residual, {1e3 * m * float(np.median(np.diff(t))):.3g}"
                " ms means / mN*m", title="recording - replay (dashed: +-noise floor)")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path
