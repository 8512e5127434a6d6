"""Each bound, tolerance and exclusion rule of the readers' checks, tried on both sides of its
threshold (issue 21, item 2): a rule whose constant or comparison changes fails here.

Rules: ``cyclo_fmu.io.checks`` (speed ratio, power balance, N*mm suspicion, time in ms,
standstill, absurd cells, static capacity, the model's torque level), ``cyclo_fmu.recordings``
(NaN share, length, duplicated timestamps), the diagnosis's spike exclusion
(``cyclo_fmu.diagnosis.residual``), the CLI's operating-point bounds (``cyclo_fmu.limits``) and
the design's drag bound. Each recording is built in edge units with numbers chosen by hand
around the documented threshold; none is computed with the rule under test.
"""
import math

import numpy as np
import pytest

from cyclo_fmu.io import checks
from cyclo_fmu.recordings import RecordingError, recording_from_arrays
from model_core import CycloidInputError, DriveDesign


def s1(n=1000, rate=100.0, ratio=15.0, eff=0.8, T_in=0.5, n_in=1000.0, ripple=True, **kw):
    """An S1 run in edge units: input at n_in r/min, output at n_in/ratio, torque_out =
    torque_in * ratio * eff (a forward power flow of efficiency eff)."""
    t = np.arange(n) / rate
    a = 1 + (0.01 * np.sin(t) if ripple else 0 * t)
    speed_in = n_in * a
    torque_in = T_in * (1 + (0.1 * np.sin(t / 2) if ripple else 0 * t))
    return dict(time=t, speed_in_rpm=speed_in, torque_in_Nm=torque_in,
                speed_out_rpm=speed_in / ratio, torque_out_Nm=torque_in * ratio * eff, **kw)


def rec(**kw):
    return recording_from_arrays(**s1(**kw), check=False)


# --- speed ratio against the mode (RATIO_TOL = 3 %) -------------------------------------------
@pytest.mark.parametrize("off", [0.0, 0.02, -0.02, 0.029, -0.029])
def test_ratio_within_tolerance_passes(off):
    mode, findings = checks.check_mode(rec(ratio=15 * (1 + off)), "S1", 15)
    assert mode == "S1" and findings[-1]["status"] == "ok"


@pytest.mark.parametrize("off", [0.031, -0.031, 0.05, -0.05, 0.06, 0.07, -0.07])
def test_ratio_beyond_tolerance_is_refused(off):
    with pytest.raises(RecordingError, match="does not match mode S1"):
        checks.check_mode(rec(ratio=15 * (1 + off)), "S1", 15)


@pytest.mark.parametrize("off,expect", [(0.02, "S1"), (-0.025, "S1"), (0.05, None)])
def test_mode_auto_uses_the_same_tolerance(off, expect):
    r = rec(ratio=15 * (1 + off))
    if expect:
        assert checks.check_mode(r, "auto", 15)[0] == expect
    else:
        with pytest.raises(RecordingError, match="matches no mode"):
            checks.check_mode(r, "auto", 15)


# --- driven samples (MIN_DRIVEN = 100, STANDSTILL_RPM = 1) -----------------------------------
def _partly_driven(k, n=400, rate=50.0):
    d = s1(n=n, rate=rate)
    for key in ("speed_in_rpm", "speed_out_rpm"):
        d[key] = d[key].copy()
        d[key][k:] = 0.0
    return recording_from_arrays(**d, check=False)


def test_standstill_boundary():
    checks.check_units(_partly_driven(100), balance=False)
    with pytest.raises(RecordingError, match="only 99 samples turn faster than 1 r/min"):
        checks.check_units(_partly_driven(99), balance=False)


def test_mode_needs_100_driven_samples():
    checks.check_mode(_partly_driven(100), "S1", 15)
    with pytest.raises(RecordingError, match="only 99 samples where both shafts turn"):
        checks.check_mode(_partly_driven(99), "S1", 15)


def test_low_speed_is_a_warning_below_350_rpm_only():
    def warned(n_in):
        f = checks.check_units(rec(n_in=n_in, ripple=False), balance=False)
        return any(x["id"] == "speed_unit" and x["status"] == "warning" for x in f)
    assert warned(349.0) and not warned(351.0)


