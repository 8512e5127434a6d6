"""FMI slave: felt friction brake with the output-side inertia.

Takes the output shaft speed and gives the torque the load applies on the reducer's output
shaft: tau_out = -(T_set tanh(w/w_reg) + J_out dw/dt). The bench sets J_out = 0 and gives the
output-side inertia to the reducer (``CycloidDrive.J_out``), which reflects it to the motor's
integrator; J_out > 0 here differentiates the input speed (backward difference over the last
step), kept only for hosts that connect the brake alone.
"""
from __future__ import annotations

import math

from . import core
from .base import Integer, Real, String, UnitSlave


class FeltBrake(UnitSlave):
    author = "cyclo-fmu"
    description = "Felt friction brake: Coulomb torque from a setpoint, regularised, with inertia"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.parameter("T_first", 5.0, "N.m", "first brake torque setpoint of the test series")
        self.parameter("T_last", 5.0, "N.m", "last brake torque setpoint of the test series")
        self.parameter("T_count", 1, None, "number of brake torque setpoints", Integer)
        self.parameter("hold_time", 1.0, "s", "time each setpoint is held")
        self.parameter("torque_schedule", "", None, "instead of the series: setpoints "
                       "'t0 T0; t1 T1; ...' (s, N*m), each held until the next", String)
        self.parameter("T_points", 0, None, "instead of the series (when torque_schedule is "
                       "empty): number of setpoints T_time_i, T_value_i used (0..8)", Integer)
        for i in range(1, core.rig.MAX_POINTS + 1):
            self.parameter(f"T_time_{i}", 0.0, "s", f"time of brake torque setpoint {i}")
            self.parameter(f"T_value_{i}", 0.0, "N.m", f"brake torque setpoint {i}, held until "
                           "the next")
        self.parameter("w_reg", 0.5, "rad/s", "speed below which the Coulomb torque is "
                       "regularised (tanh)")
        self.parameter("J_out", 2.0e-3, "kg.m2", "output-side inertia: brake drum, coupling, "
                       "output transducer rotor. Assumption")
        self.input("w", 0.0, "rad/s", "speed of the output shaft")
        self.output("tau_out", 0.0, "N.m", "torque the brake applies on the reducer's output shaft",
                    depends=("w",))
        self.output("torque_shaft", 0.0, "N.m", "torque the output shaft delivers to the brake",
                    depends=("w",))
        self.output("T_brake", 0.0, "N.m", "friction torque of the felt brake", depends=("w",))
        self._w_last = None
        self._time = 0.0

    def exit_initialization_mode(self):
        try:
            self._schedule = (core.rig.parse_schedule(self.torque_schedule, "torque_schedule")
                              if self.torque_schedule.strip() else core.rig.schedule_from_points(
                                  self.T_points, self._points("T_time"), self._points("T_value"),
                                  "T"))
            if self.T_count < 1:
                raise ValueError(f"T_count = {self.T_count!r}: must be at least 1")
            if min(self.T_first, self.T_last) < 0:
                raise ValueError("T_first, T_last: a brake torque setpoint must not be negative")
            if not (math.isfinite(self.w_reg) and self.w_reg > 0):
                raise ValueError(f"w_reg = {self.w_reg!r}: must be positive")
            if not (math.isfinite(self.J_out) and self.J_out >= 0):
                raise ValueError(f"J_out = {self.J_out!r}: must not be negative")
            if self._schedule and any(v < 0 for _, v in self._schedule):
                raise ValueError(f"torque schedule {self._schedule!r}: a brake torque "
                                 "setpoint must not be negative")
        except ValueError as exc:
            self.fail(f"invalid parameter: {exc}")
        self._update(0.0, 0.0)

    def _points(self, prefix):
        return [getattr(self, f"{prefix}_{i}") for i in range(1, core.rig.MAX_POINTS + 1)]

    def _update(self, t, dt):
        w = self.w
        if not math.isfinite(w):
            self.require_finite(w=w)
        alpha = 0.0 if (self._w_last is None or dt <= 0) else (w - self._w_last) / dt
        setpoint = (core.rig.schedule_value(self._schedule, t) if self._schedule is not None
                    else core.rig.series_value(t, self.T_first, self.T_last, self.T_count,
                                               self.hold_time))
        self.T_brake = core.rig.felt_brake_torque(w, setpoint, self.w_reg)
        self.torque_shaft = self.T_brake + self.J_out * alpha
        self.tau_out = -self.torque_shaft

    def do_step(self, current_time, step_size):
        self._update(current_time + step_size, step_size)
        self._w_last = self.w
        return True
