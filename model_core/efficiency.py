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
solved per point by a vectorised secant iteration (regula falsi where it fails). The efficiency of the mode is then Eq. (28) directly,
1 - P_L/P_in, which equals the Kreines formula (a test checks it).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import kinematics
from .errors import CycloidInputError
from .losses import LOSS_NAMES, MESH_LOSS_NAME, PartialLosses, partial_losses

#: on g(eta0) = f(eta0) - eta0 [1]. T1 depends on eta0 through 1/(i0 eta0 - 1) in the modes
#: with S driving (i0 = 14/15: about 10 times amplified, without bound near the locking limit
#: eta0 = i0 when back-driven), so 1e-9 left the losses converged to only ~1e-8 (measured:
#: 2e-8); 1e-12 costs one more secant step on part of the points
_FIXED_POINT_TOL = 1e-12
_FIXED_POINT_MAX = 30
#: up to this many points (a few points cost what one does: numpy's per-call overhead), the
#: secant starts from the frictionless eta0 = 1 and _START_NODES [1] (typical basic
#: efficiencies), all evaluated in one call, and interpolates through them; its first
#: estimate is evaluated with two companions (_COMPANION_OFFSETS), and the next one converges.
#: One operating point then takes 3 loss evaluations (the known torque on shaft 1 or 2: 2 or
#: 3) instead of 4 (paper) or 5 (physical). The nodes' order sets the contact solver's warm
#: start for the next call (a point listed twice keeps its last entry): a typical root last
_PAIR_START_MAX = 16
_START_NODES = (0.85, 0.92, 0.985, 0.96)
#: where a node lies below lo (near the locking limit): the nodes at these fractions of the
#: way from 1 to lo instead
_START_FRACTIONS = np.array((0.9, 0.65, 0.1, 0.35))
_START_NODES_COL = np.array(_START_NODES)[:, None]
#: the first estimate from the start nodes and its companions at these offsets in eta0 [1]
#: (see _secant): the first estimate is off by up to ~3e-5 (physical profile: the loss
#: ratio is not smooth enough for a closer one from nodes ~0.02 apart), and inverse quadratic
#: interpolation through three points within ~1e-5 of each other gets within ~1e-14
_COMPANION_OFFSETS = np.array((0.0, -1e-5, 1e-5))
#: lower end of the searched basic efficiency [1]: below 0.1 % no drive runs
_ETA0_FLOOR = 1e-3
#: regula falsi on the bracket (points where the secant fails): the bracket's relative width
#: at the end, adjacent floats (near the locking pole eta0 = i0 the ring torque is
#: extremely sensitive to eta0), and the most steps (the bisection it replaces took 60)
_BRACKET_RTOL = 2 * np.finfo(float).eps
_BRACKET_MAX = 100
#: the secant hands a point to the bracketed solver when _SECANT_PATIENCE evaluations in a
#: row did not bring its |f - eta0| below _SECANT_PROGRESS [1] times the smallest it had:
#: on a smooth g the secant gains orders of magnitude a step, so no progress means g is not
#: smooth at the root. The roll-or-skid switch of a plain roller (friction.roll_or_skid)
#: makes the losses jump there: g jumps across zero (measured: +6.8e-7 to -1.2e-6 at 829 r/min,
#: 0.54 N*m of the physical S1 map), there is no root to converge to, and the secant bounced to
#: _FIXED_POINT_MAX (24 single-point evaluations) before the bracket took over
_SECANT_PROGRESS = 0.5
_SECANT_PATIENCE = 3
#: [steps] the secant step from which progress is watched (the maps' points converge in 3-4)
_SECANT_WATCH = 3
#: up to this many points left on the bracket (a few points cost what one does: numpy's
#: per-call overhead, as _PAIR_START_MAX), each step evaluates _MULTISECTION_POINTS points
#: of every bracket in one call, the regula falsi's point and an even grid, and keeps the
#: sub-bracket where g changes sign: a jump of g (above) is then narrowed to adjacent floats
#: in 7 calls instead of 27 (regula falsi, Illinois, degrades to about bisection there)
_MULTISECTION_MAX = 16
_MULTISECTION_POINTS = 16


def _state_subset(state, sel):
    """The warm-start entries of the contact solver (arrays or tuples of arrays over the
    points, leading axis) at the points ``sel``."""
    return {k: (tuple(a[sel] for a in v) if isinstance(v, tuple) else v[sel])
            for k, v in state.items() if not _is_memo(k)}


def _is_memo(key):
    """Keys of the loss model's memo of whole roller sides (losses._memoised): kept for the
    whole batch only."""
    return isinstance(key, tuple) and isinstance(key[0], str) and key[0].startswith("memo")


def _covers(sel, n):
    """Whether the index array ``sel`` lists each of the points 0..n-1 (np.unique would import
    numpy.ma, 15 ms, on its first call)."""
    seen = np.zeros(n, bool)
    seen[sel] = True
    return bool(seen.all())