# --- power balance (EFFICIENCY_MAX = 1.05, POWER_RATIO_MIN = 0.01) ----------------------------
@pytest.mark.parametrize("eff", [0.011, 0.3, 0.8, 1.0, 1.04])
def test_power_balance_passes_inside(eff):
    f = checks.check_units(rec(eff=eff))
    assert [x for x in f if x["id"] == "power_balance"][-1]["status"] == "ok"


@pytest.mark.parametrize("eff,words", [(1.06, "power balance: on forward samples at a steady "
                                              "speed the power leaving the reducer is 1.06 "
                                              "times"),
                                       (1.2, "1.2 times the power entering"),
                                       (0.009, "torque_in_Nm: on forward samples the power "
                                               "leaving is 0.009 times")])
def test_power_balance_refuses_outside(eff, words):
    with pytest.raises(RecordingError, match=words.replace("(", r"\(").replace(".", r"\.")):
        checks.check_units(rec(eff=eff))


def test_an_inertia_giving_back_its_energy_is_not_refused():
    """Moves of a flywheel load: accelerated forward (the drive passes 80 %), braked by the
    load through the drive (back-driven), with an input-side inertia between the input
    transducer and the reducer. While braking, the input shaft gives back what its inertia
    stored, and the back-driven samples carry more power out than in (1.3 here); at a steady
    speed nothing is loaded. The energy is conserved: the recording is accepted, and the
    finding says why the ratio is above 1."""
    rate, ratio, eff, J_in, J_load = 1000.0, 15.0, 0.8, 1.1e-3, 0.5   # back: eff + J_in r^2/J_load
    t = np.arange(int(8 * rate)) / rate
    ph = t % 2.0                               # a move every 2 s: 0.2 s up, 0.4 s cruise, 0.2 s down
    a_in = np.where(ph < 0.2, 1.0, np.where((ph >= 0.6) & (ph < 0.8), -1.0, 0.0)) * 500.0
    w_in = np.cumsum(a_in) / rate              # rad/s
    T_out = J_load * a_in / ratio              # the load's inertia, at the output shaft
    T_red = np.where(T_out >= 0, T_out / (ratio * eff), T_out * eff / ratio)
    T_in = T_red + J_in * a_in
    r = recording_from_arrays(time=t, speed_in_rpm=w_in * 30 / math.pi, torque_in_Nm=T_in,
                              speed_out_rpm=w_in * 30 / math.pi / ratio, torque_out_Nm=T_out,
                              check=False)
    pb = [x for x in checks.check_units(r) if x["id"] == "power_balance"][-1]
    assert pb["status"] == "ok" and "inertia giving back its energy" in pb["message"], pb
    ratio_back = float(pb["message"].split("back-driven: ")[1].split("efficiency ")[1][:4])
    assert ratio_back > 1.05                   # the instantaneous ratio the old rule refused


def test_opposite_torque_sign_is_refused_and_override_accepted():
    r = rec(eff=-0.8)
    with pytest.raises(RecordingError, match="torque_out_Nm has the opposite sign"):
        checks.check_units(r)
    checks.check_units(r, units_given=("torque_out_Nm",))


# --- N*mm suspicion (N_MM_SUSPECT_NM = 1000 N*m at the input) --------------------------------
def test_input_torque_level_boundary():
    checks.check_units(rec(T_in=999.0, ripple=False))
    with pytest.raises(RecordingError, match="torque_in_Nm peaks at 1001: that looks like N\\*mm"):
        checks.check_units(rec(T_in=1001.0, ripple=False))
    checks.check_units(rec(T_in=1001.0, ripple=False), units_given=("torque_in_Nm",))


# --- time in ms (MS_SUSPECT_DT = 0.2 s with MS_SUSPECT_DURATION = 7200 s) -------------------
@pytest.mark.parametrize("dt,n,refused", [(0.2002, 36000, True), (0.2002, 35960, False),
                                          (0.1998, 36100, False), (1.0, 7201, True)])
def test_time_in_ms_boundary(dt, n, refused):
    r = rec(n=n, rate=1 / dt)
    if refused:
        with pytest.raises(RecordingError, match="look like time in ms"):
            checks.check_units(r, balance=False)
        checks.check_units(r, units_given=("time_s",), balance=False)
    else:
        checks.check_units(r, balance=False)


