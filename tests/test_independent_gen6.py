"""The sixth independent batch's generator (benchmarks/independent/gen6.py) checked on its own
physics, not on the diagnosis: the S-curve's jerk limit and the indexing table's exact index
angle, the pump's torque ~ speed^2, the robot joint's four quadrants, the new losses
dissipative, the hidden sizes as written in the truth, the resonance-amplified 1x peaking at
its speed, the sign-dependent gain, the dropped samples, and the new text dialects read back
by a plain parser. Short copies of the batch's cases keep it fast; no diagnosis runs here."""
from __future__ import annotations

import csv
import io
import os
import sys
from pathlib import Path

import numpy as np
import pytest

_HERE = Path(__file__).resolve().parents[1] / "benchmarks" / "independent"
_env = os.environ.get("CYCLO_INDEPENDENT_OUT")
sys.path.insert(0, str(_HERE))
import gen3  # noqa: E402
import gen4  # noqa: E402
import gen6  # noqa: E402

if _env is None:   # the generators set a default output folder; leave the environment alone
    os.environ.pop("CYCLO_INDEPENDENT_OUT", None)


def short(cid, duration=20.0, **over):
    c = dict(next(c for c in gen6.CASES if c["id"] == cid))
    c.update(duration=duration, **over)
    return c


def test_scurve_keeps_the_jerk_limit_and_a_pulse_area():
    fs = 1000.0
    t = np.arange(int(10 * fs)) / fs
    x = np.where((t > 1) & (t < 3), 1000.0, 0.0)
    y = gen6.scurve(x, fs)
    assert y.sum() == pytest.approx(x.sum(), rel=1e-9)       # the index angle kept exactly
    acc = np.diff(y) * fs
    jerk = np.diff(acc) * fs
    # a step of 1000 r/min: acceleration <= 1000/ta, jerk <= 1000/(ta tj) (+ one sample)
    assert np.abs(acc).max() <= 1000 / gen6.SCURVE_TA * (1 + 1e-9)
    assert np.abs(jerk).max() <= 1000 / (gen6.SCURVE_TA * gen6.SCURVE_TJ) * 1.02


def test_press_indexes_a_quarter_turn_of_the_output_and_dwells():
    _, tr, a = gen4.build(short("clean_press_S1_1k_wsbom", duration=12.0))
    w_out = a["w_out"]
    moving = np.abs(a["n_in"]) > 0
    edges = np.flatnonzero(np.diff(moving.astype(int)))
    starts, ends = edges[::2] + 1, edges[1::2] + 1
    for s0, e0 in list(zip(starts, ends))[:-1]:
        ang = np.sum(w_out[s0:e0]) / 1000.0
        assert ang == pytest.approx(np.pi / 2, rel=2e-3)
    assert tr["plan"]["standstill_share"] > 0.3 and tr["plan"]["back_driven_share"] > 0.1


def test_pump_torque_grows_with_speed_squared():
    _, _, a = gen4.build(short("clean_pump_S2_250Hz_catman", duration=40.0))
    n, L = np.abs(a["n_in"]), np.abs(a["torque_out"])
    held = np.abs(np.gradient(n, a["t"])) < 1.0
    coef = np.polyfit(np.log(n[held]), np.log(L[held] - 0.3), 1)
    assert coef[0] == pytest.approx(2.0, abs=0.05)


def test_robot_joint_visits_every_quadrant():
    _, tr, _ = gen4.build(short("clean_robot_S2_1k_negout", duration=30.0))
    q = tr["plan"]
    assert all(q[k] > 0.03 for k in ("Q1_fwd_pos", "Q2_back_pos", "Q3_fwd_neg", "Q4_back_neg"))


@pytest.mark.parametrize("cid", ["out_preloadsqrt_robot_S1_1k", "out_skid_effmap_S2_1k",
                                 "out_sealtemp_scurve_S1_1k"])
def test_new_losses_dissipate_and_have_their_written_size(cid):
    case = short(cid, duration=20.0)
    _, tr, a = gen4.build(case)
    e = case["effects"][0]
    assert tr["effects"][0]["rms_mNm_actual"] == pytest.approx(e["rms_mNm"], rel=1e-3)
    extra = a["P_extra"][e["kind"]]
    assert np.all(extra >= -1e-12) and np.mean(extra > 1e-6) > 0.3