def _state_update(state, sub, sel, n=None):
    """Write the warm-start entries ``sub`` at the points ``sel`` back into ``state`` (a point
    listed twice keeps its last entry); entries ``state`` lacks are created when ``sel`` covers
    all ``n`` points."""
    for k, v in sub.items():
        if _is_memo(k):
            continue
        old = state.get(k)
        if old is None and n is not None and _covers(sel, n):
            old = state[k] = (tuple(np.empty((n,) + a.shape[1:]) for a in v)
                              if isinstance(v, tuple) else np.empty((n,) + v.shape[1:]))
        if old is None:
            continue
        for o, new in (zip(old, v) if isinstance(v, tuple) else ((old, v),)):
            if o.shape[1:] == new.shape[1:]:
                o[sel] = new


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
    """(c1, c2, cS) with T_shaft = c * T1 by Kreines' rule and the torque balance.

    eta0 [1] basic efficiency, w = +1 where shaft 1 drives in the relative motion (T2 = -i0
    eta0 T1) and -1 where it is driven (T2 = -i0 T1/eta0); a driven ring needs eta0 > 0: at
    eta0 = 0 no torque reaches it (ValueError, naming the points)."""
    eta0 = np.asarray(eta0, float)
    driven = np.asarray(w) <= 0
    if eta0.shape != driven.shape:
        eta0, driven = np.broadcast_arrays(eta0, driven)
    at_driven = np.where(driven, eta0, 1.0)
    if not (at_driven > 0).all():
        bad = driven & ~(eta0 > 0)
        raise ValueError(f"basic efficiency eta0 = {eta0[bad].flat[0]!r} with the ring driven: "
                         "Kreines' rule needs eta0 > 0 there")
    c2 = -i0 * np.where(driven, 1.0 / at_driven, eta0)
    return np.ones(c2.shape), c2, -(1.0 + c2)


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
    drag_torques: dict = None


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
    def gear_torques(self) -> dict:
        """The torques on the gear itself (N*m per shaft): ``torques`` less ``drag_torques``,
        what the outside spends on the drag at the shafts (load-independent losses, design.extra).
        They obey Kreines' rule with eta0 exactly."""
        drag = self.drag_torques or {}
        return {k: v - drag.get(k, 0.0) for k, v in self.torques.items()}

    @property
    def eta_kreines(self) -> np.ndarray:
        """Kreines-formula efficiency of the gear's flow from eta0 (equals eta without drag at
        the shafts, i.e. the paper profile or losses = "load_dependent" and no design.extra;
        a check)."""
        fwd = kreines_efficiency(self.mode, self.eta0, self.i0)
        rev = kreines_efficiency(kinematics.reverse_mode(self.mode), self.eta0, self.i0)
        return np.where(self.flow_forward, fwd, rev)


def _inverse_interpolation(U, G):
    """u at G = 0 of the polynomial through the points (G_j, U_j) (Neville's scheme on the
    inverse function), arrays (m, ...) over the points (the G_j of a point distinct)."""
    P = U
    for k in range(1, U.shape[0]):
        P = (G[:-k] * P[1:] - G[k:] * P[:-1]) / (G[:-k] - G[k:])
    return P[0]


#: rows of the secant's history (see _secant): eta0, f, u, G, T1, then the partial losses
_X, _F, _U, _G, _T1, _L = range(6)
#: the gear's partial losses the fixed point carries: LOSS_NAMES and the calibrated mesh loss
_GEAR_NAMES = LOSS_NAMES + (MESH_LOSS_NAME,)
_ROWS = _L + len(_GEAR_NAMES)