# --- absurd cells (ABSURD, schema units) ----------------------------------------------------
@pytest.mark.parametrize("key,limit", [("torque_in_Nm", 1e7), ("speed_in_rpm", 1e6),
                                       ("time", None)])
def test_absurd_cell_boundary(key, limit):
    d = s1()
    if key == "time":            # time may reach 1e9 s (the schema's limit), not beyond
        d["time"] = d["time"] + (1e9 - 10.0)
        recording_from_arrays(**d, check=False)
        d["time"] = d["time"] + 5.0      # starts below 1e9 s, ends above it: no Unix time
        with pytest.raises(RecordingError, match="is not a measurement"):
            recording_from_arrays(**d, check=False)
        return
    d[key] = d[key].copy()
    d[key][500] = limit
    recording_from_arrays(**d, check=False)
    d[key][500] = limit * (1 + 1e-6)
    with pytest.raises(RecordingError, match=f"column '{key}'.*is not a measurement"):
        recording_from_arrays(**d, check=False)


# --- static capacity (Hertz limit of the ring rollers) ----------------------------------------
def test_capacity_boundary():
    d = DriveDesign()
    cap = checks.torque_capacity_out(d)
    # hand check of the closed form: pi b R p^2 / E* * z1 r_p / 4, with E* = 115.38 GPa
    e_star = 210e9 / (2 * (1 - 0.09))
    F = math.pi * 0.012 * 0.006 * (4e9) ** 2 / e_star
    assert cap == pytest.approx(F * 15 * (1.6 * 0.002 * 15) / 4, rel=1e-12)
    assert cap == pytest.approx(5645.82, rel=1e-5)
    ok = rec(T_in=0.99 * cap / 15, eff=1.0, ripple=False)
    checks.check_capacity(ok, "S1", d, [])
    bad = rec(T_in=1.01 * cap / 15, eff=1.0, ripple=False)
    with pytest.raises(RecordingError, match="peaks at .* N\\*m, above the .* permanent set"):
        checks.check_capacity(bad, "S1", d, [])


# --- the model's torque level (MODEL_TORQUE_FACTOR = 10) --------------------------------------
def _model_scaled(factor):
    from model_core import operating_point, rpm_to_rad_s
    d = s1(eff=1.0)
    d["torque_out_Nm"] = 5.0 + 3.0 * np.sin(d["time"])           # N*m out, forward
    op = operating_point(DriveDesign(), "S1", rpm_to_rad_s(d["speed_in_rpm"]),
                         T_out=-d["torque_out_Nm"])
    d["torque_in_Nm"] = factor * np.asarray(op.torques["S"], float)
    return recording_from_arrays(**d, check=False)


@pytest.mark.parametrize("factor", [1.0, 9.0, 1 / 9.0])
def test_model_level_within_factor_passes(factor):
    f = checks.check_model_level(_model_scaled(factor), "S1", DriveDesign(), [])
    assert f[-1]["status"] == "ok" and f"{factor:.3g} times" in f[-1]["message"]


@pytest.mark.parametrize("factor", [11.0, 1 / 11.0, 1000.0, 1e-3])
def test_model_level_beyond_factor_is_refused(factor):
    with pytest.raises(RecordingError, match="times what the design needs"):
        checks.check_model_level(_model_scaled(factor), "S1", DriveDesign(), [],
                                 units_given=("torque_in_Nm", "torque_out_Nm"))


# --- NaN share (MAX_EXCLUDED = 20 %), length (5 s, 200 samples), duplicates -------------------
def test_nan_share_boundary():
    d = s1(n=1000)
    d["torque_in_Nm"] = d["torque_in_Nm"].copy()
    d["torque_in_Nm"][100:300] = np.nan                              # 200 of 1000: 20 %
    r = recording_from_arrays(**d, check=False)
    assert r.n == 800 and [(e.reason, e.count) for e in r.exclusions] == \
        [("NaN in torque_in_Nm", 200)]
    d["torque_in_Nm"][300] = np.nan                                  # 201: beyond
    with pytest.raises(RecordingError, match="201 of 1000 samples have NaN"):
        recording_from_arrays(**d, check=False)


