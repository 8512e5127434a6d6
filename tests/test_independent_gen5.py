"""The fifth independent batch's generator (benchmarks/independent/gen5.py) checked on its own
physics, not on the diagnosis: what each new plan promises (the hoist's back-driven lowering
and its standstill under load, the 4Q random walk's quadrants, the chirp's rising frequency),
the new losses dissipative in all four quadrants, the dead zone being exactly an offset where
the input torque stays away from zero (the physics behind that case's expectation), the
hysteresis bounded by its half-width, the resonance's static gain and frequency, the run-in
decaying with the distance run, and the new text dialects read back by a plain parser.
Short copies of the batch's cases keep it fast."""
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
import gen5  # noqa: E402

if _env is None:   # the generators set a default output folder; leave the environment alone
    os.environ.pop("CYCLO_INDEPENDENT_OUT", None)


def short(cid, duration=20.0, **over):
    c = dict(next(c for c in gen5.CASES if c["id"] == cid))
    c.update(duration=duration, **over)
    return c


def quadrants(a):
    moving = np.abs(a["w_in"]) > 1.0
    p = a["P_out"]
    pos, neg = moving & (a["w_in"] > 0), moving & (a["w_in"] < 0)
    return [pos & (p > 0), pos & (p < 0), neg & (p > 0), neg & (p < 0)]


def test_hoist_lowers_back_driven_and_holds_its_payload_at_standstill():
    _, tr, a = gen4.build(short("clean_hoist_S2_1234Hz_rads", duration=40.0, fs=500))
    w_out = a["w_out"]
    moving = np.abs(a["w_in"]) > 1.0
    lift, lower = moving & (w_out > 0), moving & (w_out < 0)
    assert lift.mean() > 0.1 and lower.mean() > 0.1
    # gravity of one sign: lifting absorbs, lowering back-drives (but for the load inertia's
    # torque while a lift brakes hard or a descent speeds up)
    assert np.mean(a["P_out"][lift] > 0) > 0.8
    assert np.mean(a["P_out"][lower] < 0) > 0.8
    still = a["n_in"] == 0.0
    assert still.mean() > 0.05
    assert np.all(np.abs(a["torque_out"][still]) > 1.5)     # under load at standstill
    assert np.allclose(a["T_in"][still], a["torque_out"][still] / a["ratio"], atol=1e-12)


def test_random_walk_4q_visits_every_quadrant_and_chirp_speeds_up():
    _, _, a = gen4.build(short("clean_randomwalk4q_S1_300Hz_ar1_germanms", duration=120.0))
    assert all(m.mean() > 0.05 for m in quadrants(a))
    _, _, c = gen4.build(short("clean_chirp_S1_8k_quant_us", duration=40.0, fs=500))
    x = np.sign(c["n_in"] - c["n_in"].mean())
    cross = np.flatnonzero(np.diff(x) != 0)
    half = c["t"].size // 2
    assert np.sum(cross >= half) > 1.5 * np.sum(cross < half)
    assert c["n_in"].min() > 300


@pytest.fixture(scope="module")
def four_quadrant_base():
    base = short("clean_randomwalk4q_S1_300Hz_ar1_germanms", duration=90.0, noise={})
    return base, gen4.build(base)[2]


@pytest.mark.parametrize("effect", [gen5.E("accel_loss", rms_mNm=8.0),
                                    gen5.E("sqrt_speed_load", rms_mNm=10.0)])
def test_new_losses_dissipate_in_all_four_quadrants(effect, four_quadrant_base):
    base, a0 = four_quadrant_base
    _, _, a = gen4.build(dict(base, effects=[effect]))
    extra = a["P_loss"] - a0["P_loss"]
    for m in quadrants(a):
        assert m.mean() > 0.05
        assert np.all(extra[m] >= -1e-9)
        assert np.mean(extra[m] > 1e-6) > 0.3
    assert np.allclose(a["P_in"] - a["P_out"], a["P_loss"], rtol=0, atol=1e-9)


def test_dead_zone_is_an_offset_where_the_torque_stays_away_from_zero():
    """out_deadzone_loadramps expects torque_sensor_offset: forward load ramps keep the input
    torque above 0.1 N*m, so sign(T) max(|T| - d, 0) = T - d at every sample."""
    case = short("out_deadzone_loadramps_S1_1k", duration=30.0, fs=500)
    d = case["effects"][0]["mNm"] * 1e-3
    _, _, a = gen4.build(dict(case, effects=[]))
    T = a["T_in"]
    assert T.min() > 5 * d
    read = gen5.transducer5(case, T, 500.0, a["t"], a["w_in"])
    assert np.allclose(read, T - d, rtol=0, atol=1e-15)


