"""FMI slave: induction motor on a frequency regulator (Kloss curve, setpoint ramp, inertia).

It owns the rotor inertia (rotor, coupling, input transducer rotor), integrates it and outputs
the speed and its acceleration at the end of the step from its own equation of motion (no
direct feedthrough). In the bench it integrates the whole rigid train: the reducer reflects the
output-side inertia here, ``J_load`` while the shaft speeds up and ``J_load_dec`` while it slows
down, and ``tau_shaft`` is then the reducer's ``tau_in_static``:
(J + J_side) dw/dt = T_em(w, f) - tau_shaft, the side chosen at every sub-step. Without a
reducer ``tau_shaft`` is the torque the motor delivers into the shaft towards the load.
"""
from __future__ import annotations

import math
import sys

from . import core
from .base import Boolean, Integer, String, UnitSlave

_SUBSTEP = 2.5e-4   # s; a twentieth of the rotor's mechanical time constant on the Kloss slope (~5 ms)


class InductionMotor(UnitSlave):
    author = "cyclo-fmu"
    description = "Induction motor on a V/f frequency regulator: Kloss torque, ramp, inertia"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        m = core.rig.InductionMotor()
        self.parameter("rated_power", m.rated_power, "W", "rated power", min=0.0)
        self.parameter("rated_speed", m.rated_speed, "rad/s", "rated speed at rated frequency", min=0.0)
        self.parameter("rated_frequency", m.rated_frequency, "Hz", "rated frequency", min=0.0)
        self.parameter("pole_pairs", m.pole_pairs, None, "pole pairs", Integer, min=1)
        self.parameter("breakdown_ratio", m.breakdown_ratio, "1", "breakdown / rated torque", min=1.0)
        self.parameter("J", m.inertia, "kg.m2", "rotor, coupling and input-transducer inertia", min=0.0)
        self.parameter("ramp_rate", m.ramp_rate, "Hz", "setpoint ramp of the regulator, Hz per s", min=0.0)
        self.parameter("f_first", 50.0, "Hz", "first frequency setpoint of the test series")
        self.parameter("f_last", 50.0, "Hz", "last frequency setpoint of the test series")
        self.parameter("f_count", 1, None, "number of frequency setpoints", Integer, min=1)
        self.parameter("hold_time", 1.0, "s", "time each setpoint pair is held", min=0.0)
        self.parameter("loads_per_frequency", 1, None, "brake setpoints run at each frequency",
                       Integer, min=1)
        self.parameter("frequency_schedule", "", None, "instead of the series: setpoints "
                       "'t0 f0; t1 f1; ...' (s, Hz), each held until the next", String)
        self.schedule_parameters("Hz", "frequency")
        self.parameter("w_start", 0.0, "rad/s", "initial speed")
        self.input("tau_shaft", 0.0, "N.m", "torque the motor delivers into the shaft, without the "
                   "load's inertia (reducer tau_in_static)")
        self.input("J_load", 0.0, "kg.m2", "inertia of the load seen at the motor shaft while "
                   "the shaft speeds up (reducer J_load), integrated here")
        self.output("alpha", 0.0, "rad/s2", "shaft acceleration at the end of the step, from the "
                    "integrator's own state (its equation of motion there)")
        self.output("w", 0.0, "rad/s", "shaft speed")
        self.output("T_em", 0.0, "N.m", "electromagnetic torque")
        self.output("frequency", 0.0, "Hz", "stator frequency after the ramp")
        self.output("P_mech", 0.0, "W", "mechanical power T_em*w")
        # after the older variables: their value references stay
        self.input("J_load_dec", -1.0, "kg.m2", "inertia of the load seen at the motor shaft "
                   "while the shaft slows down (reducer J_load_dec; through a reducer it differs "
                   "from J_load by the two efficiencies); negative: the same as J_load")
        # speed control (a replay of a recording's measured input speed); after the older
        # variables, so that their value references stay
        self.parameter("speed_control", False, None, "the regulator controls the shaft speed: "
                       "it follows the input w_set through a first-order speed loop of "
                       "speed_time_constant, the motor delivering the torque that takes "
                       "(instead of the Kloss curve at the frequency setpoints)", Boolean)
        self.parameter("speed_time_constant", 1.0e-3, "s", "time constant of the closed speed "
                       "loop with speed_control. Assumption: a servo regulator's speed loop "
                       "of about 160 Hz, fast against the motor's own ~5 ms",
                       min=sys.float_info.min, max=1.0)
        self.input("w_set", 0.0, "rad/s", "speed setpoint with speed_control (e.g. a "
                   "recording's measured input speed)")
        self._t = 0.0

    #: at the start the outputs follow w_start and the motor's curve; not the inertia, ramp or
    #: the setpoints (the frequency starts at the synchronous value of w_start)
    init_independent = ("J", "ramp_rate", "f_first", "f_last", "f_count", "hold_time",
                        "loads_per_frequency", "frequency_schedule", "speed_time_constant")

    def initial_dependencies(self, name):
        # with speed_control the start follows the setpoint and carries the shaft's torque
        return [p for p in super().initial_dependencies(name)
                if not p.startswith("schedule_")] + ["w_set", "tau_shaft"]

    def _setup(self):
        try:
            self.check_limits()
            self._motor = core.rig.InductionMotor(
                rated_power=float(self.rated_power), rated_speed=float(self.rated_speed),
                rated_frequency=float(self.rated_frequency), pole_pairs=int(self.pole_pairs),
                breakdown_ratio=float(self.breakdown_ratio), inertia=float(self.J),
                ramp_rate=float(self.ramp_rate))
            for name in ("rated_power", "rated_speed", "rated_frequency", "J", "ramp_rate"):
                v = getattr(self, name)
                if not (math.isfinite(v) and v > 0):
                    raise ValueError(f"{name} = {v!r}: must be positive")
            if not self.breakdown_ratio > 1:
                raise ValueError(f"breakdown_ratio = {self.breakdown_ratio!r}: must exceed 1")
            if self.pole_pairs < 1:
                raise ValueError(f"pole_pairs = {self.pole_pairs!r}: must be at least 1")
            self._schedule = self.schedule_from_parameters("frequency_schedule")
            if self.f_count < 1 or self.loads_per_frequency < 1:
                raise ValueError("f_count and loads_per_frequency must be at least 1")
        except ValueError as exc:
            self.fail(f"invalid parameter: {exc}")
        self._torque = self._motor.torque_function()

    def _evaluate_init(self):
        if self.speed_control:
            # the shaft starts at the speed setpoint (a replay starts at the measured speed)
            if not math.isfinite(self.w_set):
                self.require_finite(w_set=self.w_set)
            self.w = float(self.w_set)
        else:
            self.w = float(self.w_start)
        self.frequency = 0.0 if self.w == 0 else self.w * self.pole_pairs / (2 * math.pi)
        self._outputs()
        if self.speed_control:          # held at the setpoint: the motor carries the shaft
            tau = self.tau_shaft
            if not math.isfinite(tau):
                self.require_finite(tau_shaft=tau)
            self.T_em, self.alpha = float(tau), 0.0
            self.P_mech = self.T_em * self.w

    def _setpoint(self, t):
        if self._schedule is not None:
            return core.rig.schedule_value(self._schedule, t)
        return core.rig.series_value(t, self.f_first, self.f_last, self.f_count, self.hold_time,
                                     self.loads_per_frequency)

    def _outputs(self):
        self.T_em = self._motor.torque(self.w, self.frequency)
        self.P_mech = self.T_em * self.w

    def do_step(self, current_time, step_size):
        tau, J_acc, J_dec = self.tau_shaft, self.J_load, self.J_load_dec
        if not (math.isfinite(tau) and math.isfinite(J_acc) and J_acc >= 0
                and math.isfinite(J_dec)):
            self.require_finite(tau_shaft=tau, J_load=J_acc, J_load_dec=J_dec)
            self.fail(f"J_load = {J_acc!r}: input must not be negative")
        if J_dec < 0:
            J_dec = J_acc
        if self.speed_control:
            return self._speed_step(step_size, tau, J_acc, J_dec)
        n = max(1, int(math.ceil(step_size / _SUBSTEP - 1e-9)))
        h = step_size / n
        m = self._motor
        # the whole rigid train: the load's torque grows with the acceleration by J_load while
        # the shaft speeds up and by J_load_dec while it slows down, so (J + J_side) dw/dt =
        # T_em - tau_shaft, the side following from the signs of the right-hand side and of w
        # (J + J_side > 0), decided at every sub-step, not once per communication step
        inv_acc, inv_dec = 1.0 / (m.inertia + J_acc), 1.0 / (m.inertia + J_dec)
        torque = self._torque
        w = self.w
        f = self.frequency
        df = m.ramp_rate * h
        # the setpoint changes at most at the series' or schedule's steps: evaluated at the
        # sub-steps only when it differs between the step's ends
        s0, s1 = self._setpoint(current_time), self._setpoint(current_time + step_size)
        for k in range(n):
            target = s0 if s0 == s1 else self._setpoint(current_time + k * h)
            f = target if abs(target - f) <= df else f + math.copysign(df, target - f)
            r = torque(w, f) - tau
            w += h * r * (inv_acc if (r >= 0) == (w >= 0) else inv_dec)
        self.w, self.frequency = w, f
        T_em = torque(w, f)
        r = T_em - tau
        self.alpha = r * (inv_acc if (r >= 0) == (w >= 0) else inv_dec)
        self.T_em = T_em
        self.P_mech = T_em * w
        if not math.isfinite(self.P_mech + self.alpha):
            self.fail(f"tau_shaft = {tau!r} N.m, J_load = {J_acc!r} kg.m2 give a speed or "
                      "acceleration that is not a finite number: refused")
        return True

    def _speed_step(self, h, tau, J_acc, J_dec):
        """Speed control: the closed speed loop as a first-order lag of time constant tc,
        dw/dt = (w_set - w)/tc, solved exactly over the step with w_set held; the motor
        delivers T_em = tau_shaft + (J + J_side) dw/dt (the side as in the Kloss branch). The
        frequency output is the shaft's synchronous frequency (the regulator's slip is not
        modelled here)."""
        w_set = self.w_set
        if not math.isfinite(w_set):
            self.require_finite(w_set=w_set)
        tc = self.speed_time_constant
        w = w_set + (self.w - w_set) * math.exp(-h / tc)
        alpha = (w_set - w) / tc
        J = self._motor.inertia + (J_acc if (alpha >= 0) == (w >= 0) else J_dec)
        self.w, self.alpha = w, alpha
        self.T_em = tau + J * alpha
        self.frequency = w * self.pole_pairs / (2 * math.pi)
        self.P_mech = self.T_em * w
        if not math.isfinite(self.P_mech):
            self.fail(f"tau_shaft = {tau!r} N.m gives a torque that is not a finite number: "
                      "refused")
        return True
