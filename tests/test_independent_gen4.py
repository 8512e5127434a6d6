"""The fourth independent batch's generator (benchmarks/independent/gen4.py) checked on its own
physics, not on the diagnosis: the written input torque against the physics core, every loss
effect dissipative in all four quadrants, the energy balance, what each new plan promises
(standstill, a rising sweep frequency, a switching load, four quadrants), the jittered instants,
the speed-dependent offset's symmetry and the new file dialects read back by a plain parser.
Short (10-30 s) copies of the batch's cases keep it fast."""
from __future__ import annotations

import csv
import os
import sys
from pathlib import Path

import numpy as np
import pytest

from model_core import DriveDesign, operating_point

_HERE = Path(__file__).resolve().parents[1] / "benchmarks" / "independent"
_env = os.environ.get("CYCLO_INDEPENDENT_OUT")
sys.path.insert(0, str(_HERE))
import gen4  # noqa: E402

if _env is None:   # gen4 sets a default output folder; leave the environment as it was
    os.environ.pop("CYCLO_INDEPENDENT_OUT", None)

DESIGN = DriveDesign()
#: [N*m] the generator's grid interpolation against the core (gen3's bound)
MAX_DEV = 0.1e-3


def short(cid, duration=12.0, **over):
    c = dict(next(c for c in gen4.CASES if c["id"] == cid))
    c.update(duration=duration, **over)
    return c


def quadrants(a):
    """Masks of the four quadrants (input speed sign x sign of the output power), moving."""
    moving = np.abs(a["w_in"]) > 1.0
    p = a["P_out"]
    pos, neg = moving & (a["w_in"] > 0), moving & (a["w_in"] < 0)
    return [pos & (p > 0), pos & (p < 0), neg & (p > 0), neg & (p < 0)]


def test_clean_four_quadrant_input_torque_is_the_core():
    case = short("clean_tri4q_S2_1k_jitter_reordered", duration=30.0, jitter=0)
    _, tr, a = gen4.build(case)
    rng = np.random.default_rng(1)
    j = rng.choice(a["t"].size, 2000, replace=False)
    j = j[np.abs(a["w_in"][j]) > 1.0]
    op = operating_point(DESIGN, case["mode"], a["w_in"][j], T_out=-a["torque_out"][j])
    ok = np.isfinite(op.torques["S"])
    stick = np.tanh(np.abs(a["w_in"][j][ok]) / gen4.W_STICK)
    T_core = a["torque_out"][j][ok] / a["ratio"] + stick * (op.torques["S"][ok]
                                                           - a["torque_out"][j][ok] / a["ratio"])
    assert np.abs(a["T_in"][j][ok] - T_core).max() < MAX_DEV
    assert np.allclose(a["P_in"] - a["P_out"], a["P_loss"], rtol=0, atol=1e-9)
    assert all(m.mean() > 0.05 for m in quadrants(a))           # every quadrant visited


LOSS_KINDS = ["drag", "stribeck", "load15", "temp_drag", "dir_friction", "idle_scale",
              "mesh_loss", "friction", "loss_scale"]


@pytest.fixture(scope="module")
def four_quadrant_base():
    base = short("clean_tri4q_S2_1k_jitter_reordered", duration=30.0, jitter=0, mode="S1",
                 fs=500)
    return base, gen4.build(base)[2]


@pytest.mark.parametrize("kind", LOSS_KINDS)
def test_every_loss_effect_dissipates_in_all_four_quadrants(kind, four_quadrant_base):
    """The hidden loss adds to the core's loss power, never delivers power, in each quadrant
    (a scale below 1 would lower it; the batch's scales are above 1)."""
    e = {"drag": gen4.E("drag", rms_mNm=10.0), "stribeck": gen4.E("stribeck", rms_mNm=6.0,
                                                                      ws=30.0),
         "load15": gen4.E("load15", rms_mNm=10.0), "temp_drag": gen4.E("temp_drag",
                                                                          rms_mNm=8.0),
         "dir_friction": gen4.E("dir_friction", rms_mNm=8.0),
         "idle_scale": gen4.E("idle_scale", factor=1.25), "mesh_loss": gen4.E("mesh_loss",
                                                                               k=0.002),
         "friction": gen4.E("friction", factor=1.2),
         "loss_scale": gen4.E("loss_scale", factor=1.12)}[kind]
    base, a0 = four_quadrant_base
    _, _, a = gen4.build(dict(base, effects=[e], temperature=kind == "temp_drag"))
    assert np.allclose(a["w_in"], a0["w_in"]) and np.allclose(a["torque_out"], a0["torque_out"])
    extra = a["P_loss"] - a0["P_loss"]
    tol = MAX_DEV * np.abs(a["w_in"]) + 1e-9
    for m in quadrants(a):
        assert m.mean() > 0.05
        assert np.all(extra[m] >= -tol[m])          # dissipative in this quadrant
        # and present in it: a Stribeck term at low speed, the one-directional friction
        # where the output torque is positive, the others everywhere
        if kind == "stribeck":
            m = m & (np.abs(a["w_in"]) < 30.0)
        elif kind == "dir_friction":
            assert np.all(np.abs(extra[m & (a["torque_out"] < -1.5)]) < 1e-3 * np.abs(
                a["w_in"][m & (a["torque_out"] < -1.5)]))
            m = m & (a["torque_out"] > 0.5)
        if m.sum() > 20:
            assert np.mean(extra[m] > tol[m]) > 0.5
    assert np.all(a["P_loss"] >= -1e-9)
    assert np.allclose(a["P_in"] - a["P_out"], a["P_loss"], rtol=0, atol=1e-9)


