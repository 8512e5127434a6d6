"""A precomputed efficiency map of one operating mode, for time-stepping hosts (FMUs).

``ModeMap`` solves the full model (efficiency.operating_point, contacts and mesh-cycle average
included) once, on a log-spaced grid of the gear's load torque |tau| x driving speed |w_in|,
for both power-flow directions, and stores the basic efficiency eta0 and the shares of the
gear's partial losses; the load-independent drag at the shafts (efficiency.shaft_drag: support
bearings, seals, grease drag; physical profile) is stored over the speed alone, as the torque
the outside spends on it at each shaft and the three losses over |w_in|. A step then costs one
bilinear interpolation in plain Python floats (a numpy call per step would cost more than the
rest of the step): eta0 gives the gear's torques by Kreines' rule and the drag adds its own, so
the energy balance tau_in w_in + tau_out w_out = P_loss holds exactly at every step, and the
interpolation error only enters through eta0 and the drag.
"""
from __future__ import annotations

import math
from bisect import bisect_right

import numpy as np

from . import kinematics
from .efficiency import operating_point, shaft_drag
from .drag import IDLE_NAMES
from .losses import LOSS_NAMES, MESH_LOSS_NAME

#: the partial losses a map carries: the load-dependent ones, the load-independent ones, then
#: the calibrated additional mesh loss (design [calibration] mesh_loss_k; zero uncalibrated)
MAP_LOSS_NAMES = LOSS_NAMES + IDLE_NAMES + (MESH_LOSS_NAME,)

#: version of the map's layout (the drag at the shafts kept over the speed alone: 2; the
#: calibrated mesh loss's share as the table's last column: 3)
MAP_LAYOUT = 3

_SHAFT_INDEX = {"1": 0, "2": 1, "S": 2}
_N_GEAR = len(LOSS_NAMES)
_N_IDLE = len(IDLE_NAMES)
# ModeMap.solve writes its rows out: eta0, five shares and the mesh loss's share, three
# losses and three drags
if (_N_GEAR, _N_IDLE) != (5, 3):
    raise ImportError("lossmap.ModeMap.solve is written for 5 load-dependent and 3 "
                      "load-independent partial losses")


def grid_cell(g, x, nodes=False):
    """The cell of the increasing grid ``g`` each ``x`` lies in, ``np.clip(np.searchsorted(g,
    x, side="right") - 1, 0, len(g) - 2)``: for a grid of equal steps (the maps' log grids)
    from the step, checked (the cell is the only i with g[i] <= x < g[i + 1], the outer cells
    open outwards) and where rounding put a value in a neighbour moved by one node;
    ``searchsorted`` itself where a value is not placed so (a NaN, a grid of unequal steps).
    The same indices, a third of the time of a binary search per value (a replay looks up
    every sample's torque). ``nodes``: return (i, g[i], g[i + 1])."""
    n = len(g)
    i = None
    if n > 2:
        step = (g[-1] - g[0]) / (n - 1)
        with np.errstate(invalid="ignore"):
            k = np.floor((x - g[0]) / step)
        np.fmin(np.fmax(k, 0, out=k), n - 2, out=k)        # (a NaN to 0: checked below)
        i = k.astype(np.intp)
        for again in (True, False):
            lo, hi = g.take(i), g.take(i + 1)
            below, above = (lo <= x) | (i == 0), (x < hi) | (i == n - 2)
            if np.all(below & above):
                break
            if not again:
                i = None
                break
            i = i - ~below + ~above                          # (one node either way)
            np.clip(i, 0, n - 2, out=i)
    if i is None:
        i = np.clip(np.searchsorted(g, x, side="right") - 1, 0, n - 2)
        lo, hi = g[i], g[i + 1]
    return (i, lo, hi) if nodes else i