def test_length_boundary():
    t = np.linspace(0.0, 5.0, 200)                    # 200 samples over exactly 5 s
    base = s1(n=200)
    recording_from_arrays(**dict(base, time=t), check=False)
    with pytest.raises(RecordingError, match="too short: 199 samples"):
        recording_from_arrays(**{k: v[:199] for k, v in dict(base, time=np.linspace(
            0, 5.0, 199)).items()}, check=False, min_samples=200)
    with pytest.raises(RecordingError, match="too short: 200 samples over 4.99 s"):
        recording_from_arrays(**dict(base, time=np.linspace(0.0, 4.99, 200)), check=False)


def test_clean_data_excludes_nothing():
    r = rec()
    assert r.exclusions == () and r.n == 1000


def test_duplicated_timestamp_is_averaged_and_counted():
    d = s1()
    d["time"] = d["time"].copy()
    d["time"][501] = d["time"][500]
    d["torque_in_Nm"] = d["torque_in_Nm"].copy()
    d["torque_in_Nm"][500], d["torque_in_Nm"][501] = 1.0, 2.0
    r = recording_from_arrays(**d, check=False)
    assert r.n == 999 and r.torque_in[500] == pytest.approx(1.5)
    assert [e.count for e in r.exclusions] == [1]


def test_time_going_backwards_is_refused():
    d = s1()
    d["time"] = d["time"].copy()
    d["time"][600] = d["time"][598]
    with pytest.raises(RecordingError, match="time_s goes backwards at sample 600"):
        recording_from_arrays(**d, check=False)


# --- the diagnosis's spike exclusion (SPIKE_SIGMA = 8 robust sigma, MAX_SPIKE_SHARE = 2 %) ---
def _spiky(spikes, n=2000):
    """A line fit of 2000 blocks with unit Gaussian noise; spikes: {index: size in robust
    standard deviations of the noise}."""
    from cyclo_fmu.diagnosis.residual import robust_sigma
    rng = np.random.default_rng(7)
    x = np.linspace(-1, 1, n)
    X = np.stack([np.ones(n), x], -1)
    noise = rng.normal(0, 1, n)
    noise -= np.polyval(np.polyfit(x, noise, 1), x)        # exactly orthogonal to the basis
    s = robust_sigma(noise)
    y = 0.3 + 2.0 * x + noise
    for i, k in spikes.items():
        y[i] += k * s
    return X, y


def test_clean_noise_excludes_no_block():
    from cyclo_fmu.diagnosis.residual import robust_weights
    assert robust_weights(*_spiky({}))[1] == 0


@pytest.mark.parametrize("size,excluded", [(6.0, 0), (7.2, 0), (8.8, 1), (10.0, 1), (40.0, 1)])
def test_spike_threshold(size, excluded):
    from cyclo_fmu.diagnosis.residual import robust_weights
    w, n_spikes, _ = robust_weights(*_spiky({1000: size}))
    assert n_spikes == excluded and (w[1000] == 0) == bool(excluded)


@pytest.mark.parametrize("share,excluded", [(0.01, True), (0.02, True), (0.025, False),
                                            (0.05, False)])
def test_spike_share(share, excluded):
    """At most 2 % of the blocks are spikes; beyond that the tails are structure, nothing is
    excluded."""
    from cyclo_fmu.diagnosis.residual import robust_weights
    k = int(round(share * 2000))
    idx = np.linspace(10, 1990, k).astype(int)
    n_spikes = robust_weights(*_spiky({int(i): 20.0 * (-1) ** j for j, i in
                                       enumerate(idx)}))[1]
    assert n_spikes == (k if excluded else 0)


# --- the CLI's operating-point bounds (cyclo_fmu.limits) --------------------------------------
@pytest.mark.parametrize("v,ok", [(1.0, True), (-1.0, True), (0.999, False), (-0.999, False),
                                  (1e5, True), (-1e5, True), (1.00001e5, False),
                                  (math.inf, False), (math.nan, False)])
def test_speed_bounds(v, ok):
    from cyclo_fmu.limits import check_speed_rpm
    if ok:
        assert check_speed_rpm("speed", v) == v
    else:
        with pytest.raises(CycloidInputError, match="speed = "):
            check_speed_rpm("speed", v)


