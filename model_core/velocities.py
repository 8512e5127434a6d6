"""Velocities at the contacts (Eqs. 2-9, 22, 24), in the carrier-fixed frame, m/s.

Ring side. The ring turns at w1' = w1 - wS, the gear at w2' = w2 - wS, w1' = i0*w2'.
omega_r = |w1' - w2'| = |w2'|/z1 is their relative angular speed (Eq. 5). Relative to the
gear, the ring turns about the pitch point P, so two bodies' velocities at a contact point C
differ by omega_r*|CP| (law of gearing):

    fixed-pin sliding    v_s  = (e z1 S_l - r_c) omega_r             = v_rt + v_ra
    profile velocity     v_rt = (e z1 S_l - r_c (1 + delta')) omega_r  (Eq. 6)
    roller-side velocity v_ra = r_c delta' omega_r                     (Eq. 7)
    summary rolling      v_sum = v_rt - v_ra                            (Eq. 3)
    delta' = (z1-1)(1 - lambda cos phi)/(1 + lambda^2 - 2 lambda cos phi)   (Eq. 4)
    S_l = sqrt(1 + lambda^2 - 2 lambda cos phi)

Erratum: the paper prints +2*lambda*cos(beta) under the root of Eqs. (3), (6) and -2*lambda*cos
in Eq. (4); one angle origin must serve all three. With phi from the line of centres on the
pitch-point side, |D P| = e z1 S_l (the minus sign) holds for all.

A free roller rolls on the tooth, so it spins relative to its pin at v_s/r_c and the pin sees
sliding at v_pin = (d_o1/d_v1) v_s (Eqs. 8, 9).

Disc side. Relative to the disc the gear translates on a circle of radius e at
Omega = |w2 - wS|. A disc roller rolling in its hole: the contact runs round the hole at
v_r2 = (D_CZ/2) Omega (Eq. 22, the rolling speed), the roller spins at e*Omega/r_v2 and its
pin sees sliding at v_s3 = e (d_o2/d_v2) Omega.
Erratum (derived): Eq. (24) prints (D_CZ/2)(d_o2/d_v2)|w_p - w_s|, the contact's travelling
speed instead of the roller's surface speed. A hole that translates at e*Omega drives the roller
surface at e*Omega, not (D_CZ/2)*Omega; the paper's form overstates the disc-pin sliding by
D_CZ/(2e) = 4.5 for the default design.
"""
from __future__ import annotations

import numpy as np


def relative_ring_speed(w2_rel, z1):
    """omega_r = |w1' - w2'| = |w2'|/z1 (Eq. 5), rad/s; w2_rel = w2 - wS."""
    return np.abs(w2_rel) / z1


def delta_prime(phi, z1, lam):
    """delta' of Eq. (4): rate at which the contact runs round the roller, in units of omega_r."""
    return (z1 - 1) * (1 - lam * np.cos(phi)) / (1 + lam * lam - 2 * lam * np.cos(phi))


def roller_pitch_distance(phi, e, z1, lam):
    """|D P| = e z1 sqrt(1 + lambda^2 - 2 lambda cos phi), m."""
    return e * z1 * np.sqrt(1 + lam * lam - 2 * lam * np.cos(phi))


def ring_contact_sliding(phi, e, z1, lam, r_c, omega_r):
    """Sliding speed v_s = v_rt + v_ra at the tooth if the pins were fixed, m/s (magnitude)."""
    return np.abs(roller_pitch_distance(phi, e, z1, lam) - r_c) * omega_r


def profile_velocity(phi, e, z1, lam, r_c, omega_r):
    """v_rt of Eq. (6): speed of the contact along the tooth profile, m/s (magnitude)."""
    return np.abs(roller_pitch_distance(phi, e, z1, lam)
                  - r_c * (1 + delta_prime(phi, z1, lam))) * omega_r


def roller_side_velocity(phi, z1, lam, r_c, omega_r):
    """v_ra of Eq. (7): speed of the contact round the roller, m/s (signed with delta')."""
    return r_c * delta_prime(phi, z1, lam) * omega_r


def summary_rolling_velocity(phi, e, z1, lam, r_c, omega_r):
    """v_sum = v_rt - v_ra of Eq. (3), m/s (signed)."""
    return (roller_pitch_distance(phi, e, z1, lam) - r_c * (1 + 2 * delta_prime(phi, z1, lam))) * omega_r


def ring_roller_spin(phi, e, z1, lam, r_c, omega_r):
    """Spin of a free ring roller relative to its pin, rad/s (Eq. 8 with v_s)."""
    return ring_contact_sliding(phi, e, z1, lam, r_c, omega_r) / r_c


def ring_pin_sliding(phi, e, z1, lam, d_v1, d_o1, omega_r):
    """Sliding speed between ring roller bore and pin, (d_o1/d_v1)*v_s (Eq. 9), m/s."""
    return d_o1 / d_v1 * ring_contact_sliding(phi, e, z1, lam, d_v1 / 2, omega_r)


def disc_rolling_speed(D_cz, w2_rel):
    """v_r2 = (D_CZ/2)|w_p - w_s| (Eq. 22), m/s."""
    return 0.5 * D_cz * np.abs(w2_rel)


def disc_roller_spin(e, d_v2, w2_rel):
    """Spin of a disc roller relative to its pin, e*Omega/r_v2, rad/s."""
    return 2 * e / d_v2 * np.abs(w2_rel)


def disc_pin_sliding(e, d_v2, d_o2, w2_rel, D_cz=None):
    """Sliding speed between disc roller bore and pin, m/s.

    Kinematic (derived): e*(d_o2/d_v2)*Omega. With ``D_cz`` given, the paper's Eq. (24) as
    printed: (D_CZ/2)*(d_o2/d_v2)*Omega (see the module note).
    """
    radius = e if D_cz is None else D_cz / 2
    return radius * d_o2 / d_v2 * np.abs(w2_rel)


def disc_hole_sliding(e, w2_rel):
    """Sliding speed of a disc roller that skids (stands still on its pin) in its hole, m/s:
    the hole translates at e*Omega (derived, see the module note)."""
    return e * np.abs(w2_rel)
