"""Temperature: the grease's viscosity over temperature and the housing's steady heat balance.

Viscosity. Walther's equation as standardised in ASTM D341,

.. math:: \\log_{10}\\log_{10}(\\nu + 0.7) = A - B \\log_{10} T

(nu in mm^2/s, T in K), through the two catalogue viscosities at 40 and 100 degC.

Heat balance (ISO/TR 14179-2 style, one lumped housing): the losses leave by convection and
radiation from the housing surface, P_L = k_h A_h (T - T_amb). Both k_h and A_h are named
assumptions of the design (``DriveDesign.housing_heat_transfer``, ``housing_area``).

Transient (the FMUs' warm-up): one thermal mass C (``DriveDesign.housing_heat_capacity``) with
the losses as its source,

.. math:: C \\frac{dT}{dt} = P_L - \\frac{T - T_{amb}}{R}, \\qquad R = \\frac{1}{k_h A_h},
          \\qquad \\tau = R C,

integrated over a communication step h by :func:`housing_step`: exactly for the linear part,
the loss held at its value at the step's start (a zero-order hold; an exponential integrator,
"exponential Euler"):

.. math:: T(t+h) = T_{amb} + P_L R + (T(t) - T_{amb} - P_L R)\\, e^{-h/\\tau}.

The grease temperature sets the viscosity (Walther) through which the physical profile's losses
depend on it; the FMUs' loss maps carry the temperature as a map dimension at
:func:`map_temperatures` (model_core.lossmap.ThermalMap).

References: ASTM D341-20, Standard Practice for Viscosity-Temperature Equations and Charts of
Liquid Petroleum or Hydrocarbon Products; ISO/TR 14179-2:2001, Gears - Thermal capacity - Part 2:
Thermal load-carrying capacity.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from .design import HOUSING_AREA, HOUSING_HEAT_CAPACITY, HOUSING_HEAT_TRANSFER, KELVIN

__all__ = ["HOUSING_AREA", "HOUSING_HEAT_CAPACITY", "HOUSING_HEAT_TRANSFER"]

#: [K] temperatures of a loss map's nodes relative to the design's operating temperature: the
#: operating temperature itself is a node (so a map evaluated there is exactly the map of one
#: temperature), 10 K apart from 30 K below it (a cold start at 10 degC for the default 40 degC)
#: to 50 K above it (90 degC). Between nodes the torques and losses are interpolated linearly
#: in T. 10 K, measured against the core on the paper's drive (S1; 30-300 rad/s, 0.3-20 N*m;
#: the map's own error at a node 0.45 %): the midpoint error of the loss is at most 6.0 %
#: between 10 and 20 degC, 4.1 % at 20-30, 2.1 % at 30-40 and below 0.8 % above 40 degC (the
#: cold grease makes the losses curve most); 20 K gave 20-30 % at the cold end. Each node is
#: one ModeMap (about 40 ms per mode in Python; the native FMU carries all nodes). Outside the
#: nodes the edge is held (clamped).
MAP_TEMPERATURE_OFFSETS = (-30.0, -20.0, -10.0, 0.0, 10.0, 20.0, 30.0, 40.0, 50.0)
#: [K] the range the design validates temperatures in (-100 to 200 degC); nodes outside it
#: are dropped
_T_VALID = (173.15, 473.15)
#: Temperatures of the catalogue viscosities [K].
T40, T100 = 40.0 + KELVIN, 100.0 + KELVIN


def walther_viscosity(temperature, nu40, nu100):
    """Kinematic viscosity [m^2/s] at temperature [K] from those at 40 and 100 degC [m^2/s]
    (ASTM D341, Walther)."""
    def ll(nu):
        return np.log10(np.log10(nu * 1e6 + 0.7))
    B = (ll(nu40) - ll(nu100)) / (np.log10(T100) - np.log10(T40))
    A = ll(nu40) + B * np.log10(T40)
    z = A - B * np.log10(np.asarray(temperature, float))
    return (10 ** (10 ** z) - 0.7) * 1e-6


def housing_temperature(loss_power, ambient, k_h=HOUSING_HEAT_TRANSFER, area=HOUSING_AREA):
    """Steady housing (grease) temperature [K] at loss power [W]: T_amb + P_L/(k_h A_h)."""
    return ambient + np.maximum(np.asarray(loss_power, float), 0.0) / (k_h * area)


def at_temperature(design, temperature):
    """The design with its grease at ``temperature`` [K] (temperature_model 'fixed')."""
    return dataclasses.replace(design, temperature_model="fixed",
                               operating_temperature=float(temperature))


def lubricant_viscosity(design):
    """Kinematic viscosity [m^2/s] the losses use: the catalogue value (paper profile) or the
    Walther value at the operating temperature (physical profile)."""
    lub = design.lubricant
    if design.profile == "paper":
        return lub.kinematic_viscosity
    key = (design.operating_temperature, lub.kinematic_viscosity, lub.kinematic_viscosity_100)
    nu = _VISCOSITY_CACHE.get(key)
    if nu is None:
        if len(_VISCOSITY_CACHE) > 256:
            _VISCOSITY_CACHE.clear()
        nu = _VISCOSITY_CACHE[key] = float(walther_viscosity(*key))
    return nu


_VISCOSITY_CACHE: dict = {}   # (temperature, nu40, nu100) -> nu: the loss model asks per call


def solve_heat_balance(design, mode, w_in, T_in, ambient=None, tol=0.01, max_iter=50):
    """Operating point of one steady state whose grease temperature closes the heat balance:
    T = T_amb + P_L(T)/(k_h A_h), by fixed-point iteration (losses fall as the grease thins,
    so it contracts). Returns (OperatingPoint, temperature [K])."""
    from .efficiency import operating_point
    amb = design.ambient_temperature if ambient is None else ambient
    T = amb
    for _ in range(max_iter):
        op = operating_point(at_temperature(design, T), mode, w_in, T_in)
        T_new = float(housing_temperature(np.nan_to_num(op.loss_power), amb,
                                          design.housing_heat_transfer, design.housing_area))
        T_new = min(T_new, 200 + KELVIN)
        if abs(T_new - T) < tol:
            T = T_new
            break
        T = 0.5 * (T + T_new)
    return operating_point(at_temperature(design, T), mode, w_in, T_in), T


def temperature_dependent(design) -> bool:
    """Whether the design's losses depend on the grease temperature: the physical profile's do
    (viscosity by Walther's law); the paper profile uses the catalogue viscosity as given."""
    return design.profile != "paper"


def map_temperatures(design) -> tuple:
    """Temperatures [K] of the nodes of a loss map over the grease temperature: the design's
    operating temperature plus MAP_TEMPERATURE_OFFSETS (inside the valid range); one node (the
    operating temperature) where the losses do not depend on it."""
    T0 = float(design.operating_temperature)
    if not temperature_dependent(design):
        return (T0,)
    return tuple(T0 + dT for dT in MAP_TEMPERATURE_OFFSETS
                 if _T_VALID[0] < T0 + dT < _T_VALID[1])


def housing_resistance(design) -> float:
    """Thermal resistance housing -> ambient R = 1/(k_h A_h) [K/W]."""
    return 1.0 / (design.housing_heat_transfer * design.housing_area)


def housing_time_constant(design) -> float:
    """Time constant of the housing's warm-up tau = R C [s]."""
    return housing_resistance(design) * design.housing_heat_capacity


def housing_step(temperature, loss_power, dt, ambient, heat_capacity, resistance):
    """Grease/housing temperature [K] after a step ``dt`` [s] of the lumped heat balance
    C dT/dt = P_L - (T - T_amb)/R, exact for the linear part with the loss ``loss_power`` [W]
    held over the step (zero-order hold, exponential Euler):

    .. math:: T(t+h) = T_{amb} + P_L R + (T(t) - T_{amb} - P_L R) e^{-h/(R C)}.

    The heat over the step then balances exactly: P_L h = C (T(t+h) - T(t)) + the heat given to
    the ambient, int (T - T_amb)/R dt.

    Parameters
    ----------
    temperature : float
        Temperature at the step's start [K].
    loss_power : float
        Loss power heating the housing over the step [W].
    dt : float
        Step [s], >= 0.
    ambient : float
        Ambient temperature [K].
    heat_capacity : float
        C [J/K].
    resistance : float
        R [K/W].
    """
    steady = ambient + loss_power * resistance
    return steady + (temperature - steady) * math.exp(-dt / (resistance * heat_capacity))


#: [K] step of the warm-up's temperature law (its coefficient is quoted per 10 K, as catalogue
#: viscosity and transducer drift figures are; model_core.effects.T_STEP)
T_STEP = 10.0
#: [K] smallest temperature scale the exponential law accepts (``loss_temperature_law``): a
#: lubricant's viscosity changes at most by about 10 % per K (d ln nu/dT of mineral and
#: synthetic gear oils at 0-100 degC: -0.02 ... -0.1 1/K, ASTM D341 lines), so a loss that
#: follows it has theta = 1/|m d ln nu/dT| of 10 K and more; 1 K keeps exp(-dT/theta) finite
#: over the valid temperatures (|dT| < 300 K: exp(300) ~ 2e130) while leaving a decade of margin
T_SCALE_MIN = 1.0


def loss_temperature_law(dT, scale=0.0):
    """Shape g of the warm-up's temperature law: the losses scale by 1 + c g(T - T_ref), c the
    relative change per 10 K at the reference (model_core.effects 'thermal_drift', its
    temperature form; design.ExtraPhysics.thermal_per_10K_torque).

    .. math:: g(\\Delta T) = \\frac{\\theta}{10\\,K}\\left(1 - e^{-\\Delta T/\\theta}\\right),
              \\qquad g(\\Delta T) \\to \\frac{\\Delta T}{10\\,K} \\;(\\theta \\to \\infty).

    A lubricant's viscosity falls nearly exponentially with the temperature over a few tens of
    kelvin (Vogel's law; Walther's line of ASTM D341 has d ln nu/dT = -0.058 1/K at 40 degC for
    the default grease, flattening as it warms). A part a of the losses that goes as nu^m then
    changes by a (exp(-dT/theta) - 1), theta = 1/|m d ln nu/dT|: the law above with
    c = -10 K a/theta. The linear per-10 K law is its first term. g has the slope 1/(10 K) at
    dT = 0 for every theta, so c keeps its meaning (the change per 10 K at the reference); the
    change levels off as the grease warms (theta > 0) and grows faster below the reference.

    Parameters
    ----------
    dT : float or array
        Temperature above the reference, T - T_ref [K].
    scale : float
        theta [K]; 0 selects the linear law dT/10 K (theta -> infinity), the default. Else at
        least ``T_SCALE_MIN``.

    Returns
    -------
    g : float or array [1]
    """
    if not scale:
        return dT / T_STEP
    return scale / T_STEP * -np.expm1(-np.asarray(dT, float) / scale)


def housing_path(t, loss_power, start, ambient, heat_capacity, resistance, per_10K=0.0,
                 T_ref=None):
    """Grease/housing temperature [K] at the times ``t`` [s] of the lumped heat balance driven
    by the loss power ``loss_power`` [W] at those times: ``housing_step`` from each time to the
    next with the power of the earlier one held (zero-order hold, as the FMUs take the loss of
    a step's inputs over the step), from ``start`` [K] at the first time:

    .. math:: y_{k} = a_k\\,y_{k-1} + (1 - a_k)\\,R\\,P_{k-1}
              \\left(1 + c\\,\\frac{T_{k-1} - T_{ref}}{10\\,K}\\right), \\qquad
              a_k = e^{-(t_k - t_{k-1})/(R C)}, \\qquad y = T - T_{amb}.

    With ``per_10K`` c the losses that heat the housing change per 10 K of its temperature from
    ``T_ref`` [K] (the warm-up per 10 K, ``design.ExtraPhysics.thermal_loss_per_10K``, linear
    law): the FMUs' heat balance runs on their loss, warm-up included. Vectorised (a
    first-order recursive filter, the warm-up's feedback by fixed-point iteration) where the
    steps are equal, step by step otherwise (a logger gap, duplicated stamps: a step of 0
    keeps T).

    Parameters
    ----------
    t : array
        Times [s], non-decreasing.
    loss_power : array
        Loss power heating the housing at each time, at T_ref [W].
    start : float
        Temperature at the first time, K.
    ambient, heat_capacity, resistance : float
        T_amb in K, C in J/K, R in K/W (``housing_step``).
    per_10K : float
        c [1 per 10 K]; 0: the losses do not depend on the temperature.
    T_ref : float
        Reference temperature of ``per_10K``, K.
    """
    from .filters import linear_filter
    lfilter = linear_filter()
    t = np.asarray(t, float)
    x = np.asarray(loss_power, float)
    if resistance != 1.0:
        x = resistance * x
    tau = resistance * heat_capacity
    y = np.empty_like(t)
    if not len(t):
        return y
    y0 = float(start) - ambient
    y[0] = y0
    k = per_10K / T_STEP
    off = 0.0 if not per_10K else ambient - T_ref    # T - T_ref = y + off
    h = _equal_step(t)
    if h is not None:
        a = math.exp(-h / tau)
        b_, a_ = np.atleast_1d([1.0 - a]), np.atleast_1d([1.0, -a])
        z_ = np.atleast_1d([a * y0])
        y[1:] = lfilter(b_, a_, x[:-1], 0, z_)[0]
        for _ in range(_FEEDBACK_PASSES if per_10K else 0):
            prev = y.copy()
            y[1:] = lfilter(b_, a_, x[:-1] * (1.0 + k * (prev[:-1] + off)), 0, z_)[0]
            if np.max(np.abs(y - prev)) <= 1e-12 * max(float(np.max(np.abs(y))), 1.0):
                y += ambient
                return y
        if not per_10K:
            y += ambient     # (in place: a long recording's arrays are the peak)
            return y
    a = np.exp(-np.diff(t) / tau)
    for j in range(1, len(t)):
        y[j] = a[j - 1] * y[j - 1] + (1.0 - a[j - 1]) * x[j - 1] * (1.0 + k * (y[j - 1] + off))
    y += ambient
    return y


def _equal_step(t, chunk=1 << 16):
    """The step of ``t`` [s] if all its steps are equal (within 1e-9 of the largest), else
    None; read in chunks (a long recording's differences are not held at once)."""
    if len(t) < 2:
        return None
    lo, hi = math.inf, -math.inf
    for i in range(0, len(t) - 1, chunk):
        d = np.diff(t[i:i + chunk + 1])
        lo, hi = min(lo, float(d.min())), max(hi, float(d.max()))
    return float(t[1] - t[0]) if hi - lo <= 1e-9 * max(abs(lo), abs(hi), 1e-300) else None


#: fixed-point passes of ``housing_path``'s warm-up feedback before it steps sample by sample:
#: each pass shrinks the error by about c times the temperature rise per 10 K (0.1 to 0.3 for
#: a warm-up the diagnosis reports), so 30 passes reach 1e-12 well within it
_FEEDBACK_PASSES = 30


def heat_to_ambient(temperature, ambient, resistance):
    """Heat flow from the housing to the ambient (T - T_amb)/R [W]."""
    return (temperature - ambient) / resistance


def viscosity_slope(design, temperature=None):
    """d ln(nu)/dT [1/K] of the design's lubricant at ``temperature`` [K] (default: the
    operating temperature), from Walther's line through its two catalogue viscosities."""
    T = float(design.operating_temperature if temperature is None else temperature)
    lub = design.lubricant
    h = 0.01
    return float((np.log(walther_viscosity(T + h, lub.kinematic_viscosity,
                                           lub.kinematic_viscosity_100))
                  - np.log(walther_viscosity(T - h, lub.kinematic_viscosity,
                                             lub.kinematic_viscosity_100))) / (2 * h))


def lubricant_with_slope(lubricant, temperature, slope):
    """The lubricant whose Walther line passes through its own viscosity at ``temperature`` [K]
    with d ln(nu)/dT = ``slope`` [1/K] (< 0: oils thin when hot); its 40 and 100 degC
    viscosities are rewritten (ASTM D341). Raises ValueError where no Walther line has it."""
    if not (math.isfinite(slope) and slope < 0):
        raise ValueError(f"viscosity slope {slope!r} 1/K: must be negative (oils thin when hot)")
    nu = float(walther_viscosity(temperature, lubricant.kinematic_viscosity,
                                 lubricant.kinematic_viscosity_100)) * 1e6   # mm^2/s
    x = math.log10(nu + 0.7)
    y = math.log10(x)
    # dy/dT = -B/(T ln 10) and dy/dnu = 1/(x (nu + 0.7) ln(10)^2): B from the slope
    B = -slope * temperature * nu / (x * (nu + 0.7) * math.log(10))
    A = y + B * math.log10(temperature)

    def nu_at(T):
        return (10 ** (10 ** (A - B * math.log10(T))) - 0.7) * 1e-6
    return dataclasses.replace(lubricant, kinematic_viscosity=nu_at(T40),
                               kinematic_viscosity_100=nu_at(T100))
