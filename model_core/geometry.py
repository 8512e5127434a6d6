"""Geometry of the cycloid mesh: profile, pitch point, lever arms, contact normals, clearance.

Frame: carrier (eccentric shaft) fixed. Origin at the ring centre O_a, x axis along the line of
centres towards the cycloid-gear centre O_c = (e, 0) and the pitch point P = (e*z1, 0).
The ring-roller angle phi is measured from +x, counter-clockwise. With K1 = e*z1/r_p = 1/lambda:

    |D_i P| = r_p * S(phi),   S(phi) = sqrt(1 + K1^2 - 2 K1 cos(phi))
    lever arm of F_Ni about O_c:  l_i = e*z_c * sin(phi_i) / S(phi_i)      (Li Lixing)

Every normal force between roller and tooth passes through P (law of gearing).
Functions take plain numbers or numpy arrays and broadcast.
"""
from __future__ import annotations

import functools

import numpy as np


def shape_factor(phi, K1):
    """S(phi) = sqrt(1 + K1^2 - 2*K1*cos(phi)) = |D P| / r_p (from Eq. 3, sign corrected)."""
    return np.sqrt(1.0 + K1 * K1 - 2.0 * K1 * np.cos(phi))


def ring_roller_levers(phi, e, z1, lam):
    """Lever arm about the cycloid centre of the normal force on the roller at angle phi (m).

    l = r'_c * sin(phi)/S with r'_c = e*(z1-1) the pitch radius of the cycloid gear. Positive on
    the loaded half 0 < phi < pi for the torque direction this module uses.
    """
    K1 = 1.0 / lam
    return e * (z1 - 1) * np.sin(phi) / shape_factor(phi, K1)


def ring_roller_normals(phi, lam):
    """Unit direction (x, y) of the force from roller i onto the gear: from D_i towards P."""
    K1 = 1.0 / lam
    S = shape_factor(phi, K1)
    return (K1 - np.cos(phi)) / S, -np.sin(phi) / S


def modification_clearance(phi, lam, delta_z, kind="equidistant"):
    """Normal clearance at the roller at angle phi created by the profile correction (m).

    Measured along the contact normal after the rigid rotation that closes the first contact
    (Li Lixing; Song et al., Machines 11:775 (2023)):
      equidistant dr_rp:  Delta = dr_rp * (1 - sin(phi)/S)
      offset dr_p < 0:    Delta = |dr_p| * (1 - K1 cos(phi) - sqrt(1-K1^2) sin(phi)) / S
    Both vanish at cos(phi*) = K1, where the lever arm is largest.
    """
    K1 = 1.0 / lam
    S = shape_factor(phi, K1)
    if kind == "equidistant":
        return delta_z * (1.0 - np.sin(phi) / S)
    if kind == "offset":
        return delta_z * (1.0 - K1 * np.cos(phi) - np.sqrt(1.0 - K1 * K1) * np.sin(phi)) / S
    raise ValueError(f"unknown profile modification {kind!r}")


def cycloid_profile(z1, e, lam, roller_radius, n=2000):
    """Points (x, y) of the cycloid-gear tooth profile in the gear frame (m).

    Pitch (roller-centre) curve, a prolate epicycloid, offset inwards by the roller radius:
      x0 = r_p cos t - e cos(z1 t),  y0 = r_p sin t - e sin(z1 t)
    """
    t = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    r_p = lam * e * z1
    x0 = r_p * np.cos(t) - e * np.cos(z1 * t)
    y0 = r_p * np.sin(t) - e * np.sin(z1 * t)
    dx = -r_p * np.sin(t) + e * z1 * np.sin(z1 * t)
    dy = r_p * np.cos(t) - e * z1 * np.cos(z1 * t)
    norm = np.hypot(dx, dy)
    # inward normal of a counter-clockwise curve is (-dy, dx)
    return x0 - roller_radius * dy / norm, y0 + roller_radius * dx / norm


def pitch_curve_curvature(t, z1, e, lam):
    """Signed curvature of the roller-centre curve (1/m), positive where it bends towards the
    gear centre (convex tooth tips), at curve parameter t."""
    r_p = lam * e * z1
    dx = -r_p * np.sin(t) + e * z1 * np.sin(z1 * t)
    dy = r_p * np.cos(t) - e * z1 * np.cos(z1 * t)
    ddx = -r_p * np.cos(t) + e * z1 * z1 * np.cos(z1 * t)
    ddy = -r_p * np.sin(t) + e * z1 * z1 * np.sin(z1 * t)
    return (dx * ddy - dy * ddx) / np.hypot(dx, dy) ** 3


@functools.lru_cache(maxsize=256)
def min_radius_of_curvature(z1, e, lam, n=1001, n_fine=201):
    """Smallest radius of curvature of the convex parts of the roller-centre curve (m).

    The tooth profile is that curve offset inwards by the roller radius; it is free of undercut
    (no loop, no cusp) only where the roller radius is smaller than this radius.
    Returns inf when the curve has no convex part. One tooth period sampled at ``n`` points,
    then ``n_fine`` points across the two intervals around the largest curvature (the
    resolution of 100 000 uniform samples; every DriveDesign is validated with it, an FMU's
    initialization builds two). Cached on (z1, e, lam).
    """
    # one tooth period suffices
    t = np.linspace(0.0, 2 * np.pi / (z1 - 1), n)
    kappa = pitch_curve_curvature(t, z1, e, lam)
    i = int(np.argmax(kappa))
    fine = np.linspace(t[max(i - 1, 0)], t[min(i + 1, n - 1)], n_fine)
    kmax = max(float(kappa[i]), float(np.max(pitch_curve_curvature(fine, z1, e, lam))))
    return np.inf if kmax <= 0 else 1.0 / kmax


def disc_roller_levers(theta, r_w):
    """Lever arm r_w*sin(theta) of the force on the disc roller at angle theta (Eqs. 13, 15).

    Every roller-hole force is parallel to the line of centres (the gear translates relative to
    the disc on a circle of radius e), so its lever arm about the gear centre and about the disc
    axis is the same.
    """
    return r_w * np.sin(theta)


def hole_clearance(D_cz, d_v2, e):
    """Radial clearance of a disc roller in its hole beyond the eccentricity (m)."""
    return (D_cz - d_v2) / 2 - e