def test_resonant_1x_peaks_near_the_structural_mode():
    fs = 3000.0
    t = np.arange(int(20 * fs)) / fs
    n_in = np.linspace(600, 3000, t.size)
    w = n_in * np.pi / 30
    theta = np.cumsum(w) / fs
    s = dict(t=t, w=w, tout=np.ones_like(t), theta=theta, alpha=np.gradient(w, t),
             T_gear_in=np.ones_like(t))
    x = gen6.extra_loss_shapes6(dict(effects=[gen6.E("resonant_1x", rms_mNm=8.0)], mode="S1"),
                                s)["resonant_1x"][0]
    env = np.array([np.abs(x[k:k + 3000]).max() for k in range(0, t.size - 3000, 3000)])
    f_at_peak = np.mean(n_in[np.argmax(env) * 3000:(np.argmax(env) + 1) * 3000]) / 60
    assert f_at_peak == pytest.approx(gen6.STRUCT_HZ, abs=2.0)
    assert env.max() > 5 * env.min()


def test_sign_gain_is_a_gain_of_one_plus_or_minus_g():
    T = np.array([-2.0, -0.5, 0.0, 0.5, 2.0])
    y = gen6.transducer6(dict(effects=[gen6.E("sign_gain", g=0.03)]), T, 1000.0,
                         np.arange(5) / 1e3, np.ones(5))
    assert np.allclose(y, np.where(T > 0, 1.03, 0.97) * T)


def test_dropped_samples_leave_exact_irregular_stamps():
    case = short("clean_effmap_S2_750Hz_drop_tsvrads", duration=10.0)
    data, tr, _ = gen4.build(case)
    n = int(10.0 * 750)
    assert tr["plan"]["samples_written"] == n - tr["plan"]["dropped_samples"]
    assert 0.07 < tr["plan"]["dropped_samples"] / n < 0.13
    k = np.round(data["time_s"] * 750)
    assert np.allclose(data["time_s"] * 750, k, atol=1e-6) and np.all(np.diff(k) >= 1)


def _read(text, sep):
    lines = [ln for ln in text.splitlines() if ln.strip()]
    if sep is None:
        rows = [ln.split() for ln in lines]
    else:
        rows = list(csv.reader(io.StringIO("\n".join(lines)), delimiter=sep))
    return rows


@pytest.mark.parametrize("dialect", ["ws_bom", "catman_tab_nmm", "neg_out", "extra_cols6",
                                     "tsv_rads_nmm"])
def test_new_dialects_hold_the_data(tmp_path, dialect):
    data, _, _ = gen4.build(short("clean_scurve_S1_750Hz_csv", duration=3.0, dialect=dialect))
    p = tmp_path / ("rec" + gen6.EXT[dialect])
    gen6.write6(p, data, dialect)
    raw = p.read_bytes()
    if dialect == "catman_tab_nmm":
        rows = _read(raw.decode("cp1252"), "\t")
        assert rows[4][3] == "N·mm"
        head, body = rows[3], rows[5:]
    else:
        if dialect == "ws_bom":
            assert raw.startswith(b"\xef\xbb\xbf")
        text = raw.decode("utf-8-sig")
        rows = _read(text, {"ws_bom": None, "tsv_rads_nmm": "\t"}.get(dialect, ","))
        head, body = rows[0], rows[1:]
    body = np.array([[float(c) for c in r] for r in body])
    assert body.shape[0] == data["time_s"].size
    col = {h: body[:, j] for j, h in enumerate(head)}
    t_name = {"ws_bom": "t", "catman_tab_nmm": "Zeit", "neg_out": "time_s"}.get(dialect,
                                                                                "time [s]")
    assert np.allclose(col[t_name], data["time_s"], atol=1e-5)
    tin = {"ws_bom": ("T_in", 1.0), "catman_tab_nmm": ("Drehmoment_An", 1e3),
           "neg_out": ("torque_in_Nm", 1.0), "extra_cols6": ("T_in [N*m]", 1.0),
           "tsv_rads_nmm": ("torque_in [N·mm]", 1e3)}[dialect]
    assert np.allclose(col[tin[0]], data["torque_in_Nm"] * tin[1], rtol=1e-6, atol=1e-9)
    if dialect == "neg_out":
        assert np.allclose(col["torque_out_Nm"], -data["torque_out_Nm"], rtol=1e-6, atol=1e-9)
        assert gen6.EXTRA_ARGS6["neg_out"] == ["--units", "torque_out_Nm=-N*m"]
    if dialect == "tsv_rads_nmm":
        assert np.allclose(col["speed_in [rad/s]"], data["speed_in_rpm"] * np.pi / 30,
                           rtol=1e-6, atol=1e-9)


def test_every_case_has_a_fixed_expectation():
    ids = [c["id"] for c in gen6.CASES]
    assert 30 <= len(ids) <= 40 and len(set(ids)) == len(ids)
    for c in gen6.CASES:
        assert c["unexplained"] in (True, False, None)
        assert 20 <= c["duration"] <= 60
        assert c["plan"] in gen4.PLANS and c["dialect"] in gen6.EXT
        if not c["effects"]:
            assert c["expect"] == []
    assert gen3.E("x") == {"kind": "x"}
