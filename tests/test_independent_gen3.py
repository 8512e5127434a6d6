"""The third independent batch's generator (benchmarks/independent/gen3.py) checked on its own
physics, not on the diagnosis: the written input torque against the physics core at random
samples and around every reversal, the energy balance P_in - P_out = modelled loss (+ stored
energy), the mode's speed ratio and roller-pass order, what each plan kind promises (four
quadrants, one speed, no plateaus) and the file's gap and duplicated stamps. Short (8-12 s)
copies of the batch's cases keep it fast."""
from __future__ import annotations

import os
import sys
from pathlib import Path

import numpy as np
import pytest

from model_core import DriveDesign, operating_point, speed_ratio

_HERE = Path(__file__).resolve().parents[1] / "benchmarks" / "independent"
_env = os.environ.get("CYCLO_INDEPENDENT_OUT")
sys.path.insert(0, str(_HERE))
import gen3  # noqa: E402

if _env is None:   # gen3 sets a default output folder; leave the environment as it was
    os.environ.pop("CYCLO_INDEPENDENT_OUT", None)

DESIGN = DriveDesign()
#: [N*m] the generator's grid interpolation against the core: largest and RMS deviation
#: (the core is evaluated exactly where the loss torques bend, gen3.W_EXACT / T_EXACT)
MAX_DEV, RMS_DEV = 0.1e-3, 0.01e-3


def short(cid, duration=10.0, **over):
    c = dict(next(c for c in gen3.CASES if c["id"] == cid))
    c.update(duration=duration, **over)
    return c


def core_at(case, audit, n=1500, seed=0):
    """The core at random samples and at every sample within 5 of a reversal of the speed or
    of the output torque (above the generator's standstill clamp)."""
    rng = np.random.default_rng(seed)
    m = audit["t"].size
    rev = np.flatnonzero((np.diff(np.sign(audit["w_in"])) != 0)
                         | (np.diff(np.sign(audit["torque_out"])) != 0))
    near = (rev[:, None] + np.arange(-5, 6)).ravel()
    j = np.unique(np.r_[rng.choice(m, min(n, m), replace=False), np.clip(near, 0, m - 1)])
    j = j[np.abs(audit["w_in"][j]) > gen3.W_MIN]
    op = operating_point(DESIGN, case["mode"], audit["w_in"][j], T_out=-audit["torque_out"][j])
    ok = np.isfinite(op.torques["S"])
    return j[ok], op, ok


@pytest.mark.parametrize("cid", ["clean_4q_S1_1k_pink", "clean_4q_S2_5k_quant_catman",
                                 "clean_duty_S2_1k_dupstamps", "clean_held_S1_1k_mdf"])
def test_clean_input_torque_is_the_core_and_energy_balances(cid):
    case = short(cid, fs=1000)
    data, truth, a = gen3.build(case)
    j, op, ok = core_at(case, a)
    dev = a["T_in"][j] - op.torques["S"][ok]
    assert np.abs(dev).max() < MAX_DEV
    assert np.sqrt(np.mean(dev ** 2)) < RMS_DEV
    # energy: what goes in and not out is the core's loss (clean: nothing stored)
    P_bal = a["P_in"][j] - a["P_out"][j] - op.losses.total[ok]
    assert np.all(np.abs(P_bal) <= MAX_DEV * np.abs(a["w_in"][j]) + 1e-9)
    # and the generator's own bookkeeping at every sample
    assert np.allclose(a["P_in"] - a["P_out"], a["P_loss"], rtol=0, atol=1e-9)
    assert np.all(a["P_loss"] >= 0)          # a loss never delivers power
    assert truth["plan"]["model_undefined_samples_bridged"] < 0.001 * a["t"].size


@pytest.mark.parametrize("mode", ["S1", "S2"])
def test_written_speed_ratio_and_roller_pass_order_of_the_mode(mode):
    case = short("clean_4q_S1_1k_pink", mode=mode)
    data, _, _ = gen3.build(case)
    moving = np.abs(data["speed_in_rpm"]) > 100
    r = np.median(data["speed_in_rpm"][moving] / data["speed_out_rpm"][moving])
    assert r == pytest.approx(speed_ratio(mode, DESIGN.z1), rel=5e-3)   # +15 / -14
    # ring rollers passed per input revolution: z1 - 1 with the disc held, z1 with the ring held
    assert gen3.roller_pass_order(mode, DESIGN) == {"S1": DESIGN.z1 - 1, "S2": DESIGN.z1}[mode]


def test_plans_keep_their_promises():
    _, tr, _ = gen3.build(short("clean_4q_S1_1k_pink", duration=40.0))
    p = tr["plan"]
    assert min(p["Q1_fwd_pos"], p["Q2_back_pos"], p["Q3_fwd_neg"], p["Q4_back_neg"]) > 0.05
    assert p["speed_reversals"] >= 2
    _, _, a = gen3.build(short("clean_held_S1_1k_mdf"))
    assert np.ptp(a["n_in"]) < 1e-6 * np.abs(a["n_in"]).max()
    _, tr, a = gen3.build(short("clean_duty_S2_1k_dupstamps", duration=30.0))
    slope = np.abs(np.gradient(a["n_in"], a["t"]))
    assert np.mean(slope < 5.0) < 0.02                  # r/min/s: no plateaus
    assert tr["plan"]["back_driven_share"] > 0.05       # the load inertia back-drives


def test_gap_and_duplicated_stamps_are_written():
    data, _, _ = gen3.build(short("clean_4q_S2_200Hz_gap_german", duration=70.0))
    dt = np.diff(data["time_s"])
    assert dt.max() == pytest.approx(4.0 + 1 / 200, abs=1e-9)
    data, tr, _ = gen3.build(short("clean_duty_S2_1k_dupstamps"))
    assert np.sum(np.diff(data["time_s"]) == 0) == tr["plan"]["duplicated_stamps"] > 0


def test_loss_scale_scales_the_core_s_load_dependent_losses():
    case = short("lossscale_p12_4q_S1_1k")
    _, _, a = gen3.build(case)
    j, op, ok = core_at(case, a)
    gear = op.losses.total[ok] - op.losses.idle[ok] - op.losses.P_extra
    P_bal = a["P_in"][j] - a["P_out"][j] - (op.losses.idle[ok] + 1.12 * gear)
    assert np.all(np.abs(P_bal) <= MAX_DEV * np.abs(a["w_in"][j]) + 1e-9)


def test_drag_dissipates_and_inertia_stores_energy():
    case = short("4q_drag+inertia_S1_1k", duration=12.0)
    _, truth, a = gen3.build(case)
    J = next(e["J"] for e in case["effects"] if e["kind"] == "inertia")
    # the extra loss beyond the core's is the drag's power: never negative, in all quadrants
    j, op, ok = core_at(case, a)
    extra = a["P_loss"][j] - op.losses.total[ok]
    assert np.all(extra >= -MAX_DEV * np.abs(a["w_in"][j]))
    assert np.mean(extra > 0) > 0.95
    # the power stored in the unmodelled inertia integrates to the kinetic energy's change
    w, t = a["w_in"], a["t"]
    stored = np.sum(0.5 * (a["P_stored"][1:] + a["P_stored"][:-1]) * np.diff(t))
    assert stored == pytest.approx(0.5 * J * (w[-1] ** 2 - w[0] ** 2),
                                   abs=2e-3 * 0.5 * J * np.max(w ** 2))
