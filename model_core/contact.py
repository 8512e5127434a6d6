"""Contact forces: ring rollers (Eqs. 10-12), disc rollers (Eqs. 13-16), eccentric bearing
(Eqs. 17-19).

Both roller sets are solved by the same compatibility method. The gear turns by a small angle
``rot`` relative to the roller carrier (the paper's Delta-phi); the normal approach at a roller
with lever arm l is l*rot, its deformation after closing its clearance Delta is
delta = l*rot - Delta, and only rollers with delta > 0 carry load. The torque balance

    T_c = sum_i l_i * Q(l_i*rot - Delta_i)                  (Eqs. 12 and 16)

fixes ``rot``; it is increasing and convex in ``rot``, so Newton's method started to the right
of the root converges monotonically. ``Q`` is the contact force law: Palmgren's line contact
(delta = 3.84e-5 Q^0.9 / l^0.8 in mm and N) or a linear spring; with the linear law and zero
clearance, F_i is proportional to l_i, the rigid distribution of the classical theory.
"""
from __future__ import annotations

import numpy as np

from . import geometry

_NEWTON_ITERATIONS = 40
_NEWTON_RTOL = 1e-12
#: gear torques [N*m] whose contact solutions start the solves of up to _REFERENCE_MAX_POINTS
#: points without a warm start (_Geometry.solve), _REFERENCE_PER_DECADE per decade over the
#: range of any drive's use. A few points then take one or two Newton steps instead of five
#: (one operating point: 50 us less); a map's batch still takes four or five (the worst of
#: its thousands of problems rules, and the start's scaling costs a step on its arrays)
_REFERENCE_MAX_POINTS = 16
#: the Newton iteration of a batch goes on with the points not yet converged alone once fewer
#: than 1/_ACTIVE_SET_SHARE of them are left (taking them out costs a copy of the rest; a
#: map's batch of 2500 points has about 10 % left after the second step, of whose problems
#: the worst ruled how long the whole batch iterated)
_ACTIVE_SET_SHARE = 2
#: [points] batches from this size on (a map's); a few points iterate together to the end
#: (the bookkeeping would cost more than the steps it saves: one operating point)
_ACTIVE_SET_MIN = 64
_REFERENCE_PER_DECADE = 2
_REFERENCE_LOG10 = np.arange(-4.0, 6.01, 1.0 / _REFERENCE_PER_DECADE)
_REFERENCE_TORQUES = 10.0 ** _REFERENCE_LOG10


def palmgren_stiffness(length):
    """K in Q = K * delta^(10/9) (N, m) for a steel line contact of the given length (m).

    Palmgren: delta[mm] = 3.84e-5 * Q[N]^0.9 / l[mm]^0.8, so
    Q = (delta[mm] * l[mm]^0.8 / 3.84e-5)^(10/9).
    """
    l_mm = length * 1e3
    return (l_mm ** 0.8 / 3.84e-5) ** (10.0 / 9.0) * 1e3 ** (10.0 / 9.0)


def contact_force(deformation, law, stiffness):
    """Normal force (N) for a normal deformation (m); zero where there is no contact."""
    return _force_and_slope(deformation, law, stiffness)[0]


def _force_and_slope(deformation, law, stiffness):
    d = np.maximum(deformation, 0.0)
    if law == "linear":
        return stiffness * d, np.where(deformation > 0, stiffness, 0.0)
    q = np.cbrt(np.cbrt(d))          # d^(1/9): two cube roots are much cheaper than a pow
    kq = stiffness * q
    return kq * d, (10.0 / 9.0) * kq


