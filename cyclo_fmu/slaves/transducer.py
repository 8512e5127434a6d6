"""FMI slave: a torque or speed transducer (gain and offset errors, a zero drifting in time
and with the transducer's temperature, bandwidth, noise, quantisation, unit scale),
switchable to ideal with ``ideal = true``.

One implementation, three FMUs that differ only in the units they declare: ``Transducer``
(any signal, unit "1"), ``TorqueTransducer`` (N.m in, N.m out) and ``SpeedTransducer`` (rad/s
in, r/min out, scale 30/pi). Hosts that check units on connections (OMSimulator refuses an
N.m output wired to an input of unit "1") take the bench with the typed ones."""
from __future__ import annotations

import math
import sys


from . import core
from .base import Boolean, Integer, UnitSlave


#: noise samples drawn at a time (one numpy call instead of one Python call a step)
_NOISE_BLOCK = 4096


class Transducer(UnitSlave):
    author = "cyclo-fmu"
    description = "Transducer: y = scale*x through first-order bandwidth, class errors, noise"
    #: declared units of the input x and the reading y (and of offset, noise, resolution)
    x_unit, y_unit = "1", "1"
    #: default of ``scale`` (the numeric factor from x's unit to y's)
    default_scale = 1.0

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        yu = self.y_unit
        self.parameter("scale", self.default_scale, "1", "unit scale and sign, y = scale*x "
                       "(e.g. 30/pi for rad/s to r/min)")
        # bounds: a span error beyond +-50 % is a wrong scale (``scale``), not an accuracy-class
        # gain error (class 0.05-1 %; the diagnosis's torque_sensor_gain allows +-5 %). The
        # offset has no bound: it is in the reading's unit, and what is plausible depends on
        # the transducer's nominal range, which this FMU does not know
        self.parameter("gain_error", 0.0, "1", "relative gain (span) error: y = (1 + "
                       "gain_error) scale x + offset (accuracy class; -0.5 to 0.5)",
                       min=-0.5, max=0.5)
        self.parameter("offset", 0.0, yu, "zero offset, in output units (finite)")
        self.parameter("bandwidth", 1000.0, "Hz", "first-order bandwidth (<= 0: none)")
        self.parameter("noise", 0.0, yu, "standard deviation of white noise, output units",
                       min=0.0)
        self.parameter("resolution", 0.0, yu, "quantisation step, output units (<= 0: none)")
        self.parameter("seed", 1, None, "noise seed", Integer, min=0)
        self.parameter("ideal", False, None, "switch all errors off: y = scale*x", Boolean)
        self.input("x", 0.0, self.x_unit, "true value")
        self.output("y", 0.0, yu, "reading", depends=("x",))
        # after the older variables, so that their value references stay
        self.parameter("zero_drift", 0.0, yu, "drift of the zero as the transducer warms up, "
                       "first order from the start: offset + zero_drift (1 - exp(-t/"
                       "zero_drift_tau)), output units (finite)")
        self.parameter("zero_drift_tau", 300.0, "s", "time constant of the zero's drift",
                       min=sys.float_info.min)
        # the zero's drift with the transducer's temperature (model_core.rig.zero_drift_per_10K)
        T_lo, T_hi = core.rig.TRANSDUCER_T_RANGE
        self.parameter("zero_per_10K", 0.0, yu, "drift of the zero per 10 K of the input "
                       "temperature from zero_T_ref: offset + zero_per_10K (temperature - "
                       "zero_T_ref)/10 K, output units (finite)")
        self.parameter("zero_T_ref", 293.15, "K", "temperature at which the zero is right "
                       "(the reference of zero_per_10K; 173.15 to 473.15 K)", min=T_lo,
                       max=T_hi)
        self.input("temperature", 293.15, "K", "the transducer's temperature (e.g. the "
                   "reducer's T_oil on the bench); read only while zero_per_10K is not 0, "
                   "then it must lie between 173.15 and 473.15 K. Not connected, it keeps its "
                   "start value 293.15 K, the default zero_T_ref: no drift")
        self._depends["y"] = ["x", "temperature"]
        self._filtered = None

    init_independent = ("bandwidth",)   # the filter starts at the input
    #: the dynamic state besides the variables (fmi2GetFMUstate): filter, noise stream
    state_attributes = ("_filtered", "_noise", "_next", "_dt", "_a", "_rng_state")

    @property
    def _rng_state(self):
        rng = getattr(self, "_rng", None)
        return None if rng is None else rng.bit_generator.state

    @_rng_state.setter
    def _rng_state(self, state):
        if state is not None:
            self._rng = np.random.default_rng(int(self.seed))
            self._rng.bit_generator.state = state

    def _setup(self):
        try:
            self.check_limits()
            for name in ("scale", "gain_error", "offset", "bandwidth", "noise", "resolution",
                         "zero_drift", "zero_drift_tau", "zero_per_10K"):
                v = getattr(self, name)
                if not math.isfinite(v):
                    raise ValueError(f"{name} = {v!r}: must be finite")
            if self.noise < 0:
                raise ValueError(f"noise = {self.noise!r}: must not be negative")
        except ValueError as exc:
            self.fail(f"invalid parameter: {exc}")
        self._model = core.rig.Transducer(self.gain_error, self.offset, self.bandwidth,
                                          self.noise, self.resolution)
        self._per_10K = core.rig.zero_drift_per_10K if self.zero_per_10K else None

    def _temperature_drift(self):
        """The zero's drift at the input temperature (output units); the temperature checked."""
        T = self.temperature
        lo, hi = core.rig.TRANSDUCER_T_RANGE
        if not (isinstance(T, (int, float)) and lo <= T <= hi):
            self.fail(f"temperature = {T!r} K: must be a temperature between {lo:g} and "
                      f"{hi:g} K while zero_per_10K = {self.zero_per_10K!r} is not 0 (a "
                      "temperature in degC needs + 273.15; a master that starts its "
                      "connections at 0 must initialise this one)")
        return self._per_10K(self.zero_per_10K, T, self.zero_T_ref)

    def _evaluate_init(self):
        x = self.x
        if not math.isfinite(x):
            self.require_finite(x=x)
        # the same first draws at every evaluation: standard-normal samples of the counter-
        # based stream of ``seed`` (model_core.rig.normal_samples, as the native transducer),
        # drawn in blocks
        self._noise, self._next, self._block = [], 0, 0
        self._filtered = self.scale * x
        self._dt, self._a = None, 0.0
        self._read(0.0)

    def _read(self, elapsed):
        if self.ideal:
            self.y = self.scale * self.x
            return
        k = self._next
        if k >= len(self._noise):
            self._noise = core.rig.normal_samples(int(self.seed), self._block * _NOISE_BLOCK,
                                                  _NOISE_BLOCK).tolist()
            self._block, k = self._block + 1, 0
        self._next = k + 1
        if self.zero_drift or self._per_10K is not None:
            # the zero's warm-up at the step's end (model_core.effects' torque_sensor_drift in
            # its time form) and its drift with the temperature input (model_core.rig.
            # zero_drift_per_10K), added before the quantisation as the offset is
            drift = (self.zero_drift * (1.0 - math.exp(-elapsed / self.zero_drift_tau))
                     if self.zero_drift else 0.0)
            if self._per_10K is not None:
                drift = drift + self._temperature_drift()
            self.y = self._model.reading(self._filtered, self._noise[k], drift)
        else:
            self.y = self._model.reading(self._filtered, self._noise[k])

    def do_step(self, current_time, step_size):
        x = self.x
        if not math.isfinite(x):
            self.require_finite(x=x)
        if step_size != self._dt:        # the filter coefficient of this step size, once
            self._dt, self._a = step_size, self._model.filter_coefficient(step_size)
        a = self._a
        self._filtered = a * self._filtered + (1 - a) * self.scale * x
        self._read(current_time + step_size)
        if not math.isfinite(self.y):
            self.fail(f"x = {x!r} gives a reading that is not a finite number (scale = "
                      f"{self.scale!r}): refused")
        return True


class TorqueTransducer(Transducer):
    """A torque transducer (e.g. HBM T22, T30FN): N.m in, N.m out."""
    description = "Torque transducer: y = scale*x through first-order bandwidth, class errors, noise"
    x_unit, y_unit = "N.m", "N.m"


class SpeedTransducer(Transducer):
    """A speed sensor: rad/s in, r/min out (scale 30/pi by default)."""
    description = ("Speed transducer: y = scale*x (rad/s to r/min) through first-order bandwidth, "
                   "class errors, noise")
    x_unit, y_unit = "rad/s", "r/min"
    default_scale = 30.0 / math.pi
