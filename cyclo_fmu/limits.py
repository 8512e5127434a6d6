"""Bounds on operating points given at the command line or in a sweep spec (the CLI's edge).

The physics core evaluates any finite number; these bounds keep a user's typo (1e9 r/min,
1e-300 r/min) from turning into a plausible-looking answer or an overflow deep in the model.
Each bound is named with its unit and its physical reason; an input outside it is refused
with a ``CycloidInputError`` naming the field the user set.
"""
from __future__ import annotations

import math

from model_core import CycloidInputError

#: [r/min] a driving shaft slower than this stands still: the same bound as the recordings'
#: standstill (``cyclo_fmu.io.checks.STANDSTILL_RPM``); no steady power flows, so an efficiency
#: there is a creeping limit, not an operating point
MIN_SPEED_RPM = 1.0
#: [r/min] fastest driving shaft evaluated: ten times the limiting speed of the drawn-cup
#: needle bearings such drives run on (about 10^4 r/min with grease); beyond it the drag,
#: churning and lubrication laws would be extrapolated by orders of magnitude (and at
#: 10^300 r/min they overflow)
MAX_SPEED_RPM = 1.0e5


def check_speed_rpm(field: str, v: float) -> float:
    """``v`` [r/min], signed, must be finite with MIN_SPEED_RPM <= |v| <= MAX_SPEED_RPM."""
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise CycloidInputError(field, v, "must be a finite number of r/min")
    if abs(v) < MIN_SPEED_RPM:
        raise CycloidInputError(field, v, f"below {MIN_SPEED_RPM:g} r/min the shaft stands "
                                "still: no power flows and the efficiency is undefined (give "
                                "the running speed)")
    if abs(v) > MAX_SPEED_RPM:
        raise CycloidInputError(field, v, f"above {MAX_SPEED_RPM:g} r/min, ten times the "
                                "limiting speed of the drive's needle bearings: outside what "
                                "the model's drag and lubrication laws describe")
    return v


def check_finite_result(field: str, value, values: dict) -> None:
    """Refuse non-finite results before they are printed: ``values`` name -> number (None is
    a documented 'undefined' and passes); the error names the input ``field`` = ``value``
    that drove the model out of range."""
    for k, v in values.items():
        if isinstance(v, dict):
            check_finite_result(field, value, v)
            continue
        if v is not None and not isinstance(v, (str, bool)) and not math.isfinite(float(v)):
            raise CycloidInputError(field, value, f"the model's {k} is not a finite number "
                                    "there: the input lies outside what the model can resolve")


def ring_share(mode: str, z1: int) -> float:
    """The ring's share of a torque at the driving shaft of ``mode`` by the lossless torque
    ratios of Table 1 (i = w_a / w_b): 1 when the ring drives, |i| when it is driven, |1 - i|
    when it is held."""
    from model_core.kinematics import parse_mode, speed_ratio
    a, b, _ = parse_mode(mode)
    i = speed_ratio(a + b, z1)
    return float(1.0 if a == "1" else abs(i) if b == "1" else abs(1.0 - i))
