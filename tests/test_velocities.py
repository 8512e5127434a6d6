"""Contact velocities: Eq. (4) against the geometry, the sliding identity, Eq. (9)."""
import numpy as np
import pytest

from model_core import velocities


def test_delta_prime_is_rate_of_contact_round_roller():
    """delta' (Eq. 4) = turning rate of the line D->P seen from the ring, per omega_r."""
    z1, e, lam = 15, 2e-3, 1.6
    r_p, a = lam * e * z1, e * z1
    phi = np.linspace(0.2, 3.0, 15)
    h = 1e-6
    ang = lambda p: np.arctan2(a * np.sin(-p) - 0.0, a * np.cos(-p) - r_p)  # D at (r_p, 0), P at angle -phi
    dtheta = (ang(phi + h) - ang(phi - h)) / (2 * h)
    # the pitch point turns round the ring at w1' = (z1-1)*omega_r
    np.testing.assert_allclose(np.abs(dtheta) * (z1 - 1),
                               np.abs(velocities.delta_prime(phi, z1, lam)), rtol=1e-6)


def test_sliding_speed_against_mesh_finite_differences():
    """Move the ring and the gear a little (carrier held) and difference the material points at
    the contact: their relative speed is the fixed-pin sliding speed (|DP| - r_c) omega_r."""
    z1, e, lam, r_c = 15, 2e-3, 1.6, 6e-3
    r_p, i0 = lam * e * z1, (z1 - 1) / z1
    w2 = 10.0                      # gear speed relative to the carrier; ring: w1 = i0 * w2
    w1 = i0 * w2
    for phi in (0.6, 0.9, 1.2, 1.8):
        D = r_p * np.array([np.cos(phi), np.sin(phi)])
        P = np.array([e * z1, 0.0])
        C = D + r_c * (P - D) / np.linalg.norm(P - D)      # contact point
        h = 1e-7
        rot = lambda a: np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
        O_c = np.array([e, 0.0])
        v_ring = (rot(w1 * h) @ C - C) / h                  # ring turns about O_a = 0
        v_gear = (rot(w2 * h) @ (C - O_c) + O_c - C) / h     # gear turns about O_c
        slide = np.linalg.norm(v_ring - v_gear)
        expected = velocities.ring_contact_sliding(phi, e, z1, lam, r_c,
                                                   velocities.relative_ring_speed(w2, z1))
        assert slide == pytest.approx(expected, rel=1e-5)


def test_sliding_is_difference_of_surface_speeds():
    z1, e, lam, r_c, w = 15, 2e-3, 1.6, 6e-3, 10.0
    phi = np.linspace(0.9, 1.4, 5)   # around the most loaded roller, where v_rt, v_ra > 0
    vs = velocities.ring_contact_sliding(phi, e, z1, lam, r_c, w)
    vrt = velocities.profile_velocity(phi, e, z1, lam, r_c, w)
    vra = velocities.roller_side_velocity(phi, z1, lam, r_c, w)
    np.testing.assert_allclose(vs, vrt + np.abs(vra) * np.sign(vra), rtol=1e-12)
    np.testing.assert_allclose(velocities.summary_rolling_velocity(phi, e, z1, lam, r_c, w),
                               vrt - vra, rtol=1e-12)


def test_pin_sliding_scales_with_diameters():
    v = velocities.ring_pin_sliding(1.0, 2e-3, 15, 1.6, 12e-3, 8e-3, 10.0)
    assert v == pytest.approx(8 / 12 * velocities.ring_contact_sliding(1.0, 2e-3, 15, 1.6, 6e-3, 10.0))
    # a hole translating on a circle of radius e drives the disc roller at e*Omega
    assert velocities.disc_pin_sliding(2e-3, 14e-3, 10e-3, 5.0) == pytest.approx(2e-3 * 10 / 14 * 5)
    assert velocities.disc_pin_sliding(2e-3, 14e-3, 10e-3, 5.0, D_cz=18e-3) == pytest.approx(9e-3 * 10 / 14 * 5)