def _secant(evaluate, H, lo, inv, companion=False):
    """Secant iteration (inverse interpolation through the points kept) on the fixed point
    eta0 = f(eta0) per point, from the evaluated points in H: rows eta0, f, u, G, T1 and the
    partial losses LOSS_NAMES (W), points K x n. ``evaluate(eta0, sel)`` gives those rows at
    the points ``sel`` (index array).

    Each point stops when |f - eta0| <= _FIXED_POINT_TOL (the others go on alone); iterates
    stay in the physical range [lo, 1] (f <= 1 always: the losses are not negative), and a
    point whose next iterate would leave it is marked ``stuck`` for the bracketed solver. The
    variable is u = eta0 where shaft 1 drives relatively and u = 1/eta0 where it is driven
    (``inv``): then f is 1 - x or 1/(1 + x), and the loss ratio x = P_L/|T1 w1'| is about
    affine in u (Coulomb losses keep x constant, speed-only losses make it grow as 1/|T1|, and
    |T1| goes as 1/u or as 1/(i0 u - 1) through Kreines' rule), so the secant on
    G(u) = u(f) - u is nearly exact even where the losses rival the power (on g = f - eta0
    it crawled there). Each step interpolates u(G) at G = 0 through the K points kept (K = 2:
    the secant; more: inverse polynomial interpolation, whose order of convergence is nearer
    2), falling back to the secant of the two best where that leaves the range; the new
    point replaces the one of largest |G|. ``companion``: the first step also evaluates
    points _COMPANION_OFFSETS [1] from its estimate (in the same call: a few points cost what
    one does), which then make the history: the next interpolation has three points near
    the root (from start nodes ~0.02 apart the first estimate is off by up to ~3e-5, and the
    next one, through it and the nodes, by ~1e-10, short of _FIXED_POINT_TOL). Returns (the
    rows at each point's evaluation of smallest |f - eta0|, stuck, the points kept (eta0 and
    g, each (K, n)): where g jumps at the root the secant's last points straddle the jump, and
    they narrow the bracket of the solver that takes over)."""
    n = H.shape[2]
    stuck = np.zeros(n, bool)
    active = np.flatnonzero((np.abs(H[_F] - H[_X]) > _FIXED_POINT_TOL).all(0))
    # from the _SECANT_WATCH-th step on (a smooth point has converged by then): the smallest
    # |f - eta0| each point had, and its evaluations in a row without progress
    best_r = strikes = None
    for step_no in range(_FIXED_POINT_MAX):
        if active.size == 0:
            break
        at = slice(None) if active.size == n else active   # all: no index copies
        Ua, Ga = H[_U][:, at], H[_G][:, at]
        inv_a, lo_a = inv[at], lo[at]
        with np.errstate(divide="ignore", invalid="ignore"):
            u2 = _inverse_interpolation(Ua, Ga)
            x2 = np.where(inv_a, 1.0 / u2, u2)
        bad = ~((x2 >= lo_a) & (x2 <= 1.0))
        if bad.any():
            # the secant of the two best points
            o = np.argsort(np.abs(Ga), axis=0)[:2]
            (ub, ua), (gb, ga) = np.take_along_axis(Ua, o, 0), np.take_along_axis(Ga, o, 0)
            denom = gb - ga
            safe = np.abs(denom) > 1e-300
            us = np.where(safe, ub - gb * (ub - ua) / np.where(safe, denom, 1.0), ub + gb)
            u2 = np.where(bad, us, u2)
            x2 = np.where(inv_a, 1.0 / np.where(u2 > 0, u2, np.inf), u2)
            out = ~((x2 >= lo_a) & (x2 <= 1.0))
            if out.any():
                stuck[active[out]] = True
                ok = ~out
                active, x2, lo_a, Ga = active[ok], x2[ok], lo_a[ok], Ga[:, ok]
                if active.size == 0:
                    break
                at = slice(None) if active.size == n else active
        if companion:
            # the estimate and its companions, which then make the history (the points that
            # have converged already keep their best one)
            companion = False
            k = _COMPANION_OFFSETS.size
            xs = x2 + _COMPANION_OFFSETS[:, None]
            xs[1] = np.where(xs[1] >= lo_a, xs[1], x2 + 2 * _COMPANION_OFFSETS[2])
            xs[2] = np.where(xs[2] <= 1.0, xs[2], x2 + 2 * _COMPANION_OFFSETS[1])
            E = evaluate(xs.reshape(-1), np.concatenate((active,) * k))
            best = np.argmin(np.abs(H[_F] - H[_X]), axis=0)
            H = np.repeat(H[:, best, np.arange(n)][:, None], k, 1)
            H[:, :, at] = E.reshape(_ROWS, k, -1)
            active = active[(np.abs(E[_F] - E[_X]) > _FIXED_POINT_TOL).reshape(k, -1).all(0)]
            continue
        # the new point replaces the one of largest |G|
        worst = np.argmax(np.abs(Ga), axis=0)
        if step_no == _SECANT_WATCH:
            best_r, strikes = np.abs(H[_F] - H[_X]).min(0), np.zeros(n, int)
        E = evaluate(x2, active)
        H[:, worst, active] = E
        r = np.abs(E[_F] - E[_X])
        going = r > _FIXED_POINT_TOL
        if best_r is not None:
            # no progress for _SECANT_PATIENCE evaluations in a row: g is not smooth at the
            # root; the bracketed solver takes the point
            gained = r <= _SECANT_PROGRESS * best_r[active]
            strikes[active] = np.where(gained, 0, strikes[active] + 1)
            best_r[active] = np.minimum(best_r[active], r)
            tired = going & (strikes[active] >= _SECANT_PATIENCE)
            if tired.any():
                stuck[active[tired]] = True
                going = going & ~tired
        active = active[going]
    best = np.argmin(np.abs(H[_F] - H[_X]), axis=0)
    return H[:, best, np.arange(n)], stuck, (H[_X], H[_F] - H[_X])


