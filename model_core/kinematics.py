"""Kinematics: Willis equation, speed ratios of the six operating modes, shaft speeds.

Shafts: "1" central ring with rollers, "2" disc with rollers, "S" eccentric shaft (carrier).
A mode "ab" drives shaft a, takes power off shaft b and holds the third (Table 1).
Willis equation (carrier S):  w1 - i0*w2 - (1 - i0)*wS = 0,  i0 = (z1-1)/z1   (Eq. 1).
Speeds in rad/s.
"""
from __future__ import annotations

import numpy as np

from .errors import CycloidInputError

SHAFTS = ("1", "2", "S")
MODES = ("12", "21", "1S", "S1", "2S", "S2")


def parse_mode(mode: str) -> tuple[str, str, str]:
    """(driving shaft, driven shaft, held shaft) of a mode such as "S1"."""
    mode = str(mode).strip().upper().replace("s", "S")
    if mode not in MODES:
        raise CycloidInputError("mode", mode, f"must be one of {', '.join(MODES)}")
    a, b = mode[0], mode[1]
    held = next(s for s in SHAFTS if s not in (a, b))
    return a, b, held


def reverse_mode(mode: str) -> str:
    """The mode with the power flowing the other way ("S1" -> "1S")."""
    a, b, _ = parse_mode(mode)
    return b + a


def basic_ratio(z1: int) -> float:
    """i0 = (n1/n2) with the eccentric shaft held = (z1-1)/z1 (Eq. 1, Table 1)."""
    return (z1 - 1) / z1


def speed_ratio(mode: str, z1: int) -> float:
    """Speed ratio i_ab = w_a/w_b of a mode (Table 1, with the erratum i_S1 = +z1).

    i12 = i0, i21 = 1/i0, i1S = 1 - i0 = 1/z1, iS1 = 1/(1-i0) = z1,
    i2S = 1 - 1/i0 = 1/(1-z1), iS2 = i0/(i0-1) = 1 - z1.
    """
    a, b, held = parse_mode(mode)
    w = shaft_speeds(mode, 1.0, z1)
    return w[a] / w[b]


def shaft_speeds(mode: str, w_in, z1: int) -> dict:
    """Speeds of all three shafts (rad/s) from the driving shaft's speed, held shaft at rest.

    Willis: w1 = i0*w2 + (1-i0)*wS.
    """
    a, b, held = parse_mode(mode)
    i0 = basic_ratio(z1)
    w_in = np.asarray(w_in, float)
    zero = np.zeros_like(w_in)
    if held == "S":
        w = {"S": zero, a: w_in, b: w_in / i0 if a == "1" else w_in * i0}
    elif held == "2":   # w1 = (1 - i0) wS
        w = {"2": zero, a: w_in, b: w_in * (1 - i0) if a == "S" else w_in / (1 - i0)}
    else:               # held 1: 0 = i0 w2 + (1 - i0) wS
        w = {"1": zero, a: w_in, b: -w_in * (1 - i0) / i0 if a == "S" else -w_in * i0 / (1 - i0)}
    return w


def relative_speeds(w1, w2, wS):
    """Speeds seen with the carrier held: (w1 - wS, w2 - wS), rad/s."""
    return np.asarray(w1) - np.asarray(wS), np.asarray(w2) - np.asarray(wS)


def rpm_to_rad_s(n):
    """Convert r/min to rad/s (edge conversion)."""
    return np.asarray(n, float) * (2 * np.pi / 60.0)


def rad_s_to_rpm(w):
    """Convert rad/s to r/min (edge conversion)."""
    return np.asarray(w, float) * (60.0 / (2 * np.pi))
