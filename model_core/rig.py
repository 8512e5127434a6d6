"""Physics of the paper's test rig around the reducer: an induction motor on a frequency
regulator, a felt friction brake and torque/speed transducers. Plain functions and small
frozen dataclasses; the FMUs in cyclo_fmu.slaves wrap them.

Rig (paper, Section 5): frequency regulator, 250 W motor at 2800 r/min, optical speed sensor
HySense RS110, torque transducer HBM T22/20 on the input, torque and speed transducer HBM T30FN
on the output, felt brake. Values the paper does not give are named assumptions below.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from .effects import T_STEP


@dataclass(frozen=True)
class InductionMotor:
    """Two-pole induction motor on a V/f frequency regulator (constant flux).

    With constant flux the Kloss curve keeps its breakdown torque and its breakdown *slip
    speed*; only the synchronous speed moves with the frequency:
        T = 2 T_k / (dw/dw_k + dw_k/dw),  dw = w_sync - w,  w_sync = 2 pi f / p
    """

    rated_power: float = 250.0            # W [paper]
    rated_speed: float = 2800 * math.pi / 30   # rad/s at 50 Hz [paper]
    rated_frequency: float = 50.0         # Hz [paper: 2800 r/min is a 2-pole motor at 50 Hz]
    pole_pairs: int = 1                   # [derived from 2800 r/min at 50 Hz]
    breakdown_ratio: float = 2.2          # T_k/T_n. **Assumption**: 2.0-2.5 for small motors
    inertia: float = 3.0e-4               # kg m^2, rotor + coupling + T22 rotor. **Assumption**:
    #                                       catalogue rotors of 250 W 2-pole motors ~1.5e-4
    ramp_rate: float = 25.0               # Hz/s: 0-50 Hz in 2 s. **Assumption** (regulator setting)

    @property
    def rated_torque(self) -> float:
        return self.rated_power / self.rated_speed

    @property
    def rated_slip_speed(self) -> float:
        return 2 * math.pi * self.rated_frequency / self.pole_pairs - self.rated_speed

    @property
    def breakdown_slip_speed(self) -> float:
        """dw_k from the rated point on the Kloss curve (the stable branch: dw_n < dw_k)."""
        k = self.breakdown_ratio
        x = k - math.sqrt(k * k - 1)          # dw_n/dw_k, root of x + 1/x = 2k
        return self.rated_slip_speed / x

    def torque(self, w: float, frequency: float) -> float:
        """Electromagnetic torque (N*m) at shaft speed w (rad/s) and stator frequency (Hz)."""
        return self.torque_function()(w, frequency)

    def torque_function(self):
        """``torque`` with the motor's constants evaluated once (for sub-stepping loops)."""
        c_sync = 2 * math.pi / self.pole_pairs
        dwk = self.breakdown_slip_speed
        tk2 = 2 * self.breakdown_ratio * self.rated_torque

        def torque(w, frequency):
            dw = c_sync * frequency - w
            if dw == 0.0:
                return 0.0
            return tk2 / (dw / dwk + dwk / dw)
        return torque


def ramp_toward(value: float, target: float, rate: float, dt: float) -> float:
    """Move ``value`` toward ``target`` at most ``rate*dt`` (a setpoint ramp)."""
    step = rate * dt
    return target if abs(target - value) <= step else value + math.copysign(step, target - value)


def schedule_value(schedule, t: float) -> float:
    """Piecewise-constant schedule [(t0, v0), (t1, v1), ...]: the last v with t_i <= t."""
    v = schedule[0][1] if schedule else 0.0
    for ti, vi in schedule:
        if ti <= t + 1e-12:
            v = vi
        else:
            break
    return v


#: setpoints a schedule can carry as numbered Real parameters (``schedule_time_k``,
#: ``schedule_value_k``, k = 1..SCHEDULE_POINTS), which every FMI master can set (fmpy's SSP
#: master cannot set String parameters); longer schedules need the String form
SCHEDULE_POINTS = 8


def schedule_from_points(count: int, times, values, name: str = "schedule"):
    """The first ``count`` (time, value) pairs as a schedule; ValueError names the field."""
    if not 0 <= count <= SCHEDULE_POINTS:
        raise ValueError(f"{name}_points = {count!r}: must be 0 to {SCHEDULE_POINTS}")
    out = []
    for k in range(count):
        t, v = float(times[k]), float(values[k])
        if not (math.isfinite(t) and math.isfinite(v)):
            raise ValueError(f"{name}_time_{k + 1}, {name}_value_{k + 1}: must be finite")
        if out and t < out[-1][0]:
            raise ValueError(f"{name}_time_{k + 1} = {t!r}: times must increase")
        out.append((t, v))
    return out