def solve_rotation(levers, clearances, torque, law, stiffness, guess=None):
    """Rotation ``rot`` (rad) that makes sum(l * Q(l*rot - Delta)) equal ``torque``.

    levers, clearances: arrays (..., n) over the rollers (only l > 0 can carry load);
    torque: array broadcastable to (...), N*m, >= 0. Returns rot with shape (...).
    ``guess``: a nearby solution (warm start). Newton's first step from any point with contact
    lands right of the root of this convex function, so a warm start is as safe as a cold one.
    """
    levers = np.asarray(levers, float)
    clearances = np.broadcast_to(np.asarray(clearances, float), levers.shape)
    torque = np.asarray(torque, float)
    lpos = np.where(levers > 0, levers, 0.0)
    # start right of the root: the roller with the largest lever carries the torque alone
    m = np.argmax(lpos, axis=-1)[..., None]
    l_m = np.take_along_axis(lpos, m, -1)[..., 0]
    c_m = np.take_along_axis(clearances, m, -1)[..., 0]
    if law == "linear":
        d_single = torque / (l_m * stiffness)
    else:
        d_single = (torque / (l_m * stiffness)) ** 0.9
    rot = (c_m + d_single) / l_m * (1 + 1e-9) + 1e-18
    if guess is not None:
        # keep the cold start where the guess has no contact (zero slope)
        rot = np.where(guess * l_m > c_m, guess, rot)
    target = torque
    for _ in range(_NEWTON_ITERATIONS):
        f, slope = _force_and_slope(lpos * rot[..., None] - clearances, law, stiffness)
        t = np.sum(lpos * f, axis=-1)
        dt = np.sum(lpos * lpos * slope, axis=-1)
        step = np.where(dt > 0, (t - target) / np.where(dt > 0, dt, 1.0), 0.0)
        rot = rot - step
        if np.all(np.abs(step) <= _NEWTON_RTOL * np.abs(rot)):
            break
    return rot


def _roller_forces(levers, clearances, torque, law, stiffness, state=None, key=None):
    torque = np.asarray(torque, float)
    guess = None if state is None else state.get(key)
    if guess is not None and guess.shape != torque.shape:
        guess = None
    rot = solve_rotation(levers, clearances, torque, law, stiffness, guess)
    if state is not None:
        state[key] = rot
    lpos = np.where(levers > 0, levers, 0.0)
    f = contact_force(lpos * rot[..., None] - clearances, law, stiffness)
    return np.where((lpos > 0) & (torque[..., None] > 0), f, 0.0)


# Distinct contact problems. Over a mesh cycle many positions present the same set of
# (lever arm, clearance) pairs to the solver, only permuted over the rollers (the pattern of a
# roller set repeats every roller pitch; the disc pattern is also mirror-symmetric). Each
# distinct set is solved once and its forces are scattered back. Two rows are the same problem
# when their pairs, sorted, agree after rounding to _KEY_DIGITS significant digits of the
# set's largest lever (clearances on the same absolute scale as the levers' rounding times the
# rotation, i.e. rounded in metres to _KEY_CLEARANCE_M): the rows of one class then differ by
# floating-point noise only (~1e-16), so the shared solution is that of every member to ~1e-14.
_KEY_DIGITS = 11          # significant digits of the lever arms kept in the key
_KEY_CLEARANCE_M = 1e-15  # m, rounding step of the clearances in the key (far below any load)
_ZERO_LEVER = 1e-12       # lever arms below this fraction of the largest are rounding noise


def distinct_problems(levers, clearances):
    """Classes of identical contact problems among the rows of (levers, clearances).

    levers, clearances: arrays (m, n) over positions x rollers. Returns (rep, cls, inv):
    ``rep`` the row index of each class's representative (n_d,), ``cls`` the class of each row
    (m,), and ``inv`` (m, n) such that a row's roller j corresponds to the representative's
    roller ``order[rep[cls], inv]`` after sorting, see ``scatter_forces``. Also returns the
    sorting order of the representatives' rollers.
    """
    levers = np.asarray(levers, float)
    clearances = np.broadcast_to(np.asarray(clearances, float), levers.shape)
    scale = np.max(np.abs(levers)) or 1.0
    # rollers with l <= 0 carry nothing whatever their values: one key (0, 0) for all of them
    pos = levers > 0
    kl = np.where(pos, np.round(levers / scale * 10.0 ** _KEY_DIGITS), 0.0)
    kc = np.where(pos, np.round(clearances / _KEY_CLEARANCE_M), 0.0)
    # sort each row's pairs by (lever key, clearance key): permutation-invariant rows
    order = np.lexsort((kc, kl), axis=-1)
    inv = np.argsort(order, axis=-1)
    key = np.concatenate([np.take_along_axis(kl, order, -1),
                          np.take_along_axis(kc, order, -1)], -1)
    _, rep, cls = np.unique(key, axis=0, return_index=True, return_inverse=True)
    return rep, cls.reshape(-1), inv, order


