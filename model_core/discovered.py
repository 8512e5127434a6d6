"""A discovered loss: a small sum of power laws in driving speed and load, fitted by a diagnosis.

When a bench recording leaves a mismatch that no effect of the library
(:mod:`model_core.effects`) explains, the diagnosis fits a sparse closed form to it
(``cyclo_fmu.diagnosis.discover``) and writes the steady part of that form into the design
(``[[extra.discovered]]``). This module is the one implementation of that form: the replay,
the Python FMU (through ``ExtraPhysics.discovered_torque``), the synthesiser and the native
FMU (the same formula in C, ``cd_discovered_torque``) all evaluate it.

Each term is a loss torque at the driving shaft that opposes the motion in all four quadrants
(forward and reverse, driving and back-driven):

.. math::

    T_k = c_k \\, \\operatorname{sgn}(\\omega_{in})
          \\left(\\frac{|\\omega_{in}|}{\\omega_{ref}}\\right)^{p_k}
          \\left(\\frac{|\\tau_{out}|}{\\tau_{ref}}\\right)^{q_k}

with :math:`c_k` the torque (N*m) at the reference point (300 rad/s, 10 N*m). Its power
:math:`T_k \\omega_{in} = c_k |\\omega_{in}| (\\dots) \\ge 0` for :math:`c_k > 0` whatever the
direction of the power flow: a loss referred to the driving shaft always takes the sign of the
driving speed. A negative :math:`c_k` is a loss the model over-estimates.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import CycloidInputError

#: [rad/s] reference driving speed of the terms: the drag law's (``effects.W_REF``)
W_REF = 300.0
#: [N*m] reference load torque of the terms. **Assumption**: 10 N*m, a round value inside the
#: paper bench's range (the output transducer's nominal torque is 20 N*m, the synthesised plans
#: load up to 7.5 N*m); only the unit of the coefficient depends on it
T_REF = 10.0
#: at most this many terms: a discovered form is a sparse closed form, not a fit of everything;
#: the native FMU holds this many (cd_model.h, CD_MAX_DISCOVERED)
MAX_TERMS = 4
#: [1] exponents beyond this are not a loss law (the dictionary's grid ends at 3)
MAX_EXPONENT = 4.0


@dataclass(frozen=True)
class DiscoveredTerm:
    """One power-law loss term (see the module docstring)."""

    coefficient: float        # N*m at |w_in| = W_REF, |tau_out| = T_REF
    speed_exponent: float = 0.0   # p, 1
    load_exponent: float = 0.0    # q, 1

    def validate(self, where="extra.discovered") -> None:
        for name in ("coefficient", "speed_exponent", "load_exponent"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v):
                raise CycloidInputError(f"{where}.{name}", v, "must be a finite number")
        for name in ("speed_exponent", "load_exponent"):
            v = getattr(self, name)
            if not 0.0 <= v <= MAX_EXPONENT:
                raise CycloidInputError(f"{where}.{name}", v,
                                        f"must lie between 0 and {MAX_EXPONENT:g}")

    def text(self) -> str:
        """The term as a formula with units."""
        parts = [f"{1e3 * self.coefficient:+.4g} mN*m * sgn(w_in)"]
        if self.speed_exponent:
            parts.append(f"(|w_in|/{W_REF:g} rad/s)^{self.speed_exponent:g}")
        if self.load_exponent:
            parts.append(f"(|tau_out|/{T_REF:g} N*m)^{self.load_exponent:g}")
        return " * ".join(parts)


def term_torque(w_in, tau_out, speed_exponent, load_exponent):
    """One term's torque per N*m of coefficient: sgn(w) (|w|/W_REF)^p (|tau_out|/T_REF)^q.

    ``w_in`` [rad/s] driving speed, ``tau_out`` [N*m] load torque on the driven shaft (its
    magnitude enters). 0^0 = 1: p = 0 is a constant (Coulomb) loss, q = 0 a load-independent
    one."""
    w = np.asarray(w_in, float)
    T = np.asarray(tau_out, float)
    return (np.sign(w) * np.power(np.abs(w) / W_REF, speed_exponent)
            * np.power(np.abs(T) / T_REF, load_exponent))


def discovered_torque(terms, w_in, tau_out):
    """Torque (N*m) of a design's discovered terms at the driving shaft, in the sense of the
    driving torque, at driving speed ``w_in`` (rad/s) and load torque ``tau_out`` (N*m).

    Scalars (an FMU's step) or arrays (a replay) broadcast."""
    w = np.asarray(w_in, float)
    T = np.asarray(tau_out, float)
    total = np.zeros(np.broadcast(w, T).shape)
    for k in terms:
        total = total + k.coefficient * term_torque(w, T, k.speed_exponent, k.load_exponent)
    return total


def terms_from_toml(data, where="extra.discovered") -> tuple:
    """``[[extra.discovered]]`` tables (keys coefficient_Nm, speed_exponent, load_exponent)
    as a tuple of :class:`DiscoveredTerm`."""
    if not isinstance(data, list):
        raise CycloidInputError(where, data, "must be an array of tables ([[extra.discovered]])")
    if len(data) > MAX_TERMS:
        raise CycloidInputError(where, len(data), f"at most {MAX_TERMS} terms")
    out = []
    keys = {"coefficient_Nm": "coefficient", "speed_exponent": "speed_exponent",
            "load_exponent": "load_exponent"}
    for i, row in enumerate(data):
        w = f"{where}[{i}]"
        if not isinstance(row, dict):
            raise CycloidInputError(w, row, "must be a table")
        for k in row:
            if k not in keys:
                raise CycloidInputError(f"{w}.{k}", row[k], "unknown key (known: "
                                        + ", ".join(keys) + ")")
        if "coefficient_Nm" not in row:
            raise CycloidInputError(f"{w}.coefficient_Nm", None, "missing")
        kw = {keys[k]: v for k, v in row.items()}
        for k, v in kw.items():
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise CycloidInputError(f"{w}.{k}", v, "must be a number")
        term = DiscoveredTerm(**{k: float(v) for k, v in kw.items()})
        term.validate(w)
        out.append(term)
    return tuple(out)


def terms_to_toml(terms) -> str:
    """TOML text of the terms (``[[extra.discovered]]`` tables)."""
    return "".join(f"\n[[extra.discovered]]\ncoefficient_Nm = {t.coefficient!r}\n"
                   f"speed_exponent = {t.speed_exponent!r}\nload_exponent = "
                   f"{t.load_exponent!r}\n" for t in terms)
