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
        dw = 2 * math.pi * frequency / self.pole_pairs - w
        dwk = self.breakdown_slip_speed
        if dw == 0.0:
            return 0.0
        return 2 * self.breakdown_ratio * self.rated_torque / (dw / dwk + dwk / dw)


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


#: most breakpoints a schedule carries as numbered Real parameters (``<x>_time_<i>``,
#: ``<x>_value_<i>``, i = 1..MAX_POINTS): enough for the named scenarios; longer schedules
#: (the synthesiser's plans) go as the String parameter to masters that can set Strings
MAX_POINTS = 8


def schedule_from_points(count: int, times, values, name: str = "schedule"):
    """[(t_i, v_i)] from ``count`` numbered breakpoints (the first ``count`` of ``times`` and
    ``values``); ValueError names the field when count is out of 0..MAX_POINTS, a value is not
    finite or the times do not increase. count = 0: no schedule (None)."""
    if not 0 <= count <= min(MAX_POINTS, len(times), len(values)):
        raise ValueError(f"{name}_points = {count!r}: must be 0..{MAX_POINTS}")
    if count == 0:
        return None
    out = []
    for i in range(count):
        t, v = float(times[i]), float(values[i])
        if not (math.isfinite(t) and math.isfinite(v)):
            raise ValueError(f"{name}_time_{i + 1}, {name}_value_{i + 1} = {t!r}, {v!r}: "
                             "must be finite")
        if out and t < out[-1][0]:
            raise ValueError(f"{name}_time_{i + 1} = {t!r}: times must increase")
        out.append((t, v))
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


@dataclass(frozen=True)
class Transducer:
    """Torque or speed transducer: accuracy-class gain error and zero offset, first-order
    bandwidth, white noise and quantisation (each switchable by setting it to zero)."""

    gain_error: float = 0.0      # relative, e.g. 0.002 for 0.2 % of reading
    offset: float = 0.0          # in the measured unit
    bandwidth: float = 1000.0    # Hz, first-order; <= 0 means none
    noise: float = 0.0           # standard deviation, measured unit
    resolution: float = 0.0      # quantisation step, measured unit; <= 0 means none

    def filter_factor(self, dt: float) -> float:
        """a = exp(-2 pi f_c dt) of the exact first-order update y' = a y + (1 - a) x over dt
        (0 without a bandwidth: y' = x)."""
        return 0.0 if self.bandwidth <= 0 else math.exp(-2 * math.pi * self.bandwidth * dt)

    def filter_step(self, y: float, x: float, dt: float, a: float = None) -> float:
        """Exact first-order low-pass update over dt with x held (``a``: filter_factor(dt),
        when the caller keeps it for a fixed step)."""
        if a is None:
            a = self.filter_factor(dt)
        return a * y + (1 - a) * x

    def reading(self, filtered: float, noise_sample: float) -> float:
        """Reading from the filtered true value and a standard-normal sample."""
        y = filtered * (1 + self.gain_error) + self.offset + self.noise * noise_sample
        if self.resolution > 0:
            y = self.resolution * round(y / self.resolution)
        return y