def test_startstop_reaches_standstill_in_both_directions_and_back_drives():
    _, tr, a = gen4.build(short("clean_startstop_S1_1k_pink_comment", duration=40.0, fs=500))
    p = tr["plan"]
    assert p["standstill_share"] > 0.05
    assert a["n_in"].max() > 400 and a["n_in"].min() < -400
    assert p["back_driven_share"] > 0.03                 # the load inertia while braking
    still = a["n_in"] == 0.0
    # at a standstill the transducer reads the output torque alone (W_STICK)
    assert np.allclose(a["T_in"][still], a["torque_out"][still] / a["ratio"], atol=1e-12)


def test_sine_sweep_frequency_rises_and_stays_forward():
    _, _, a = gen4.build(short("clean_sine_S1_333Hz_tsv", duration=90.0))
    n = a["n_in"]
    assert n.min() > 300 and n.max() < 2700
    x = np.sign(n - n.mean())
    cross = np.flatnonzero(np.diff(x) != 0)
    half = a["t"].size // 2
    assert np.sum(cross >= half) > np.sum(cross < half)


def test_prbs_load_switches_often():
    _, _, a = gen4.build(short("clean_prbs_S1_1k_jitter_dup_tsv", duration=30.0, jitter=0))
    L = np.abs(a["torque_out"])
    hi = L > 4.0
    switches = np.sum(np.diff(hi.astype(int)) != 0)
    assert switches >= 30 / 1.5                         # dwell at most 1.5 s


def test_jittered_instants_are_irregular_monotonic_and_on_the_plan():
    case = short("clean_prbs_S1_1k_jitter_dup_tsv", duration=10.0, dup=0)
    data, _, a = gen4.build(case)
    dt = np.diff(data["time_s"])
    assert np.all(dt > 0)
    assert np.std(dt) > 0.1 / case["fs"]
    # the input speed written at the irregular instants is the plan's at those instants
    n_true = np.interp(data["time_s"], a["t"], a["n_in"])
    assert np.std(data["speed_in_rpm"] - n_true) == pytest.approx(0.3, rel=0.1)


def test_speed_offset_is_even_in_speed():
    case = short("out_speedoffset_tri4q_S1_1k", duration=30.0)
    e = case["effects"][0]
    w = np.array([-200.0, 200.0, -50.0, 50.0])
    err = gen4.transducer4(dict(effects=[e]), np.zeros(4), 1000.0, np.zeros(4), w)
    assert err[0] == pytest.approx(err[1]) and err[2] == pytest.approx(err[3])
    assert err[0] == pytest.approx(16 * err[2])         # ~ w^2


def _read_back(path, dialect):
    text = path.read_text(encoding="utf-8").splitlines()
    lines = [ln for ln in text if not ln.startswith("#")]
    sep = {"tsv": "\t", "semicolon_comma": ";"}.get(dialect, ",")
    rows = list(csv.reader(lines, delimiter=sep))
    head = rows[0]
    body = np.array([[float(c.replace(",", ".")) if dialect == "semicolon_comma" else float(c)
                      for c in r] for r in rows[1:]])
    return head, body


@pytest.mark.parametrize("dialect", ["tsv", "semicolon_comma", "time_ms", "comment_header",
                                     "reordered", "extra_cols"])
def test_new_dialects_hold_the_data(tmp_path, dialect):
    case = short("clean_sine_S1_333Hz_tsv", duration=3.0, dialect=dialect)
    data, _, _ = gen4.build(case)
    p = tmp_path / ("rec" + gen4.EXT[dialect])
    gen4.write(p, data, dialect)
    head, body = _read_back(p, dialect)
    assert body.shape == (data["time_s"].size, len(head))
    t_col = next(k for k, h in enumerate(head) if h.startswith("time"))
    scale = 1e3 if dialect == "time_ms" else 1.0
    assert np.allclose(body[:, t_col], data["time_s"] * scale, rtol=1e-6, atol=1e-9)
    tin = next(k for k, h in enumerate(head) if h.startswith(("torque_in", "T_in")))
    assert np.allclose(body[:, tin], data["torque_in_Nm"], rtol=1e-6, atol=1e-9)
