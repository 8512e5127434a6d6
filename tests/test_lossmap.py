"""The precomputed mode map used by the FMU agrees with the direct core."""
import numpy as np
import pytest

from model_core import DriveDesign, Friction, operating_point, rpm_to_rad_s
from model_core.kinematics import parse_mode
from model_core.lossmap import ModeMap
from model_core.paper import BenchEnvelope

IDX = {"1": 0, "2": 1, "S": 2}


@pytest.mark.parametrize("mode", ["S1", "S2"])
def test_map_matches_core_over_envelope_both_directions(design, mode):
    m = ModeMap(design, mode, 30.0, 350.0)
    env = BenchEnvelope(n_speed=5, n_torque=5)
    b = parse_mode(mode)[1]
    worst = 0.0
    for w in env.speeds():
        for T in env.torques():
            for sign in (1, -1):
                op = operating_point(design, mode, w, sign * T)
                speeds, torques, losses, eta, eta0, locked, fwd = m.solve(float(w), float(op.torques[b]))
                worst = max(worst, abs(eta - float(op.eta)))
                assert fwd == bool(op.flow_forward)
                p = sum(t * s for t, s in zip(torques, speeds))
                assert p == pytest.approx(sum(losses), rel=1e-12)      # exact energy balance
                assert torques[IDX[b]] == pytest.approx(float(op.torques[b]), rel=1e-12)
    assert worst < 1e-3, worst   # 0.1 percentage point
    assert m.out_of_range == 0


def test_map_locks_like_the_core():
    sticky = DriveDesign(profile="paper", friction=Friction(mu_boundary=0.3))
    m = ModeMap(sticky, "S1", 30.0, 350.0)
    # the load drives the ring (power into shaft 1): back-driving 1 -> S is self-locking
    speeds, torques, losses, eta, eta0, locked, fwd = m.solve(rpm_to_rad_s(1500), 9.0)
    assert not fwd and locked and eta == 0.0
    assert eta0 < sticky.i0
    assert torques[2] * speeds[2] > 0            # the driving shaft must still push (LossyGear)
    assert sum(losses) > 0
    core = operating_point(sticky, "S1", rpm_to_rad_s(1500), T_out=9.0)
    assert bool(core.locked)


def test_map_zero_speed_and_torque(design):
    m = ModeMap(design, "S2", 30.0, 350.0)
    assert sum(m.solve(0.0, 5.0)[2]) == 0.0
    assert sum(m.solve(100.0, 0.0)[2]) == 0.0


def test_heap_settings_change_no_number(design):
    """keep_temporaries_on_heap (for our own processes only: the FMUs never touch the host's
    allocator, tests/test_fmu_safety.py) leaves every table of the map as it was, to the bit."""
    import json
    import subprocess
    import sys
    code = ("import json\nfrom cyclo_fmu.slaves.heap import keep_temporaries_on_heap\n"
            "from model_core import DriveDesign\nfrom model_core.lossmap import ModeMap\n"
            "keep_temporaries_on_heap()\n"
            "m = ModeMap(DriveDesign(profile='paper'), 'S2', 30.0, 350.0, n_torque=12, n_speed=6)\n"
            "print(json.dumps([m._tables[True], m._tables[False], m._idle]))\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    plain = ModeMap(design, "S2", 30.0, 350.0, n_torque=12, n_speed=6)
    tuned = json.loads(r.stdout)
    assert tuned == json.loads(json.dumps([plain._tables[True], plain._tables[False],
                                           plain._idle]))


def test_heap_settings_can_be_switched_off(monkeypatch):
    from cyclo_fmu.slaves import heap
    monkeypatch.setenv("CYCLO_FMU_KEEP_MALLOC", "1")
    assert heap._glibc() is None
    assert heap.keep_temporaries_on_heap() is False


@pytest.mark.parametrize("mode", ["S1", "S2", "1S", "2S", "12", "21"])
def test_replay_kernel_gives_solve_arrays_input_torque_to_the_bit(design, mode):
    """The replay's input-torque kernel (``input_torque_arrays``, only what tau_in needs) is
    the same arithmetic as ``solve_arrays``: the same numbers to the bit, both flow
    directions, standstill, zero load, below the grid's lowest speed, and with the speed
    location shared from a map of another design on the same grid."""
    from model_core.design import scale_friction_level
    rng = np.random.default_rng(3)
    n = 20000
    w = rng.normal(0, 150, n)
    w[::50] = 0.0
    w[1::50] = rng.normal(0, 0.05, w[1::50].size)      # below the grid's lowest speed
    T = rng.normal(0, 8, n)
    T[::70] = 0.0
    m = ModeMap(design, mode, 30.0, 300.0)
    ref = m.solve_arrays(w, T)["tau_in"]
    assert np.array_equal(m.input_torque_arrays(w, T), ref)
    other = ModeMap(scale_friction_level(design, 1.1), mode, 30.0, 300.0)
    assert other.same_speed_grid(m)
    assert np.array_equal(m.input_torque_arrays(w, T, other.locate_speeds(w)), ref)


@pytest.mark.parametrize("mode", ["S1", "S2", "1S", "21"])
def test_replay_load_loss_torque_is_the_gear_friction_of_solve(mode):
    """The run-in's basis in a replay (``replay_input_torque(..., load_loss=True)``) is the
    gear's load-dependent partial losses PL1..PL6 that ``ModeMap.solve`` reports over the
    driving speed (``load_loss_torque``), every flow direction, with the sign of a loss; it is
    the part of the whole loss torque that the idle losses (bearings' drag, seals, churning:
    physical profile) are not, so loss_in - T_load = (PL_support + PL_seal + PL_churn)/w_in;
    zero at a standstill."""
    from model_core.lossmap import load_loss_torque, replay_input_torque
    d = DriveDesign()       # physical profile, idle losses included
    rng = np.random.default_rng(8)
    w = rng.normal(0, 150, 300)
    w[::40] = 0.0
    T = rng.normal(0, 8, 300)
    m = ModeMap(d, mode, 30.0, 300.0)
    tau_in, T_load = m.input_torque_arrays(w, T, None, True)
    assert np.array_equal(tau_in, m.input_torque_arrays(w, T))
    for k in range(w.size):
        _, _, L, _, _, _, _ = m.solve(w[k], T[k])
        assert T_load[k] == pytest.approx(load_loss_torque(sum(L[:5]), w[k]), rel=1e-12,
                                          abs=1e-15)
        assert T_load[k] * w[k] >= 0
    assert np.all(T_load[w == 0] == 0.0)
    t_in, loss_in, load_in = replay_input_torque(d, mode, w, T, load_loss=True)
    assert np.array_equal(t_in, replay_input_torque(d, mode, w, T)[0])
    # the replay's own map (REPLAY_MARGIN over the recording's ranges)
    from model_core.lossmap import REPLAY_MARGIN
    mr = ModeMap(d, mode, float(np.max(np.abs(T))) * REPLAY_MARGIN + 1e-6,
                 float(np.max(np.abs(w))) * REPLAY_MARGIN + 1e-6)
    for k in np.flatnonzero(w != 0)[:40]:
        _, _, L, _, _, _, _ = mr.solve(w[k], T[k])
        assert loss_in[k] - load_in[k] == pytest.approx(sum(L[5:8]) / w[k], rel=1e-9,
                                                        abs=1e-12)
