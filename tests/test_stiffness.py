"""Torsional stiffness and lost motion from the contact model: the rigid, zero-clearance limit
against its closed form, a finite difference of the solver, lost motion growing with the
profile correction, an odd twist curve, a hysteresis loop that encloses work."""
from dataclasses import replace

import numpy as np
import pytest

from model_core import DriveDesign, contact, geometry
from model_core import stiffness as st
from model_core.losses import mesh_positions


def _no_clearance(**kw):
    """Linear contacts and no clearance anywhere (needle rollers with zero internal clearance:
    no pin gap)."""
    return replace(DriveDesign(), contact_law="linear", delta_z=0.0, ring_rollers="needle",
                   disc_rollers="needle", bearing_clearance=0.0, **kw)


def test_linear_zero_clearance_twist_is_springs_in_series():
    """Linear contacts, no clearance: every roller is its contact spring k in series with its
    pin c (compliances add: 1/k_eff = 1/k + c), so rot = T_c / (k_eff sum l^2) for each roller
    set (the rigid load distribution), split between contact and pin as 1/k : c; the shafts
    twist T L / (G J); the parts add up to the twist."""
    d = _no_clearance()
    assert geometry.hole_clearance(d.D_cz, d.d_v2, d.e) == pytest.approx(0.0, abs=1e-15)
    T = 7.0
    s = max(d.torque_share, 1 - d.torque_share)
    psi = mesh_positions(d)
    l_r = geometry.ring_roller_levers(contact.loaded_half_angles(psi, d.z1), d.e, d.z1, d.lam)
    l_d = geometry.disc_roller_levers(contact.loaded_half_angles(psi, d.n_disc_rollers), d.r_w)
    k = d.linear_stiffness
    parts = st.twist_parts(d, T)
    for name, l in (("ring", l_r), ("disc", l_d)):
        c = st.pin_compliance(d, name)
        k_eff = 1.0 / (1.0 / k + c)
        expect = np.mean(s * T / (k_eff * np.sum(np.clip(l, 0, None) ** 2, -1)))
        got = parts[f"{name}_contact"] + parts[f"{name}_pins"]
        assert got[0] == pytest.approx(expect, rel=1e-9)
        assert parts[f"{name}_pins"][0] / parts[f"{name}_contact"][0] == pytest.approx(c * k, rel=1e-9)
        assert parts[f"{name}_clearance"][0] == pytest.approx(0.0, abs=1e-15)
    J = np.pi * d.output_shaft_diameter ** 4 / 32
    assert parts["output_shaft"][0] == pytest.approx(T * d.output_shaft_length / (st.STEEL_G * J))
    assert st.twist(d, T) == pytest.approx(sum(v[0] for v in parts.values()), rel=1e-12)
    # stiffer pins (the largest pins the rollers allow) stiffen the drive
    stiff_pins = _no_clearance(d_o1=11.9e-3, d_o2=13.9e-3)
    assert st.torsional_stiffness(stiff_pins, 5.0) > st.torsional_stiffness(d, 5.0)
    # no clearance anywhere: no dead band
    assert st.backlash(d) == pytest.approx(0.0, abs=1e-12)


def test_pin_compliance_is_castigliano_of_the_beam():
    """The pin's compliance at its load (Roark Table 8.1 case 1e plus Timoshenko shear)
    against Castigliano's theorem evaluated numerically, delta = int M^2/(EI P) + V^2/(kGA P)
    over the beam, and at mid-span against Roark's P L^3 / (48 E I) (+ shear P L / (4 k G A))."""
    d, L = 8e-3, 27e-3
    A, I, _ = st.round_section(d)
    E, G, k = st.STEEL_E, st.STEEL_G, st.SHEAR_COEFFICIENT_ROUND
    for a in (7e-3, 13.5e-3, 20e-3):
        b = L - a
        x = np.linspace(0, L, 200001)
        M = np.where(x < a, b * x / L, a * (L - x) / L)        # unit load at a
        V = np.where(x < a, b / L, a / L)
        delta = np.trapezoid(M ** 2, x) / (E * I) + np.trapezoid(V ** 2, x) / (k * G * A)
        assert st.simply_supported_compliance(a, L, d) == pytest.approx(delta, rel=1e-6)
    mid = L ** 3 / (48 * E * I) + L / (4 * k * G * A)
    assert st.simply_supported_compliance(L / 2, L, d) == pytest.approx(mid, rel=1e-12)