def _regula_falsi(eta0_from, sel, a, ga, gb, x_last, g_last, T1, Ls, converged):
    # (x_last, g_last: the secant's points, (K, points) or (points,))
    """Regula falsi (Illinois) on the bracket (a, 1] with g(a) = ga >= 0 >= g(1) = gb, at the
    points ``sel`` where the secant failed, narrowed first by the secant's last point in range
    (x_last, g_last). Keeps each point's best evaluation (smallest |g|: near the locking pole g
    is steep, so even the float next to the root leaves |g| ~ 1e-12); a point stops when
    |g| <= _FIXED_POINT_TOL and ``converged(f, T1, points)``, or when its bracket is down to
    adjacent floats. Returns (x, f, T1, losses) of the best evaluations; T1 and Ls hold the
    values at a on entry."""
    xs, fs, Ts, gs = a.copy(), ga + a, T1.copy(), ga.copy()
    Ls = [np.array(arr, float) for arr in Ls]
    b = np.ones_like(a)
    for x0, g0 in zip(np.atleast_2d(x_last), np.atleast_2d(g_last)):
        inside = (x0 > a) & (x0 < b)
        up0, down0 = inside & (g0 >= 0), inside & (g0 < 0)
        a, ga = np.where(up0, x0, a), np.where(up0, g0, ga)
        b, gb = np.where(down0, x0, b), np.where(down0, g0, gb)
    live = np.ones(sel.size, bool)
    side = np.zeros(sel.size)   # Illinois: which end was kept last (+1 b, -1 a)
    for _ in range(_BRACKET_MAX):
        if not live.any():
            break
        i = np.flatnonzero(live)
        den = ga[i] - gb[i]
        m = np.where(den != 0, (a[i] * -gb[i] + b[i] * ga[i]) / np.where(den != 0, den, 1.0),
                     0.5 * (a[i] + b[i]))
        m = np.where((m > a[i]) & (m < b[i]), m, 0.5 * (a[i] + b[i]))
        if i.size <= _MULTISECTION_MAX:
            _multisection_step(eta0_from, sel, i, m, a, b, ga, gb, side, xs, fs, Ts, gs, Ls,
                               live, converged)
            continue
        fm, Lm, Tm = eta0_from(m, sel[i])
        gm = fm - m
        better = np.abs(gm) < np.abs(gs[i])
        j = i[better]
        xs[j], fs[j], Ts[j], gs[j] = m[better], fm[better], Tm[better], gm[better]
        for arr, name in zip(Ls, _GEAR_NAMES):
            arr[j] = np.broadcast_to(getattr(Lm, name), m.shape)[better]
        up = gm >= 0
        a[i] = np.where(up, m, a[i])
        b[i] = np.where(up, b[i], m)
        # Illinois: halve the retained end's value when the same end is kept twice
        gb[i] = np.where(up, np.where(side[i] > 0, 0.5 * gb[i], gb[i]), gm)
        ga[i] = np.where(up, gm, np.where(side[i] < 0, 0.5 * ga[i], ga[i]))
        side[i] = np.where(up, 1.0, -1.0)
        done = (np.abs(gm) <= _FIXED_POINT_TOL) & converged(fm, Tm, sel[i])
        live[i] = (gm != 0) & (b[i] - a[i] > _BRACKET_RTOL * b[i]) & ~done
    return xs, fs, Ts, Ls