def test_design_drag_bound():
    """The documented rule (docs/reference/errors.md, "design drag"): a drag at the driving
    shaft beyond the ring's static rating over z1 - 1 is refused, just below it accepted. The
    bound is derived from the rating (``stiffness.ring_torque_rating``: the static output
    rating over i0, limited by the eccentric bearing since the series stiffness model of
    2026-11-26; 68.7 N*m for the paper's drive, 368 N*m before)."""
    from model_core.stiffness import ring_torque_rating, static_torque_rating
    from model_core.design import ExtraPhysics
    d = DriveDesign()
    cap = ring_torque_rating(d) / (d.z1 - 1)
    assert cap == pytest.approx(static_torque_rating(d)["rating_Nm"] / d.i0 / (d.z1 - 1),
                                rel=1e-12)
    assert round(cap, 2) == 68.69         # the number errors.md states
    for name in ("drag_torque", "stribeck_torque"):
        DriveDesign(extra=ExtraPhysics(**{name: 0.999 * cap}))
        with pytest.raises(CycloidInputError, match=f"extra.{name}"):
            DriveDesign(extra=ExtraPhysics(**{name: 1.001 * cap}))


# --- the diagnosis's physical bounds: a fit outside them is not that effect --------------------
def _selection_problem(slope):
    """2000 blocks: y = 0.01 + slope * x + noise (0.001); candidates 'offset' (column 0,
    bounds -1..1) and 'drag' (column 1, bounds 0..1: a drag cannot feed power in)."""
    from cyclo_fmu.diagnosis.selection import GramProblem, Term
    rng = np.random.default_rng(3)
    n = 2000
    x = np.abs(np.sin(np.linspace(0, 20, n)))
    X = np.stack([np.ones(n), x], -1)
    y = 0.01 + slope * x + rng.normal(0, 0.001, n)
    terms = {"offset": [Term("offset", None, (0,), ("c",), ("N*m",), (-1.0,), (1.0,))],
             "drag": [Term("drag", None, (1,), ("T",), ("N*m",), (0.0,), (1.0,))]}
    return GramProblem(X, y, np.ones(n)), terms


@pytest.mark.parametrize("slope,named", [(0.02, True), (1e-3, True), (-1e-3, False),
                                         (-0.02, False)])
def test_fit_outside_its_bounds_is_not_named(slope, named):
    from cyclo_fmu.diagnosis.selection import stepwise
    problem, terms = _selection_problem(slope)
    fit = problem.fit((terms["offset"][0], terms["drag"][0]))
    assert fit.admissible == (slope >= 0)
    sel = stepwise(problem, terms, min_explained=1e-5)
    assert ("drag" in sel.fit.ids) == named, sel.fit.ids
    assert "offset" in sel.fit.ids


# --- loaded samples (MIN_LOADED = 10) and the output's standstill (1e-3 r/min) ---------------
def _loaded(k, n=600):
    """k loaded samples: input torque and output torque high on k samples, ~0 elsewhere."""
    d = s1(n=n, ripple=False)
    T = np.full(n, 1e-4)
    T[:k] = 0.5
    d["torque_in_Nm"], d["torque_out_Nm"] = T, T * 15 * 0.8
    return recording_from_arrays(**d, check=False)


def test_power_balance_needs_10_loaded_samples():
    f = checks.check_units(_loaded(10))
    assert [x for x in f if x["id"] == "power_balance"][-1]["status"] == "ok"
    f = checks.check_units(_loaded(9))
    assert [x for x in f if x["id"] == "power_balance"][-1]["status"] == "warning"


def test_output_standstill_allows_a_ratio_of_1000():
    """A z1 = 1000 drive in S1 at 1.5 r/min turns its output at 0.0015 r/min: still turning
    (OUTPUT_STANDSTILL_RPM = 1e-3 r/min); at 0.0009 r/min it stands still."""
    r = rec(n_in=1.5, ratio=1000.0, ripple=False)
    assert checks.check_mode(r, "S1", 1000)[0] == "S1"
    with pytest.raises(RecordingError, match="only 0 samples where both shafts turn"):
        checks.check_mode(rec(n_in=1.5, ratio=1.5 / 0.0009, ripple=False),
                          "S1", 1000)


