"""FMI slave: felt friction brake on a compliant coupling, with the output-side inertia.

Takes the output shaft speed and gives the torque the load applies on the reducer's output
shaft: the torque of the coupling between the output shaft and the brake drum,
T_s = k twist + c (w - w_drum), where the drum (inertia of drum, coupling half and the output
transducer's rotor) is integrated here with its own sub-steps against the felt brake's
friction T_set tanh(w_drum/w_reg). The twist is the integral of the speed the FMU receives, so
no co-simulation input is differentiated: an earlier version took J_out dw/dt from a backward
difference of the input speed, which made a +-1.5 N*m oscillation that moved with the
communication step. With J_out = 0 (the bench's default: the reducer carries the output
inertia and reflects it to the motor's integrator) there is no drum and no coupling: the felt
brake's friction acts on the shaft, T_set tanh(w/w_reg).
"""
from __future__ import annotations

import math

from . import core
from .base import Boolean, Integer, String, UnitSlave


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
        self.schedule_parameters("N.m", "brake torque")
        self.parameter("w_reg", 0.5, "rad/s", "speed below which the Coulomb torque is "
                       "regularised (tanh)", min=0.0)
        self.parameter("J_out", 2.0e-3, "kg.m2", "output-side inertia: brake drum, coupling, "
                       "output transducer rotor. Assumption", min=0.0)
        self.parameter("k_coupling", 500.0, "N.m/rad", "torsional stiffness of the coupling "
                       "between output shaft and brake drum. Assumption: a small bellows or "
                       "jaw coupling (catalogues: 100-2000 N*m/rad)", min=0.0)
        self.parameter("zeta_coupling", 0.3, "1", "damping ratio of the coupling with the drum "
                       "(c = 2 zeta sqrt(k J_out)). Assumption: an elastomer insert", min=0.0)
        self.input("w", 0.0, "rad/s", "speed of the output shaft")
        self.output("tau_out", 0.0, "N.m", "torque the brake applies on the reducer's output shaft",
                    depends=("w", "T_set"))
        self.output("torque_shaft", 0.0, "N.m", "torque the output shaft delivers to the brake",
                    depends=("w", "T_set"))
        self.output("T_brake", 0.0, "N.m", "friction torque of the felt brake", depends=("w", "T_set"))
        # torque control (a replay of a recording's measured output torque); after the older
        # variables, so that their value references stay
        self.parameter("torque_control", False, None, "a load machine in torque control "
                       "instead of the felt brake: the shaft delivers the input T_set to the "
                       "load, whatever its speed (both signs: it may drive the output); no "
                       "drum (J_out must be 0: the measured torque holds the drum's inertia)",
                       Boolean)
        self.input("T_set", 0.0, "N.m", "with torque_control: the torque the output shaft "
                   "delivers to the load, signed in the shaft's coordinate (e.g. a recording's "
                   "measured output torque)")
        self._twist = 0.0
        self._w_drum = 0.0

    #: the dynamic state besides the variables (fmi2GetFMUstate)
    state_attributes = ("_twist", "_w_drum")

    #: at the start the drum turns with the shaft, untwisted: no coupling torque yet
    init_independent = ("J_out", "k_coupling", "zeta_coupling")

    def _setup(self):
        try:
            self.check_limits()
            self._schedule = self.schedule_from_parameters("torque_schedule")
            if self.T_count < 1:
                raise ValueError(f"T_count = {self.T_count!r}: must be at least 1")
            if min(self.T_first, self.T_last) < 0:
                raise ValueError("T_first, T_last: a brake torque setpoint must not be negative")
            for name in ("w_reg", "k_coupling", "zeta_coupling"):
                v = getattr(self, name)
                if not (math.isfinite(v) and v > 0):
                    raise ValueError(f"{name} = {v!r}: must be positive")
            if not (math.isfinite(self.J_out) and self.J_out >= 0):
                raise ValueError(f"J_out = {self.J_out!r}: must not be negative")
            if self.torque_control and self.J_out != 0:
                raise ValueError(f"J_out = {self.J_out!r}: must be 0 with torque_control (the "
                                 "controlled torque acts at the shaft)")
            if self._schedule and any(v < 0 for _, v in self._schedule):
                raise ValueError("torque schedule: a brake torque setpoint must not be negative")
        except ValueError as exc:
            self.fail(f"invalid parameter: {exc}")
        self._c = 2 * self.zeta_coupling * math.sqrt(self.k_coupling * self.J_out)

    def _evaluate_init(self):
        w = self.w
        if not math.isfinite(w):
            self.require_finite(w=w)
        self._w_drum = float(w)          # the drum starts with the shaft, untwisted
        self._twist = 0.0
        self._update(0.0, 0.0)

    def _setpoint(self, t):
        return (core.rig.schedule_value(self._schedule, t) if self._schedule is not None
                else core.rig.series_value(t, self.T_first, self.T_last, self.T_count,
                                           self.hold_time))

    def _update(self, t, dt):
        w = self.w
        if not math.isfinite(w):
            self.require_finite(w=w)
        if self.torque_control:
            T = self.T_set
            if not math.isfinite(T):
                self.require_finite(T_set=T)
            self.T_brake = self.torque_shaft = T
            self.tau_out = -T
            return
        setpoint = self._setpoint(t)
        if self.J_out == 0:
            # no drum here (the bench gives the output inertia to the reducer, which reflects
            # it to the motor's integrator): the friction acts on the shaft directly
            Ts = Tb = core.rig.felt_brake_torque(w, setpoint, self.w_reg)
        elif dt > 0:
            self._twist, self._w_drum, Ts, Tb = core.rig.coupled_drum_step(
                self._twist, self._w_drum, w, dt, setpoint, self.w_reg, self.J_out,
                self.k_coupling, self._c)
        else:
            Ts = self.k_coupling * self._twist + self._c * (w - self._w_drum)
            Tb = core.rig.felt_brake_torque(self._w_drum, setpoint, self.w_reg)
        self.T_brake = Tb
        self.torque_shaft = Ts
        self.tau_out = -Ts

    def do_step(self, current_time, step_size):
        # the setpoint of the step's start (a step in the setpoint acts from its time on)
        try:
            self._update(current_time, step_size)
        except OverflowError:
            self.tau_out = self.T_brake = math.nan
        if not math.isfinite(self.tau_out + self.T_brake):
            self.fail(f"w = {self.w!r} rad/s gives a torque that is not a finite number: "
                      "refused")
        return True
