"""FMI slave: felt friction brake with the output-side inertia.

Takes the output shaft speed and gives the torque the load applies on the reducer's output
shaft: tau_out = -(T_set tanh(w/w_reg) + J_out dw/dt). The inertia of brake drum, coupling and
output transducer is carried here as a torque from the speed's backward difference over the
last step (the reducer is massless, the motor integrates the drive train).
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
        self.parameter("T_first", 5.0, "N.m", "first brake torque setpoint of the test series", min=0.0)
        self.parameter("T_last", 5.0, "N.m", "last brake torque setpoint of the test series", min=0.0)
        self.parameter("T_count", 1, None, "number of brake torque setpoints", Integer, min=1)
        self.parameter("hold_time", 1.0, "s", "time each setpoint is held", min=0.0)
        self.parameter("torque_schedule", "", None, "instead of the series: setpoints "
                       "'t0 T0; t1 T1; ...' (s, N*m), each held until the next", String)
        self.parameter("w_reg", 0.5, "rad/s", "speed below which the Coulomb torque is "
                       "regularised (tanh)", min=0.0)
        self.parameter("J_out", 2.0e-3, "kg.m2", "output-side inertia: brake drum, coupling, "
                       "output transducer rotor. Assumption", min=0.0)
        self.input("w", 0.0, "rad/s", "speed of the output shaft")
        self.output("tau_out", 0.0, "N.m", "torque the brake applies on the reducer's output shaft",
                    depends=("w",))
        self.output("torque_shaft", 0.0, "N.m", "torque the output shaft delivers to the brake",
                    depends=("w",))
        self.output("T_brake", 0.0, "N.m", "friction torque of the felt brake", depends=("w",))
        self._w_last = None
        self._time = 0.0

    init_independent = ("J_out",)   # no step yet: no acceleration

    def _setup(self):
        try:
            self.check_limits()
            self._schedule = (core.rig.parse_schedule(self.torque_schedule, "torque_schedule")
                              if self.torque_schedule.strip() else None)
            if self.T_count < 1:
                raise ValueError(f"T_count = {self.T_count!r}: must be at least 1")
            if min(self.T_first, self.T_last) < 0:
                raise ValueError("T_first, T_last: a brake torque setpoint must not be negative")
            for name in ("w_reg", "J_out"):
                v = getattr(self, name)
                if not (math.isfinite(v) and v > 0):
                    raise ValueError(f"{name} = {v!r}: must be positive")
            if self._schedule and any(v < 0 for _, v in self._schedule):
                raise ValueError(f"torque_schedule = {self.torque_schedule!r}: a brake torque "
                                 "setpoint must not be negative")
        except ValueError as exc:
            self.fail(f"invalid parameter: {exc}")

    def _evaluate_init(self):
        self._update(0.0, 0.0)

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