def _multisection_step(eta0_from, sel, i, m, a, b, ga, gb, side, xs, fs, Ts, gs, Ls, live,
                       converged):
    """One step of ``_regula_falsi`` for the few live brackets ``i`` (arrays updated in
    place): g at the regula falsi's point ``m`` and at _MULTISECTION_POINTS - 1 evenly spaced
    points of each bracket, all in one call; the bracket becomes the sub-interval where g
    first changes sign (g >= 0 at its lower end, < 0 at its upper end, as the bracket's
    invariant), the best evaluation (smallest |g|) is kept, and a bracket stops as in the
    regula falsi. The points of a bracket are listed with ``m`` last, so that the contact
    solver's warm start for the next call is that of the regula falsi's point."""
    k = _MULTISECTION_POINTS
    ni = i.size
    grid = a[i] + (b[i] - a[i]) * (np.arange(1, k) / k)[:, None]          # (k - 1, ni)
    X = np.concatenate([grid, m[None, :]])                               # (k, ni)
    fm, Lm, Tm = eta0_from(X.reshape(-1), np.tile(sel[i], k))
    F, T = fm.reshape(k, ni), Tm.reshape(k, ni)
    G = F - X
    cols = np.arange(ni)
    j = np.argmin(np.abs(G), axis=0)
    gj = G[j, cols]
    better = np.abs(gj) < np.abs(gs[i])
    w = i[better]
    xs[w], fs[w], Ts[w], gs[w] = X[j, cols][better], F[j, cols][better], T[j, cols][better], \
        gj[better]
    for arr, name in zip(Ls, _GEAR_NAMES):
        arr[w] = np.broadcast_to(getattr(Lm, name), (k * ni,)).reshape(k, ni)[j, cols][better]
    # the sub-bracket: the first point (ascending) with g < 0 and the point below it
    order = np.argsort(X, axis=0)
    Xs, Gs = np.take_along_axis(X, order, 0), np.take_along_axis(G, order, 0)
    neg = Gs < 0
    has = neg.any(0)
    first = np.argmax(neg, axis=0)
    below = np.maximum(first - 1, 0)
    lower_a = has & (first > 0)
    b_new = np.where(has, Xs[first, cols], b[i])
    gb_new = np.where(has, Gs[first, cols], gb[i])
    a_new = np.where(lower_a, Xs[below, cols], np.where(has, a[i], Xs[-1]))
    ga_new = np.where(lower_a, Gs[below, cols], np.where(has, ga[i], Gs[-1]))
    a[i], b[i], ga[i], gb[i] = a_new, b_new, ga_new, gb_new
    side[i] = 0.0
    done = ((np.abs(G) <= _FIXED_POINT_TOL)
            & converged(fm, Tm, np.tile(sel[i], k)).reshape(k, ni)).any(0)
    live[i] = ~(G == 0).any(0) & (b[i] - a[i] > _BRACKET_RTOL * b[i]) & ~done


def mesh_loss(eta0_model, x, wdir, mesh_power, k, losses=None):
    r"""The calibrated additional mesh loss: a loss element of efficiency 1 - k in series with
    the mechanism, on its disc side (design ``[calibration] mesh_loss_k``).

    .. math:: \eta_0 = \eta_{0,m} (1 - k)

    in both relative flow directions, with eta0_m the basic efficiency of the modelled losses.
    Where the ring drives (w = +1) the element takes k of the power the mechanism passes on,
    k eta0_m |T1 w1'|; where the disc drives (w = -1) k of the power it receives,
    k (1 + x) |T1 w1'| / (1 - k). The energy balance holds exactly: the gear's loss
    |T1 w1'| (1 - eta0) (w = +1) or |T1 w1'| (1/eta0 - 1) (w = -1) is the modelled losses plus
    this one.

    Parameters
    ----------
    eta0_model : array_like
        Basic efficiency from the modelled losses [1].
    x : array_like
        Modelled gear losses over the relative ring power, P_L / |T1 w1'| [1].
    wdir : array_like
        +1 where the ring drives in the relative motion, -1 where it is driven.
    mesh_power : array_like
        |T1 w1'|, the ring's power in the relative motion [W].
    k : float
        Additional loss fraction [1], 0 <= k < 1.
    losses : PartialLosses, optional
        The modelled partial losses; returned with ``PL_mesh`` set.

    Returns
    -------
    eta0 : ndarray
        eta0_model (1 - k) [1].
    losses : PartialLosses or ndarray
        ``losses`` with PL_mesh [W], or PL_mesh itself without ``losses``.
    """
    from dataclasses import replace as _replace
    eta0_model = np.asarray(eta0_model, float)
    P = np.where(np.asarray(wdir) > 0, k * eta0_model, k / (1.0 - k) * (1.0 + np.asarray(x))) \
        * mesh_power
    eta0 = eta0_model * (1.0 - k)
    return eta0, (P if losses is None else _replace(losses, PL_mesh=P))


def scale_load_losses(losses, scale):
    r"""The calibrated friction level of the whole gear: the load-dependent partial losses
    PL1..PL6 (every sliding and rolling contact of the mechanism) times ``scale`` (design
    ``[calibration] load_loss_scale``).

    .. math:: P_{Li}' = s \, P_{Li}, \quad i = 1, 2, 3, 5, 6

    Applied inside the fixed point of :func:`operating_point` (the losses enter Kreines' rule
    through eta0 = 1 - sum P_Li / P_mesh, or 1 / (1 + ...) when the ring is driven), so the
    contact forces, the torques, self-locking and back-driving follow the scaled losses and the
    energy balance P_in = P_out + P_loss holds exactly. Not scaled: the calibrated mesh-power
    loss PL_mesh (``mesh_loss_k``, applied after, an additive fraction of the mesh power) and
    the load-independent losses (``idle_loss_scale``). Unlike ``mesh_loss_k``, a scale keeps
    the model's own variation of the losses over the operating points (speed, load, film
    regime), so the two separate where the efficiency changes across the recording.

    Parameters
    ----------
    losses : PartialLosses
        The modelled partial losses, W.
    scale : float
        The scale s, 1 (0 to 10, ``design.LOAD_LOSS_SCALE_BOUNDS``).

    Returns
    -------
    PartialLosses
        ``losses`` with PL1..PL6 times ``scale`` (the other fields unchanged).
    """
    from dataclasses import replace as _replace
    return _replace(losses, **{n: scale * np.asarray(getattr(losses, n)) for n in LOSS_NAMES})


