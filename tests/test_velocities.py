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