def test_echo_clipping_boundary():
    """A cell or line is echoed whole up to ECHO_CHARS (60) characters, clipped beyond."""
    from cyclo_fmu.io.text import ECHO_CHARS, clip
    assert ECHO_CHARS == 60
    assert clip("x" * 60) == repr("x" * 60)
    assert clip("x" * 61) == repr("x" * 60) + "... (61 characters)"


def test_one_corrupt_cell_does_not_switch_the_checks_off():
    """A single 99999 r/min cell: the mode check still judges the ratio on every other sample
    (peaks are the 99.9th percentile, PEAK_QUANTILE), and the power balance still runs."""
    d = s1(n=2000)
    d["speed_in_rpm"] = d["speed_in_rpm"].copy()
    d["speed_in_rpm"][700] = 99999.0
    r = recording_from_arrays(**d, check=False)
    mode, f = checks.check_mode(r, "S1", 15)
    assert mode == "S1" and "2000 driven samples" in f[-1]["message"]
    f = checks.check_units(r)
    assert [x for x in f if x["id"] == "power_balance"][-1]["status"] == "ok"


def test_viscosity_floor():
    """Catalogue viscosities below water's 1 mm^2/s are refused (the Walther line is undefined
    from 0.3 mm^2/s down); 1 mm^2/s at 100 degC is accepted."""
    from model_core.design import Lubricant
    DriveDesign(lubricant=Lubricant(kinematic_viscosity=20e-6, kinematic_viscosity_100=1.0e-6))
    with pytest.raises(CycloidInputError, match="lubricant.kinematic_viscosity_100"):
        DriveDesign(lubricant=Lubricant(kinematic_viscosity=20e-6,
                                        kinematic_viscosity_100=0.99e-6))


# --- the diagnosis's residual rules against closed forms and hand counts (mutation survivors) ---

def test_generic_time_basis_is_legendre():
    """The generic basis's time columns are Legendre P1..P5 (closed forms, Abramowitz & Stegun
    22.3.8) and orthogonal on [-1, 1]: integral of Pm Pn = 2 / (2n + 1) delta_mn."""
    from cyclo_fmu.diagnosis.residual import _legendre
    x = np.linspace(-1.0, 1.0, 7)
    closed = np.stack([x, (3 * x**2 - 1) / 2, (5 * x**3 - 3 * x) / 2,
                       (35 * x**4 - 30 * x**2 + 3) / 8, (63 * x**5 - 70 * x**3 + 15 * x) / 8], -1)
    np.testing.assert_allclose(_legendre(x, 5), closed, atol=1e-12)
    g, wq = np.polynomial.legendre.leggauss(8)        # exact for degree <= 15
    P = _legendre(g, 5)
    np.testing.assert_allclose(P.T @ (wq[:, None] * P),
                               np.diag(2.0 / (2 * np.arange(1, 6) + 1)), atol=1e-12)


def test_burst_length_counted_by_hand():
    """One speed reversal at t = 4.995 s (blocks of 10 ms, +1 -> -1): spike blocks 497-499 and
    501-502 are two bursts of 3 and 2 blocks at it (mean 2.5 blocks), block 100 lies elsewhere
    (5 of the 6 spike blocks within EVENT_WINDOW, 0.1 s, of the one reversal). Which kinds a
    transient is tied to is decided against twins (``remainder.burst_claims``), not here."""
    from cyclo_fmu.diagnosis.residual import EVENT_WINDOW, bursts
    assert EVENT_WINDOW == 0.1
    t = np.arange(1000) * 0.01
    w = np.where(t < 4.995, 1.0, -1.0)
    T_out = np.ones_like(t)
    spikes = np.zeros(t.size, bool)
    spikes[[497, 498, 499, 501, 502, 100]] = True
    b = bursts(t, spikes, w, T_out)
    assert b["count"] == 6
    assert b["at"]["speed reversals"] == 5 and b["at"]["elsewhere"] == 1
    assert b["burst_blocks"]["speed reversals"] == pytest.approx(2.5)
    assert b["events_with_burst"]["speed reversals"] == (1, 1)
    assert b["tied"] == []
    # one burst of 5 consecutive blocks: mean length 5
    spikes[497] = False
    spikes[500] = True                       # blocks 498-502
    assert bursts(t, spikes, w, T_out)["burst_blocks"]["speed reversals"] == pytest.approx(5.0)