def schedule_parameters(prefix: str, schedule) -> dict:
    """{'<prefix>schedule_points': n, '<prefix>schedule_time_k': t, ...} for a schedule of at
    most SCHEDULE_POINTS setpoints (Integer count, Real times and values)."""
    if len(schedule) > SCHEDULE_POINTS:
        raise ValueError(f"schedule = {schedule!r}: more than {SCHEDULE_POINTS} setpoints cannot "
                         "be carried as Real parameters; use the String schedule (run_fmus)")
    out = {f"{prefix}schedule_points": len(schedule)}
    for k, (t, v) in enumerate(schedule, 1):
        out[f"{prefix}schedule_time_{k}"] = float(t)
        out[f"{prefix}schedule_value_{k}"] = float(v)
    return out


def parse_schedule(text: str, name: str = "schedule"):
    """'t0 v0; t1 v1; ...' -> [(t0, v0), ...] with increasing times; ValueError names the field."""
    out = []
    for part in (p for p in text.replace(",", " ").split(";") if p.strip()):
        fields = part.split()
        if len(fields) != 2:
            raise ValueError(f"{name} = {text!r}: each entry must be 'time value'")
        t, v = float(fields[0]), float(fields[1])
        if not (math.isfinite(t) and math.isfinite(v)):
            raise ValueError(f"{name} = {text!r}: times and values must be finite")
        if out and t < out[-1][0]:
            raise ValueError(f"{name} = {text!r}: times must increase")
        out.append((t, v))
    if not out:
        raise ValueError(f"{name} = {text!r}: needs at least one entry")
    return out