class _Geometry:
    """Angles, levers and clearances of one roller set at the mesh positions, with the classes
    of distinct contact problems (cached per design and positions)."""

    __slots__ = ("angles", "levers", "clear", "rep_levers", "rep_clear", "cls", "inv", "_l", "_l2",
                 "_c", "_l_m", "_c_m", "_no_clearance", "_sum_l2", "_sum_l19", "_compact_cache",
                 "_cls_flat", "_l2_109", "_rot0", "_reference_cache")

    def __init__(self, angles, levers, clear, dedup=True):
        # a roller at the end of the loaded half (sin = 0 up to rounding, e.g. sin(pi) = 1.2e-16)
        # has no lever arm: zero it, so that its sign is not left to rounding noise (a force of
        # 1e-25 N would still count in loss laws with a power of the force below one)
        levers = np.where(np.abs(levers) <= _ZERO_LEVER * np.max(np.abs(levers)), 0.0, levers)
        self.angles, self.levers = angles, levers
        self.clear = np.broadcast_to(clear, levers.shape)
        m = levers.shape[0]
        if dedup and m > 1:
            rep, cls, inv, order = distinct_problems(levers, self.clear)
            o = order[rep]
            self.rep_levers = np.take_along_axis(levers[rep], o, -1)
            self.rep_clear = np.take_along_axis(self.clear[rep], o, -1)
            self.cls, self.inv = cls[:, None], inv
        else:
            self.rep_levers, self.rep_clear = levers, self.clear
            self.cls = np.arange(m)[:, None]
            self.inv = np.broadcast_to(np.arange(levers.shape[1]), levers.shape)

        # the distinct problems, rollers first: (n, n_d), so that the sums over the rollers in
        # the Newton iteration add whole contiguous arrays
        lpos = np.where(self.rep_levers > 0, self.rep_levers, 0.0)
        self._l = np.ascontiguousarray(lpos.T)
        self._l2 = self._l * self._l
        self._c = np.ascontiguousarray(self.rep_clear.T)
        m_ = np.argmax(lpos, axis=-1)
        idx = np.arange(lpos.shape[0])
        self._l_m, self._c_m = lpos[idx, m_], self.rep_clear[idx, m_]
        # without clearance on any loaded roller the balance has a closed form
        self._no_clearance = bool(np.all(self.rep_clear[lpos > 0] == 0))
        self._sum_l2 = np.sum(lpos * lpos, axis=-1)
        self._sum_l19 = np.sum(lpos ** (19.0 / 9.0), axis=-1)
        self._compact_cache = {}
        self._l2_109 = (10.0 / 9.0) * self._l2
        self._rot0 = np.maximum(self._c_m / self._l_m, 0.0)
        self._cls_flat = np.ascontiguousarray(self.cls[:, 0])
        self._reference_cache = {}

    @property
    def n_distinct(self):
        return self.rep_levers.shape[0]

    def _reference(self, law, stiffness, T):
        """A start for a solve without a guess: the solutions at the torques
        _REFERENCE_TORQUES (solved once per contact law and stiffness) nearest T (...), as a
        guess (rot (..., n_d), T_ref (..., 1))."""
        key = (law, stiffness)
        table = self._reference_cache.get(key)
        if table is None:
            table = self._reference_cache[key] = (
                self.solve(_REFERENCE_TORQUES, law, stiffness, reference=False),
                _REFERENCE_TORQUES[:, None])
        # (fmax: a NaN torque takes the first entry)
        j = np.minimum(np.rint((np.log10(np.fmax(T[..., 0], _REFERENCE_TORQUES[0]))
                                - _REFERENCE_LOG10[0]) * _REFERENCE_PER_DECADE),
                       _REFERENCE_TORQUES.size - 1).astype(int)
        return table[0][j], table[1][j]

    def solve(self, torque, law, stiffness, guess=None, reference=True):
        """Rotation (rad, shape (..., n_d)) of every distinct problem at gear torque(s) T (...).

        The Newton iteration of ``solve_rotation`` (same steps, same stop) on the
        rollers-first layout, started from the free rotation of the closed form; without
        clearance that closed form is the solution. ``guess``: (rot, T) of a previous call at
        the same positions, shapes (..., n_d) and (..., 1); without one (and ``reference``),
        for up to _REFERENCE_MAX_POINTS torques, the solution at the nearest of
        _REFERENCE_TORQUES (a cold start from the closed form takes about five Newton steps,
        that start one or two).
        """
        T = np.asarray(torque, float)[..., None]
        linear = law == "linear"
        # the balance without clearance has a closed form (rigid-body rotation of the contact
        # pattern): rot_0 = T/(K sum l^2) (linear) or (T/(K sum l^(19/9)))^(9/10) (Palmgren)
        rot_free = T / (stiffness * self._sum_l2) if linear else \
            (T / (stiffness * self._sum_l19)) ** 0.9
        if self._no_clearance:
            return rot_free
        ex = (slice(None),) + (None,) * (T.ndim - 1)
        l, c = self._l[ex], self._c[ex]
        # the balance's slope carries 10/9 with Palmgren's law (Q/K = d^(10/9))
        l2 = self._l2[ex] if linear else self._l2_109[ex]
        l_m, c_m = self._l_m, self._c_m
        # start: the clearance of the most loaded roller closed (rot0), then the free rotation.
        # Any start with contact is safe: from the left of the root of this increasing convex
        # function, Newton's first step lands right of it, then converges monotonically.
        rot0 = self._rot0
        rot = rot0 + rot_free
        if guess is None and reference and 0 < T.size <= _REFERENCE_MAX_POINTS:
            guess = self._reference(law, stiffness, T)
        if guess is not None:
            # warm start from the solution (rot_old, T_old): its part beyond the clearance
            # scaled like the free rotation, keeping the cold start where it had no contact
            rot_old, T_old = guess
            ratio = np.where(T_old > 0, T / np.where(T_old > 0, T_old, 1.0), 0.0)
            scaled = rot0 + (rot_old - rot0) * (ratio if linear else ratio ** 0.9)
            rot = np.where((rot_old * l_m > c_m) & (T_old > 0), scaled, rot)
        T_k = T / stiffness
        # the points flat, (N, n_d): a point whose problems have all converged leaves the
        # iteration (active set), the others go on; each point then stops by its own test
        shape = rot.shape
        nd = self.n_distinct
        batch = rot.size >= _ACTIVE_SET_MIN * nd
        if batch:
            rot = rot.reshape(-1, nd)
            T_k = np.broadcast_to(T_k, shape[:-1] + (1,)).reshape(-1, 1)
            if l.ndim != 3:
                l, c, l2 = (x.reshape(x.shape[0], 1, nd) for x in (l, c, l2))
        out, idx = None, None
        for it in range(_NEWTON_ITERATIONS):
            if it == 1 and l.shape[0] > 1:
                # after one step every rotation is right of its root and only decreases: a
                # roller out of contact at the largest rotation of the batch stays out, and
                # its terms (zeros) are dropped from the sums
                r_max = rot.reshape(-1, nd).max(0)
                rows = np.any(self._l * r_max - self._c > 0, axis=1)
                if not rows.all():
                    l, l2, c = l[rows], l2[rows], c[rows]
            # the balance divided by the stiffness: sum l Q/K - T/K (Q/K = d or d^(10/9))
            d = l * rot - c
            np.maximum(d, 0.0, out=d)
            if linear:
                t = np.add.reduce(l * d, axis=0)
                dt = np.add.reduce(l2 * (d > 0), axis=0)
            else:
                q = np.cbrt(np.cbrt(d))
                t = np.add.reduce(l * q * d, axis=0)
                dt = np.add.reduce(l2 * q, axis=0)     # l2 carries the 10/9 here
            # (np.zeros: np.zeros_like's Python wrapper costs more than the division)
            step = np.divide(t - T_k, dt, out=np.zeros(t.shape), where=dt > 0)
            rot = rot - step
            if not batch:
                if (np.abs(step) <= _NEWTON_RTOL * np.abs(rot)).all():
                    break
                continue
            going = (np.abs(step) > _NEWTON_RTOL * np.abs(rot)).any(-1)
            if not going.any():
                break
            n_going = np.count_nonzero(going)
            if n_going * _ACTIVE_SET_SHARE < going.size:
                # most points have converged: they keep their rotation, the rest iterate
                if out is None:
                    out, idx = rot, np.flatnonzero(going)
                else:
                    out[idx] = rot
                    idx = idx[going]
                rot, T_k = rot[going], T_k[going]
        if out is None:
            return rot.reshape(shape)
        out[idx] = rot
        return out.reshape(shape)

    def forces(self, torque, law, stiffness, state=None, key=None, layout="positions"):
        """Forces (N) for gear torque(s) T (...), in one of three layouts:

        - "positions": at every position, shape (..., m, n); returns F.
        - "compact": at every position, only the rollers that carry load at some point of the
          batch (padded with unloaded ones, whose forces are exactly zero): returns (F, phi),
          F shaped (..., m, n_c) for the rollers at the angles phi (m, n_c). Sums
          over the rollers are those of "positions" (the dropped terms are zeros).
        - "distinct": at the distinct problems only (rollers as sorted in the problem): returns
          (F, cls), F (..., n_d, n) and ``cls`` (m,) the problem of each position. Anything
          that depends on the forces alone (not on the rollers' angles) is the same at all
          positions of a problem.
        """
        T = np.asarray(torque, float)
        guess = None if state is None else state.get(key)
        if guess is not None and guess[0].shape != T.shape + (self.n_distinct,):
            guess = None
        rot = self.solve(T, law, stiffness, guess)
        if state is not None:
            state[key] = (rot, T[..., None])
        if layout != "compact":
            ex = (slice(None),) + (None,) * T.ndim
            f = contact_force(self._l[ex] * rot - self._c[ex], law, stiffness)
            f = np.where((self._l[ex] > 0) & (T[..., None] > 0), f, 0.0)
            f = f.transpose(tuple(range(1, f.ndim)) + (0,))
            return (f, self._cls_flat) if layout == "distinct" else f[..., self.cls, self.inv]
        # a roller can carry load somewhere in the batch only if it does at the largest
        # rotation (the approach l*rot - Delta grows with rot)
        r_max = rot.reshape(-1, self.n_distinct).max(0) if rot.size else np.zeros(
            self.n_distinct)
        loaded = (self._l * r_max - self._c > 0) & (self._l > 0)           # (n, n_d)
        angles, l_s, c_s, cls = self._compact(loaded)
        # the same approach l*rot - Delta per roller as above, at the selected rollers only
        f = contact_force(l_s * rot[..., cls, None] - c_s, law, stiffness)
        return np.where((l_s > 0) & (T[..., None, None] > 0), f, 0.0), angles

    def _compact(self, loaded):
        """Rollers kept at each position for the rollers ``loaded`` (n, n_d) of the distinct
        problems: (their angles (m, n_c), levers and clearances, the problem of each
        position); cached per pattern (few occur)."""
        key = loaded.tobytes()
        hit = self._compact_cache.get(key)
        if hit is None:
            at_pos = loaded.T[self.cls, self.inv]                              # (m, n)
            n_c = max(int(at_pos.sum(-1).max()), 1)
            sel = np.argsort(~at_pos, axis=-1, kind="stable")[:, :n_c]
            roller = np.take_along_axis(self.inv, sel, -1)
            hit = (np.take_along_axis(self.angles, sel, -1), self._l.T[self.cls, roller],
                   self._c.T[self.cls, roller], self._cls_flat)
            if len(self._compact_cache) > 256:
                self._compact_cache.clear()
            self._compact_cache[key] = hit
        return hit