def test_hysteresis_is_bounded_and_lags_the_torque_ramps():
    case = short("out_hysteresis_loadramps_S2_1k", duration=40.0, fs=500)
    h = case["effects"][0]["mNm"] * 1e-3
    _, _, a = gen4.build(dict(case, effects=[]))
    T = a["T_in"]
    err = gen5.transducer5(case, T, 500.0, a["t"], a["w_in"]) - T
    assert np.abs(err).max() <= h + 1e-15
    dT = np.gradient(T, a["t"])
    fast = np.abs(dT) > 0.01                    # ramping by more than 10 mN*m/s
    # on a ramp the reading trails the torque by the half-width
    assert np.mean(np.isclose(err[fast], -h * np.sign(dT[fast]), atol=1e-6)) > 0.9


def test_resonance_keeps_the_static_torque_and_rings_at_its_frequency():
    fs = 2000.0
    t = np.arange(int(4 * fs)) / fs
    T = np.where(t > 1.0, 0.5, 0.2)
    y = gen5.resonance(T, fs)
    assert y[-1] == pytest.approx(0.5, abs=1e-6) and y[int(0.9 * fs)] == pytest.approx(0.2)
    ring = y[(t > 1.0) & (t < 2.0)] - 0.5
    f = np.fft.rfftfreq(ring.size, 1 / fs)
    assert f[np.argmax(np.abs(np.fft.rfft(ring)))] == pytest.approx(gen5.RESONANCE_HZ, abs=1.5)
    assert np.abs(ring).max() > 0.25 * 0.3          # it rings: a light damping


def test_run_in_decays_with_the_distance_run_through_reversals():
    case = short("clean_randomwalk4q_S1_300Hz_ar1_germanms", duration=90.0)
    _, _, a = gen4.build(case)
    w = a["w_in"]
    s = dict(t=a["t"], w=w, revs=np.abs(a["theta"]) / (2 * np.pi))
    e = gen5.E("run_in", a=0.25, revs0=300.0, distance=True)
    fg = gen3.loss_factors(dict(effects=[e]), s)[0]
    assert np.all(np.diff(fg) <= 1e-15)             # never rises again: distance only grows
    net = gen5._orig_loss_factors(dict(effects=[dict(e, distance=False)]), s)[0]
    assert np.any(np.diff(net) > 1e-6)              # the net angle's run-in does (gen3)


def _rows(text, sep, comma=False, skip=1):
    rows = list(csv.reader(io.StringIO(text), delimiter=sep))
    body = np.array([[float(c.replace(",", ".")) if comma else float(c) for c in r]
                     for r in rows[skip:] if r])
    return rows[0], body


@pytest.mark.parametrize("dialect", ["us_time", "rad_s", "german_units_ms", "epoch",
                                     "utf16_tab", "suffix", "fahrenheit", "time_ms_fine"])
def test_new_dialects_hold_the_data(tmp_path, dialect):
    case = short("clean_hoist_S1_1k_tempF_jitter", duration=3.0, jitter=0, fs=1234.5,
                 dialect=dialect)
    data, _, _ = gen4.build(case)
    p = tmp_path / ("rec" + gen5.EXT[dialect])
    gen5.write5(p, data, dialect)
    if dialect == "german_units_ms":
        head, body = _rows(p.read_bytes().decode("cp1252"), ";", True, skip=2)
    elif dialect == "utf16_tab":
        head, body = _rows(p.read_text(encoding="utf-16"), "\t")
    else:
        head, body = _rows(p.read_text(encoding="utf-8"), ",")
    t_scale = {"us_time": 1e6, "german_units_ms": 1e3, "time_ms_fine": 1e3}.get(dialect, 1.0)
    assert body.shape[0] == data["time_s"].size
    assert np.allclose(body[:, 0], data["time_s"] * t_scale, rtol=0, atol=1.1e-6 * t_scale)
    n_scale = np.pi / 30 if dialect == "rad_s" else 1.0
    assert np.allclose(body[:, 1], data["speed_in_rpm"] * n_scale, rtol=1e-6, atol=1e-9)
    T_scale = 1e3 if dialect in ("german_units_ms", "suffix") else 1.0
    assert np.allclose(body[:, 3], data["torque_in_Nm"] * T_scale, rtol=1e-6, atol=1e-9)
    if dialect == "fahrenheit":
        assert "°F" in head[-1]
        assert np.allclose((body[:, -1] - 32) / 1.8, data["temperature_C"], atol=1e-4)