def test_series_solver_against_the_contact_solver():
    """Without pins (c = 0) the series solver is the contact solver of model_core.contact
    (Palmgren law, with the profile correction's clearances)."""
    d = DriveDesign()
    psi = mesh_positions(d)
    phi = contact.loaded_half_angles(psi, d.z1)
    l = geometry.ring_roller_levers(phi, d.e, d.z1, d.lam)
    c = geometry.modification_clearance(phi, d.lam, d.delta_z, d.profile_modification)
    K = contact.palmgren_stiffness(d.b1)
    T = np.array([0.5, 5.0, 50.0])
    rot, _ = st.solve_series_set(l, c, T, K, "hertz", 0.0)
    ref = contact.solve_rotation(np.broadcast_to(l, (3,) + l.shape),
                                 np.broadcast_to(c, (3,) + c.shape),
                                 np.broadcast_to(T[:, None], (3, l.shape[0])), "hertz", K)
    np.testing.assert_allclose(rot, ref, rtol=1e-10)


def test_paper_drive_in_the_band_of_small_reducers():
    """The paper's drive (12 N*m rated) lands in the torsional rigidity band of small
    reducers, 2-15 N*m/arcmin (Harmonic Drive RSF-14: 1.0-1.7), not at the ~100 of the Hertz
    contacts alone; every series element is named with its share, the shares sum to 1."""
    v = st.catalogue_values(DriveDesign())
    assert 2.0 <= v["torsional_rigidity_Nm_per_arcmin"] <= 15.0
    shares = {k: e["rigidity_compliance_share"] for k, e in v["elements"].items()}
    assert sum(shares.values()) == pytest.approx(1.0, abs=1e-6)
    assert set(shares) == set(st.ELEMENT_DESCRIPTIONS)
    # the elements' lost motions add up to the drive's
    lm = sum(e["lost_motion_arcmin"] for e in v["elements"].values())
    assert lm == pytest.approx(v["lost_motion_arcmin"], rel=1e-9)


def test_static_rating_is_the_weakest_element():
    """The rating is the minimum over the elements, the limiting one named; at each element's
    torque its own limit is reached (C0 of ISO 76 for the bearing, yield for pins and shaft)."""
    d = DriveDesign()
    r = st.static_torque_rating(d)
    assert r["rating_Nm"] == min(r["elements"].values())
    assert r["elements"][r["limiting"]] == r["rating_Nm"]
    # ISO 76: C0r = 44 (1 - Dwe/Dpw) Z Lwe Dwe = 44 * (1 - 2.5/27.5) * 24 * 10 * 2.5 N
    assert st.eccentric_bearing_C0(d) == pytest.approx(44 * (1 - 2.5 / 27.5) * 24 * 10 * 2.5)
    loads = st._element_loads(d, r["elements"]["eccentric_bearing"])
    assert loads["eccentric_bearing"][0][0] == pytest.approx(st.eccentric_bearing_C0(d), rel=1e-6)
    loads = st._element_loads(d, r["elements"]["ring_pins"])
    assert loads["ring_pins"][0][0] == pytest.approx(st.YIELD_STRENGTH, rel=1e-6)
    loads = st._element_loads(d, r["elements"]["ring_contact"])
    assert loads["ring_contact"][0][0] == pytest.approx(contact.STATIC_CONTACT_PRESSURE_LIMIT,
                                                        rel=1e-6)
    # Johnson's line contact: p0 = sqrt(F E* / (pi l R))
    assert float(contact.line_contact_pressure(1000.0, 0.012, 0.006)) == pytest.approx(
        np.sqrt(1000.0 * 210e9 / (2 * (1 - 0.09)) / (np.pi * 0.012 * 0.006)))
    T_shaft = st.YIELD_STRENGTH / np.sqrt(3) * np.pi * d.output_shaft_diameter ** 3 / 16
    assert r["elements"]["output_shaft"] == pytest.approx(T_shaft, rel=1e-9)
    # far below the ring contacts' rating alone (the rating before pins and bearings counted)
    assert r["rating_Nm"] < 0.5 * r["elements"]["ring_contact"]
    # a thin output shaft becomes the limit
    weak = d.replace(output_shaft_diameter=8e-3)
    assert st.static_torque_rating(weak)["limiting"] == "output_shaft"


@pytest.mark.parametrize("field,values", [
    ("bearing_clearance", (0.0, 0.01e-3, 0.03e-3)),
    ("D_cz", (18e-3, 18.01e-3, 18.03e-3)),
    ("delta_z", (0.0, 0.02e-3, 0.05e-3))])
def test_lost_motion_grows_with_every_clearance(field, values):
    lm = [st.catalogue_values(replace(DriveDesign(), **{field: x}))["lost_motion_arcmin"]
          for x in values]
    assert all(b > a for a, b in zip(lm, lm[1:])), lm


def test_lost_motion_grows_with_pin_clearance():
    from model_core.design import Friction
    lm = [st.catalogue_values(replace(DriveDesign(), friction=Friction(pin_clearance_ratio=r)))
          ["lost_motion_arcmin"] for r in (1e-4, 1e-3, 3e-3)]
    assert all(b > a for a, b in zip(lm, lm[1:])), lm