class ModeMap:
    """eta0 and loss shares of one mode over |tau| x |w_in|, both flow directions, and the
    drag at the shafts over |w_in|.

    The torque axis is the gear's own torque at the driven shaft, tau_out less the torque the
    driven shaft's drag takes (the same thing without load-independent losses). Bilinear in
    (ln |tau|, ln |w_in|), clamped at the grid edges; ``out_of_range`` counts the clamped
    look-ups (below the grid the gear's loss shares and eta0 of the edge are used; at zero
    speed or torque the gear's losses vanish with its power, the drag with the speed).
    ``dedup=False`` builds it by the straightforward per-position path of the losses (the
    reference; same tables to ~1e-12).
    """

    #: torque nodes: 36. They were 48 while the load-independent losses were folded into eta0
    #: and made it curve as 1/|tau| at light load; with them as drag at the shafts (kept over
    #: the speed alone) 36 leave the map's error where 48 did: against the core at 300 random
    #: points of the bench's envelope (500-2800 r/min, 0.1-0.85 N*m, both signs), worst
    #: 0.052/0.067 points of eta for the paper profile S1/S2 (48: 0.059/0.060) and
    #: 0.101/0.119 for the physical one (48: 0.096/0.113), set by the speed axis and the
    #: kinks of roll or skid; the build takes a quarter less
    def __init__(self, design, mode, torque_max, speed_max, n_torque=36, n_speed=28, span=1e-3,
                 dedup=True):
        if not (torque_max > 0 and speed_max > 0):
            raise ValueError("the map needs positive torque and speed ranges")
        self.a, self.b, self.h = kinematics.parse_mode(mode)
        self.mode = self.a + self.b
        self.i0 = design.i0
        unit = kinematics.shaft_speeds(self.mode, 1.0, design.z1)
        self.ratio = (float(unit["1"]), float(unit["2"]), float(unit["S"]))
        self._k = _SHAFT_INDEX[self.b]
        T = np.geomspace(torque_max * span, torque_max, n_torque)
        W = np.geomspace(speed_max * span, speed_max, n_speed)
        WW, TT = np.meshgrid(W, T, indexing="ij")
        sign_b = math.copysign(1.0, self.ratio[self._k])
        # the drag at the shafts over the speed (w_in > 0; it is odd in w_in): the three
        # load-independent losses over w_in (N*m, smooth in ln w) and the torque the outside
        # spends on it at shafts 1, 2, S; sum_x D_x r_x = sum of the three, so the energy
        # balance survives the interpolation
        T_drag, idle = shaft_drag(design, kinematics.shaft_speeds(self.mode, W, design.z1),
                                  W.shape)
        idle_rows = [idle.get(n, np.zeros(W.shape)) / W for n in IDLE_NAMES]
        idle_rows += [T_drag[x] for x in "12S"]
        self._idle = np.stack(idle_rows, -1).tolist()       # [j_speed][0..2 losses/w, 3..5 D]
        D_b = np.broadcast_to(T_drag[self.b][:, None], WW.shape)
        self._tables = {}
        self._wdir = {}
        for forward in (True, False):
            # forward: the gear's load absorbs power, tau * w_out < 0; the outside applies the
            # gear's torque plus what the driven shaft's drag takes
            op = operating_point(design, self.mode, WW,
                                 T_out=(-sign_b if forward else sign_b) * TT + D_b, dedup=dedup)
            shares = np.stack([np.broadcast_to(getattr(op.losses, n), WW.shape)
                               for n in LOSS_NAMES + (MESH_LOSS_NAME,)], -1)
            # shares of the gear's PL1..PL6 and PL_mesh: they sum to its loss, which eta0
            # carries exactly
            shares = shares / np.maximum(shares.sum(-1, keepdims=True), 1e-300)
            table = np.concatenate([op.eta0[..., None], shares], -1)
            # below the lightest load that runs (the gear's losses above its power, or locked
            # with the torque on S) hold the values of the lightest running load along the
            # torque axis
            valid = np.isfinite(table).all(-1) & (table[..., 0] > 0)
            if not valid.any():
                raise ValueError(f"mode {self.mode}: no operating point of the map runs")
            for j in range(table.shape[0]):
                good = np.flatnonzero(valid[j])
                src = good if good.size else np.flatnonzero(valid.any(0))
                ref = table[j] if good.size else table[valid.any(1)][0]
                idx = np.clip(np.searchsorted(src, np.arange(table.shape[1])), 0, src.size - 1)
                table[j] = np.where(valid[j][:, None], table[j], ref[src[idx]])
            self._tables[forward] = table.tolist()   # [j_speed][i_torque][0: eta0, 1..6: shares]
            self._arrays = getattr(self, "_arrays", {})
            self._arrays[forward] = table
            w1p = (self.ratio[0] - self.ratio[2]) * WW
            # the relative flow direction follows from the known torque's sign alone: read it at
            # a point that runs
            p1 = (op.gear_torques["1"] * w1p)[valid]
            self._wdir[forward] = 1 if float(p1.flat[0]) >= 0 else -1
        self._idle_array = np.asarray(self._idle)
        self._w_low = float(W[0])
        self._lt = [math.log(t) for t in T]
        self._lw = [math.log(w) for w in W]
        self.torque_range = (float(T[0]), float(T[-1]))
        self.speed_range = (float(W[0]), float(W[-1]))
        self.names = MAP_LOSS_NAMES
        self.out_of_range = 0

    def _locate_speed(self, w):
        """Index j and weight fw of |w_in| = w on the speed grid (linear in ln w, clamped at
        both ends of the grid), shared by the drag row and the table."""
        gw = self._lw
        lw = math.log(w) if w > 0 else gw[0]
        if lw > gw[-1]:
            lw = gw[-1]
        elif lw < gw[0]:
            lw = gw[0]
        j = bisect_right(gw, lw) - 1
        if j > len(gw) - 2:
            j = len(gw) - 2
        return j, (lw - gw[j]) / (gw[j + 1] - gw[j])

    def _interp_speed(self, w, j, fw):
        """The drag row at |w_in| = w (j, fw from ``_locate_speed``): linear in ln w, clamped
        at the top of the grid; below its lowest speed proportional to w (the drag's torque is
        linear in the speed near a standstill, drag.DRAG_SIGN_SPEED, and so are the losses over
        w). Written out for the row's six entries (a comprehension costs more than the sums)."""
        if w < self._w_low:
            s = w / self._w_low
            a = self._idle[0]
            return (a[0] * s, a[1] * s, a[2] * s, a[3] * s, a[4] * s, a[5] * s)
        a, b = self._idle[j], self._idle[j + 1]
        g = 1 - fw
        return (g * a[0] + fw * b[0], g * a[1] + fw * b[1], g * a[2] + fw * b[2],
                g * a[3] + fw * b[3], g * a[4] + fw * b[4], g * a[5] + fw * b[5])

    def _interp(self, table, t, w, j, fw):
        """Bilinear in (ln t, ln w) of the table's seven columns (eta0 and the six shares), at
        the speed located by ``_locate_speed``; clamped at the grid's edges, counted in
        ``out_of_range`` where t or w lies beyond them."""
        gt, gw = self._lt, self._lw
        lt = math.log(t) if t > 0 else gt[0]
        if lt < gt[0] or lt > gt[-1] or (w > 0 and not gw[0] <= math.log(w) <= gw[-1]):
            if t > 0 and w > 0:
                self.out_of_range += 1
            lt = min(max(lt, gt[0]), gt[-1])
        i = bisect_right(gt, lt) - 1
        if i > len(gt) - 2:
            i = len(gt) - 2
        ft = (lt - gt[i]) / (gt[i + 1] - gt[i])
        row0, row1 = table[j], table[j + 1]
        p, q, r, z = row0[i], row0[i + 1], row1[i], row1[i + 1]
        u, v = (1 - fw) * (1 - ft), (1 - fw) * ft
        x, y = fw * (1 - ft), fw * ft
        return (u * p[0] + v * q[0] + x * r[0] + y * z[0],
                u * p[1] + v * q[1] + x * r[1] + y * z[1],
                u * p[2] + v * q[2] + x * r[2] + y * z[2],
                u * p[3] + v * q[3] + x * r[3] + y * z[3],
                u * p[4] + v * q[4] + x * r[4] + y * z[4],
                u * p[5] + v * q[5] + x * r[5] + y * z[5],
                u * p[6] + v * q[6] + x * r[6] + y * z[6])

    def solve(self, w_in: float, tau_out: float):
        """Steady state at driving speed w_in (rad/s) and load torque tau_out (N*m, applied by
        the load on the driven shaft). Returns (speeds, torques, losses, eta, eta0, locked,
        forward): speeds and torques as tuples over shafts (1, 2, S), losses a list in
        MAP_LOSS_NAMES order (W), eta the efficiency of the actual flow (0 without power or when
        locked), forward the gear's flow direction."""
        r1, r2, rS = self.ratio
        speeds = (r1 * w_in, r2 * w_in, rS * w_in)
        k = self._k
        w_abs = abs(w_in)
        j, fw = self._locate_speed(w_abs)
        q = self._interp_speed(w_abs, j, fw)
        sgn = 1.0 if w_in > 0 else (-1.0 if w_in < 0 else 0.0)
        drag = (sgn * q[3], sgn * q[4], sgn * q[5])
        tau = tau_out - drag[k]                 # the gear's own torque at the driven shaft
        forward = tau * speeds[k] <= 0
        row = self._interp(self._tables[forward], abs(tau), w_abs, j, fw)
        eta0 = row[0]
        wdir = self._wdir[forward]
        if wdir > 0:
            e = eta0
        elif k == 2:   # the known torque is on S: keep 1 - i0/eta0 off zero (locking pole)
            e = 1.0 / max(eta0, self.i0 * (1 + 1e-9))
        else:
            e = 1.0 / eta0
        c2 = -self.i0 * e
        c = (1.0, c2, -(1.0 + c2))
        T1 = tau / c[k]
        gear = (T1, T1 * c2, T1 * c[2])
        p_gear = gear[0] * speeds[0] + gear[1] * speeds[1] + gear[2] * speeds[2]
        losses = [row[1] * p_gear, row[2] * p_gear, row[3] * p_gear, row[4] * p_gear,
                  row[5] * p_gear, q[0] * w_abs, q[1] * w_abs, q[2] * w_abs, row[6] * p_gear]
        torques = (gear[0] + drag[0], gear[1] + drag[1], gear[2] + drag[2])
        a = _SHAFT_INDEX[self.a]
        p_a, p_b = torques[a] * speeds[a], torques[k] * speeds[k]
        p_in, p_out = (p_a, -p_b) if forward else (p_b, -p_a)
        # Kreines: only power flowing into S from 1 or 2 can lock, when eta0 <= i0
        flow = self.mode if forward else self.b + self.a
        locked = flow[1] == "S" and eta0 <= self.i0
        eta = p_out / p_in if (p_in > 0 and p_out > 0 and not locked) else 0.0
        return speeds, torques, losses, eta, eta0, locked, forward

    def solve_arrays(self, w_in, tau_out):
        """Vectorised ``solve`` for recordings: arrays of driving speed (rad/s) and load torque
        (N*m). Returns dict with speeds ``w_out``, torques ``tau_in``, ``tau_housing``,
        ``P_loss`` (W), ``eta0`` and ``forward`` (bool)."""
        w_in = np.asarray(w_in, float)
        tau_out = np.asarray(tau_out, float)
        r = self.ratio
        k = self._k
        speeds = [ri * w_in for ri in r]
        gt, gw = np.asarray(self._lt), np.asarray(self._lw)
        with np.errstate(divide="ignore"):
            lw = np.clip(np.log(np.abs(w_in)), gw[0], gw[-1])
        j = np.clip(np.searchsorted(gw, lw, side="right") - 1, 0, len(gw) - 2)
        fw = (lw - gw[j]) / (gw[j + 1] - gw[j])
        q = (1 - fw)[..., None] * self._idle_array[j] + fw[..., None] * self._idle_array[j + 1]
        # below the grid's lowest speed: proportional to the speed (see _interp_speed)
        low = np.minimum(np.abs(w_in) / self._w_low, 1.0)
        q = np.where((np.abs(w_in) < self._w_low)[..., None], self._idle_array[0] * low[..., None],
                     q)
        sgn = np.sign(w_in)
        drag = [sgn * q[..., 3 + x] for x in range(3)]
        tau = tau_out - drag[k]
        forward = tau * speeds[k] <= 0
        with np.errstate(divide="ignore"):
            lt = np.clip(np.log(np.abs(tau)), gt[0], gt[-1])
        i = np.clip(np.searchsorted(gt, lt, side="right") - 1, 0, len(gt) - 2)
        ft = (lt - gt[i]) / (gt[i + 1] - gt[i])
        eta0 = np.empty_like(w_in)
        for fwd in (True, False):
            tab = self._arrays[fwd][..., 0]
            sel = forward == fwd
            a, b = tab[j, i], tab[j, i + 1]
            c, d = tab[j + 1, i], tab[j + 1, i + 1]
            val = (1 - fw) * ((1 - ft) * a + ft * b) + fw * ((1 - ft) * c + ft * d)
            eta0 = np.where(sel, val, eta0)
        wdir = np.where(forward, self._wdir[True], self._wdir[False])
        e = np.where(wdir > 0, eta0, 1.0 / np.maximum(eta0, self.i0 * (1 + 1e-9))
                     if k == 2 else 1.0 / eta0)
        c2 = -self.i0 * e
        c = (np.ones_like(c2), c2, -(1.0 + c2))
        T1 = tau / c[k]
        torques = [T1 * ci + di for ci, di in zip(c, drag)]
        p_loss = sum(t * w for t, w in zip(torques, speeds))
        a_ = _SHAFT_INDEX[self.a]
        h_ = _SHAFT_INDEX[self.h]
        return {"w_out": speeds[k], "tau_in": torques[a_], "tau_housing": torques[h_],
                "P_loss": p_loss, "eta0": eta0, "forward": forward}


    def locate_speeds(self, w_in):
        """Where the driving speeds ``w_in`` (rad/s, array) lie on the map's speed grid: the
        part of :meth:`input_torque_arrays` that depends on the speed alone (maps with the same
        speed grid share it). Returns ``(j, fw, low, sgn)``: grid index, weight, the factor
        below the grid's lowest speed (``None`` where no speed lies below it) and sign(w_in)."""
        w_in = np.asarray(w_in, float)
        gw = np.asarray(self._lw)
        aw = np.abs(w_in)
        with np.errstate(divide="ignore"):
            lw = np.clip(np.log(aw), gw[0], gw[-1])
        j, g0, g1 = grid_cell(gw, lw, nodes=True)
        fw = (lw - g0) / (g1 - g0)
        below = aw < self._w_low
        low = (below, np.minimum(aw[below] / self._w_low, 1.0)) if below.any() else None
        return j, fw, low, np.sign(w_in)

    def same_speed_grid(self, other) -> bool:
        """True when ``other`` has this map's speed grid (``locate_speeds`` can be shared)."""
        return self._lw == other._lw and self._w_low == other._w_low

    def input_torque_arrays(self, w_in, tau_out, located=None, load_loss=False):
        """The input torque of :meth:`solve_arrays` alone (N*m; the same arithmetic, element
        by element, so the same numbers), for replays of long recordings: only the two drag
        columns and the basic efficiency it needs are interpolated, each flow direction's
        table is read at its own samples. ``located``: ``locate_speeds(w_in)`` of this map or
        of one with the same speed grid. ``load_loss``: return (tau_in, T_load) with T_load the
        gear's load-dependent loss torque at the driving shaft (:func:`load_loss_torque` of
        the partial losses PL1..PL6 that :meth:`solve` reports)."""
        w_in = np.asarray(w_in, float)
        tau_out = np.asarray(tau_out, float)
        j, fw, low, sgn = located if located is not None else self.locate_speeds(w_in)
        k = self._k
        a_ = _SHAFT_INDEX[self.a]
        idle = self._idle_array
        g = 1 - fw

        def drag(x):       # sgn * q[..., 3 + x] of solve_arrays
            col = idle[:, 3 + x]
            q = g * col.take(j) + fw * col.take(j + 1)
            if low is not None:
                q[low[0]] = col[0] * low[1]
            return sgn * q
        d_k = drag(k)
        d_a = d_k if a_ == k else drag(a_)
        tau = tau_out - d_k
        forward = tau * (self.ratio[k] * w_in) <= 0
        gt = np.asarray(self._lt)
        with np.errstate(divide="ignore"):
            lt = np.clip(np.log(np.abs(tau)), gt[0], gt[-1])
        i, g0, g1 = grid_cell(gt, lt, nodes=True)
        ft = (lt - g0) / (g1 - g0)
        # both directions' eta0 tables stacked: one gather per corner
        tabs = getattr(self, "_eta0_stack", None)
        if tabs is None:
            tabs = self._eta0_stack = np.stack(
                [self._arrays[False][..., 0], self._arrays[True][..., 0]]).ravel()
        nw, nt = self._arrays[True].shape[:2]
        flat = forward * (nw * nt) + j * nt + i
        h = 1 - ft
        eta0 = g * (h * tabs.take(flat) + ft * tabs.take(flat + 1)) \
            + fw * (h * tabs.take(flat + nt) + ft * tabs.take(flat + nt + 1))
        wf, wb = self._wdir[True], self._wdir[False]
        if wf > 0 and wb > 0:
            e = eta0
        else:
            inv = 1.0 / np.maximum(eta0, self.i0 * (1 + 1e-9)) if k == 2 else 1.0 / eta0
            e = inv if (wf <= 0 and wb <= 0) else np.where(
                np.where(forward, wf, wb) > 0, eta0, inv)
        c2 = -self.i0 * e
        c = (1.0, c2, -(1.0 + c2))
        T1 = tau / c[k] if k else tau        # (c[0] = 1: the division is exact)
        if not load_loss:
            return T1 * c[a_] + d_a
        # the gear's load-dependent losses PL1..PL6 (their shares of its loss power, the table's
        # columns 1..5, summed) over the driving speed: share * sum_x T_x w_x / w_in, with
        # w_x = r_x w_in (load_loss_torque; zero at a standstill, as there)
        shares = getattr(self, "_load_share_stack", None)
        if shares is None:
            shares = self._load_share_stack = np.stack(
                [self._arrays[False][..., 1:1 + len(LOSS_NAMES)].sum(-1),
                 self._arrays[True][..., 1:1 + len(LOSS_NAMES)].sum(-1)]).ravel()
        share = g * (h * shares.take(flat) + ft * shares.take(flat + 1)) \
            + fw * (h * shares.take(flat + nt) + ft * shares.take(flat + nt + 1))
        r = self.ratio
        T_load = np.where(w_in != 0, share * T1 * (r[0] + c[1] * r[1] + c[2] * r[2]), 0.0)
        return T1 * c[a_] + d_a, T_load