def shaft_drag(design, speeds, shape=()):
    """The load-independent drag at the shafts (physical profile, losses = "all").

    The support bearings, seals and grease drag (``model_core.drag``) act on the shafts, not
    on the mesh, so they stay outside Kreines' rule: folded into eta0 they would make it
    meaningless at light load, where they exceed the power the gear transmits (a real drive
    then still needs its no-load running torque).

    Parameters
    ----------
    design : DriveDesign
    speeds : dict
        Shaft speeds {"1", "2", "S": rad/s}.
    shape : tuple
        Shape to broadcast the results to.

    Returns
    -------
    T_drag : dict
        Torque the outside spends on the drag at each shaft, N*m (zeros without such losses).
    idle : dict
        The load-independent partial losses (W) keyed ``drag.IDLE_NAMES`` (empty without).
    """
    if design.profile == "physical" and design.losses == "all":
        from . import drag, thermal
        idle_t = drag.idle_torques(design, speeds, thermal.lubricant_viscosity(design))
        scale = design.calibration.idle_loss_scale
        if scale != 1.0:   # calibrated (design [calibration] idle_loss_scale)
            idle_t = {name: {x: scale * v for x, v in t.items()} for name, t in idle_t.items()}

        def shaped(v):   # (np.broadcast_to costs more than the sums where it changes nothing)
            return v if np.shape(v) == shape else np.broadcast_to(v, shape)
        idle = {name: shaped(t["1"] * speeds["1"] + t["2"] * speeds["2"] + t["S"] * speeds["S"])
                for name, t in idle_t.items()}
        T_drag = {x: shaped(sum(t[x] for t in idle_t.values())) for x in "12S"}
        return T_drag, idle
    return {x: np.zeros(shape) for x in "12S"}, {}


