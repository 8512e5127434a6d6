"""Torsional stiffness and lost motion from the contact model: the rigid, zero-clearance limit
against its closed form, a finite difference of the solver, lost motion growing with the
profile correction, an odd twist curve, a hysteresis loop that encloses work."""
from dataclasses import replace

import numpy as np
import pytest

from model_core import DriveDesign, contact, geometry
from model_core import stiffness as st
from model_core.losses import mesh_positions


def test_linear_zero_clearance_twist_is_the_closed_form():
    """Linear contacts, no clearance anywhere: rot = T_c / (k sum l^2) for each roller set
    (the rigid load distribution of the classical theory), twist = the mean over positions."""
    d = replace(DriveDesign(), contact_law="linear", delta_z=0.0)
    assert geometry.hole_clearance(d.D_cz, d.d_v2, d.e) == pytest.approx(0.0, abs=1e-15)
    T = 7.0
    s = max(d.torque_share, 1 - d.torque_share)
    psi = mesh_positions(d)
    l_r = geometry.ring_roller_levers(contact.loaded_half_angles(psi, d.z1), d.e, d.z1, d.lam)
    l_d = geometry.disc_roller_levers(contact.loaded_half_angles(psi, d.n_disc_rollers), d.r_w)
    k = d.linear_stiffness
    expect = np.mean(s * T / (k * np.sum(np.clip(l_r, 0, None) ** 2, -1))
                     + s * T / (k * np.sum(np.clip(l_d, 0, None) ** 2, -1)))
    assert st.twist(d, T) == pytest.approx(expect, rel=1e-9)
    # linear and clearance-free: the stiffness is the same at every torque
    assert st.torsional_stiffness(d, 2.0) == pytest.approx(st.torsional_stiffness(d, 10.0),
                                                             rel=1e-6)
    assert st.backlash(d) == pytest.approx(0.0, abs=1e-12)


def test_stiffness_is_the_solvers_finite_difference():
    d = DriveDesign()
    T = 9.0
    h = 1e-5 * T
    fd = 2 * h / (st.twist(d, T + h) - st.twist(d, T - h))
    assert st.torsional_stiffness(d, T) == pytest.approx(fd, rel=1e-3)
    # Palmgren contacts stiffen with load
    assert st.torsional_stiffness(d, 2 * T) > st.torsional_stiffness(d, T)


def test_lost_motion_grows_with_the_profile_correction():
    lm = [st.catalogue_values(replace(DriveDesign(), delta_z=dz))["lost_motion_arcmin"]
          for dz in (0.0, 0.02e-3, 0.05e-3, 0.1e-3)]
    assert all(b > a for a, b in zip(lm, lm[1:])), lm
    # the correction's free rotation dominates: 2 delta_z / (e (z1 - 1)) in arcmin
    d = DriveDesign()
    free = 2 * d.delta_z / (d.e * (d.z1 - 1)) * st.RAD_TO_ARCMIN
    assert st.catalogue_values(d)["backlash_arcmin"] == pytest.approx(free, rel=0.05)


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
    assert (tmp_path / "s" / "stiffness.png").stat().st_size > 1000
    bad = subprocess.run([sys.executable, "-m", "cyclo_fmu.cli", "stiffness", "--rated-torque",
                          "-3"], capture_output=True, text=True, timeout=120)
    assert bad.returncode == 2 and "rated-torque" in bad.stderr
