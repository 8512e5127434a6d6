"""Efficiency: Kreines formulas, Eq. (28) in every mode and quadrant, energy balance,
self-locking, trends, mesh-cycle convergence, the paper's numbers."""
import numpy as np
import pytest

from model_core import (MODES, DriveDesign, Friction, kreines_efficiency, operating_point,
                        partial_losses, rpm_to_rad_s)
from model_core.efficiency import basic_efficiency
from model_core.kinematics import parse_mode, reverse_mode
from model_core.paper import PAPER_THEORY, envelope_statistics

I0 = 14 / 15


@pytest.mark.parametrize("mode, expected", [
    ("12", 0.962), ("21", 0.962), ("S1", 0.6527), ("S2", 0.6279), ("1S", 0.4470), ("2S", 0.4300)])
def test_kreines_table(mode, expected):
    assert kreines_efficiency(mode, 0.962, I0) == pytest.approx(expected, abs=5e-5)


def test_kreines_relations():
    for eta0 in (0.9, 0.95, 0.99):
        assert kreines_efficiency("S2", eta0, I0) == pytest.approx(eta0 * kreines_efficiency("S1", eta0, I0))
        assert kreines_efficiency("2S", eta0, I0) == pytest.approx(eta0 * kreines_efficiency("1S", eta0, I0))
    assert kreines_efficiency("1S", 1.0, I0) == pytest.approx(1.0)
    assert kreines_efficiency("1S", I0, I0) == pytest.approx(0.0)   # locking limit eta0 = i0


def _input_speed(mode, rpm=1500.0):
    """A representative input speed: fast for S, slow for a shaft that is geared up."""
    a = parse_mode(mode)[0]
    return rpm_to_rad_s(rpm if a == "S" else rpm / 15)


def _input_torque(mode):
    a = parse_mode(mode)[0]
    return 0.6 if a == "S" else 8.0


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("sw, st", [(1, 1), (-1, -1), (1, -1), (-1, 1)])
def test_energy_balance_and_eq28_equals_kreines(design, mode, sw, st):
    op = operating_point(design, mode, sw * _input_speed(mode), st * _input_torque(mode))
    p_ext = sum(op.torques[s] * op.speeds[s] for s in "12S")   # power into the reducer
    assert p_ext == pytest.approx(float(op.loss_power), rel=1e-8)
    assert float(op.loss_power) > 0
    assert float(op.input_power) == pytest.approx(float(op.output_power + op.loss_power), rel=1e-9)
    assert bool(op.flow_forward) == (sw * st > 0)
    a = parse_mode(mode)[0]
    assert float(op.torques[a]) == pytest.approx(st * _input_torque(mode), rel=1e-8)
    if not op.locked:
        assert float(op.eta) == pytest.approx(float(op.eta_kreines), rel=1e-9)
        assert 0 < float(op.eta) < 1


def test_eq29_basic_efficiency(design):
    op = operating_point(design, "12", 30.0, 8.0)
    eta0 = basic_efficiency(op.torques["1"], op.torques["2"], op.speeds["1"], op.speeds["2"])
    assert float(eta0) == pytest.approx(float(op.eta0), rel=1e-9)
    assert float(op.eta) == pytest.approx(float(op.eta0), rel=1e-9)


def test_same_relative_motion_same_losses(design):
    """Losses follow the relative motion: S1 and 12 at the same w1 - wS and T1 agree."""
    s1 = operating_point(design, "S1", 200.0, 0.6)
    w1_rel = float(s1.speeds["1"] - s1.speeds["S"])
    m12 = operating_point(design, "12", w1_rel, float(s1.torques["1"]))
    assert float(m12.speeds["2"]) == pytest.approx(float(s1.speeds["2"] - s1.speeds["S"]))
    assert float(m12.loss_power) == pytest.approx(float(s1.loss_power), rel=1e-8)
    assert float(m12.eta0) == pytest.approx(float(s1.eta0), rel=1e-10)
    # and the mode efficiencies are Kreines' functions of that one eta0
    assert float(s1.eta) == pytest.approx(float(kreines_efficiency("S1", m12.eta, I0)), rel=1e-8)


@pytest.mark.parametrize("mode", MODES)
def test_known_torque_reproduced_or_flagged_over_decades(design, mode):
    """From 1e-6 to 10 N*m: the given torque is reproduced, or the point is flagged (stall)
    with NaN torques; never a plausible-looking wrong answer."""
    a = parse_mode(mode)[0]
    T = np.geomspace(1e-6, 10.0, 15) * (1 if a == "S" else 12)
    for sign in (1, -1):
        op = operating_point(design, mode, _input_speed(mode), sign * T)
        ok = np.isfinite(op.torques[a])
        np.testing.assert_allclose(op.torques[a][ok], sign * T[ok], rtol=1e-6)
        assert np.all(np.isnan(op.eta[~ok]))
        assert ok[-5:].all()                       # the bench's torques always run
        p_ext = sum(op.torques[s] * op.speeds[s] for s in "12S")
        np.testing.assert_allclose(p_ext[ok], op.loss_power[ok], rtol=1e-8)


