"""Efficiency: basic efficiency eta0 (Eqs. 28, 29), the six operating modes (Kreines/Mueller,
Table 2 corrected), power-flow direction in all four quadrants, self-locking.

Torques are those the outside applies on the reducer's shafts (Modelica flange convention), so
the power into the reducer at a shaft is T*w and the loss is T1 w1 + T2 w2 + TS wS >= 0.

Kreines' rule with the carrier held: T2 = -i0 * eta0^w * T1, TS = -(T1 + T2), where
w = sign(T1 (w1 - wS)) is +1 when shaft 1 drives in the relative motion. It gives

    mode  fixed  w   efficiency                         eta0 = 0.962
    12    S     +1   eta0                                0.962
    21    S     -1   eta0                                0.962
    1S    2     -1   (eta0 - i0) / (eta0 (1 - i0))        0.4470
    S1    2     +1   (1 - i0) / (1 - i0 eta0)             0.6527
    2S    1     -1   (eta0 - i0) / (1 - i0)               0.4300
    S2    1     +1   eta0 (1 - i0) / (1 - i0 eta0)        0.6279

(the paper's Table 2 prints 1S and S1 garbled). Back-driving into S is self-locking when
eta0 <= i0 (the formula turns non-positive); it is then reported as locked.

Operating point: the loss model gives P_L(|T1|, w2 - wS) from the frictionless contact forces
at the ring torque T1. The basic efficiency follows from Eq. (28) on the relative motion,
eta0 = 1 - P_L/|T1 w1'| (w = +1) or 1/(1 + P_L/|T1 w1'|) (w = -1, shaft 2 drives relatively),
and T1 from the given input torque depends on eta0 through Kreines' rule: a scalar fixed point,
solved by a vectorised secant iteration. The efficiency of the mode is then Eq. (28) directly,
1 - P_L/P_in, which equals the Kreines formula (a test checks it).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import kinematics
from .errors import CycloidInputError
from .losses import LOSS_NAMES, PartialLosses, partial_losses

_FIXED_POINT_TOL = 1e-9   # on eta0: the known torque is then reproduced to ~1e-8
_FIXED_POINT_MAX = 30


def kreines_efficiency(mode: str, eta0, i0):
    """Efficiency of an operating mode from the basic efficiency eta0 (corrected Table 2)."""
    a, b, _ = kinematics.parse_mode(mode)
    eta0 = np.asarray(eta0, float)
    table = {
        "12": lambda: eta0,
        "21": lambda: eta0,
        "1S": lambda: (eta0 - i0) / (eta0 * (1 - i0)),
        "S1": lambda: (1 - i0) / (1 - i0 * eta0),
        "2S": lambda: (eta0 - i0) / (1 - i0),
        "S2": lambda: eta0 * (1 - i0) / (1 - i0 * eta0),
    }
    return table[a + b]()


def basic_efficiency(T1, T2, w1, w2):
    """eta0 = -(T2 w2)/(T1 w1) with the carrier held and shaft 1 driving (Eq. 29)."""
    return -(np.asarray(T2) * np.asarray(w2)) / (np.asarray(T1) * np.asarray(w1))


def torque_coefficients(eta0, w, i0):
    """(c1, c2, cS) with T_shaft = c * T1 by Kreines' rule and the torque balance."""
    c2 = -i0 * np.where(w > 0, eta0, 1.0 / eta0)
    return np.ones_like(c2), c2, -(1.0 + c2)


@dataclass(frozen=True)
class OperatingPoint:
    """Steady operating point of the drive (arrays broadcast over the inputs).

    speeds and torques: dicts keyed "1", "2", "S" (rad/s; N*m applied by the outside on the
    shaft). ``eta`` is the efficiency of the actual power flow (NaN where locked, unloaded, or
    where the load-dependent losses exceed the power at a vanishing load: then torques and
    losses are NaN too, as they are for a locked drive whose torque is given on S);
    ``flow_mode`` the mode the power actually flows in ("S1", or "1S" when back-driven).
    """

    mode: str
    flow_forward: np.ndarray
    speeds: dict
    torques: dict
    eta: np.ndarray
    eta0: np.ndarray
    locked: np.ndarray
    losses: PartialLosses
    input_power: np.ndarray
    output_power: np.ndarray
    i0: float

    @property
    def driving(self) -> str:
        return kinematics.parse_mode(self.mode)[0]

    @property
    def driven(self) -> str:
        return kinematics.parse_mode(self.mode)[1]

    @property
    def held(self) -> str:
        return kinematics.parse_mode(self.mode)[2]

    @property
    def loss_power(self) -> np.ndarray:
        return self.losses.total

    @property
    def eta_kreines(self) -> np.ndarray:
        """Kreines-formula efficiency of the actual flow from eta0 (equals eta; a check)."""
        fwd = kreines_efficiency(self.mode, self.eta0, self.i0)
        rev = kreines_efficiency(kinematics.reverse_mode(self.mode), self.eta0, self.i0)
        return np.where(self.flow_forward, fwd, rev)


