"""Contact forces: closed forms of the rigid theory, torque balance, Eq. (19), clearance."""
import numpy as np
import pytest

from model_core import DriveDesign, contact, geometry

RIGID = dict(contact_law="linear", linear_stiffness=1e13, delta_z=0.0)


def positions(n, pitch):
    return np.arange(n) * pitch / n


def test_rigid_ring_roller_peak_force_closed_form():
    d = DriveDesign(**RIGID)
    Tc = 3.0
    psi = positions(32, 2 * np.pi / d.z1)
    phi, F = contact.ring_roller_forces(d, Tc, psi)
    l = geometry.ring_roller_levers(phi, d.e, d.z1, d.lam)
    loaded = F > 0
    # rigid theory: F_i = F_max * l_i / r'_c  with  F_max = 4 T_c / (K1 z_c r_p)
    coef = np.where(loaded, F / np.where(loaded, l / (d.e * d.z_c), 1), np.nan)
    closed = 4 * Tc / (d.K1 * d.z_c * d.r_p)
    assert np.nanmean(coef) == pytest.approx(closed, rel=5e-3)
    assert np.all(np.abs(np.nanmax(coef, -1) / closed - 1) < 0.01)
    # every loaded roller on the same line F_i / l_i (rigid body rotation, linear springs)
    assert np.allclose(np.nanmin(coef, -1), np.nanmax(coef, -1), rtol=1e-9)


def test_rigid_disc_roller_peak_force_closed_form():
    d = DriveDesign(**RIGID)
    Tc = 3.0
    theta, Q = contact.disc_roller_forces(d, Tc, positions(32, 2 * np.pi / d.n_disc_rollers))
    s = np.sin(theta)
    coef = np.where((Q > 0) & (s > 0.05), Q / np.where(s > 0.05, s, 1), np.nan)
    assert np.nanmean(np.nanmax(coef, -1)) == pytest.approx(4 * Tc / (d.n_disc_rollers * d.r_w), rel=1e-2)


@pytest.mark.parametrize("law", ["hertz", "linear"])
@pytest.mark.parametrize("Tc", [0.05, 1.0, 20.0])
def test_torque_balance(law, Tc):
    d = DriveDesign(contact_law=law)
    psi = positions(9, 2 * np.pi / d.z1)
    phi, F = contact.ring_roller_forces(d, Tc, psi)
    l = geometry.ring_roller_levers(phi, d.e, d.z1, d.lam)
    np.testing.assert_allclose((F * l).sum(-1), Tc, rtol=1e-9)
    theta, Q = contact.disc_roller_forces(d, Tc, psi)
    np.testing.assert_allclose((Q * d.r_w * np.sin(theta)).sum(-1), Tc, rtol=1e-9)


def test_eccentric_force_eq19():
    """F_EV = T_S/e per gear, with T_S = T_c/z_c from the torque balance of the gear."""
    d = DriveDesign()
    Tc = 4.0
    psi = positions(16, 2 * np.pi / d.z1)
    phi, F = contact.ring_roller_forces(d, Tc, psi)
    _, Q = contact.disc_roller_forces(d, Tc, psi / d.i0)
    F_EV, F_EH = contact.eccentric_bearing_force(d, phi, F, Q)
    np.testing.assert_allclose(F_EV, (Tc / d.z_c) / d.e, rtol=1e-9)
    assert np.all(np.abs(F_EH) > 0)


def test_more_clearance_fewer_loaded_rollers_at_light_load():
    psi = positions(16, 2 * np.pi / 15)
    counts = []
    for dz in (0.0, 0.005e-3, 0.01e-3, 0.03e-3):
        d = DriveDesign(delta_z=dz)
        _, F = contact.ring_roller_forces(d, 4.0, psi)
        counts.append((F > 0).sum(-1).mean())
    assert all(a > b for a, b in zip(counts, counts[1:])), counts


def test_more_load_more_loaded_rollers():
    d = DriveDesign()
    psi = positions(16, 2 * np.pi / 15)
    n = [(contact.ring_roller_forces(d, T, psi)[1] > 0).sum(-1).mean() for T in (0.1, 2.0, 50.0)]
    assert n[0] < n[1] < n[2]


def test_equidistant_clearance_zero_at_first_contact():
    d = DriveDesign()
    phi_star = np.arccos(d.K1)
    assert geometry.modification_clearance(phi_star, d.lam, 0.05e-3) == pytest.approx(0, abs=1e-15)
    assert geometry.modification_clearance(phi_star, d.lam, 0.05e-3, "offset") == pytest.approx(0, abs=1e-15)
    phi = np.linspace(0.01, np.pi - 0.01, 50)
    assert np.all(geometry.modification_clearance(phi, d.lam, 0.05e-3) >= 0)


def test_min_radius_of_curvature_matches_three_point_circles():
    """Analytic curvature vs circles through neighbouring points of the pitch curve."""
    z1, e, lam = 15, 2e-3, 1.6
    t = np.linspace(0, 2 * np.pi / (z1 - 1), 4001)
    r_p = lam * e * z1
    p = np.stack([r_p * np.cos(t) - e * np.cos(z1 * t), r_p * np.sin(t) - e * np.sin(z1 * t)], -1)
    a, b, c = p[:-2], p[1:-1], p[2:]
    ab, bc, ca = (np.linalg.norm(b - a, axis=1), np.linalg.norm(c - b, axis=1),
                  np.linalg.norm(a - c, axis=1))
    cross = (b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0]
    R = ab * bc * ca / (2 * cross)   # signed: > 0 where the curve turns left (convex tips)
    assert np.min(R[R > 0]) == pytest.approx(geometry.min_radius_of_curvature(z1, e, lam), rel=1e-4)


def test_profile_is_z1_minus_1_lobed():
    x, y = geometry.cycloid_profile(15, 2e-3, 1.6, 6e-3, n=14000)
    r = np.hypot(x, y)
    peaks = np.sum((r > np.roll(r, 1)) & (r > np.roll(r, -1)))
    assert peaks == 14