#: [1] headroom of a replay's map over the recording's largest torque and speed
REPLAY_MARGIN = 1.05
#: samples per chunk of a replay: its temporaries (128 kB each) stay in a core's cache; twice
#: as fast as chunks of 65 536 samples, and the memory of a replay is its output alone
REPLAY_CHUNK = 16384


def load_loss_torque(P_load, w_in):
    r"""The gear's load-dependent loss torque at the driving shaft (N*m): the power of its
    load-dependent partial losses PL1..PL6 (every sliding and rolling contact; what
    ``[calibration] load_loss_scale`` scales) over the driving speed,

    .. math:: T_{load} = \frac{P_{L1} + P_{L2} + P_{L3} + P_{L5} + P_{L6}}{\omega_{in}},

    with the sign of a loss (T_load w_in >= 0), zero at a standstill. The load-independent
    (idle) losses of bearings' drag, seals and churning are not in it. The one formula of the
    run-in (``design.ExtraPhysics.run_in_torque``) in the core's replays, both FMUs (the
    native one in C, cd_model.h) and the diagnosis.

    Parameters
    ----------
    P_load : float or ndarray
        PL1 + PL2 + PL3 + PL5 + PL6 [W].
    w_in : float or ndarray
        Driving speed [rad/s].
    """
    w_in = np.asarray(w_in, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        T = np.where(w_in != 0, np.asarray(P_load, float) / np.where(w_in != 0, w_in, 1.0), 0.0)
    return T if T.ndim else float(T)


def replay_input_torque(design, mode, w_in, tau_out, grid=None, located=None, load_loss=False):
    """The input torque the model predicts along a recording, and its loss part (both N*m).

    Parameters
    ----------
    design : DriveDesign
    mode : str
        Operating mode, e.g. ``"S1"``.
    w_in : array_like
        Measured driving speed [rad/s].
    tau_out : array_like
        Torque the load applies on the driven shaft [N*m] (minus the delivered output torque).

    grid : (int, int), optional
        Points of the map over torque and speed (default: ModeMap's 36 x 28).
    located : dict, optional
        Shared by the replays of one ``w_in`` (a replay and its sensitivities): where its
        speeds lie on a map's speed grid (``ModeMap.locate_speeds``), per chunk, kept under
        the grid, so that maps with the same speed grid look them up once. The same numbers.

    Returns
    -------
    tau_in, loss_in : ndarray
        Model input torque [N*m] and its part beyond the lossless torque
        ``-tau_out * w_out / w_in`` [N*m], from a ``ModeMap`` spanning the recording; with
        the design's ``extra.loss_transition`` w_c > 0 the loss part times tanh(|w_in|/w_c)
        (``friction.loss_transition``: the losses through standstill).
    load_loss_in : ndarray
        With ``load_loss=True``: the gear's load-dependent loss torque at the driving shaft
        [N*m] (:func:`load_loss_torque`), the part of ``loss_in`` that PL1..PL6 make.
    """
    w_in = np.asarray(w_in, float)
    tau_out = np.asarray(tau_out, float)
    tmax = float(np.max(np.abs(tau_out))) * REPLAY_MARGIN + 1e-6
    wmax = float(np.max(np.abs(w_in))) * REPLAY_MARGIN + 1e-6
    m = ModeMap(design, mode, tmax, wmax) if grid is None else \
        ModeMap(design, mode, tmax, wmax, n_torque=grid[0], n_speed=grid[1])
    # in chunks (the map is the same for every chunk), the input torque alone: the numbers of
    # solve_arrays(...)["tau_in"], without its other outputs' temporaries
    tau_in = np.empty_like(w_in)
    load_in = np.empty_like(w_in) if load_loss else None
    chunks = None if located is None else located.setdefault(
        (w_in.size, tuple(m._lw), m._w_low), [])
    for c, k0 in enumerate(range(0, w_in.size, REPLAY_CHUNK)):
        sl = slice(k0, k0 + REPLAY_CHUNK)
        loc = None
        if chunks is not None:
            if c == len(chunks):       # (compact: grid index and sign fit 4 and 1 bytes)
                j, fw, low, sgn = m.locate_speeds(w_in[sl])
                chunks.append((j.astype(np.int32), fw, low, sgn.astype(np.int8)))
            loc = chunks[c]
        if load_loss:
            tau_in[sl], load_in[sl] = m.input_torque_arrays(w_in[sl], tau_out[sl], loc, True)
        else:
            tau_in[sl] = m.input_torque_arrays(w_in[sl], tau_out[sl], loc)
    lossless = -tau_out * m.ratio[m._k]
    if design.extra.loss_transition:
        # the losses through standstill (friction.loss_transition): the loss torque, and its
        # load-dependent part with it, times tanh(|w_in|/w_c), as both FMUs scale theirs
        share = design.extra.loss_transition_share(w_in)
        tau_in = lossless + share * (tau_in - lossless)
        if load_loss:
            load_in = share * load_in
    if load_loss:
        return tau_in, tau_in - lossless, load_in
    return tau_in, tau_in - lossless


class ThermalMap:
    """The loss map of one mode over the grease temperature too: a ``ModeMap`` at each of the
    design's map temperatures (thermal.map_temperatures: the operating temperature and nodes
    10 K apart), solved when first needed, and the steady state linear in T between the two
    nodes around it (clamped at the outer nodes).

    Between nodes the torques and losses are blended, (1 - f) a + f b with the same driving
    speed, so tau_in w_in + tau_out w_out = P_loss and the partial losses' sum hold as at a
    node; eta follows from the blended torques. At a node (f = 0) the node's own solution is
    returned unchanged: at the operating temperature this is exactly the one-temperature map.
    ``build(design_at_T)`` makes a node's ModeMap (default: ModeMap(design, mode, torque_max,
    speed_max)); the FMUs pass one that looks in their shipped maps first.
    """

    def __init__(self, design, mode, torque_max, speed_max, build=None):
        from . import thermal
        self.design = design
        self.temperatures = thermal.map_temperatures(design)
        self.mode = kinematics.parse_mode(mode)[0] + kinematics.parse_mode(mode)[1]
        self._build = build or (lambda d: ModeMap(d, self.mode, torque_max, speed_max))
        self._maps = [None] * len(self.temperatures)
        self.reference = self.temperatures.index(float(design.operating_temperature))
        self.node(self.reference)

    @property
    def dependent(self) -> bool:
        """Whether the map changes with the temperature (more than one node)."""
        return len(self.temperatures) > 1

    def node(self, i) -> ModeMap:
        """The ModeMap at node i (solved now if it was not)."""
        m = self._maps[i]
        if m is None:
            from . import thermal
            d = self.design
            if not (d.temperature_model == "fixed"
                    and self.temperatures[i] == d.operating_temperature):
                d = thermal.at_temperature(d, self.temperatures[i])
            m = self._maps[i] = self._build(d)
        return m

    @property
    def solved_nodes(self) -> int:
        return sum(m is not None for m in self._maps)

    def locate(self, temperature):
        """(i, f): the node below ``temperature`` [K] and the weight of the one above (clamped
        to the outer nodes; f = 0 at a node)."""
        T = self.temperatures
        n = len(T)
        if n == 1:
            return 0, 0.0
        x = min(max(temperature, T[0]), T[-1])
        i = bisect_right(T, x) - 1
        if i > n - 2:
            i = n - 2
        return i, (x - T[i]) / (T[i + 1] - T[i])

    def solve(self, w_in: float, tau_out: float, temperature: float):
        """ModeMap.solve at grease temperature ``temperature`` [K] (same returns)."""
        i, f = self.locate(temperature)
        a = self.node(i).solve(w_in, tau_out)
        if f == 0.0:
            return a
        b = self.node(i + 1).solve(w_in, tau_out)
        return blend_solutions(a, b, f, _SHAFT_INDEX[self.mode[0]], _SHAFT_INDEX[self.mode[1]])

    @property
    def out_of_range(self) -> int:
        return sum(m.out_of_range for m in self._maps if m is not None)


def blend_solutions(a, b, f, ia, ib):
    """(1 - f) a + f b of two ModeMap.solve results at the same operating point (the same
    speeds); ``locked`` and ``forward`` of the nearer one, eta from the blended torques. ia, ib:
    the driving and driven shafts' indices."""
    g = 1.0 - f
    speeds = a[0]
    ta, tb = a[1], b[1]
    torques = (g * ta[0] + f * tb[0], g * ta[1] + f * tb[1], g * ta[2] + f * tb[2])
    losses = [g * x + f * y for x, y in zip(a[2], b[2])]
    eta0 = g * a[4] + f * b[4]
    near = a if f < 0.5 else b
    locked, forward = near[5], near[6]
    p_a, p_b = torques[ia] * speeds[ia], torques[ib] * speeds[ib]
    p_in, p_out = (p_a, -p_b) if forward else (p_b, -p_a)
    eta = p_out / p_in if (p_in > 0 and p_out > 0 and not locked) else 0.0
    return speeds, torques, losses, eta, eta0, locked, forward


def viscosity_steps(design, mode, w_in, tau_out, span, grid=None):
    """``(span, dT_half, dT_full)``: the change of the model's input torque along a recording
    [N*m] when ln(viscosity) changes by ``span``/2 and by ``span`` (three replays on ``grid``,
    by default the full map's: the map's interpolation error changes with the viscosity, and
    on the sensitivities' coarser 18 x 14 grid the differences biased a fitted change of
    ln 0.5 by 0.02-0.06 on independent recordings, against 0.01 on the full grid).

    With them a viscosity change x between 0 and ``span`` is evaluated through the quadratic
    in ln(nu) through the three replays (``model_core.effects._viscosity``): the drift at its
    size rather than linearised at the design's viscosity. The core's input torque is not
    linear in ln(nu), nor is a Taylor series at the design's viscosity good over a large drift:
    at ln 0.5 the linear term misses a fifth of the response and the second-order term at the
    design's viscosity still 40 % of that miss; the quadratic through the drift's own end and
    middle interpolates where a Taylor series extrapolates."""
    from .design import scale_viscosity
    base = replay_input_torque(design, mode, w_in, tau_out, grid)[0]
    half, full = (replay_input_torque(scale_viscosity(design, math.exp(x)), mode, w_in,
                                      tau_out, grid)[0] - base for x in (0.5 * span, span))
    return span, half, full