def operating_point(design, mode: str, w_in, T_in=None, *, T_out=None) -> OperatingPoint:
    """Solve the drive at driving-shaft speed w_in (rad/s, signed) and one known torque:
    T_in, the torque delivered into the driving shaft, or T_out, the torque the load applies on
    the driven shaft (both as applied by the outside; N*m, signed). Arrays broadcast (maps)."""
    a, b, h = kinematics.parse_mode(mode)
    if (T_in is None) == (T_out is None):
        raise CycloidInputError("torque", None, "give exactly one of T_in and T_out")
    known = a if T_out is None else b
    w_in, T_known = np.broadcast_arrays(np.asarray(w_in, float),
                                     np.asarray(T_in if T_out is None else T_out, float))
    if not np.all(np.isfinite(w_in)):
        raise CycloidInputError("speed", w_in[~np.isfinite(w_in)].flat[0], "must be finite")
    if not np.all(np.isfinite(T_known)):
        raise CycloidInputError("torque", T_known[~np.isfinite(T_known)].flat[0], "must be finite")
    if np.any(w_in == 0):
        raise CycloidInputError("speed", 0.0, "zero input speed gives no direction of motion "
                                "(the efficiency is undefined at standstill)")
    i0 = design.i0
    # physics beyond the paper (design.extra): a drag/Stribeck torque at the driving shaft; the
    # gear itself sees the rest
    T_extra = design.extra.steady_torque(w_in)
    if known == a:
        T_known = T_known - T_extra
    w = kinematics.shaft_speeds(mode, w_in, design.z1)
    w1p, w2p = kinematics.relative_speeds(w["1"], w["2"], w["S"])
    idx = {"1": 0, "2": 1, "S": 2}
    # direction of the relative power flow from the frictionless torques
    c_free = torque_coefficients(np.ones_like(T_known), np.ones_like(T_known), i0)
    T1_free = T_known / c_free[idx[known]]
    wdir = np.where(T1_free * w1p >= 0, 1.0, -1.0)
    base = np.abs(w1p)
    def guarded(eta0):
        # with the known torque on S and shaft 2 driving relatively (w = -1), T1 = T_S/(i0/eta0 - 1)
        # has a pole at the locking limit eta0 = i0: keep off it (such points are locked)
        if known != "S":
            return eta0
        return np.where(wdir < 0, np.maximum(eta0, i0 * (1 + 1e-9)), eta0)

    def ring_torque(eta0):
        c = torque_coefficients(guarded(eta0), wdir, i0)[idx[known]]
        return T_known / c

    state = {}   # warm start of the contact solutions between iterations
    # load-independent losses (physical profile, losses = "all"): they depend on the speeds
    # only; loss power is frame-invariant, so they enter eta0 like the gear's own losses
    if design.profile == "physical" and design.losses == "all":
        from . import drag, thermal
        idle = drag.idle_losses(design, w, thermal.lubricant_viscosity(design))
        idle = {k: np.broadcast_to(v, T_known.shape) for k, v in idle.items()}
    else:
        idle = {}
    P_idle = sum(idle.values()) if idle else 0.0

    def eta0_from(eta0):
        T1 = ring_torque(eta0)
        # physical profile: friction in the force balance. The gear's torque balance with its
        # losses makes the disc side carry |T2| = i0 eta0^w |T1| (less than the ring side's
        # frictionless share when the ring drives, more when the disc drives), so the disc
        # rollers' and the eccentric bearing's forces follow the power-flow direction
        Td = (np.abs(T1) * i0 * np.where(wdir > 0, eta0, 1.0 / np.maximum(eta0, 1e-3))
              if design.profile == "physical" else None)
        L = partial_losses(design, np.abs(T1), w2p, state=state, disc_torque=Td,
                           ring_flow=wdir if design.profile == "physical" else None)
        with np.errstate(divide="ignore", invalid="ignore"):
            x = np.where(T1 != 0, (L.total + P_idle) / (np.abs(T1) * base), 0.0)
        return np.where(wdir > 0, 1.0 - x, 1.0 / (1.0 + x)), L, T1

    # secant iteration on g(eta0) = f(eta0) - eta0, started from the frictionless point
    x0 = np.ones_like(T_known)
    f0, _, _ = eta0_from(x0)
    x1 = f0
    f1, L, T1 = eta0_from(x1)
    g0, g1 = f0 - x0, f1 - x1
    for _ in range(_FIXED_POINT_MAX):
        if np.all(np.abs(g1) <= _FIXED_POINT_TOL):
            break
        denom = g1 - g0
        safe = np.abs(denom) > 1e-300
        x2 = np.where(safe, x1 - g1 * (x1 - x0) / np.where(safe, denom, 1.0), f1)
        x0, g0 = x1, g1
        x1 = x2
        f1, L, T1 = eta0_from(x1)
        g1 = f1 - x1
    # the secant can fail where the losses rival the power (very light load) or run into the
    # locking pole; such points are solved again by bisection on the bracket (lo, 1], where
    # g(1) <= 0. No root above lo: self-locking (known torque on S, w = -1) or a stall.
    lo = np.where((wdir < 0) & (known == "S"), i0 * (1 + 1e-9), 1e-3)

    def reproduced(eta0, T1):
        c_k = torque_coefficients(guarded(eta0), wdir, i0)[idx[known]]
        return np.abs(T1 * c_k - T_known) <= 1e-7 * np.abs(T_known) + 1e-300

    ok = (np.abs(g1) <= 10 * _FIXED_POINT_TOL) & (f1 > lo) & (f1 <= 1) & reproduced(f1, T1)
    solvable = np.ones_like(ok)
    if not np.all(ok):
        g_lo = eta0_from(lo)[0] - lo
        solvable = g_lo >= 0
        a_, b_ = lo.copy(), np.ones_like(lo)
        for _ in range(60):
            mid = 0.5 * (a_ + b_)
            gm = eta0_from(np.where(ok, x1, mid))[0] - mid
            a_, b_ = np.where(gm >= 0, mid, a_), np.where(gm >= 0, b_, mid)
        x1 = np.where(ok, x1, 0.5 * (a_ + b_))
        f1, L, T1 = eta0_from(x1)
    eta0 = f1   # consistent with the losses L evaluated at T1
    c = torque_coefficients(guarded(eta0), wdir, i0)
    # all torques from T1 and eta0, so that Kreines' rule and the energy balance hold exactly;
    # the known torque is reproduced to the fixed-point tolerance (about 1e-9 relative)
    torques = {"1": T1 * c[0], "2": T1 * c[1], "S": T1 * c[2]}
    forward = (T_known * w[a] >= 0) if known == a else (T_known * w[b] <= 0)
    flow_into_S = np.where(forward, b == "S", a == "S")
    # self-locking: power flowing into S from 1 or 2 with eta0 <= i0 (Kreines formula <= 0)
    locked = flow_into_S & ((eta0 <= i0) | ~solvable)
    # no steady solution at all (locked with the torque given on S, or losses above the power)
    undefined = ~solvable | (locked & (known == "S"))
    nan = np.full_like(eta0, np.nan)
    torques = {k: np.where(undefined, nan, v) for k, v in torques.items()}
    torques[a] = torques[a] + T_extra
    L = PartialLosses(*(np.where(undefined, nan, getattr(L, n)) for n in LOSS_NAMES),
                      P_extra=np.where(undefined, nan, T_extra * w[a]),
                      **{k: np.where(undefined, nan, v) for k, v in idle.items()})
    p_a, p_b = torques[a] * w[a], torques[b] * w[b]
    p_in = np.where(forward, p_a, p_b)
    p_out = -np.where(forward, p_b, p_a)
    with np.errstate(divide="ignore", invalid="ignore"):
        eta = np.where(locked | undefined | ~(p_in > 0), np.nan, 1.0 - L.total / p_in)
        eta = np.where(eta > 0, eta, np.nan)
    return OperatingPoint(mode=a + b, flow_forward=forward, speeds=w, torques=torques, eta=eta,
                          eta0=eta0, locked=locked, losses=L, input_power=p_in,
                          output_power=p_out, i0=i0)
