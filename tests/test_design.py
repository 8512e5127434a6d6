"""Design data: defaults, validation naming the field, design files."""
import math

import pytest

from model_core import CycloidInputError, DriveDesign, Friction, design_from_toml, design_to_toml


def test_defaults_are_the_paper_bench(design):
    assert (design.z1, design.n_disc_rollers) == (15, 7)
    assert design.e == 2e-3 and design.lam == 1.6 and design.delta_z == 0.05e-3
    assert design.r_p == pytest.approx(0.048) and design.K1 == pytest.approx(0.625)
    assert design.i0 == pytest.approx(14 / 15)
    assert design.lubricant.dynamic_viscosity == pytest.approx(0.18)


@pytest.mark.parametrize("changes, field", [
    (dict(lam=0.9), "lam"),                       # K1 = 1/lambda >= 1
    (dict(lam=1.0), "lam"),
    (dict(z1=2), "z1"),
    (dict(d_o1=12e-3), "d_o1"),                   # pin >= roller
    (dict(d_o2=15e-3), "d_o2"),
    (dict(e=-1e-3), "e"),
    (dict(b1=0.0), "b1"),
    (dict(lam=1.2), "d_v1"),         # roller radius 6 mm > rho_min 6.05 mm - delta_z
    (dict(D_cz=17e-3), "D_cz"),                   # hole does not clear roller + 2e
    (dict(e=float("nan")), "e"),
    (dict(d_m2=float("inf")), "d_m2"),
    (dict(ring_rollers="ball"), "ring_rollers"),
    (dict(torque_share=1.5), "torque_share"),
    (dict(friction=Friction(mu_boundary=-0.1)), "friction.mu_boundary"),
    (dict(n_disc_rollers=2), "n_disc_rollers"),
    (dict(lam="1.6"), "lam"),
    (dict(z1=15.5), "z1"),
])
def test_invalid_designs_name_the_field(changes, field):
    with pytest.raises(CycloidInputError) as info:
        DriveDesign(**changes)
    assert info.value.field == field
    assert field in str(info.value)
    assert isinstance(info.value, ValueError)


def test_undercut_limit_follows_curvature():
    from model_core.geometry import min_radius_of_curvature
    rho = min_radius_of_curvature(15, 2e-3, 1.3)   # 7.57 mm: a short-width (K1 = 0.77) profile
    small = dict(lam=1.3, d_v2=10e-3, d_o2=6e-3, D_cz=14e-3, d_m2=44e-3, D_p=26e-3, d_p=20e-3)
    DriveDesign(d_v1=2 * (rho - 0.06e-3), **small)   # just below the limit: fine
    with pytest.raises(CycloidInputError, match="undercut"):
        DriveDesign(d_v1=2 * (rho + 0.01e-3), **small)


def test_toml_round_trip(tmp_path):
    d = DriveDesign(lam=1.7, b1=10e-3, ring_rollers="needle", friction=Friction(mu_boundary=0.11))
    path = tmp_path / "d.toml"
    path.write_text(design_to_toml(d))
    assert design_from_toml(path) == d
    assert "b1_mm = 10.0" in path.read_text()


def test_toml_partial_and_errors(tmp_path):
    assert design_from_toml("[geometry]\nz1 = 17\n").z1 == 17
    with pytest.raises(CycloidInputError, match="unknown key"):
        design_from_toml("[geometry]\nz2 = 17\n")
    with pytest.raises(CycloidInputError, match="z1"):
        design_from_toml("[geometry]\nz1 = 2\n")
    with pytest.raises(CycloidInputError, match="not valid TOML"):
        design_from_toml("[geometry\n")
    with pytest.raises(CycloidInputError, match="e_mm"):
        design_from_toml('[geometry]\ne_mm = "two"\n')
    with pytest.raises(CycloidInputError, match="cannot be read"):
        design_from_toml(tmp_path / "missing.toml")


def test_whole_number_floats_become_ints():
    assert DriveDesign(z1=15.0).z1 == 15 and isinstance(DriveDesign(z1=15.0).z1, int)