def test_peak_level_flanks_and_dc_rule():
    """The local level of a bin (residual._level) on a flat spectrum of 1 with a plateau of
    height 100: the flanks are the three bins PEAK_FLANK_BINS (2) to 4 away on each side, so a
    plateau of half-width 2 (5 bins) stands on a level of 1, one of half-width 3 (7 bins) has
    two of each flank's three bins on it and its level is 100 (not narrow); a bin whose lower
    flank would reach the DC bin (index < 5), or whose upper flank the Nyquist bin (index >
    95 of 0..100), is not judged (NaN)."""
    from cyclo_fmu.diagnosis.residual import PEAK_FLANK_BINS, _level
    assert PEAK_FLANK_BINS == 2
    for half, want in ((0, 1.0), (2, 1.0), (3, 100.0)):
        P = np.ones(101)
        P[50 - half:51 + half] = 100.0
        got, level = _level(P[:, None], slice(None), 21)
        np.testing.assert_array_equal(got, P)
        assert level[50] == want, half
        assert np.all(np.isnan(level[:5])) and np.all(np.isfinite(level[5:96]))
        assert np.all(np.isnan(level[96:]))
    # the median over the width (21 bins, 40-60 for bin 50), outside the centre's flanks: 11 of
    # them at 100 (40-45, 55-59) lift its level to 100 (of 23 bins they would not); 10 of them
    # (41-45, 55-59) do not (of 19 bins they would)
    P = np.ones(101)
    P[40:46] = P[55:60] = 100.0
    assert _level(P[:, None], slice(None), 21)[1][50] == 100.0
    P[40] = 1.0
    assert _level(P[:, None], slice(None), 21)[1][50] == 1.0


@pytest.mark.parametrize("T_in", [0.5, 1e-4])
def test_power_balance_efficiency_is_scale_free(T_in):
    """The efficiency the power balance reports is the ratio of the energies that leave and
    enter, a ratio free of the power's scale: with torque_out = 15 * 0.8 * torque_in at a
    15:1 speed ratio it is 0.8 at 0.5 N*m (~50 W) and at 1e-4 N*m (~10 mW) alike; driven
    backwards (both torques negative, |P_in| = 0.8 |P_out|) it is 0.8 too."""
    f = checks.check_units(rec(T_in=T_in))
    msg = [x for x in f if x["id"] == "power_balance"][-1]["message"]
    assert "forward: 1000 samples, efficiency 0.8;" in msg + ";", msg
    d = s1(T_in=T_in)
    d["torque_in_Nm"] = -d["torque_in_Nm"]
    d["torque_out_Nm"] = -d["torque_in_Nm"] * (-15.0 / 0.8)   # P_out = P_in / 0.8, both < 0
    f = checks.check_units(recording_from_arrays(**d, check=False))
    msg = [x for x in f if x["id"] == "power_balance"][-1]["message"]
    assert "back-driven: 1000 samples, efficiency 0.8;" in msg + ";", msg


# --- Unix time stamps (recordings.UNIX_TIME_S) ------------------------------------------------
def test_unix_time_is_referred_to_its_first_stamp():
    """A logger's Unix time (s since 1970, first stamp 2025-11-26 08:00:00 UTC) is read as the
    time since its first stamp, to the sample interval, with a note naming the stamp; a first
    stamp beyond 2099 (4.1e9 s) is no Unix time and no measurement: refused."""
    from cyclo_fmu.recordings import UNIX_TIME_S
    d = s1()
    rel = d["time"] - d["time"][0]
    d["time"] = rel + 1764144000.0
    r = recording_from_arrays(**d, check=False)
    np.testing.assert_allclose(r.time, rel, atol=1e-6)
    assert any("Unix time" in n and "2025-11-26T08:00:00.000 UTC" in n for n in r.notes)
    d["time"] = rel + UNIX_TIME_S[1] + 1.0
    with pytest.raises(RecordingError, match="is not a measurement"):
        recording_from_arrays(**d, check=False)
