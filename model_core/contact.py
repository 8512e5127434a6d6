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


def loaded_half_angles(psi, n):
    """Angles (rad, in [0, 2 pi)) of n equally spaced rollers at mesh position(s) psi, keeping
    only the ceil(n/2) nearest the middle of the loaded half 0 < angle < pi: the others have
    lever arms <= 0 and cannot carry load. Shape (m, ceil(n/2))."""
    psi = np.atleast_1d(np.asarray(psi, float))
    ang = np.mod(psi[:, None] + 2 * np.pi * np.arange(n) / n, 2 * np.pi)
    order = np.argsort(np.abs(ang - np.pi / 2), axis=-1)[:, : (n + 1) // 2]
    return np.take_along_axis(ang, order, -1)


def _roller_set_forces(design, gear_torque, state, key, make_geometry, width):
    """Solve one roller set; its geometry (angles, levers, clearances) is kept in ``state``."""
    geom = None if state is None else state.get((key, "geometry"))
    if geom is None:
        geom = make_geometry()
        if state is not None:
            state[(key, "geometry")] = geom
    angles, levers, clear = geom
    stiff = (design.linear_stiffness if design.contact_law == "linear"
             else palmgren_stiffness(width))
    T = np.asarray(gear_torque, float)[..., None]
    full = T.shape[:-1] + levers.shape
    F = _roller_forces(np.broadcast_to(levers, full), np.broadcast_to(clear, full),
                       np.broadcast_to(T, full[:-1]), design.contact_law, stiff, state, key)
    return angles, F


def ring_roller_forces(design, gear_torque, psi, state=None, key="ring"):
    """Normal forces F_Ni (N) between tooth and ring rollers (Eqs. 10-12).

    gear_torque: torque T_c (N*m) the ring rollers exert on one cycloid gear about its centre,
    shape (...); psi: mesh position(s), shape (m,). Returns (phi, F) for the rollers of the
    loaded half, shapes (m, n) and (..., m, n), n = ceil(z1/2); the other rollers carry nothing.
    ``state``: optional dict that keeps geometry and the solved rotation under ``key``, for a
    warm start of the next call with nearby torques at the same positions.
    """
    def make_geometry():
        phi = loaded_half_angles(psi, design.z1)
        return (phi, geometry.ring_roller_levers(phi, design.e, design.z1, design.lam),
                geometry.modification_clearance(phi, design.lam, design.delta_z,
                                                design.profile_modification))
    return _roller_set_forces(design, gear_torque, state, key, make_geometry, design.b1)


def disc_roller_forces(design, gear_torque, psi, state=None, key="disc"):
    """Normal forces F_Kj (N) between disc rollers and holes (Eqs. 13-16).

    Returns (theta, F) for the rollers of the loaded half, shapes (m, n) and (..., m, n),
    n = ceil(k/2); every force is parallel to the line of centres.
    """
    def make_geometry():
        theta = loaded_half_angles(psi, design.n_disc_rollers)
        levers = geometry.disc_roller_levers(theta, design.r_w)
        return (theta, levers,
                np.full_like(levers, geometry.hole_clearance(design.D_cz, design.d_v2, design.e)))
    return _roller_set_forces(design, gear_torque, state, key, make_geometry, design.b2)


def eccentric_bearing_force(design, phi, F_ring, F_disc):
    """Components (F_EV, F_EH) of the eccentric-bearing force on one gear (Eqs. 17, 18), N.

    F_EV is perpendicular to the line of centres (only ring forces have such a component);
    F_EH along it (ring forces plus disc forces, which all act along -x on the gear).
    Shapes: phi, F_ring (..., n1) and F_disc (..., n2) with the same leading shape.
    The bearing force balances the gear: it is minus the sum of the roller forces.
    """
    nx, ny = geometry.ring_roller_normals(phi, design.lam)
    F_EV = -np.sum(F_ring * ny, axis=-1)
    F_EH = np.sum(F_ring * nx, axis=-1) - np.sum(F_disc, axis=-1)
    return F_EV, F_EH


#: Static limit of the Hertz contact pressure [Pa]: 4000 MPa, the basic static load rating's
#: contact stress for roller bearings of through-hardened bearing steel (ISO 76:2006, 6.1.2);
#: above it the rollers and teeth dent permanently.
STATIC_CONTACT_PRESSURE_LIMIT = 4.0e9
#: Contact modulus E* = E / (2 (1 - nu^2)) of steel on steel [Pa] (E = 210 GPa, nu = 0.3).
STEEL_CONTACT_MODULUS = 210e9 / (2 * (1 - 0.3 ** 2))


def ring_contact_pressure(design, gear_torque, n_positions=16):
    """Largest Hertz line-contact pressure p0 (Pa) between a ring roller and the tooth of one
    cycloid gear carrying ``gear_torque`` (N*m), over ``n_positions`` mesh positions of one pitch.

    p0 = sqrt(F E* / (pi l R)) (Johnson, Contact Mechanics, 1985, Eq. 4.45), R the roller radius
    d_v1/2 against a flat tooth: the tooth's convex curvature only raises p0, so this is a lower
    bound on the pressure and the rating derived from it an upper bound."""
    psi = np.linspace(0.0, 2 * np.pi / design.z1, n_positions, endpoint=False)
    _, F = ring_roller_forces(design, abs(float(gear_torque)), psi)
    F_max = float(np.nanmax(F))
    return np.sqrt(F_max * STEEL_CONTACT_MODULUS / (np.pi * design.b1 * design.d_v1 / 2))


def ring_torque_rating(design) -> float:
    """Static torque rating (N*m) of the ring (shaft 1): the ring torque at which the most
    loaded ring roller reaches :data:`STATIC_CONTACT_PRESSURE_LIMIT` (see
    :func:`ring_contact_pressure`; p0 grows about as sqrt(torque), found by fixed-point steps)."""
    T = 100.0
    for _ in range(6):
        p = ring_contact_pressure(design, T * design.torque_share)
        T *= (STATIC_CONTACT_PRESSURE_LIMIT / p) ** 2
    return float(T)