_GEOMETRY_CACHE: dict = {}
_GEOMETRY_CACHE_SIZE = 64   # entries; a design and its mesh positions per roller set


def _cached_geometry(key, make):
    geom = _GEOMETRY_CACHE.get(key)
    if geom is None:
        if len(_GEOMETRY_CACHE) >= _GEOMETRY_CACHE_SIZE:
            _GEOMETRY_CACHE.pop(next(iter(_GEOMETRY_CACHE)))
        geom = _GEOMETRY_CACHE[key] = make()
    return geom


def loaded_half_angles(psi, n):
    """Angles (rad, in [0, 2 pi)) of n equally spaced rollers at mesh position(s) psi, keeping
    only the ceil(n/2) nearest the middle of the loaded half 0 < angle < pi: the others have
    lever arms <= 0 and cannot carry load. Shape (m, ceil(n/2))."""
    psi = np.atleast_1d(np.asarray(psi, float))
    ang = np.mod(psi[:, None] + 2 * np.pi * np.arange(n) / n, 2 * np.pi)
    order = np.argsort(np.abs(ang - np.pi / 2), axis=-1)[:, : (n + 1) // 2]
    return np.take_along_axis(ang, order, -1)


def _roller_set_forces(design, gear_torque, state, key, geom, width, dedup, layout="positions"):
    """Solve the distinct problems of one roller set and scatter the forces to all positions
    (layout: see ``_Geometry.forces``; "compact" returns the selected rollers' angles, and
    "distinct" the class of each position in place of the angles)."""
    stiff = (design.linear_stiffness if design.contact_law == "linear"
             else palmgren_stiffness(width))
    T = np.asarray(gear_torque, float)
    if dedup:
        out = geom.forces(T, design.contact_law, stiff, state, key, layout)
        if layout == "compact":
            F, angles = out
            return angles, F
        if layout == "distinct":
            F, cls = out
            return cls, F
        return geom.angles, out
    # reference path: every position on its own, the general solver
    levers, clear = geom.levers, geom.clear
    full = T.shape + levers.shape
    F = _roller_forces(np.broadcast_to(levers, full), np.broadcast_to(clear, full),
                       np.broadcast_to(T[..., None], full[:-1]), design.contact_law, stiff,
                       state, key)
    return geom.angles, F


def _psi_key(psi):
    psi = np.atleast_1d(np.asarray(psi, float))
    return psi, psi.tobytes()


def ring_roller_forces(design, gear_torque, psi, state=None, key="ring", dedup=True,
                       layout="positions"):
    """Normal forces F_Ni (N) between tooth and ring rollers (Eqs. 10-12).

    gear_torque: torque T_c (N*m) the ring rollers exert on one cycloid gear about its centre,
    shape (...); psi: mesh position(s), shape (m,). Returns (phi, F) for the rollers of the
    loaded half, shapes (m, n) and (..., m, n), n = ceil(z1/2); the other rollers carry nothing.
    ``state``: optional dict that keeps the solved rotations under ``key``, for a warm start of
    the next call with nearby torques at the same positions. Positions presenting the same set
    of lever arms and clearances are solved once (``dedup=False``: every position on its own,
    the reference path; the results agree to ~1e-14). ``layout="compact"`` (with dedup):
    only the rollers that carry load somewhere in the batch, see ``_Geometry.forces``.
    """
    psi, pbytes = _psi_key(psi)

    def make():
        phi = loaded_half_angles(psi, design.z1)
        return _Geometry(phi, geometry.ring_roller_levers(phi, design.e, design.z1, design.lam),
                         geometry.modification_clearance(phi, design.lam, design.delta_z,
                                                         design.profile_modification))
    geom = _cached_geometry(("ring", design.z1, design.e, design.lam, design.delta_z,
                             design.profile_modification, pbytes), make)
    return _roller_set_forces(design, gear_torque, state, key, geom, design.b1, dedup, layout)


def disc_roller_forces(design, gear_torque, psi, state=None, key="disc", dedup=True,
                       layout="positions"):
    """Normal forces F_Kj (N) between disc rollers and holes (Eqs. 13-16).

    Returns (theta, F) for the rollers of the loaded half, shapes (m, n) and (..., m, n),
    n = ceil(k/2); every force is parallel to the line of centres. ``state``, ``dedup``: as in
    ``ring_roller_forces``. ``layout="distinct"`` (with dedup): returns (cls, F) with F at
    the distinct contact problems only, (..., n_d, n), and cls (m,) the problem of each
    position (the disc rollers' losses depend on their forces alone).
    """
    psi, pbytes = _psi_key(psi)
    c = geometry.hole_clearance(design.D_cz, design.d_v2, design.e)

    def make():
        theta = loaded_half_angles(psi, design.n_disc_rollers)
        levers = geometry.disc_roller_levers(theta, design.r_w)
        return _Geometry(theta, levers, np.full_like(levers, c))
    geom = _cached_geometry(("disc", design.n_disc_rollers, design.r_w, c, pbytes), make)
    return _roller_set_forces(design, gear_torque, state, key, geom, design.b2, dedup, layout)


def eccentric_bearing_force(design, phi, F_ring, F_disc, ring_index=None, disc_index=None):
    """Components (F_EV, F_EH) of the eccentric-bearing force on one gear (Eqs. 17, 18), N.

    F_EV is perpendicular to the line of centres (only ring forces have such a component);
    F_EH along it (ring forces plus disc forces, which all act along -x on the gear).
    Shapes: phi, F_ring (..., n1) and F_disc (..., n2) with the same leading shape.
    The bearing force balances the gear: it is minus the sum of the roller forces.
    ring_index, disc_index: when given, F_ring and F_disc belong to distinct positions and the
    gear's position k combines ring position ring_index[k] with disc position disc_index[k].
    """
    nx, ny = geometry.ring_roller_normals(phi, design.lam)
    F_EV = -np.sum(F_ring * ny, axis=-1)
    F_x = np.sum(F_ring * nx, axis=-1)
    F_d = np.sum(F_disc, axis=-1)
    if ring_index is not None:
        F_EV, F_x, F_d = F_EV[..., ring_index], F_x[..., ring_index], F_d[..., disc_index]
    return F_EV, F_x - F_d


#: Static limit of the Hertz contact pressure [Pa]: 4000 MPa, the basic static load rating's
#: contact stress for roller bearings of through-hardened bearing steel (ISO 76:2006, 6.1.2);
#: above it the rollers and teeth dent permanently.
STATIC_CONTACT_PRESSURE_LIMIT = 4.0e9
#: Contact modulus E* = E / (2 (1 - nu^2)) of steel on steel [Pa] (E = 210 GPa, nu = 0.3).
STEEL_CONTACT_MODULUS = 210e9 / (2 * (1 - 0.3 ** 2))


def line_contact_pressure(force, length, radius):
    """Peak Hertz pressure p0 [Pa] of a steel line contact: force [N] over length [m], effective
    radius of curvature [m] (1/R = 1/R1 +- 1/R2, minus for a concave partner):
    p0 = sqrt(F E* / (pi l R)) (Johnson, Contact Mechanics, 1985, Eq. 4.45)."""
    return np.sqrt(np.asarray(force, float) * STEEL_CONTACT_MODULUS / (np.pi * length * radius))