def test_self_locking_back_drive_is_reported_locked():
    sticky = DriveDesign(profile="paper", friction=Friction(mu_boundary=0.3))
    op = operating_point(sticky, "1S", rpm_to_rad_s(100), 8.0)
    assert float(op.eta0) < I0
    assert bool(op.locked) and np.isnan(op.eta)
    # back-driven with the torque given on S: no finite torque can do it
    held = operating_point(sticky, "S1", rpm_to_rad_s(1500), -0.6)
    assert bool(held.locked) and np.isnan(held.torques["1"]) and np.isnan(held.eta)
    # the forward direction of the same drive still runs
    fwd = operating_point(sticky, "S1", rpm_to_rad_s(1500), 0.6)
    assert not bool(fwd.locked) and 0 < float(fwd.eta) < 1


def test_default_drive_back_drives(design):
    op = operating_point(design, "1S", rpm_to_rad_s(100), 8.0)
    assert not bool(op.locked)
    assert float(op.eta0) > I0


def test_efficiency_rises_with_torque(design):
    """The paper (Section 5): efficiency increases with torque."""
    for mode in ("S1", "S2"):
        op = operating_point(design, mode, rpm_to_rad_s(2000), np.linspace(0.3, 0.85, 6))
        assert np.all(np.diff(op.eta) > 0), op.eta


def test_mesh_cycle_average_converged(design):
    etas = [float(operating_point(design.replace(n_positions=n), "S1", 250.0, 0.5).eta)
            for n in (design.n_positions, 64)]
    assert abs(etas[0] - etas[1]) < 5e-5


def test_largest_losses_are_roller_pin_sliding_and_needles_help(design):
    op = operating_point(design, "S1", rpm_to_rad_s(2800), 0.85)
    L = op.losses.as_dict()
    two_largest = sorted(L, key=L.get)[-2:]
    assert set(two_largest) == {"PL3", "PL6"}
    needle = operating_point(design.replace(ring_rollers="needle", disc_rollers="needle"),
                             "S1", rpm_to_rad_s(2800), 0.85)
    assert float(needle.eta) > float(op.eta) + 0.05
    assert float(needle.losses.PL6) < 0.5 * float(op.losses.PL6)


@pytest.mark.parametrize("mode", ["S1", "S2"])
def test_paper_envelope(design, mode):
    s = envelope_statistics(design, mode)
    ref = PAPER_THEORY[mode]
    assert ref["min"] - 0.01 <= s["min"] and s["max"] <= ref["max"] + 0.01
    assert abs(s["mean"] - ref["mean"]) <= 0.01


def test_vectorised_map_equals_points(design):
    w = rpm_to_rad_s(np.array([[1000.0], [2800.0]]))
    T = np.array([[0.3, 0.85]])
    grid = operating_point(design, "S2", w, T)
    for i in range(2):
        for j in range(2):
            single = operating_point(design, "S2", float(w[i, 0]), float(T[0, j]))
            assert float(single.eta) == pytest.approx(float(grid.eta[i, j]), rel=1e-9)


def test_unloaded_and_bad_points(design):
    from model_core import CycloidInputError
    with pytest.raises(CycloidInputError, match="speed"):
        operating_point(design, "S1", 0.0, 0.5)
    with pytest.raises(CycloidInputError, match="torque"):
        operating_point(design, "S1", 100.0, float("nan"))
    with pytest.raises(CycloidInputError, match="mode"):
        operating_point(design, "S3", 100.0, 0.5)
    op = operating_point(design, "S1", 100.0, 0.0)
    assert float(op.loss_power) == 0 and np.isnan(op.eta)


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("sign", [1, -1])
def test_known_output_torque_gives_the_same_point(design, mode, sign):
    fwd = operating_point(design, mode, _input_speed(mode), sign * _input_torque(mode))
    b = parse_mode(mode)[1]
    back = operating_point(design, mode, _input_speed(mode), T_out=float(fwd.torques[b]))
    for s in "12S":
        assert float(back.torques[s]) == pytest.approx(float(fwd.torques[s]), rel=1e-7)
    assert float(back.loss_power) == pytest.approx(float(fwd.loss_power), rel=1e-7)
    assert bool(back.flow_forward) == bool(fwd.flow_forward)


def test_mesh_loss_closes_the_energy_balance():
    """The calibrated mesh-loss element (efficiency 1 - k in series, disc side) closes the gear's
    energy balance in both relative flow directions, with eta0 = eta0_m (1 - k): ring driving,
    |T1 w1'| (1 - eta0) = x |T1 w1'| + PL_mesh with eta0_m = 1 - x; disc driving,
    |T1 w1'| (1 / eta0 - 1) = x |T1 w1'| + PL_mesh with eta0_m = 1 / (1 + x)."""
    from model_core.efficiency import mesh_loss
    x = np.array([0.02, 0.1, 0.3])
    P = np.array([1.0, 50.0, 400.0])                     # |T1 w1'| [W]
    for k in (0.0, 0.05, 0.2):
        eta0, PL = mesh_loss(1.0 - x, x, np.ones(3), P, k)
        np.testing.assert_allclose(eta0, (1.0 - x) * (1.0 - k), rtol=1e-14)
        np.testing.assert_allclose(P * (1.0 - eta0), x * P + PL, rtol=1e-12)
        eta0, PL = mesh_loss(1.0 / (1.0 + x), x, -np.ones(3), P, k)
        np.testing.assert_allclose(P * (1.0 / eta0 - 1.0), x * P + PL, rtol=1e-12)
