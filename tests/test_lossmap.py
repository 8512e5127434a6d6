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


def test_map_solving_heap_changes_no_number(design, monkeypatch):
    """The FMU solves its map inside slaves.heap.map_solving_heap (glibc keeps the temporaries
    on its heap): the same tables to the bit, and the allocator is left alone on request."""
    from cyclo_fmu.slaves import heap
    plain = ModeMap(design, "S2", 30.0, 350.0, n_torque=12, n_speed=6)
    with heap.map_solving_heap():
        tuned = ModeMap(design, "S2", 30.0, 350.0, n_torque=12, n_speed=6)
    for forward in (True, False):
        assert tuned._tables[forward] == plain._tables[forward]
    assert tuned._idle == plain._idle
    monkeypatch.setenv("CYCLO_FMU_KEEP_MALLOC", "1")
    assert heap._glibc() is None


def test_map_solving_heap_gives_a_host_its_own_thresholds_back(monkeypatch):
    """An FMU runs in its host's process: thresholds the host gave glibc in its environment are
    restored after the map's solve; without any, glibc's 2x rule for the trim threshold."""
    from cyclo_fmu.slaves import heap

    class Recorder:
        def __init__(self):
            self.calls = []

        def mallopt(self, param, value):
            self.calls.append((param, value))
            return 1

        def malloc_trim(self, pad):
            self.calls.append(("trim", pad))
            return 1

    for var in ("MALLOC_MMAP_THRESHOLD_", "MALLOC_TRIM_THRESHOLD_", "GLIBC_TUNABLES"):
        monkeypatch.delenv(var, raising=False)
    libc = Recorder()
    monkeypatch.setattr(heap, "_glibc", lambda: libc)
    with heap.map_solving_heap():
        assert libc.calls == [(heap._M_MMAP_THRESHOLD, heap.MMAP_THRESHOLD),
                              (heap._M_TRIM_THRESHOLD, heap.TRIM_THRESHOLD)]
    assert libc.calls[2:] == [(heap._M_TRIM_THRESHOLD, 2 * heap.MMAP_THRESHOLD), ("trim", 0)]
    monkeypatch.setenv("MALLOC_MMAP_THRESHOLD_", "262144")
    monkeypatch.setenv("GLIBC_TUNABLES", "glibc.malloc.arena_max=2:glibc.malloc.trim_threshold=0x100000")
    assert heap.host_thresholds() == (262144, 1 << 20)
    libc.calls.clear()
    with heap.map_solving_heap():
        pass
    assert libc.calls[2:] == [(heap._M_MMAP_THRESHOLD, 262144),
                              (heap._M_TRIM_THRESHOLD, 1 << 20), ("trim", 0)]
    # tunables win over the older variables, and what glibc would not parse is not given
    assert heap.host_thresholds({"MALLOC_TRIM_THRESHOLD_": "5",
                                 "GLIBC_TUNABLES": "glibc.malloc.trim_threshold=7"}) == (None, 7)
    assert heap.host_thresholds({"MALLOC_MMAP_THRESHOLD_": "4k"}) == (None, None)
