"""Stage ``orders`` (cyclo_fmu.diagnosis.sample_orders): a roller-pass ripple far above the block
rate (300-500 Hz against 10 ms blocks) under a load that switches every few blocks is fitted on
the within-block residual at sample level, its amplitude law chosen on BIC and held out."""
import math
from types import SimpleNamespace

import numpy as np
import pytest

from cyclo_fmu.diagnosis.sample_orders import fit_ripple
from model_core.discovered import T_REF

FS = 2500.0
Z = 14.0          # the roller pass of a 15-lobe disc, S1 (ring fixed)
PHASE = 0.4


def _problem(b_load, seed=0, duration=40.0):
    """A fast plan (1800 r/min +-10 %) with a load switching between 2 and 7.5 N*m every 20 to
    60 ms, and a residual holding a roller-pass ripple (a + b |tau_out|/T_REF) sin(z th + phi),
    white noise of 3 mN*m and a slow mismatch that follows the load (what the block-level
    selection sees)."""
    rng = np.random.default_rng(seed)
    dt = 1.0 / FS
    n = int(duration * FS)
    t = np.arange(n) * dt
    w = 1800 * math.pi / 30 * (1 + 0.1 * np.sin(2 * math.pi * t / 7.0))
    th = np.cumsum(w) * dt
    switch = np.cumsum(rng.integers(50, 150, size=n // 50))
    level = np.where(np.arange(len(switch)) % 2 == 0, 2.0, 7.5)
    tau = level[np.minimum(np.searchsorted(switch, np.arange(n)), len(level) - 1)]
    a = 0.004
    ripple = (a + b_load * tau / T_REF) * np.sin(Z * th + PHASE)
    r = ripple + 0.003 * rng.standard_normal(n) + 0.01 * tau / T_REF
    m = 25                                    # 10 ms blocks
    sig = {"w_in": w, "theta_in": th, "tau_out": tau, "order_roller": Z,
           "ratio_out": -1.0 / 14.0, "t": t}
    P = SimpleNamespace(y=np.zeros(n // m), m=m, mask=np.ones(n, bool), sig=sig, dt=dt,
                        bandwidth=0.0)
    return P, r, ripple


def test_a_load_scaled_ripple_is_found_with_its_law_and_phase():
    """The load law 1 is chosen; the roller pass's constant and load parts come back with the
    hidden amplitudes and phase (sin/cos parts a cos(phi), a sin(phi)) within their 95 %
    intervals; the fitted ripple explains the hidden ripple's RMS, not the slow mismatch."""
    P, r, ripple = _problem(b_load=0.006)
    fit = fit_ripple(P, r)
    assert fit["law"] == 1.0
    c, se = fit["coef"], fit["se"]
    # columns: (sin, cos) of 1x, roller pass, 2x, output 1x, output 2x; then the same * load
    for (i_sin, amp) in ((2, 0.004), (12, 0.006)):
        for k, want in ((0, amp * math.cos(PHASE)), (1, amp * math.sin(PHASE))):
            assert abs(c[i_sin + k] - want) < 1.96 * se[i_sin + k] + 1e-5
    rms = float(np.sqrt(np.mean(ripple ** 2)))
    assert fit["explained"] == pytest.approx(rms, rel=0.05)


def test_a_constant_ripple_keeps_the_constant_law():
    """A ripple of constant amplitude is not charged four load terms it does not have."""
    P, r, _ = _problem(b_load=0.0, seed=1)
    fit = fit_ripple(P, r)
    assert fit["law"] == 0.0
    assert math.hypot(fit["coef"][2], fit["coef"][3]) == pytest.approx(0.004, rel=0.05)


def test_block_means_do_not_enter_the_fit():
    """Within-block deviations are orthogonal to the block means: a residual that is constant
    over each block (any slow mismatch) leaves the fitted ripple unchanged to rounding."""
    P, r, _ = _problem(b_load=0.006, seed=2)
    slow = np.repeat(np.random.default_rng(3).standard_normal(len(P.y)) * 0.05, P.m)
    a = fit_ripple(P, r)["coef"]
    b = fit_ripple(P, r + slow)["coef"]
    np.testing.assert_allclose(a, b, atol=1e-9)


def test_the_diagnosis_names_a_fast_load_scaled_ripple():
    """The synthesiser's one-speed plan (2000 r/min, load steps) at 2.5 kHz: the roller pass at
    467 Hz averages out of the 10 ms blocks (before this stage: the friction level named and
    "order 14 (roller pass) 7.84 mN*m" left). Now the mesh ripple is named with load law 1,
    the amplitude and phase of its constant and load parts those hidden, nothing left."""
    from cyclo_fmu.diagnosis import Diagnoser
    from cyclo_fmu.synth import SynthSettings, synthesize
    truth = {"A1_sin": 0.0, "A1_cos": 0.0, "Az_sin": 0.002, "Az_cos": 0.001,
             "Bz_sin": 0.012, "Bz_cos": 0.005}
    r = synthesize("mesh_ripple", 21, "S1", "small", effect_values=truth, shape=1.0,
                   plan="one_speed", settings=SynthSettings(sample_rate=2500.0), duration=40.0)
    rec = SimpleNamespace(time=r["time_s"], speed_in=r["speed_in_rpm"] * np.pi / 30,
                          torque_in=r["torque_in_Nm"], speed_out=r["speed_out_rpm"] * np.pi / 30,
                          torque_out=r["torque_out_Nm"], temperature=None)
    d = Diagnoser(None, "S1").fit(rec).diagnosis_
    assert [e["id"] for e in d.effects] == ["mesh_ripple"]
    assert not d.unexplained["present"], d.unexplained["statement"]
    p = d.effects[0]["parameters"]
    assert p["load_law"]["value"] == 1.0
    # each part within its 95 % interval (the fold jackknife's where wider than white noise's:
    # with white noise's alone Bz_cos was 4 of them off), and the amplitude and phase of the
    # constant and the load part to test_ripple_orders' closure tolerances, 5 % and 0.05 rad
    for name in ("Az_sin", "Az_cos", "Bz_sin", "Bz_cos"):
        lo, hi = p[name]["ci95"]
        assert lo <= truth[name] <= hi, (name, p[name])
    for part in ("A", "B"):
        s, c = p[f"{part}z_sin"]["value"], p[f"{part}z_cos"]["value"]
        s0, c0 = truth[f"{part}z_sin"], truth[f"{part}z_cos"]
        assert math.hypot(s, c) == pytest.approx(math.hypot(s0, c0), rel=0.05), part
        assert math.atan2(c, s) == pytest.approx(math.atan2(c0, s0), abs=0.05), part
