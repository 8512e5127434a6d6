"""Temperature: the grease's viscosity over temperature and the housing's steady heat balance.

Viscosity. Walther's equation as standardised in ASTM D341,

.. math:: \\log_{10}\\log_{10}(\\nu + 0.7) = A - B \\log_{10} T

(nu in mm^2/s, T in K), through the two catalogue viscosities at 40 and 100 degC.

Heat balance (ISO/TR 14179-2 style, one lumped housing): the losses leave by convection and
radiation from the housing surface, P_L = k_h A_h (T - T_amb). Both k_h and A_h are named
assumptions of the design (module constants below).

References: ASTM D341-20, Standard Practice for Viscosity-Temperature Equations and Charts of
Liquid Petroleum or Hydrocarbon Products; ISO/TR 14179-2:2001, Gears - Thermal capacity - Part 2:
Thermal load-carrying capacity.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from .design import KELVIN

#: Combined convection and radiation coefficient of the housing [W/(m^2 K)]. **Assumption**:
#: 15, still air around a small painted housing (ISO/TR 14179-2 gives about 10-20 for natural
#: convection plus radiation).
HOUSING_HEAT_TRANSFER = 15.0
#: Radiating and convecting surface of the housing [m^2]. **Assumption**: a 130 mm x 80 mm
#: cylinder (the paper's drive: ring rollers on a 96 mm pitch circle), 2 pi r^2 + pi d l.
HOUSING_AREA = 2 * np.pi * 0.065 ** 2 + np.pi * 0.13 * 0.08
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
        T_new = float(housing_temperature(np.nan_to_num(op.loss_power), amb))
        T_new = min(T_new, 200 + KELVIN)
        if abs(T_new - T) < tol:
            T = T_new
            break
        T = 0.5 * (T + T_new)
    return operating_point(at_temperature(design, T), mode, w_in, T_in), T
