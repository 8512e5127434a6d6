"""Physical effects the paper's load-dependent model leaves out: one registry entry per effect.

Each effect adds a torque at the reducer's driving (input) shaft, in N*m and in the sense of
the input torque (positive = the driver must deliver more). An entry carries everything the
rest of the project needs about the effect, so that adding one touches this file only:

- its torque as a combination of basis columns (``basis``), linear in its parameters, with at
  most one nonlinear shape parameter scanned on a grid (a time constant, a Stribeck speed);
  effects that act through the model's own parameters (the friction level, the lubricant's
  viscosity) use the full model's sensitivity to that parameter as their column, not a proxy;
- its parameters with units and physical bounds (a fit outside them is not that effect);
- what it maps to in a design (``apply``: the ``[extra]`` fields, the friction level, or the
  ``[calibration]`` of the design: mesh loss k and idle-loss scale);
- the run that separates it from look-alikes, and the size the synthesiser hides by default.

The synthesiser hides effects with these terms, the diagnosis fits them, and a design's
``[extra]`` section switches them on in the replay (``extra_torque``); the FMUs evaluate the
steady and dynamic terms of ``design.ExtraPhysics`` from the same formulas.

Signals ``s`` (numpy arrays over samples, SI), built by :func:`effect_signals`: ``t`` (s),
``w_in`` (rad/s), ``alpha_in`` (rad/s^2), ``theta_in`` (rad, integral of w_in),
``distance_in`` (rad, integral of |w_in|: the distance run), ``loss_in``
(the model's loss torque referred to the input, N*m), ``load_loss_in`` (its load-dependent
part, the gear's PL1..PL6 over the driving speed, N*m: ``lossmap.load_loss_torque``; where a
replay provides it), ``T_in_model`` (the model's input
torque, N*m), ``order_roller`` (roller-pass order of the input speed), ``ratio_out``
(w_out/w_in of the mode, signed: the driven shaft's angle is ``ratio_out * theta_in``),
``temperature`` (degC
or None), ``sens_mu`` and ``sens_nu`` (d T_in_model / d ln mu_boundary and / d ln nu, N*m),
``sens_k``, ``sens_idle`` and ``sens_load`` (d T_in_model / d mesh_loss_k, / d idle_loss_scale
and / d load_loss_scale, N*m; ``sens_idle`` only where the design has load-independent losses);
the sensitivities only where a model replay provides them.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .design import SHAFT_ORDER_RIPPLES
from .kinematics import parse_mode, shaft_speeds

W_REF = 300.0   # rad/s, reference input speed of the drag law (about 2860 r/min)
#: exponent of the no-load drag on speed: (nu n)^(2/3) for churning and the viscous part of
#: bearing drag (SKF M0, Niemann/Winter); the grid the diagnosis scans spans a seal's nearly
#: constant friction (0), a purely viscous drag (1) and the turbulent losses of splash
#: lubrication and windage, whose torque grows up to the square of the speed (churning losses
#: of dip-lubricated gears: T ~ n^1.5 .. n^2 at high Reynolds numbers, Changenet & Velex 2007;
#: windage T ~ rho w^2 r^5, ISO/TR 14179-2)
DRAG_EXPONENT = 2.0 / 3.0
DRAG_EXPONENTS = (0.0, 1.0 / 3.0, 0.5, 2.0 / 3.0, 0.85, 1.0, 1.5, 2.0)
#: [K] temperature step of the temperature form of the warm-up terms (per 10 K, as catalogue
#: viscosity and transducer drift figures are quoted; defined with the law in model_core.thermal)
from .thermal import T_STEP, loss_temperature_law  # noqa: E402

#: [K] temperature scales theta of the warm-up's exponential temperature law scanned beside the
#: linear one (thermal.loss_temperature_law; the linear law is theta -> infinity, the shape
#: None): a loss that follows the viscosity has theta = 1/|m d ln nu/dT|, 17 K for the whole
#: of a loss proportional to the default grease's viscosity at 40 degC (d ln nu/dT = -0.058
#: 1/K) and more for losses that follow it less than in proportion (m < 1: EHL film
#: friction ~ nu^0.2-0.7, churning ~ nu^0.2-1); a factor 2 apart, as TAU_GRID, from 10 K (the
#: steepest lubricant) to 80 K (beyond it the law differs from the linear one by less than
#: dT/(2 theta) = 12 % of the change over a 20 K warm-up, which the held-out test rarely sees)
THETA_GRID = (10.0, 20.0, 40.0, 80.0)


class _TaggedShape(float):
    """A float shape value of one kind, told apart from a plain float (or another kind) of the
    same value: equal only to a value of its own class (``_tag`` keys its hash)."""

    __slots__ = ()
    _tag = ""

    def __repr__(self):
        return f"{type(self).__name__}({float(self)!r})"

    def __eq__(self, other):
        return isinstance(other, type(self)) and float(self) == float(other)

    def __ne__(self, other):
        return not self == other

    def __hash__(self):
        return hash((self._tag, float(self)))


class TemperatureScale(_TaggedShape):
    """A shape value of a warm-up's temperature form: the temperature scale theta [K] of the
    exponential temperature law (thermal.loss_temperature_law). A float, told apart from the
    time constant [s] the same effect has in its time form: equal only to another
    TemperatureScale of the same value."""

    __slots__ = ()
    _tag = "theta"


class HeatBalanceTau(_TaggedShape):
    """A shape value of a warm-up in time driven by the loss power: the time constant tau = R C
    [s] of the housing's lumped heat balance (thermal.housing_path), heated by the replayed
    model's loss power; told apart from the plain first-order time constant (a float) of the
    same value: equal only to another HeatBalanceTau of the same value."""

    __slots__ = ()
    _tag = "tau_housing"


def heat_balance_rise(s, tau):
    """Temperature rise [K] over the recording of the housing's lumped heat balance (tau = R
    C [s], R the design's ``housing_R`` in the signals, else the default design's) from a
    cold start (T = T_amb at the recording's start), heated by the model's loss power loss_in w_in
    (thermal.housing_path: the FMUs' own step); with ``heat_secant`` c0 in the signals, by
    that power changed by the warm-up at the size c0 per 10 K (the FMUs' heat balance runs on
    their loss, warm-up included: the rise of a warm-up of size c0, a re-linearisation at the
    fitted size as the viscosity drift's)."""
    from . import thermal
    R = s.get("housing_R")
    if R is None:
        from .design import DriveDesign
        R = thermal.housing_resistance(DriveDesign())
    P = np.asarray(s["loss_in"], float) * np.asarray(s["w_in"], float)
    P *= R      # the power in K of steady rise: housing_path's R P, at R = 1 (one array less)
    return thermal.housing_path(s["t"], P, 0.0, 0.0, float(tau), 1.0,
                                float(s.get("heat_secant") or 0.0), 0.0)


@dataclass(frozen=True)
class Parameter:
    name: str
    unit: str
    lower: float       # physical bounds: a fit outside them is not this effect
    upper: float
    description: str


@dataclass(frozen=True)
class Effect:
    """One candidate effect (see the module docstring)."""

    id: str
    description: str
    parameters: tuple          # linear parameters (Parameter), in basis-column order
    shape: tuple = ()          # grid of the nonlinear shape parameter, () if none
    shape_name: str = ""
    shape_unit: str = ""
    separating_run: str = ""   # the run that tells it apart from its look-alikes
    synth_default: tuple = ({}, None)   # (values, shape) the synthesiser hides by default
    requires: tuple = ()       # signals it needs (e.g. "sens_nu")
    temperature_form: bool = False   # with a temperature column the shape becomes (T - T0)
    #: the effect changes the torque at a fixed operating point over time (a warm-up): it is
    #: named only when it explains what no steady function of the operating point explains
    #: (a recording that visits its operating points in time order makes any smooth function
    #: of the operating point correlate with time)
    time_drift: bool = False
    #: shapes(s) keeps only the shape values for which this returns True (e.g. a drift that
    #: must not settle before the recording's folds can see it); None keeps all
    shape_filter: object = None
    #: a finer grid of the shape around the one selected on ``shape``, scanned only once the
    #: effect is selected (a refinement: the Stribeck friction's transition width through a
    #: reversal): a function of the selected shape giving the shapes; None if none
    refine: object = None
    #: grid of the temperature form's shape (with a temperature column): the temperature
    #: scale theta [K] of the exponential law, scanned beside the linear law (shape None);
    #: () keeps the linear law alone
    temperature_shape: tuple = ()

    def parameters_for(self, shape=None) -> tuple:
        """The linear parameters the basis has at ``shape`` (the mesh ripple's constant
        amplitude law has the first half of its parameters, the a parts)."""
        if self.id == "mesh_ripple" and not shape:
            return self.parameters[:len(RIPPLE_ORDERS) * 2]
        return self.parameters

    def basis(self, s: dict, shape=None, lead=None) -> np.ndarray:
        """Columns (n_samples, n_params) whose combination with the parameters is the torque.
        ``lead``: (shape, its basis) of another shape whose columns this basis begins with
        (``leads``): they are copied, not evaluated again (the same numbers)."""
        if lead is not None and self.leads(shape, lead[0]):
            return _BASIS_AFTER[self.id](s, shape, lead[1])
        return _BASIS[self.id](s, shape)

    def basis_beyond(self, s: dict, shape, lead) -> np.ndarray:
        """The columns of ``basis(s, shape, lead)`` after the lead's (``leads``): the same
        numbers, without the copy of the lead's columns (the mesh ripple's load columns,
        a's columns times |tau_out|/T_REF)."""
        beyond = _BASIS_BEYOND.get(self.id)
        if beyond is None:
            return self.basis(s, shape, lead)[:, lead[1].shape[1]:]
        return beyond(s, shape, lead[1])

    @property
    def nested(self) -> bool:
        """True where the basis at one shape may begin with the basis at another (``leads``)."""
        return self.id in _BASIS_AFTER

    def leads(self, shape, other) -> bool:
        """Does the basis at ``shape`` begin with the columns of the basis at ``other`` (the
        mesh ripple's load law 1, a + b |tau_out|/T_REF, with law 0's, a)?"""
        return self.id in _BASIS_AFTER and bool(shape) and not other

    def torque(self, s: dict, values, shape=None) -> np.ndarray:
        """The effect's torque at the input shaft for parameter values (N*m)."""
        B = self.basis(s, shape)
        v = np.asarray(values, float)
        return B @ v[:B.shape[1]] if B.shape[1] else np.zeros(len(s["t"]))

    def shapes(self, s: dict, around=None) -> tuple:
        """The shape values to scan for these signals (``(None,)`` for a linear effect or the
        temperature form; ``()`` where the shape filter leaves none: no candidate); with
        ``around`` (a shape selected on the grid), the finer grid ``refine(around)`` where the
        effect has one, the grid itself included."""
        if self.temperature_form and s.get("temperature") is not None:
            return (None,) + tuple(TemperatureScale(x) for x in self.temperature_shape)
        grid = self.shape
        if around is not None and self.refine is not None:
            grid = tuple(dict.fromkeys(self.shape + tuple(self.refine(around))))
        if grid and self.shape_filter is not None:
            # none left: the effect cannot be resolved in this recording (no candidate)
            return tuple(x for x in grid if self.shape_filter(s, x))
        return grid or (None,)

    @property
    def shape_names(self) -> tuple:
        """Names of the shape's parameters (a shape of several is a tuple, e.g. (w_s, delta))."""
        return tuple(n.strip() for n in self.shape_name.split(",")) if self.shape_name else ()

    def shape_count(self, shape) -> int:
        """Shape parameters chosen on the grid at ``shape``, charged in the BIC: all of them,
        but a Stribeck transition width of 0 (the sharp sign, the nested model) is no
        parameter: a width must earn its own place against the sharp sign."""
        if not self.shape or shape is None:
            return 0
        n = len(self.shape_names)
        if self.id == "low_speed_friction" and isinstance(shape, tuple) and len(shape) > 2 \
                and shape[2] == 0:
            n -= 1
        return n

    def shape_parameters(self, shape) -> dict:
        """{name: (value, unit)} of a shape value."""
        if isinstance(shape, TemperatureScale):
            return {"theta": (float(shape), "K")}
        if isinstance(shape, HeatBalanceTau):
            return {"tau_housing": (float(shape), "s")}
        vals = shape if isinstance(shape, tuple) else (shape,)
        units = [u.strip() for u in self.shape_unit.split(",")]
        return {n: (float(v), u) for n, v, u in zip(self.shape_names, vals, units)}

    def shape_from(self, values: dict):
        """The shape value from reported parameters ({name: value}); None if absent."""
        if self.temperature_shape and values.get("theta") is not None:
            return TemperatureScale(values["theta"])
        if values.get("tau_housing") is not None:
            return HeatBalanceTau(values["tau_housing"])
        got = [values.get(n) for n in self.shape_names]
        if not got or any(g is None for g in got):
            return None
        return tuple(got) if len(got) > 1 else got[0]

    def apply(self, design, values: dict, shape=None, temperature=False):
        """``design`` with the effect switched on at fitted values; returns (design, notes)."""
        return _APPLY.get(self.id, _apply_nothing)(design, values, shape, temperature)


# -- the terms --------------------------------------------------------------------------------
def _warm(s, shape):
    """Warm-up shape: (T - T0)/10 K with a temperature column (``shape`` None), or its
    exponential law at the temperature scale ``shape`` (a TemperatureScale:
    thermal.loss_temperature_law), else 1 - exp(-(t - t0)/tau)."""
    if isinstance(shape, TemperatureScale):
        T = s["temperature"]
        return loss_temperature_law(T - T[0], float(shape))
    if isinstance(shape, HeatBalanceTau):
        g = heat_balance_rise(s, shape)
        g /= T_STEP
        return g
    if s.get("temperature") is not None and shape is None:
        T = s["temperature"]
        return (T - T[0]) / T_STEP
    return 1.0 - np.exp(-(s["t"] - s["t"][0]) / shape)


def _drag(s, shape):
    w = s["w_in"]
    p = DRAG_EXPONENT if shape is None else shape
    return (np.sign(w) * (np.abs(w) / W_REF) ** p)[:, None]


def _thermal(s, shape):
    return (s["loss_in"] * _warm(s, shape))[:, None]


def _load_loss_in(s):
    """The load-dependent loss torque of the signals (N*m), which the run-in scales."""
    T = s.get("load_loss_in")
    if T is None:
        raise ValueError("the run-in needs the gear's load-dependent loss torque (signals "
                         "'load_loss_in': lossmap.replay_input_torque(..., load_loss=True))")
    return T


def _run_in(s, shape):
    return (_load_loss_in(s) * np.exp(-s["distance_in"] / shape))[:, None]


def _viscosity(s, shape):
    """d T/d ln(nu) times the warm-up g; with ``nu_secant`` c0 and ``nu_steps`` (span X, the
    model's torque changes at X/2 and X: ``lossmap.viscosity_steps``) in the signals, the
    secant D(c0 g)/c0 of the response D(x) = u (4 D_1/2 - D_1) + u^2 (2 D_1 - 4 D_1/2),
    u = x/X, the quadratic in ln(nu) through the three replays: the drift c g evaluated at its
    size c = c0 (a re-linearisation at the fitted size) instead of at the design's viscosity."""
    g = _warm(s, shape)
    c0 = s.get("nu_secant")
    if c0 and s.get("nu_steps") is not None:
        X, half, full = s["nu_steps"]
        u = c0 * g / X
        return ((u * (4.0 * half - full) + u * u * (2.0 * full - 4.0 * half)) / c0)[:, None]
    return (s["sens_nu"] * g)[:, None]


def viscosity_span(s, shape):
    """The largest |warm-up| of the viscosity drift's basis along a recording (1 for a drift
    in time; the largest |T - T0|/10 K of the temperature form, ``shape`` None): the span of
    ln(viscosity) the replays of ``lossmap.viscosity_steps`` must cover is the drift's size
    times it."""
    return float(np.max(np.abs(_warm(s, shape)))) if shape is None else 1.0


def _inertia(s, shape):
    return s["alpha_in"][:, None]


def ripple_orders(s) -> tuple:
    """The mesh ripple's orders of the driving shaft's angle, in RIPPLE_ORDERS' order: 1x,
    the roller pass, 2x, and 1x and 2x of the driven shaft (k_out r, r = w_out/w_in of the
    mode, signed: the driven shaft's own angle r theta; design.SHAFT_ORDER_RIPPLES)."""
    r = s["ratio_out"]
    return tuple(s["order_roller"] if k_in is None else k_in + k_out * r
                 for _, _, k_in, k_out in RIPPLE_ORDERS)


def _ripple(s, shape):
    return _mesh_ripple(s, None)


def _mesh_ripple(s, shape, lead=None):
    """Ripple at the shaft orders (RIPPLE_ORDERS), amplitude a (``shape`` 0 or None) or
    a + b |tau_out| / T_REF (``shape`` 1: a transmission error times the mesh stiffness):
    columns sin(k th), cos(k th) per order, then (law 1) the same times |tau_out|/T_REF.
    Filled in place (a long recording's basis is its largest array: no stacked copies).
    ``lead``: the basis at law 0 of these signals (law 1's first columns, copied)."""
    th = s["theta_in"]
    ks = ripple_orders(s)
    m = 2 * len(ks)
    B = np.empty((len(th), 2 * m if shape else m))
    if lead is not None:
        B[:, :m] = lead
    else:
        arg = np.empty(len(th))
        for i, k in enumerate(ks):
            np.multiply(k, th, out=arg)
            np.sin(arg, out=B[:, 2 * i])
            np.cos(arg, out=B[:, 2 * i + 1])
    if shape:
        _ripple_load_columns(s, B[:, :m], B[:, m:])
    return B


def _ripple_load_columns(s, a_cols, out=None):
    """The mesh ripple's load columns (law 1, a + b |tau_out|/T_REF): the b parts, the
    constant law's columns ``a_cols`` times |tau_out|/T_REF (into ``out``)."""
    from .discovered import T_REF
    v = np.abs(s["tau_out"]) / T_REF
    return np.multiply(a_cols, v[:, None], out=out)


def _mesh_ripple_beyond(s, shape, lead):
    """``_mesh_ripple(s, shape, lead)[:, lead.shape[1]:]``: law 1's load columns alone."""
    return _ripple_load_columns(s, lead)


def _stribeck(s, shape):
    """s_r(w) exp(-(|w|/w_s)^delta), s_r = friction.reversal_sign(w, w_r) (tanh(w/w_r), the
    sharp sgn(w) at w_r = 0); ``shape`` (w_s, delta, w_r), (w_s, delta) (w_r = 0) or w_s alone
    (delta = 2, w_r = 0)."""
    from .friction import reversal_sign
    shape = shape if isinstance(shape, tuple) else (shape, STRIBECK_EXPONENT)
    w_s, delta = shape[:2]
    w_r = shape[2] if len(shape) > 2 else 0.0
    w = s["w_in"]
    return (reversal_sign(w, w_r) * np.exp(-(np.abs(w) / w_s) ** delta))[:, None]


def _loss_transition(s, shape):
    """-(1 - tanh(|w|/w_c)) loss_in: the part of the model's loss torque a drive has not yet
    built up near standstill (friction.loss_transition, the one formula; ``shape`` w_c
    [rad/s]). Zero in double precision where |w| >= 20 w_c (tanh saturates): evaluated only
    below."""
    from .friction import loss_transition
    w = np.asarray(s["w_in"], float)
    col = np.zeros(w.shape)
    near = np.flatnonzero(np.abs(w) < LOSS_TRANSITION_SATURATION * shape)
    if near.size:
        loss = np.asarray(s["loss_in"], float)
        col[near] = -(1.0 - loss_transition(w[near], shape)) * loss[near]
    return col[:, None]


def _offset(s, shape):
    return np.ones((len(s["t"]), 1))


def _zero_drift(s, shape):
    return _warm(s, shape)[:, None]


def _gain(s, shape):
    return s["T_in_model"][:, None]


def _friction(s, shape):
    return s["sens_mu"][:, None]


def _mesh_loss(s, shape):
    return s["sens_k"][:, None]


def _idle_scale(s, shape):
    return s["sens_idle"][:, None]


def _load_scale(s, shape):
    return s["sens_load"][:, None]


def _none(s, shape):
    return np.zeros((len(s["t"]), 0))


#: {effect: basis(s, shape, lead)} of the effects whose basis at one shape begins with the
#: basis at another (``Effect.leads``): the later one from the earlier one's columns
_BASIS_AFTER = {"mesh_ripple": _mesh_ripple}
#: {effect: its basis's columns after the lead's} (``Effect.basis_beyond``)
_BASIS_BEYOND = {"mesh_ripple": _mesh_ripple_beyond}
_BASIS = {"load_independent_loss": _drag, "thermal_drift": _thermal,
          "viscosity_drift": _viscosity, "inertia": _inertia, "mesh_ripple": _mesh_ripple,
          "low_speed_friction": _stribeck, "torque_sensor_offset": _offset,
          "loss_transition": _loss_transition,
          "torque_sensor_gain": _gain, "torque_sensor_drift": _zero_drift,
          "friction_miscalibrated": _friction, "mesh_loss": _mesh_loss,
          "idle_loss_scale": _idle_scale, "load_loss_scale": _load_scale, "run_in": _run_in,
          "none": _none}

TAU_GRID = (60.0, 150.0, 300.0, 600.0, 1200.0)    # s, warm-up time constants scanned
#: [rad] run-in distances scanned (angle of the driving shaft over which the excess decays by
#: 1/e): 3000 rad are 8 minutes at 60 r/min or 10 s at 2800 r/min, 1e5 rad about ten minutes at
#: the bench's top speed: a run-in spread over minutes to an hour of the paper's bench plan
RUN_IN_DISTANCES = (3e3, 1e4, 3e4, 1e5)
#: [1] a run-in is scanned only at distances of at least this share of the recording's whole
#: distance run: 0.2, one of the diagnosis's five time-ordered folds. A run-in that settles
#: within the first fold cannot be confirmed by the held-out test, and fits a start-up
#: transient instead (a 3000 rad run-in took the first seconds of a warm-up recording with the
#: best in-sample BIC and stopped the selection)
RUN_IN_MIN_SHARE = 0.2


#: [1] ... and at most this multiple of it: 2, the excess then falls to exp(-1/2) = 61 % of
#: its start by the recording's end, a change the time-ordered folds see. A run-in that barely
#: decays within the recording is a constant scale on the losses there: a loss-scale error
#: (the calibration effects, the friction level), not a run-in (measured: a 10 % loss scale in
#: a 60 s four-quadrant recording was named run_in at 1e5 rad, 10 times its distance run)
RUN_IN_MAX_SHARE = 2.0


def _run_in_resolvable(s, s0):
    d = s.get("distance_in")
    if d is None:
        return True
    total = float(d[-1])
    return RUN_IN_MIN_SHARE * total <= s0 <= RUN_IN_MAX_SHARE * total
#: shape exponent delta of the Stribeck decay exp(-(|w|/w_s)^delta): 2, the Gaussian form
#: (Armstrong-Helouvry 1994), by default; 1 is Tustin's exponential (Tustin 1947), the other
#: end of the range measured on lubricated contacts (delta = 0.5..2, Armstrong-Helouvry et al.,
#: Automatica 30, 1994)
STRIBECK_EXPONENT = 2.0
STRIBECK_EXPONENTS = (1.0, 2.0)
#: the exponents of the refinement (``Effect.refine``, once the effect is selected): the
#: middle of the range too. Measured on independent recordings whose decay has delta = 1.3
#: (not on either grid): with 1 and 2 alone the width and the Stribeck speed took up the
#: wrong exponent (a duty cycle: T_s 45.8 mN*m at w_s = 20 rad/s, w_r = 4 rad/s, truth 31.6
#: mN*m at 30 rad/s, 0.51 mN*m left at the reversals); with 1.5, 31.0 mN*m at 30 rad/s,
#: w_r = 2 rad/s
STRIBECK_EXPONENTS_REFINED = (1.0, 1.5, 2.0)
#: [rad/s] transition widths w_r of the friction's sign through a speed reversal scanned
#: (``friction.reversal_sign``: tanh(w/w_r); 0 the sharp Coulomb sign, the default of a
#: design). A contact passes through pre-sliding when the speed reverses (Dahl 1968,
#: Armstrong-Helouvry et al. 1994): its friction follows the micro-displacement, not the
#: speed, over a band of speeds that depends on the contact's stiffness and on how fast the
#: reversal is run, unknown beforehand, so it is fitted. Steps of 2: the widths a reversal
#: can show lie between the speed change over the settling window the diagnosis does not
#: compare (problem.SETTLE_S, 5 ms: 0.5 rad/s at a reversal run at 100 rad/s^2) and the
#: Stribeck speed itself (the smallest scanned is 15 rad/s: a width of 4 rad/s, 38 r/min,
#: already bends a quarter of the decay's first part)
STRIBECK_TRANSITIONS = (0.0, 0.5, 1.0, 2.0, 4.0)
#: [rad/s] transition widths w_c of the whole loss through standstill scanned
#: (``friction.loss_transition``: tanh(|w|/w_c)). The diagnosis compares the replay from the
#: rest bound up (diagnosis.problem.REST_SPEED, 1 r/min = 0.105 rad/s): a width of half of it
#: (0.05 rad/s) still takes 3 % of the loss at the bound, the narrowest the compared samples
#: can see; steps of 2 up to 0.4 rad/s (3.8 r/min: the loss at 99.5 % by 11 r/min), where
#: the band meets the Stribeck term's reversal widths (STRIBECK_TRANSITIONS from 0.5 rad/s),
#: the speeds at which pre-sliding (micrometres of contact deformation, Dahl 1968) ends in a
#: drive run at the speeds of a test plan
LOSS_TRANSITIONS = (0.05, 0.1, 0.2, 0.4)
#: [1] beyond |w| = 20 w_c, 1 - tanh(|w|/w_c) is 0 in double precision (8e-18 at 20, below
#: half the spacing of doubles under 1): the loss transition's column is exactly zero there
#: (diagnosis.problem.TANH_SATURATION, the same bound)
LOSS_TRANSITION_SATURATION = 20.0
#: [1] a fitted share of the loss transition further than this from 1 (the whole loss) is said
#: in a note when the width is written (the design carries the whole loss's transition): 0.1,
#: the spread measured over hoists whose whole loss builds up (1.06 with a 0.5 r/min speed
#: reading, 1.10-1.22 on batch 5's generator)
LOSS_TRANSITION_SHARE_NOTE = 0.1


def _stribeck_refined(shape) -> tuple:
    """The refinement of a Stribeck shape selected with the sharp sign: every width of
    STRIBECK_TRANSITIONS and exponent of STRIBECK_EXPONENTS_REFINED at the selected Stribeck
    speed and its neighbours on STRIBECK_SPEEDS. Measured on the independent recordings: a
    sharp sign that soaks up a reversal moves w_s by one step of the grid (40 for 30, 80 for
    60 rad/s), never more. The whole grid of speeds (105 shapes instead of 45) cost 2.9 s more
    CPU on a 600 000-sample four-quadrant recording (3.6 s without a refinement), this one
    1.4-1.9 s."""
    k = STRIBECK_SPEEDS.index(shape[0])
    speeds = STRIBECK_SPEEDS[max(k - 1, 0):k + 2]
    return tuple((w, d, r) for w in speeds for d in STRIBECK_EXPONENTS_REFINED
                 for r in STRIBECK_TRANSITIONS)
#: [rad/s] Stribeck speeds scanned: steps of about 1.4 (the exponential form is sharp: a w_s
#: a third off leaves a remainder of a quarter of its size)
STRIBECK_SPEEDS = (15.0, 20.0, 30.0, 40.0, 60.0, 80.0, 150.0)
#: amplitude laws of the mesh ripple scanned: 0, a constant amplitude a (4 parameters); 1,
#: a + b |tau_out|/T_REF (8 parameters: a transmission error times the mesh stiffness, the
#: amplitude growing with the transmitted load; issue 18 item 3). Scanned as a shape so that a
#: constant ripple is not charged the BIC of four load terms it does not have
RIPPLE_LOAD_LAWS = (0.0, 1.0)
#: the mesh ripple's orders (parameter suffix, design field, k_in, k_out): the driving shaft's
#: 1x (the eccentric), the roller pass (k_in None: the mode's roller_pass_order), then
#: design.SHAFT_ORDER_RIPPLES: 2x of the driving shaft, 1x and 2x of the driven shaft (runout
#: of the output flange, an eccentric or oval pin circle); the order of the driving angle is
#: k_in + k_out r (r = w_out/w_in of the mode, signed). Each design field has ``_phase``,
#: ``_load`` and ``_load_phase`` companions
_SUFFIX = {"ripple_2x": "2", "ripple_out_1x": "o1", "ripple_out_2x": "o2"}
RIPPLE_ORDERS = (("1", "ripple_1x", 1.0, 0.0), ("z", "ripple_roller", None, None)) + tuple(
    (_SUFFIX[f], f, k_in, k_out) for f, k_in, k_out in SHAFT_ORDER_RIPPLES)
#: the design field of each of RIPPLE_ORDERS' suffixes
RIPPLE_FIELDS = {k: f for k, f, _, _ in RIPPLE_ORDERS}
_RIPPLE_TEXT = {"1": "1x ripple", "z": "roller-pass ripple", "2": "2x ripple",
                "o1": "output 1x ripple", "o2": "output 2x ripple"}


def _ripple_parameters():
    """A{k}_sin, A{k}_cos for every order (the constant part a), then B{k}_sin, B{k}_cos (the
    load-scaled part b, per 10 N*m of |tau_out|)."""
    par = []
    for part, what in (("A", ""), ("B", "'s growth per 10 N*m load")):
        for k, *_ in RIPPLE_ORDERS:
            for trig in ("sin", "cos"):
                name = "sine" if trig == "sin" else "cosine"
                par.append(Parameter(f"{part}{k}_{trig}", "N*m", -0.5, 0.5,
                                     f"{_RIPPLE_TEXT[k]}{what}, {name}"))
    return tuple(par)

EFFECTS = {
    "friction_miscalibrated": Effect(
        "friction_miscalibrated", "the model's friction level is off: the pins' boundary "
        "friction coefficient differs (the full model's sensitivity to mu_boundary)",
        (Parameter("mu_boundary_rel_error", "1", -0.9, 2.0,
                   "relative error of the model's boundary friction coefficient"),),
        separating_run="a load sweep at constant speed, and back-driven runs",
        requires=("sens_mu",)),
    "mesh_loss": Effect(
        "mesh_loss", "a loss proportional to the mesh power that the model lacks (or has too "
        "much of): eta0 -> eta0 (1 - k), the full model's sensitivity to the design's "
        "calibrated mesh_loss_k (Coulomb-like: it scales with the transmitted torque)",
        # bounds: the change of k; the design keeps k in MESH_LOSS_K_BOUNDS (0 to 0.5). Down to
        # -0.05: a calibrated design may have had k too high, and the fit's noise straddles 0
        # at k = 0 (the result is clipped at 0, with a note); up to 0.3: beyond it the model
        # misses most of the mesh power's loss, a different defect than a missing mechanism
        (Parameter("mesh_loss_k_change", "1", -0.05, 0.3, "change of the additional mesh "
                   "loss k (a fraction of the mesh power)"),),
        separating_run="S2 at the same input points as S1, or back-driven runs at the same "
                       "points: in one forward mode k and an input torque transducer gain "
                       "both scale the input torque (look-alikes); k enters S2 once more than "
                       "S1 (Kreines, eta_S2 = eta0 eta_S1) and changes side when back-driven, "
                       "a gain does neither; against a scale of the gear's own losses "
                       "(load_loss_scale): operating points where the model's efficiency "
                       "changes (light and rated load at a low and a high speed), the only "
                       "place the two differ",
        synth_default=({"mesh_loss_k_change": 0.003}, None), requires=("sens_k",)),
    "idle_loss_scale": Effect(
        "idle_loss_scale", "the load-independent losses (support bearings, seals, grease "
        "drag of model_core.drag) are off by a factor: the full model's sensitivity to the "
        "design's idle_loss_scale (their speed laws are the model's, unlike a free drag term)",
        # bounds: the change of the scale; the design keeps it in IDLE_LOSS_SCALE_BOUNDS
        # (0 to 10): -1 removes them all, +9 is ten times the catalogue estimate
        (Parameter("idle_loss_scale_change", "1", -1.0, 9.0, "change of the scale on the "
                   "load-independent losses"),),
        separating_run="a speed sweep at no load in both directions (the model's bearing, seal "
                       "and grease laws against a drag of free exponent, "
                       "load_independent_loss), and a load sweep at one speed (a mesh loss "
                       "grows with the load, idle losses do not)",
        synth_default=({"idle_loss_scale_change": -0.6}, None), requires=("sens_idle",)),
    "load_loss_scale": Effect(
        "load_loss_scale", "the gear's load-dependent friction losses PL1..PL6 (every sliding "
        "and rolling contact of the mechanism) are off by a factor: the friction level of the "
        "whole gear, the most common real mismatch; the full model's sensitivity to the "
        "design's load_loss_scale (the losses keep the model's variation over speed, load and "
        "film regime, unlike mesh_loss's fixed fraction of the mesh power)",
        # bounds: the change of the scale; the design keeps it in LOAD_LOSS_SCALE_BOUNDS
        # (0 to 10): -1 removes the gear's friction, +9 is ten times the modelled losses
        (Parameter("load_loss_scale_change", "1", -1.0, 9.0, "change of the scale on the "
                   "gear's load-dependent losses PL1..PL6"),),
        separating_run="operating points where the model's efficiency changes: a load sweep "
                       "from light to rated load at a low and a high speed (the gear's losses "
                       "follow the model's load and film laws, a mesh loss k is a fixed "
                       "fraction of the mesh power, a pin friction level acts on the pins' "
                       "share alone); S2 or back-driven runs at the same points against a "
                       "transducer gain",
        synth_default=({"load_loss_scale_change": 0.12}, None), requires=("sens_load",)),
    "load_independent_loss": Effect(
        "load_independent_loss",
        "no-load drag (grease churning, seals, bearing drag, windage): a torque that grows with "
        "speed as n^p (p = 2/3 for churning, (nu n)^(2/3); 0 for seal friction; 1 for viscous "
        "drag; 1.5 to 2 for turbulent churning and windage) and does not depend on load",
        (Parameter("T_drag", "N*m", 0.0, 0.5, f"drag torque at the input at {W_REF:.0f} rad/s"),),
        shape=DRAG_EXPONENTS, shape_name="p", shape_unit="1",
        separating_run="a speed sweep at light load, in both directions",
        synth_default=({"T_drag": 0.012}, None)),
    "thermal_drift": Effect(
        "thermal_drift",
        "the losses drift as the drive warms (first order in time, or following the "
        "housing's heat balance driven by the loss power, or with the temperature column, "
        "linearly or exponentially as a viscosity): every loss scaled",
        (Parameter("loss_change", "1", -0.9, 1.0, "relative change of the losses when warm "
                   "(or per 10 K of the temperature column or of the heat balance's rise)"),),
        shape=TAU_GRID + tuple(HeatBalanceTau(x) for x in TAU_GRID), shape_name="tau",
        shape_unit="s",
        separating_run="a cold start held at one operating point, with a temperature channel",
        synth_default=({"loss_change": 0.12}, 150.0), temperature_form=True, time_drift=True,
        temperature_shape=THETA_GRID),
    "viscosity_drift": Effect(
        "viscosity_drift",
        "the lubricant's viscosity changes as the drive warms (first order in time, or with the "
        "temperature column), acting through the model's own viscosity dependence",
        (Parameter("ln_viscosity_change", "1", -3.0, 1.0, "change of ln(viscosity) when warm "
                   "(or per 10 K with a temperature column)"),),
        shape=TAU_GRID, shape_name="tau", shape_unit="s",
        separating_run="a cold start with a temperature channel at several speeds (viscosity "
                       "losses change sign with speed, a friction level does not)",
        synth_default=({"ln_viscosity_change": -0.8}, 300.0), requires=("sens_nu",),
        temperature_form=True, time_drift=True),
    "run_in": Effect(
        "run_in", "the drive runs in: the friction of its sliding and rolling contacts starts "
        "above the model's and settles with the distance they have slid (the gear's "
        "load-dependent losses PL1..PL6 scaled by 1 + c exp(-distance/s0), the distance the "
        "angle travelled by the driving shaft; the idle losses of seals, bearings' drag and "
        "churning do not run in); unlike a warm-up it needs no temperature change and follows "
        "the distance run, not the time",
        (Parameter("loss_excess", "1", 0.0, 2.0, "excess of the load-dependent losses at the "
                   "start, relative"),),
        shape=RUN_IN_DISTANCES, shape_name="s0", shape_unit="rad",
        separating_run="a temperature channel (a warm-up follows it, a run-in does not) and a "
                       "return to the first operating points late in the run, at another speed "
                       "(a run-in follows the distance run, a warm-up the time)",
        synth_default=({"loss_excess": 0.15}, 1e4), time_drift=True,
        shape_filter=_run_in_resolvable, requires=("load_loss_in",)),
    "inertia": Effect(
        "inertia", "unmodelled rotating inertia on the input side: torque J dw/dt",
        (Parameter("J", "kg*m^2", 0.0, 1e-2, "inertia referred to the input shaft"),),
        separating_run="slow and fast ramps up and down",
        synth_default=({"J": 1.5e-4}, None)),
    "mesh_ripple": Effect(
        "mesh_ripple", "torque ripple at orders of the shaft speeds: 1x and 2x of the driving "
        "shaft (eccentric), the roller pass, 1x and 2x of the driven shaft (runout of the "
        "output flange, pin-circle errors), amplitude a + b |tau_out|/10 N*m (a transmission "
        "error times the mesh stiffness grows with the load; load_law 0: constant amplitude "
        "a alone)",
        _ripple_parameters(),
        shape=RIPPLE_LOAD_LAWS, shape_name="load_law", shape_unit="1",
        separating_run="an order analysis at several constant speeds, and at several loads at "
                       "one speed (the load-scaled part b)",
        synth_default=({"A1_sin": 0.006, "A1_cos": 0.003, "Az_sin": 0.004, "Az_cos": 0.0},
                       0.0),
        shape_filter=lambda s, law: not law or s.get("tau_out") is not None),
    "low_speed_friction": Effect(
        "low_speed_friction", "boundary / Stribeck friction rising at low sliding speed: "
        "T_s tanh(w/w_r) exp(-(|w|/w_s)^delta), delta from 1 (Tustin's exponential) to 2 "
        "(Gaussian), through a speed reversal over a width w_r (pre-sliding; 0: a sharp sign)",
        (Parameter("T_stribeck", "N*m", 0.0, 0.5, "extra friction torque at standstill"),),
        # selected with the sharp sign (w_r = 0), then the width refined with w_s and delta
        # chosen again (the full grid on every recording costs a third of a 600 000-sample
        # diagnosis: benchmarks/bench_diagnosis.py)
        shape=tuple((w, d, 0.0) for w in STRIBECK_SPEEDS for d in STRIBECK_EXPONENTS),
        refine=lambda shape: _stribeck_refined(shape),
        shape_name="w_s, delta, w_r", shape_unit="rad/s, 1, rad/s",
        separating_run="a low-speed sweep at constant load",
        synth_default=({"T_stribeck": 0.025}, 40.0)),
    "loss_transition": Effect(
        "loss_transition", "the losses build up through standstill: a drive's friction passes "
        "through zero with the speed over a band of a few r/min (pre-sliding of every "
        "contact), where the model's losses take their full value at any speed above zero: "
        "the model's loss torque times tanh(|w|/w_c)",
        # share: 1 is the whole loss regularised (the physical form, written to the design);
        # up to 1.5 leaves room for the fit's noise and a loss level off near standstill;
        # negative would make the losses grow towards standstill (the Stribeck term's part)
        (Parameter("share", "1", 0.0, 1.5, "share of the model's loss torque that builds up "
                   "through standstill (1: the whole loss)"),),
        shape=LOSS_TRANSITIONS, shape_name="w_c", shape_unit="rad/s",
        separating_run="a slow speed ramp through 0-10 r/min at a held load, or start-stop "
                       "runs (a hoist's lift, hold and lowering): the loss rising from zero "
                       "over the first r/min",
        synth_default=({"share": 1.0}, 0.1)),
    "torque_sensor_offset": Effect(
        "torque_sensor_offset", "a zero offset of the input torque transducer",
        (Parameter("offset", "N*m", -0.5, 0.5, "zero offset of the input torque reading"),),
        separating_run="a zero reading at standstill and runs in both directions",
        synth_default=({"offset": 0.006}, None)),
    "torque_sensor_drift": Effect(
        "torque_sensor_drift", "the input torque transducer's zero drifts as it warms (first "
        "order in time, or with the temperature column): the same in both directions of "
        "motion and at every load, unlike a loss",
        # bounds: a strain-gauge transducer's zero drifts by about 0.1 % of its nominal
        # torque per 10 K (HBM T22: +-0.1 %/10 K, 10 mN*m at 10 N*m); ten times that,
        # +-0.1 N*m, holds a warm-up of several tens of K; beyond it the zero is wrong, not
        # drifting (the offset's own bounds are +-0.5 N*m)
        (Parameter("offset_change", "N*m", -0.1, 0.1, "change of the zero reading when warm "
                   "(or per 10 K with a temperature column)"),),
        shape=TAU_GRID, shape_name="tau", shape_unit="s",
        separating_run="zero readings at standstill before and after the run (a zero drift "
                       "stays at standstill, a loss does not), or runs in both directions",
        synth_default=({"offset_change": 0.010}, 150.0), temperature_form=True,
        time_drift=True),
    "torque_sensor_gain": Effect(
        "torque_sensor_gain", "a gain (span) error of the input torque transducer: the "
        "reading is (1 + g) times the torque",
        # bounds: +-5 %, ten times the accuracy class (0.5 %) of the paper's HBM T22; a larger
        # span error is a wrong transducer setting, which the plausibility checks catch
        (Parameter("gain_error", "1", -0.05, 0.05, "relative gain error of the input torque "
                   "reading"),),
        separating_run="back-driven runs (the losses change side, a gain error does not) or an "
                       "in-situ calibration with a lever and weights",
        synth_default=({"gain_error": 0.02}, None), requires=("T_in_model",)),
    "none": Effect("none", "the model explains the data within its noise", ()),
}

#: effect ids of earlier versions, read from old diagnosis.json files and scripts: the
#: load-scaled ripple ``load_ripple`` (amplitude b |tau_out|/10 N*m alone) is the mesh
#: ripple's load law 1 since it was merged into ``mesh_ripple`` (one entry, a + b |tau_out|)
EFFECT_ALIASES = {"load_ripple": "mesh_ripple"}


def resolve_effect(eid: str, values: dict = None, shape=None):
    """``(id, values, shape)`` of an effect id of any version: an alias's values carried
    over (``load_ripple``'s B* values become the mesh ripple's load-scaled part at load law 1,
    its constant part a zero)."""
    if eid not in EFFECT_ALIASES:
        return eid, values, shape
    new = EFFECT_ALIASES[eid]
    v = {"A1_sin": 0.0, "A1_cos": 0.0, "Az_sin": 0.0, "Az_cos": 0.0, **(values or {})}
    return new, v, 1.0


#: effects that act through the model's own parameters (the friction level, the calibration),
#: not through ``[extra]``: a synthesiser hides them in the true design
MODEL_PARAMETER_EFFECTS = ("none", "friction_miscalibrated", "mesh_loss", "idle_loss_scale",
                           "load_loss_scale")

#: effects that calibrate the model's own loss scales (design [calibration]). Candidates of
#: every diagnosis (``cyclo-fmu diagnose --no-calibrate``, ``Diagnoser(..., calibrate=False)``
#: leave them out). As free scales of the model's own losses they could stand in for a loss
#: outside the library (a load-squared loss is fitted by k |T| in part); the diagnosis keeps
#: them honest by the twins and the discovery stage: where a remainder beyond the twins is
#: left beside a calibration effect, a closed form is fitted to it with the calibration
#: refitted next to it, and a calibration effect that falls within its interval of zero there
#: is withdrawn (it stood in for the form; ``Diagnoser._discover``)
CALIBRATION_EFFECTS = ("mesh_loss", "idle_loss_scale", "load_loss_scale")
#: the design field each calibration effect changes (design [calibration])
CALIBRATION_FIELDS = {"mesh_loss": "mesh_loss_k", "idle_loss_scale": "idle_loss_scale",
                      "load_loss_scale": "load_loss_scale"}
#: the loss-level family: effects that each raise or lower the gear's load-dependent losses
#: as a whole (a fraction k of the mesh power, a scale on PL1..PL6, the pins' boundary
#: coefficient). Their columns differ only by how the model's efficiency varies over the
#: operating points, so one recording separates them only where it spans points of different
#: efficiency (light and rated load, low and high speed). Principle: the selection names the
#: one the recording's BIC prefers (the stepwise pass enters the best and the others then add
#: too little); the others are listed as its look-alikes wherever their replacement fits
#: within selection.DELTA_BIC (result.lookalikes), with the separating run
LOSS_LEVEL_FAMILY = ("load_loss_scale", "mesh_loss", "friction_miscalibrated")
#: effects a diagnosis considers only when asked (``Diagnoser(candidates=...)``, ``diagnose
#: --with-effect``): ``loss_transition``, the losses' build-up through standstill. Simulated
#: recordings commonly regularise friction through zero speed (tanh(w/eps)) as a numerical
#: convenience, not as a finding; as a default candidate it was named on five of batch 5's
#: eight hoist recordings (whose generator does exactly that) and stood in for an idle-loss
#: scale on a start-stop one. Where creeping speeds matter (hoists, positioning), ask for it
OPT_IN = ("loss_transition",)
#: the candidates of a diagnosis (and "none"): every effect of the registry but OPT_IN
DEFAULT_CANDIDATES = tuple(e for e in EFFECTS if e not in OPT_IN)
#: look-alikes by physics, not by the data at hand: in a recording where power flows from the
#: input to the output only (no back-driven blocks, one mode), an input-torque transducer gain
#: (1 + g) T_in is exactly the mesh loss k = g/(1 + g) (every transmitted torque over eta0
#: (1 - k)) together with the idle-loss scale 1 + g (the load-independent losses scaled
#: alike). Back-driving separates them (the losses change side, a gain does not: Kreines,
#: eta_back = eta0 (1 - k) against the reading's (1 + g)), as does S2 at the same input points
#: (eta_S2 = eta0 eta_S1: k enters once more). ``result.lookalikes`` tests each side's
#: replacement by the other on the recording (BIC within selection.DELTA_BIC)
#: (load_loss_scale is not in a group: a scale of losses that vary over the operating points
#: is no exact gain; where it looks like one, the recording's BIC lists it, result.lookalikes)
LOOKALIKE_GROUPS = ((("torque_sensor_gain",), ("mesh_loss", "idle_loss_scale")),)


#: effects that are faults of the measurement, not physics of the drive
SENSOR_EFFECTS = ("torque_sensor_offset", "torque_sensor_gain", "torque_sensor_drift")


# -- signals ----------------------------------------------------------------------------------
def output_ratio(mode: str, z1: int) -> float:
    """w_out/w_in of a mode (signed; 1/speed_ratio): the driven shaft's angle per radian of
    the driving shaft's."""
    a, b, _ = parse_mode(mode)
    return float(shaft_speeds(mode, 1.0, z1)[b])


def roller_pass_order(mode: str, z1: int) -> float:
    """Roller-pass order of the driving speed: z1 passes per turn of the ring relative to the
    carrier, per turn of the driving shaft."""
    w = shaft_speeds(mode, 1.0, z1)
    a = parse_mode(mode)[0]
    return z1 * abs(float(w["1"] - w["S"])) / abs(float(w[a]))


def effect_signals(t, w_in, loss_in, mode, z1, temperature=None, T_in_model=None,
                   sens_mu=None, sens_nu=None, sens_k=None, sens_idle=None,
                   tau_out=None, sens_load=None, load_loss_in=None) -> dict:
    """The signal dict the effects' terms read (see the module docstring); ``tau_out``
    [N*m], the load torque on the driven shaft, feeds a design's discovered terms."""
    t = np.asarray(t, float)
    w_in = np.asarray(w_in, float)
    alpha = np.gradient(w_in, t) if len(t) > 1 else np.zeros_like(w_in)
    theta = np.concatenate([[0.0], np.cumsum(0.5 * (w_in[1:] + w_in[:-1]) * np.diff(t))])
    aw = np.abs(w_in)
    distance = np.concatenate([[0.0], np.cumsum(0.5 * (aw[1:] + aw[:-1]) * np.diff(t))])
    return {"t": t, "w_in": w_in, "alpha_in": alpha, "theta_in": theta, "loss_in": loss_in,
            "distance_in": distance,
            "order_roller": roller_pass_order(mode, z1), "ratio_out": output_ratio(mode, z1),
            "temperature": temperature,
            "T_in_model": T_in_model, "sens_mu": sens_mu, "sens_nu": sens_nu,
            "sens_k": sens_k, "sens_idle": sens_idle, "sens_load": sens_load,
            "load_loss_in": None if load_loss_in is None else np.asarray(load_loss_in, float),
            "tau_out": None if tau_out is None else np.asarray(tau_out, float)}


# -- a design's extra physics in a replay ---------------------------------------------------------
def extra_torque(extra, s: dict) -> np.ndarray:
    """Torque (N*m) at the driving shaft of a design's ``extra`` physics (design.ExtraPhysics),
    from the same terms the diagnosis fits; steady (drag, Stribeck, discovered terms), dynamic (inertia, ripple,
    warm-up) and, in a replay, the temperature-form warm-up and the viscosity drift.

    The transducer corrections of ``extra`` are not torque of the drive: see
    :func:`reading_model`."""
    n = len(s["t"])
    total = np.zeros(n)
    if extra.drag_torque or extra.stribeck_torque:   # the one steady formula of the FMUs
        total += extra.steady_torque(s["w_in"])
    if (extra.input_inertia or extra.ripple_1x or extra.ripple_roller
            or extra.thermal_loss_change):
        total += extra.dynamic_torque(s["alpha_in"], s["theta_in"], s["order_roller"],
                                      s["t"] - s["t"][0], s["loss_in"])
    if extra.ripple_1x_load or extra.ripple_roller_load:
        total += extra.load_ripple_torque(s["theta_in"], s["order_roller"], s["tau_out"])
    if any(getattr(extra, f) or getattr(extra, f + "_load") for f, _, _ in SHAFT_ORDER_RIPPLES):
        total += extra.shaft_order_ripple_torque(s["theta_in"], s["ratio_out"],
                                                 s.get("tau_out"))
    if extra.discovered:
        if s.get("tau_out") is None:
            raise ValueError("the design's discovered terms need the load torque (signals "
                             "'tau_out')")
        total += extra.discovered_torque(s["w_in"], s["tau_out"])
    if extra.run_in_change:
        total += extra.run_in_torque(s["distance_in"], _load_loss_in(s))
    temp = s.get("temperature")
    if extra.thermal_loss_per_10K and temp is not None:
        # the column is in degC; the design's reference (thermal_T_ref) in K
        from .design import KELVIN
        total += extra.thermal_per_10K_torque(np.asarray(temp, float) + KELVIN, s["loss_in"])
    elif extra.thermal_loss_per_10K and s.get("housing") is not None:
        # no temperature column: the grease temperature of the FMUs' own heat balance from
        # T_oil_start (the operating temperature), heated by the model's loss power
        from . import thermal
        T0, T_amb, C, R = s["housing"]
        T = thermal.housing_path(s["t"], np.asarray(s["loss_in"], float) * s["w_in"], T0,
                                 T_amb, C, R, extra.thermal_loss_per_10K, extra.thermal_T_ref)
        total += extra.thermal_per_10K_torque(T, s["loss_in"])
    # (through the replays at the drift's size where the signals carry them: effects._viscosity)
    if extra.viscosity_ln_change and s.get("sens_nu") is not None:
        total += EFFECTS["viscosity_drift"].torque({**s, "nu_secant": extra.viscosity_ln_change},
                                                   [extra.viscosity_ln_change],
                                                   extra.viscosity_tau)
    if extra.viscosity_ln_per_10K and temp is not None and s.get("sens_nu") is not None:
        total += EFFECTS["viscosity_drift"].torque({**s, "nu_secant": extra.viscosity_ln_per_10K},
                                                   [extra.viscosity_ln_per_10K], None)
    return total


def reading_model(extra, torque_in, s=None):
    """What the input torque transducer reads for a true input torque (N*m), with the
    transducer corrections a diagnosis wrote to ``extra``: (1 + gain_error) T + offset, plus
    the zero's drift where the signals ``s`` (time, temperature) are given: in time from the
    recording's start, and per 10 K of the temperature column (degC) from the design's
    ``torque_in_zero_T_ref`` (model_core.rig.zero_drift_per_10K, the transducer FMU's
    formula)."""
    reading = (1.0 + extra.torque_in_gain_error) * torque_in + extra.torque_in_offset
    if s is not None:
        if extra.torque_in_zero_drift:
            reading = reading + EFFECTS["torque_sensor_drift"].torque(
                s, [extra.torque_in_zero_drift], extra.torque_in_zero_tau)
        if extra.torque_in_zero_per_10K and s.get("temperature") is not None:
            from .design import KELVIN
            from .rig import zero_drift_per_10K
            reading = reading + zero_drift_per_10K(
                extra.torque_in_zero_per_10K, np.asarray(s["temperature"], float) + KELVIN,
                extra.torque_in_zero_T_ref)
    return reading


# -- what each effect maps to in a design ------------------------------------------------------
def _apply_nothing(design, v, shape, temperature):
    return design, []


def _with_extra(design, **kw):
    return replace(design, extra=replace(design.extra, **kw))


def _apply_friction(design, v, shape, temperature):
    from .design import scale_friction_level
    factor = 1 + v["mu_boundary_rel_error"]
    new = scale_friction_level(design, factor)
    return new, [f"friction level x {factor:.6g} (diagnosed): friction.mu_boundary "
                 f"{design.friction.mu_boundary:.6g} -> {new.friction.mu_boundary:.6g}"
                 + (f", mu_pin_boundary -> {new.friction.mu_pin_boundary:.6g}, mu_tooth -> "
                    f"{new.friction.mu_tooth:.6g}" if design.profile == "physical" else "")]


def _apply_thermal(design, v, shape, temperature):
    if temperature:
        # the form is referred to the column's first value (_warm); ``temperature`` carries it
        # in K where the diagnosis gives it (cyclo_fmu.diagnosis.report.updated_design)
        ref = (float(temperature) if not isinstance(temperature, bool)
               else design.extra.thermal_T_ref)
        # the exponential law's temperature scale (a TemperatureScale), 0 the linear law
        theta = float(shape) if isinstance(shape, TemperatureScale) else 0.0
        law = (f", thermal_T_scale = {theta:g} K: the exponential law (the change levels off "
               "as the grease warms, as a viscosity's does)" if theta else "")
        return _with_extra(design, thermal_loss_per_10K=v["loss_change"], thermal_T_ref=ref,
                           thermal_T_scale=theta), [
            f"extra.thermal_loss_per_10K, thermal_T_ref = {ref - 273.15:.4g} degC{law}: the "
            "losses change per 10 K of the grease temperature from the temperature column's "
            "first value, against the model held at one temperature (reducer FMUs: at their "
            "T_oil, T_oil_in or the heat balance's, their losses held at T_oil_start: one "
            "warm-up)"
            + ("" if not isinstance(temperature, bool) else
               " (no reference temperature given: the design's thermal_T_ref is kept)")]
    if isinstance(shape, HeatBalanceTau):
        return _apply_heat_balance(design, v, shape)
    # one warm-up (docs/explanation/thermal.md): the FMUs hold the losses at T_oil_start while
    # a warm-up in time is in the design (it was fitted against the model held at one
    # temperature), and their heat balance warms T_oil with the fitted time constant: it is
    # the housing's, tau = R C, as for the viscosity drift
    from . import thermal
    C = shape / thermal.housing_resistance(design)
    new = replace(_with_extra(design, thermal_loss_change=v["loss_change"], thermal_tau=shape),
                  housing_heat_capacity=C)
    return new, [f"housing_heat_capacity {C:.4g} J/K (was {design.housing_heat_capacity:.4g}): "
                 f"the warm-up's time constant {shape:g} s diagnosed is the housing's R C; the "
                 "FMUs' losses follow the fitted warm-up in time, held at T_oil_start (one "
                 "warm-up, not also through the grease temperature)"]


def _apply_heat_balance(design, v, shape):
    """The warm-up driven by the loss power onto the FMUs' own heat balance: the losses change
    by c per 10 K of the grease temperature T_oil (``thermal_loss_per_10K``, linear law), which
    the FMUs' heat balance integrates from T_oil_start with their own loss (one warm-up: the
    losses held at T_oil_start); a cold start, the drive at the ambient when the recording
    begins: ``ambient_temperature`` = ``thermal_T_ref`` = the operating temperature (the
    FMUs' default T_oil_start); tau = R C with the design's R: ``housing_heat_capacity`` =
    tau / R."""
    from . import thermal
    T0 = design.operating_temperature
    C = float(shape) / thermal.housing_resistance(design)
    new = replace(_with_extra(design, thermal_loss_per_10K=v["loss_change"], thermal_T_ref=T0,
                              thermal_T_scale=0.0, thermal_loss_change=0.0),
                  housing_heat_capacity=C, ambient_temperature=T0)
    return new, [f"extra.thermal_loss_per_10K {v['loss_change']:.4g} with the FMUs' heat "
                 f"balance: housing_heat_capacity {C:.4g} J/K (tau = R C = {float(shape):g} s "
                 f"diagnosed, R = {thermal.housing_resistance(design):.4g} K/W of the design), "
                 f"ambient_temperature = thermal_T_ref = {T0 - 273.15:.4g} degC (a cold start: "
                 "the drive at the ambient when the recording begins, the FMUs' T_oil_start): "
                 "the losses change per 10 K of the grease temperature the loss power warms "
                 "(leave use_T_oil_input false)"]


def _apply_viscosity(design, v, shape, temperature):
    """The viscosity drift onto the drive's own temperature physics where it is the same
    thing (physical profile: the losses depend on the grease temperature in the FMUs):

    - per 10 K of a temperature column: the observed d ln(nu)/dT is the lubricant's
      viscosity-temperature slope, so the lubricant's Walther line is rewritten to have it at
      the operating temperature (thermal.lubricant_with_slope; nu there unchanged); the FMUs,
      given the temperature (input T_oil_in) or warming by their heat balance, carry it;
    - first order in time: the warm-up's time constant is the housing's, tau = R C, so
      ``housing_heat_capacity`` = tau / R (R = 1/(k_h A_h) of the design).

    The replay (which holds the design's temperature) keeps its fields (viscosity_ln_per_10K,
    viscosity_ln_change/viscosity_tau), so a recording is replayed as it was fitted."""
    from . import thermal
    notes = []
    if temperature:
        new = _with_extra(design, viscosity_ln_per_10K=v["ln_viscosity_change"])
        slope = v["ln_viscosity_change"] / T_STEP
        if thermal.temperature_dependent(design):
            try:
                lub = thermal.lubricant_with_slope(design.lubricant,
                                                   design.operating_temperature, slope)
                new = replace(new, lubricant=lub)
                notes.append(f"lubricant: viscosity-temperature slope {slope:.4g} 1/K at "
                             f"{design.operating_temperature:g} K diagnosed (was "
                             f"{thermal.viscosity_slope(design):.4g} 1/K): kinematic_viscosity "
                             f"{lub.kinematic_viscosity * 1e6:.4g}, kinematic_viscosity_100 "
                             f"{lub.kinematic_viscosity_100 * 1e6:.4g} mm2/s; the FMUs carry it "
                             "through their grease temperature (T_oil_in or the heat balance)")
            except ValueError as exc:
                notes.append(f"viscosity drift per 10 K not a lubricant's ({exc}): replay only")
        else:
            notes.append("viscosity drift per 10 K: replay only (the paper profile's losses do "
                         "not depend on the temperature)")
        return new, notes
    new = _with_extra(design, viscosity_ln_change=v["ln_viscosity_change"],
                      viscosity_tau=shape)
    if thermal.temperature_dependent(design) and shape:
        C = shape / thermal.housing_resistance(design)
        new = replace(new, housing_heat_capacity=C)
        notes.append(f"housing_heat_capacity {C:.4g} J/K (was {design.housing_heat_capacity:.4g}): "
                     f"the warm-up's time constant {shape:g} s diagnosed is the housing's R C; "
                     "the FMUs' heat balance warms the grease with it (the size of the change "
                     "follows from their losses and the lubricant; the replay keeps the fitted "
                     "ln-viscosity change)")
    else:
        notes.append("viscosity drift in time: replay only (the paper profile's losses do not "
                     "depend on the temperature)")
    return new, notes


def _apply_drag(design, v, shape, temperature):
    ex = design.extra
    p = DRAG_EXPONENT if shape is None else shape
    if ex.drag_torque and abs(ex.drag_exponent - p) > 1e-12:
        # a second drag term of another exponent: keep the larger one's exponent, add at W_REF
        p = ex.drag_exponent
    return _with_extra(design, drag_torque=ex.drag_torque + max(v["T_drag"], 0.0),
                       drag_exponent=p), []


def _apply_loss_transition(design, v, shape, temperature):
    """The fitted width w_c onto ``extra.loss_transition``; the design carries the whole loss's
    transition (share 1, the physical form): a fitted share other than 1 is said in a note
    (part of the loss then builds up differently, or the loss level near standstill is off)."""
    share = float(v["share"])
    notes = [] if abs(share - 1.0) <= LOSS_TRANSITION_SHARE_NOTE else [
        f"loss transition: the fitted share {share:.3g} of the loss is written as the whole "
        f"loss (1) through standstill at w_c = {float(shape):g} rad/s"]
    return _with_extra(design, loss_transition=float(shape)), notes


def _apply_ripple(design, v, shape, temperature):
    """The ripple's a part (``A*``) onto ``ripple_1x``, ``ripple_roller``, ``ripple_2x``,
    ``ripple_out_1x``, ``ripple_out_2x`` (RIPPLE_FIELDS), its load-scaled b part (the ``B*``
    values, present with load law 1) onto their ``_load`` fields, each with its phase:
    A sin(th + phi) = A cos(phi) sin(th) + A sin(phi) cos(th). An order absent from ``v``
    (a diagnosis of an earlier version) is set to 0; the b parts are left as they are where
    no ``B*`` value is given."""
    kw = {}
    with_b = any(n.startswith("B") for n in v)
    for k, field in RIPPLE_FIELDS.items():
        for part, sfx in (("A", ""), ("B", "_load")):
            if part == "B" and not with_b:
                continue
            s_, c_ = float(v.get(f"{part}{k}_sin", 0.0)), float(v.get(f"{part}{k}_cos", 0.0))
            kw[field + sfx] = float(np.hypot(s_, c_))
            kw[field + sfx + "_phase"] = float(np.arctan2(c_, s_))
    return _with_extra(design, **kw), []


def _apply_offset(design, v, shape, temperature):
    return _with_extra(design, torque_in_offset=design.extra.torque_in_offset + v["offset"]), [
        f"diagnosed: input torque transducer zero offset {v['offset']:.6g} N*m (a sensor fault, "
        "not physics of the drive: re-zero the transducer; the replay corrects the reading)"]


def _apply_zero_drift(design, v, shape, temperature):
    ex = design.extra
    note = (f"diagnosed: input torque transducer zero drift {1e3 * v['offset_change']:.3g} mN*m"
            + (" per 10 K" if temperature else f" (time constant {shape:g} s)")
            + " (a sensor fault: warm the transducer up and re-zero it; the replay corrects the "
            "reading)")
    if temperature:
        # the form is referred to the column's first value (_warm); ``temperature`` carries it
        # in K where the diagnosis gives it (cyclo_fmu.diagnosis.report.updated_design): the
        # transducer's torque_in_zero_T_ref. A drift per 10 K already in the design keeps its
        # reference; the new one's, c2 (T - T0)/10 K = c2 (T - T1)/10 K + c2 (T1 - T0)/10 K,
        # adds the constant to the offset (exact: the transducer has one reference)
        c = v["offset_change"]
        ref = (float(temperature) if not isinstance(temperature, bool)
               else ex.torque_in_zero_T_ref)
        if ex.torque_in_zero_per_10K:
            from .rig import zero_drift_per_10K
            shift = zero_drift_per_10K(c, ex.torque_in_zero_T_ref, ref)
            return _with_extra(design, torque_in_zero_per_10K=ex.torque_in_zero_per_10K + c,
                               torque_in_offset=ex.torque_in_offset + shift), [
                note + f"; added at the design's reference {ex.torque_in_zero_T_ref - 273.15:.4g}"
                f" degC, {1e3 * shift:.3g} mN*m to the offset"]
        return _with_extra(design, torque_in_zero_per_10K=c, torque_in_zero_T_ref=ref), [
            note + f"; extra.torque_in_zero_per_10K from torque_in_zero_T_ref = "
            f"{ref - 273.15:.4g} degC (the bench's input torque transducer at its temperature "
            "input, the reducer's T_oil)"
            + ("" if not isinstance(temperature, bool) else
               " (no reference temperature given: the design's torque_in_zero_T_ref is kept)")]
    if ex.torque_in_zero_drift and abs(ex.torque_in_zero_tau - shape) > 1e-9:
        # a drift of another time constant already in the design: the new fit holds only
        # what that one left; kept at the earlier time constant, added (a first-order sum)
        return _with_extra(design, torque_in_zero_drift=ex.torque_in_zero_drift
                           + v["offset_change"]), [note + f"; added at the design's time "
                                                   f"constant {ex.torque_in_zero_tau:g} s"]
    return _with_extra(design, torque_in_zero_drift=ex.torque_in_zero_drift
                       + v["offset_change"], torque_in_zero_tau=shape), [note]


def _apply_gain(design, v, shape, temperature):
    g = (1 + design.extra.torque_in_gain_error) * (1 + v["gain_error"]) - 1
    return _with_extra(design, torque_in_gain_error=g), [
        f"diagnosed: input torque transducer gain error {100 * v['gain_error']:+.3g} % (a sensor "
        "fault: re-calibrate; the replay corrects the reading)"]


def _apply_calibration(name, design, change, effect):
    """``design`` with its calibration ``name`` changed by ``change``, clipped to the design's
    bounds, and the source naming the diagnosis."""
    from .design import IDLE_LOSS_SCALE_BOUNDS, LOAD_LOSS_SCALE_BOUNDS, MESH_LOSS_K_BOUNDS
    lo, hi = {"mesh_loss_k": MESH_LOSS_K_BOUNDS, "idle_loss_scale": IDLE_LOSS_SCALE_BOUNDS,
              "load_loss_scale": LOAD_LOSS_SCALE_BOUNDS}[name]
    cal = design.calibration
    old = getattr(cal, name)
    new = min(max(old + change, lo), hi)
    src = (f"{name} {new:.6g} diagnosed by cyclo-fmu diagnose (effect {effect}: change "
           f"{change:+.6g} from {old:.6g}) from a bench recording; confidence interval in its "
           "diagnosis.json")
    source = src if not cal.source else f"{cal.source}; {src}"
    notes = [f"calibration.{name} {old:.6g} -> {new:.6g} (diagnosed, effect {effect})"]
    if new != old + change:
        notes.append(f"calibration.{name}: the fitted {old + change:.6g} lies beyond the "
                     f"design's bounds {lo:g}..{hi:g}; clipped (the mismatch is not only "
                     "this effect)")
    return replace(design, calibration=replace(cal, **{name: new, "source": source})), notes


_APPLY = {
    "mesh_loss": lambda d, v, sh, T: _apply_calibration("mesh_loss_k", d,
                                                        v["mesh_loss_k_change"], "mesh_loss"),
    "idle_loss_scale": lambda d, v, sh, T: _apply_calibration(
        "idle_loss_scale", d, v["idle_loss_scale_change"], "idle_loss_scale"),
    "load_loss_scale": lambda d, v, sh, T: _apply_calibration(
        "load_loss_scale", d, v["load_loss_scale_change"], "load_loss_scale"),
    "friction_miscalibrated": _apply_friction,
    "load_independent_loss": _apply_drag,
    "low_speed_friction": lambda d, v, sh, T: (_with_extra(
        d, stribeck_torque=max(v["T_stribeck"], 0.0),
        **dict(zip(("stribeck_speed", "stribeck_exponent", "stribeck_transition"),
                   sh if isinstance(sh, tuple) else (sh,)))), []),
    "inertia": lambda d, v, sh, T: (
        _with_extra(d, input_inertia=d.extra.input_inertia + max(v["J"], 0.0)), []),
    "mesh_ripple": _apply_ripple,
    "thermal_drift": _apply_thermal,
    "run_in": lambda d, v, sh, T: (_with_extra(d, run_in_change=v["loss_excess"],
                                               run_in_distance=sh), []),
    "loss_transition": _apply_loss_transition,
    "viscosity_drift": _apply_viscosity,
    "torque_sensor_offset": _apply_offset,
    "torque_sensor_gain": _apply_gain,
    "torque_sensor_drift": _apply_zero_drift,
}


def switch_on(extra, effect: str, values: dict, shape=None):
    """``extra`` (design.ExtraPhysics) with an effect's values switched on (the synthesiser's
    hidden physics); effects that act elsewhere (friction level, none) leave it unchanged."""
    from .design import DriveDesign
    if effect in MODEL_PARAMETER_EFFECTS:
        return extra
    d, _ = EFFECTS[effect].apply(DriveDesign(extra=extra), values, shape)
    return d.extra