def test_stiffness_is_the_solvers_finite_difference():
    d = DriveDesign()
    T = 9.0
    h = 1e-5 * T
    fd = 2 * h / (st.twist(d, T + h) - st.twist(d, T - h))
    assert st.torsional_stiffness(d, T) == pytest.approx(fd, rel=1e-3)
    # Palmgren contacts stiffen with load
    assert st.torsional_stiffness(d, 2 * T) > st.torsional_stiffness(d, T)


def test_backlash_is_the_sum_of_the_free_rotations():
    """Backlash: each clearance's free rotation at the output, both sides: the profile
    correction and the ring pin gap at the gear's pitch radius e (z1 - 1), the eccentric
    bearing's half clearance likewise (a tangential shift u of the gear is an eccentric
    rotation u/e), the disc pin gap at about the disc pitch radius (within 5 %: the largest
    disc lever arm varies over the mesh cycle)."""
    d = DriveDesign()
    ez = d.e * (d.z1 - 1)
    g1, g2 = st.pin_gap(d, "ring"), st.pin_gap(d, "disc")
    free = 2 * ((d.delta_z + g1) / ez + g2 / d.r_w + d.bearing_clearance / 2 / ez)
    assert st.catalogue_values(d)["backlash_arcmin"] == pytest.approx(
        free * st.RAD_TO_ARCMIN, rel=0.05)


def test_twist_is_odd_and_the_loop_encloses_work():
    d = DriveDesign()
    T = np.linspace(0.5, 12.0, 7)
    np.testing.assert_allclose(st.twist(d, -T), -st.twist(d, T), rtol=1e-13)
    loop = st.hysteresis_loop(d)
    assert 0 < loop["eta_mesh"] < 1
    # the applied torque rising lies above the one falling at every twist: friction dissipates
    up, down = loop["torque_loading_Nm"], loop["torque_unloading_Nm"]
    assert np.all(up[loop["twist_rad"] > 0] > down[loop["twist_rad"] > 0])
    work = np.trapezoid(up - down, loop["twist_rad"])
    assert work > 0


def test_cli_stiffness(tmp_path):
    import json
    import subprocess
    import sys
    r = subprocess.run([sys.executable, "-m", "cyclo_fmu.cli", "stiffness", "--json", "--out",
                        str(tmp_path / "s")], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    v = json.loads(r.stdout)
    assert v["torsional_rigidity_Nm_per_arcmin"] > 0 and v["lost_motion_arcmin"] > v["backlash_arcmin"]
    assert v["static_rating"]["limiting"] in v["static_rating"]["elements"]
    assert "output_shaft" in v["elements"]
    text = subprocess.run([sys.executable, "-m", "cyclo_fmu.cli", "stiffness"],
                          capture_output=True, text=True, timeout=120).stdout
    assert "ring_pins" in text and "limited by" in text
    assert (tmp_path / "s" / "stiffness.png").stat().st_size > 1000
    bad = subprocess.run([sys.executable, "-m", "cyclo_fmu.cli", "stiffness", "--rated-torque",
                          "-3"], capture_output=True, text=True, timeout=120)
    assert bad.returncode == 2 and "rated-torque" in bad.stderr


def test_sweep_stiffness_columns_are_the_catalogue_values():
    from cyclo_fmu.sweep import stiffness_columns
    d = DriveDesign()
    cols = stiffness_columns(d)
    v = st.catalogue_values(d)
    assert cols["torsional_rigidity_Nm_arcmin"] == pytest.approx(
        v["torsional_rigidity_Nm_per_arcmin"], rel=1e-12)
    assert cols["lost_motion_arcmin"] == pytest.approx(v["lost_motion_arcmin"], rel=1e-12)
    assert cols["stiffness_Nm_rad"] == pytest.approx(v["stiffness_Nm_per_rad"], rel=1e-12)


def test_ring_contact_rating_is_hertz_inverted_on_the_roller_radius():
    """At the ring contacts' element torque the most loaded ring roller carries exactly the force
    at which Johnson's line-contact pressure reaches 4000 MPa on the roller's own radius,
    R = d_v1 / 2 (the conforming flank only enlarges the contact): F = pi b1 R p0^2 / E*
    (Eq. 4.45 inverted), with E* = 210 GPa / (2 (1 - 0.3^2))."""
    d = DriveDesign()
    T = st.static_torque_rating(d)["elements"]["ring_contact"]
    share = max(d.torque_share, 1.0 - d.torque_share)
    F_max = float(np.max(st.gear_path(d, share * T)["F_ring"]))
    E_star = 210e9 / (2 * (1 - 0.3 ** 2))
    assert F_max == pytest.approx(np.pi * d.b1 * (d.d_v1 / 2) * 4.0e9 ** 2 / E_star, rel=1e-6)