def series_value(t: float, first: float, last: float, count: int, hold: float,
                 repeat: int = 1) -> float:
    """Setpoint of a stepped test series: ``count`` values from ``first`` to ``last``, each held
    for ``repeat`` slots of ``hold`` seconds, then the series starts over. With the motor at
    repeat = number of loads and the brake at repeat = 1, every frequency meets every load."""
    if count <= 1 or hold <= 0:
        return first
    slot = int(max(t, 0.0) // hold)
    i = (slot // max(repeat, 1)) % count
    return first + (last - first) * i / (count - 1)


def felt_brake_torque(w: float, setpoint: float, w_reg: float) -> float:
    """Coulomb friction torque of the felt brake opposing motion, regularised near standstill:
    T = T_set * tanh(w / w_reg) (N*m, positive for positive w)."""
    return setpoint * math.tanh(w / w_reg)


def coupled_drum_step(twist, w_drum, w_shaft, dt, setpoint, w_reg, J, k, c):
    """Advance the brake drum on its compliant coupling by ``dt`` (s): the output shaft turns at
    ``w_shaft`` (rad/s, held over the step), the coupling (stiffness k N*m/rad, damping c
    N*m*s/rad) carries T_s = k twist + c (w_shaft - w_drum) to the drum of inertia J, which the
    felt brake holds back:

    .. math:: J \\dot w_d = T_s - T_{set} \\tanh(w_d / w_{reg}), \\quad \\dot{twist} = w_s - w_d

    The brake's friction is taken implicitly (it is stiff near standstill: T_set/w_reg), the
    coupling symplectically. Returns (twist, w_drum, T_s, T_brake) at the end of the step."""
    th, wd = twist, w_drum
    for _ in range(max(1, int(math.ceil(dt / COUPLING_SUBSTEP - 1e-9)))):
        h = dt / max(1, int(math.ceil(dt / COUPLING_SUBSTEP - 1e-9)))
        Ts = k * th + c * (w_shaft - wd)
        Tb = felt_brake_torque(wd, setpoint, w_reg)
        dTb = setpoint / w_reg / math.cosh(wd / w_reg) ** 2 if setpoint else 0.0
        # implicit in the friction and the damper: (J + h (dTb + c)) dw = h (Ts - Tb)
        wd = wd + h * (Ts - Tb) / (J + h * (dTb + c))
        th = th + h * (w_shaft - wd)
    Ts = k * th + c * (w_shaft - wd)
    return th, wd, Ts, felt_brake_torque(wd, setpoint, w_reg)


#: [s] sub-step of the brake drum on its coupling: a fiftieth of the period of a 500 N*m/rad
#: coupling on a 2e-3 kg*m^2 drum (80 Hz, 12.6 ms); the friction and the damper are implicit
COUPLING_SUBSTEP = 2.5e-4


_GOLDEN = 0x9E3779B97F4A7C15
_MASK64 = (1 << 64) - 1


def _mix64(z):
    """SplitMix64's output function (Steele, Lea and Flood 2014) on uint64 arrays."""
    import numpy as np
    z = z ^ (z >> np.uint64(30))
    z = z * np.uint64(0xBF58476D1CE4E5B9)
    z = z ^ (z >> np.uint64(27))
    z = z * np.uint64(0x94D049BB133111EB)
    return z ^ (z >> np.uint64(31))


def normal_samples(seed: int, start: int, count: int):
    """Standard-normal samples ``start`` .. ``start + count - 1`` of the stream ``seed``.

    Counter-based, so any sample can be drawn without the ones before it and a transducer's
    noise state is one integer: uniform pairs from SplitMix64 over the counter, one Box-Muller
    pair per sample (the cosine branch):

    .. math:: n_k = \\sqrt{-2 \\ln u_{1,k}} \\cos(2 \\pi u_{2,k})

    The native transducer FMU (cyclo_fmu/native/rig_common.c, ``rig_normal_sample``) draws the
    same numbers, so the Python and native bench components give the same noisy readings."""
    import numpy as np
    base = _mix64(np.array([(int(seed) + _GOLDEN) & _MASK64], dtype=np.uint64))[0]
    k = np.arange(int(start), int(start) + int(count), dtype=np.uint64)
    g = np.uint64(_GOLDEN)
    with np.errstate(over="ignore"):
        z1 = _mix64(base + (np.uint64(2) * k + np.uint64(1)) * g)
        z2 = _mix64(base + (np.uint64(2) * k + np.uint64(2)) * g)
    u1 = ((z1 >> np.uint64(11)).astype(np.float64) + 1.0) * 2.0 ** -53
    u2 = (z2 >> np.uint64(11)).astype(np.float64) * 2.0 ** -53
    return np.sqrt(-2.0 * np.log(u1)) * np.cos(6.283185307179586 * u2)


@dataclass(frozen=True)
class Transducer:
    """Torque or speed transducer: accuracy-class gain error and zero offset, first-order
    bandwidth, white noise and quantisation (each switchable by setting it to zero)."""

    gain_error: float = 0.0      # relative, e.g. 0.002 for 0.2 % of reading
    offset: float = 0.0          # in the measured unit
    bandwidth: float = 1000.0    # Hz, first-order; <= 0 means none
    noise: float = 0.0           # standard deviation, measured unit
    resolution: float = 0.0      # quantisation step, measured unit; <= 0 means none

    def filter_coefficient(self, dt: float) -> float:
        """a of the exact first-order low-pass update over dt with x held: y <- a y + (1 - a) x
        (0 without a bandwidth)."""
        return math.exp(-2 * math.pi * self.bandwidth * dt) if self.bandwidth > 0 else 0.0

    def filter_step(self, y: float, x: float, dt: float) -> float:
        """Exact first-order low-pass update over dt with x held."""
        a = self.filter_coefficient(dt)
        return a * y + (1 - a) * x

    def reading(self, filtered: float, noise_sample: float, drift: float = 0.0) -> float:
        """Reading from the filtered true value and a standard-normal sample; ``drift``: the
        zero's drift at this time, in the measured unit, added to the offset."""
        y = filtered * (1 + self.gain_error) + (self.offset + drift) + self.noise * noise_sample
        if self.resolution > 0:
            y = self.resolution * round(y / self.resolution)
        return y


#: [K] the temperatures a transducer's zero-drift reference and temperature input may take
#: (-100 to 200 degC, the reducer FMUs' grease temperature range): beyond them a value is a
#: unit mistake (degC given as K), not a transducer's environment
TRANSDUCER_T_RANGE = (173.15, 473.15)


def zero_drift_per_10K(per_10K, T, T_ref):
    """A transducer zero's drift with temperature: c (T - T_ref)/(10 K), in the reading's
    unit.

    The zero of a strain-gauge torque transducer moves with its temperature (catalogues quote
    it per 10 K, e.g. HBM T22: 0.1 % of the nominal torque per 10 K); to first order the
    reading gains ``per_10K`` (c, reading unit per 10 K) for each 10 K that ``T`` (K) lies
    above the reference ``T_ref`` (K) at which it was zeroed. The one implementation, used by
    the transducer FMU (cyclo_fmu.slaves.transducer; its C twin rig_transducer.c), the
    diagnosis's replay (model_core.effects.reading_model) and the synthesiser. Scalars or
    numpy arrays.

    Parameters
    ----------
    per_10K : float
        Drift c of the zero per 10 K, reading unit (N*m for a torque transducer).
    T : float or array
        Temperature of the transducer, K.
    T_ref : float
        Temperature at which the zero is right, K.

    Returns
    -------
    float or array
        The zero's drift, reading unit: c (T - T_ref) / T_STEP, T_STEP = 10 K
        (model_core.effects.T_STEP).
    """
    return per_10K * (T - T_ref) / T_STEP