def operating_point(design, mode: str, w_in, T_in=None, *, T_out=None,
                    dedup=True) -> OperatingPoint:
    """Solve the drive at driving-shaft speed w_in (rad/s, signed) and one known torque:
    T_in, the torque delivered into the driving shaft, or T_out, the torque the load applies on
    the driven shaft (both as applied by the outside; N*m, signed). Arrays broadcast (maps).

    Every point is solved on its own (a point in a map gives what it gives alone, to ~1e-12):
    the fixed point in eta0 by a secant iteration per point, stopped per point, with a
    regula falsi on (lo, 1] where the secant fails. ``dedup=False``: the losses by the
    straightforward per-position path (losses.partial_losses), the reference of the fast one."""
    a, b, h = kinematics.parse_mode(mode)
    if (T_in is None) == (T_out is None):
        raise CycloidInputError("torque", None, "give exactly one of T_in and T_out")
    known = a if T_out is None else b
    w_in, T_known = np.broadcast_arrays(np.asarray(w_in, float),
                                     np.asarray(T_in if T_out is None else T_out, float))
    if not np.isfinite(w_in).all():
        raise CycloidInputError("speed", w_in[~np.isfinite(w_in)].flat[0], "must be finite")
    if not np.isfinite(T_known).all():
        raise CycloidInputError("torque", T_known[~np.isfinite(T_known)].flat[0], "must be finite")
    if (w_in == 0).any():
        raise CycloidInputError("speed", 0.0, "zero input speed gives no direction of motion "
                                "(the efficiency is undefined at standstill)")
    i0 = design.i0
    w = kinematics.shaft_speeds(mode, w_in, design.z1)
    # drag at the shafts, outside the gear (load-independent losses; physics beyond the paper,
    # design.extra: a drag/Stribeck torque at the driving shaft): the gear itself sees the
    # known torque less the drag on its shaft
    T_extra = design.extra.steady_torque(w_in)
    T_drag, idle = shaft_drag(design, w, T_known.shape)
    T_drag[a] = T_drag[a] + T_extra
    T_known = T_known - T_drag[known]
    w1p, w2p = kinematics.relative_speeds(w["1"], w["2"], w["S"])
    idx = {"1": 0, "2": 1, "S": 2}
    # the solver works on flat arrays of the points (subsets of them are iterated on their own)
    shape = T_known.shape
    T_flat, w1p_f = T_known.reshape(-1), np.broadcast_to(w1p, shape).reshape(-1)
    w2p_f = np.broadcast_to(w2p, shape).reshape(-1)
    # direction of the relative power flow from the frictionless torques
    c_free = torque_coefficients(1.0, 1.0, i0)
    T1_free = T_flat / c_free[idx[known]]
    wdir = np.where(T1_free * w1p_f >= 0, 1.0, -1.0)
    base = np.abs(w1p_f)
    physical = design.profile == "physical"
    # the physical range of eta0 searched: (lo, 1]; with the known torque on S and shaft 2
    # driving relatively (w = -1), T1 = T_S/(i0/eta0 - 1) has a pole at the locking limit
    # eta0 = i0, so such points are searched above it (below, they are locked)
    lo = np.where((wdir < 0) & (known == "S"), i0 * (1 + 1e-9), _ETA0_FLOOR)

    def guarded(eta0, wd):
        if known != "S":
            return eta0
        return np.where(wd < 0, np.maximum(eta0, i0 * (1 + 1e-9)), eta0)

    state = {}   # warm start of the contact solutions between iterations
    k_mesh = design.calibration.mesh_loss_k   # calibrated additional mesh loss (0: none)
    s_load = design.calibration.load_loss_scale   # calibrated friction level (1: as derived)

    def eta0_from(eta0, sel=None):
        """f(eta0): the basic efficiency the losses give at the ring torque that eta0 implies,
        at the points ``sel`` (index array; None: all). Returns (f, losses, T1)."""
        full = sel is None or sel.size == T_flat.size
        pick = (lambda v: v) if full else (lambda v: v[sel])
        wd = pick(wdir)
        c = torque_coefficients(guarded(eta0, wd), wd, i0)[idx[known]]
        T1 = pick(T_flat) / c
        # physical profile: friction in the force balance. The gear's torque balance with its
        # losses makes the disc side carry |T2| = i0 eta0^w |T1| (less than the ring side's
        # frictionless share when the ring drives, more when the disc drives), so the disc
        # rollers' and the eccentric bearing's forces follow the power-flow direction
        # (with the torque known on shaft 2 that is |T2| itself, the same in every iteration)
        if not physical:
            Td = None
        elif known == "2":
            Td = np.abs(pick(T_flat))
        else:
            Td = np.abs(T1) * i0 * np.where(wd > 0, eta0, 1.0 / np.maximum(eta0, 1e-3))
        sub = state if full else _state_subset(state, sel)
        L = partial_losses(design, np.abs(T1), pick(w2p_f), state=sub, disc_torque=Td,
                           ring_flow=wd if physical else None, dedup=dedup)
        if not full:
            _state_update(state, sub, sel, T_flat.size)
        if s_load != 1.0:   # calibrated friction level of the whole gear (load_loss_scale)
            L = scale_load_losses(L, s_load)
        num = L.total
        x = np.divide(num, np.abs(T1) * pick(base), out=np.zeros_like(num), where=T1 != 0)
        f = np.where(wd > 0, 1.0 - x, 1.0 / (1.0 + x))
        if k_mesh:
            f, L = mesh_loss(f, x, wd, np.abs(T1) * pick(base), k_mesh, L)
        return f, L, T1

    # the secant on the fixed point eta0 = f(eta0) (_secant), started from the frictionless
    # point; u = 1/eta0 where the ring is driven relatively
    inv = wdir < 0
    n = T_flat.size

    def evaluate(eta0, sel=None):
        """The rows of _secant's history at the points eta0 (at the points ``sel``)."""
        f, L, T1 = eta0_from(eta0, sel)
        iv = inv if sel is None else inv[sel]
        E = np.empty((_ROWS, eta0.size))
        E[_X], E[_F], E[_T1] = eta0, f, T1
        E[_U] = np.where(iv, 1.0 / eta0, eta0)
        E[_G] = np.where(iv, 1.0 / f, f) - E[_U]
        E[_L:-1] = [getattr(L, k) for k in LOSS_NAMES]
        E[-1] = L.PL_mesh   # (a scalar 0 uncalibrated)
        return E

    if n <= _PAIR_START_MAX:
        # a few points cost what one does (numpy's per-call overhead): evaluate the secant's
        # first points together, the frictionless one and _START_NODES below it (within
        # (lo, 1]), and interpolate through them
        K = 1 + len(_START_NODES)
        X = np.empty((K, n))
        X[0] = 1.0
        X[1:] = np.where(_START_NODES_COL > lo, _START_NODES_COL,
                         1.0 - (1.0 - lo) * _START_FRACTIONS[:, None])
        H = evaluate(X.reshape(-1), np.concatenate((np.arange(n),) * K)).reshape(_ROWS, K, n)
    else:
        E0 = evaluate(np.ones_like(T_flat))
        H = np.stack([E0, evaluate(np.clip(E0[_F], lo, 1.0))], axis=1)
    g_one = H[_F, 0] - 1.0                       # g(1) <= 0: the upper end of every bracket
    h, stuck, (x_kept, g_kept) = _secant(evaluate, H, lo, inv, companion=n <= _PAIR_START_MAX)
    x1, f1, T1 = h[_X], h[_F], h[_T1]
    g1 = f1 - x1
    L = list(h[_L:])

    def reproduced(eta0, T1, sel):
        wd = wdir[sel]
        c_k = torque_coefficients(guarded(eta0, wd), wd, i0)[idx[known]]
        return np.abs(T1 * c_k - T_flat[sel]) <= 1e-7 * np.abs(T_flat[sel]) + 1e-300

    allp = np.arange(T_flat.size)
    ok = (~stuck & (np.abs(g1) <= 10 * _FIXED_POINT_TOL) & (f1 > lo) & (f1 <= 1)
          & reproduced(f1, T1, allp))
    solvable = np.ones_like(ok)
    bad = np.flatnonzero(~ok)
    if bad.size:
        # the secant can fail where the losses rival the power (very light load) or run into
        # the locking pole; such points are solved again on the bracket (lo, 1], where
        # g(1) <= 0, by regula falsi (Illinois); no root above lo where g(lo) < 0
        lo_b = lo[bad]
        x_last, g_last = x_kept, g_kept
        f_lo, L_lo, T1_lo = eta0_from(lo_b, bad)
        g_lo = f_lo - lo_b
        solvable[bad] = g_lo >= 0
        # without a steady solution: the values at the bracket's lower end (torques and losses
        # are reported NaN below, eta0 is the basic efficiency the losses give there)
        x1[bad], f1[bad], T1[bad] = lo_b, f_lo, T1_lo
        for arr, name in zip(L, _GEAR_NAMES):
            arr[bad] = getattr(L_lo, name)
        keep = g_lo >= 0
        bad = bad[keep]
        if bad.size:
            def converged(fm, Tm, sel):
                # converged as the secant's points are, with the known torque reproduced to
                # 1e-10 (near the locking pole only adjacent floats get there)
                wd = wdir[sel]
                c_k = torque_coefficients(guarded(fm, wd), wd, i0)[idx[known]]
                return np.abs(Tm * c_k - T_flat[sel]) <= 1e-10 * np.abs(T_flat[sel])

            xs, fs, Ts, Ls = _regula_falsi(
                eta0_from, bad, lo_b[keep], g_lo[keep], g_one[bad], x_last[:, bad],
                g_last[:, bad], T1[bad], [arr[bad] for arr in L], converged)
            x1[bad], f1[bad], T1[bad] = xs, fs, Ts
            for arr, ls in zip(L, Ls):
                arr[bad] = ls
    L = PartialLosses(**{name: arr.reshape(shape) for name, arr in zip(_GEAR_NAMES, L)})
    f1, T1, solvable = f1.reshape(shape), T1.reshape(shape), solvable.reshape(shape)
    wdir = wdir.reshape(shape)

    def guarded_full(eta0):
        return guarded(eta0, wdir)
    eta0 = f1   # consistent with the losses L evaluated at T1
    c = torque_coefficients(guarded_full(eta0), wdir, i0)
    # all torques from T1 and eta0, so that Kreines' rule and the energy balance hold exactly;
    # the known torque is reproduced to the fixed-point tolerance (checked to 1e-7 in ``ok``)
    torques = {"1": T1 * c[0], "2": T1 * c[1], "S": T1 * c[2]}
    forward = (T_known * w[a] >= 0) if known == a else (T_known * w[b] <= 0)
    flow_into_S = np.where(forward, b == "S", a == "S")
    # self-locking: power flowing into S from 1 or 2 with eta0 <= i0 (Kreines formula <= 0)
    locked = flow_into_S & ((eta0 <= i0) | ~solvable)
    # no steady solution at all (locked with the torque given on S, or losses above the power)
    undefined = ~solvable | (locked & (known == "S"))
    if undefined.any():
        def blank(v):
            return np.where(undefined, np.nan, v)
    else:
        def blank(v):
            return np.array(v, float)
    # the gear's torques plus what the outside spends on the shafts' drag
    torques = {k: blank(v) + T_drag[k] for k, v in torques.items()}
    L = PartialLosses(*(blank(getattr(L, n)) for n in LOSS_NAMES), PL_mesh=blank(L.PL_mesh),
                      P_extra=blank(T_extra * w[a]), **{k: blank(v) for k, v in idle.items()})
    p_a, p_b = torques[a] * w[a], torques[b] * w[b]
    p_in = np.where(forward, p_a, p_b)
    p_out = -np.where(forward, p_b, p_a)
    with np.errstate(divide="ignore", invalid="ignore"):
        eta = np.where(locked | undefined | ~(p_in > 0), np.nan, 1.0 - L.total / p_in)
        eta = np.where(eta > 0, eta, np.nan)
    return OperatingPoint(mode=a + b, flow_forward=forward, speeds=w, torques=torques, eta=eta,
                          eta0=eta0, locked=locked, losses=L, input_power=p_in,
                          output_power=p_out, i0=i0,
                          drag_torques={k: np.array(v, float) for k, v in T_drag.items()})
