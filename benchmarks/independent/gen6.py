"""Sixth independent batch of bench recordings for cyclo-fmu's diagnosis: what batches 1-5 do
not cover.

Written without reading the diagnosis (cyclo_fmu/diagnosis) or its explanation pages: every
hidden effect is built here (or in gen3/gen4/gen5) from its physical description, the sizes of
the library's effects taken near `model_core.effects.EFFECTS`' synth defaults. The expectation
of every case is fixed in CASES below and committed before the first diagnosis run. The
reducer is the physics core through gen3.reducer_losses and gen4.build (standstill, power
bookkeeping), in modes S1 and S2.

New here:
- plans: ``scurve`` (jerk-limited S-curve moves between speed levels, some reversed, load
  steps, a fifth back-driven), ``press`` (an indexing table: 90 deg output indexes with
  S-curve profiles, dwells at standstill under the press's reaction torque, the table's
  inertia back-driving every deceleration), ``pump`` (a centrifugal load: torque ~ speed^2,
  power ~ speed^3, ramps and holds), ``sineoffset`` (a sinusoidal speed around an offset that
  never stops, a sinusoidal load of an incommensurate period), ``robot`` (a robot joint:
  short S-curve moves back and forth with pauses, gravity ~ cos(joint angle) plus the link's
  inertia: every quadrant, back-driven), ``effmap`` (an efficiency map: six speeds x five
  loads, held), ``settlepump`` (the pump after a leading standstill of 6-10 s);
- rates: 250 Hz, 750 Hz, 3 kHz, 16 kHz; irregular logging (10 % of the samples dropped at
  random);
- noise: heavy tails (Student t, 3 degrees of freedom), a 50 Hz mains pickup of fixed
  amplitude, sparse spikes, coarse quantisation;
- dialects (forms docs/how-to/read-an-export.md documents): ``ws_bom`` (whitespace, UTF-8 with
  BOM, bare names t/n_in/n_out/T_in/T_out), ``catman_tab_nmm`` (metadata lines, tab, a units
  row with N·mm, cp1252), ``neg_out`` (the output torque written with the opposite sign, read
  with ``--units torque_out_Nm=-N*m`` as a user would), ``extra_cols6`` (bracketed units among
  unrelated channels), ``mdf_rads`` (MDF4 with speeds in rad/s), ``tsv_rads_nmm`` (tab,
  speeds in rad/s, input torque in N·mm);
- effects outside the library (my own design): a seal drag depending on speed and the
  recorded temperature, a bearing preload loss ~ |T|^0.5, a 1x unbalance amplified by a
  structural resonance at 25 Hz (1500 r/min), a motor torque ripple at 6x the electrical
  frequency (24x the shaft, amplitude with the current), a transducer gain changing with
  speed^2, a bearing skid loss at light load and high speed, a transducer gain differing by
  the torque's sign.

    python benchmarks/independent/gen6.py [case_id ...]      # writes OUT/recs, OUT/cases6.json

OUT: the environment variable CYCLO_INDEPENDENT_OUT (default out/independent6);
CYCLO_INDEPENDENT_SEED_SHIFT=n draws every case with another seed (default 0).
"""
from __future__ import annotations

import json
import os
import sys
from pathlib import Path

os.environ.setdefault("CYCLO_INDEPENDENT_OUT", "out/independent6")
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import gen   # noqa: E402  (EXTRA_ARGS)
import gen3  # noqa: E402  (the reducer through the core, library effects)
import gen4  # noqa: E402  (build)
import gen5  # noqa: E402  (its wrappers of gen3/gen4 and its dialects)

import numpy as np  # noqa: E402

from model_core import rpm_to_rad_s  # noqa: E402

HERE = Path(os.environ["CYCLO_INDEPENDENT_OUT"]).resolve()
RECS = HERE / "recs"

#: [s] the S-curve profiles' acceleration time and jerk time (a servo's motion profile:
#: two moving averages of a step give a trapezoidal acceleration, i.e. a jerk limit)
SCURVE_TA, SCURVE_TJ = 0.35, 0.08
#: [kg*m^2] the indexing table's inertia on the output shaft (an assumption)
PRESS_TABLE_INERTIA = 0.5
#: [kg*m^2] the robot link's inertia about the joint (output shaft) (an assumption)
ROBOT_LINK_INERTIA = 0.05
#: [Hz], [1] the structural mode that amplifies the input shaft's 1x (a bench frame's first
#: mode at 1500 r/min; light damping of a bolted steel frame)
STRUCT_HZ, STRUCT_ZETA = 25.0, 0.05
#: the motor's pole pairs: its dominant torque ripple lies at 6x the electrical frequency
MOTOR_POLE_PAIRS = 4
#: [N*m] the output torque below which a rolling bearing's rollers skid (the skid loss falls
#: as exp(-|T_out| / SKID_T0))
SKID_T0 = 1.0
#: [K] the temperature rise over which the seal's drag falls by 1/e (the lip's oil film
#: thickens as the viscosity falls)
SEAL_THETA = 20.0


# ----------------------------------------------------------------------------- plans
def _boxcar(x, dur, fs):
    """A causal moving average over dur [s], started settled."""
    k = max(1, int(round(dur * fs)))
    c = np.cumsum(np.r_[0.0, np.full(k - 1, x[0]), x])
    return (c[k:] - c[:-k]) / k


def scurve(x, fs, ta=SCURVE_TA, tj=SCURVE_TJ):
    """A set-point staircase (or pulses) turned into jerk-limited S-curve moves: two moving
    averages (ta, tj): the acceleration is a trapezoid, the jerk bounded by step/(ta tj), and
    a pulse's area (an angle) is kept exactly."""
    return _boxcar(_boxcar(x, ta, fs), tj, fs)


def _steps(t, tk, vk):
    """A staircase: value vk[j] from tk[j] on."""
    idx = np.searchsorted(np.asarray(tk), t, side="right") - 1
    return np.asarray(vk)[np.clip(idx, 0, len(vk) - 1)]


def plan_scurve(rng, t, fs, i):
    """Speed levels 300-2800 r/min held 2-5 s (a quarter in the other direction), reached by
    S-curve moves (SCURVE_TA, SCURVE_TJ; no speed loop: a servo with feed-forward tracks its
    profile); at each level's start a load step to 1-8 N*m against the motion, a fifth of them
    with the motion (back-driven)."""
    dur = t[-1]
    tk, nk, Lk = [0.0], [rng.uniform(500, 1500)], [3.0]
    while tk[-1] < dur:
        tk.append(tk[-1] + rng.uniform(2, 5))
        nk.append(rng.uniform(300, 2800) * (-1 if rng.random() < 0.25 else 1))
        d = np.sign(nk[-1]) * np.sign(i)
        Lk.append(rng.uniform(1, 8) * (-d if rng.random() < 0.2 else d))
    n_in = scurve(_steps(t, tk, nk), fs)
    return n_in, gen3._torque_loop(_steps(t, np.array(tk) + 0.5, Lk), fs)


def plan_press(rng, t, fs, i):
    """An indexing table under a press: 90 deg output indexes (|i|/4 input revolutions) in
    0.45-0.7 s as S-curve moves (SCURVE_TA 0.15 s, SCURVE_TJ 0.05 s), forward, then a dwell of
    0.4-1.2 s at standstill while the press acts (a reaction torque of 3-7 N*m held by the
    reducer). The load: the table's inertia PRESS_TABLE_INERTIA plus a guide friction of
    1-2 N*m while it moves; each deceleration back-drives the reducer."""
    dur = t[-1]
    rev_in = abs(i) / 4.0                                 # input revolutions per index
    pulse = np.zeros_like(t)
    press = np.zeros_like(t)
    tt = rng.uniform(0.3, 0.8)
    while tt < dur:
        D = rng.uniform(0.45, 0.7) - 0.15                 # the pulse; the profile adds ta
        V = rev_in * 60.0 / D                             # r/min so that V*D = the index
        pulse[(t >= tt) & (t < tt + D)] = V * np.sign(i)
        end = tt + D + 0.15 + 0.05
        dwell = rng.uniform(0.4, 1.2)
        press[(t >= end + 0.05) & (t < end + dwell - 0.05)] = rng.uniform(3, 7) * np.sign(i)
        tt = end + dwell
    n_in = scurve(pulse, fs, 0.15, 0.05)
    n_in[np.abs(n_in) < 1e-6] = 0.0
    w_out = rpm_to_rad_s(n_in) / i
    fric = rng.uniform(1, 2) * np.tanh(w_out / 0.2)
    tout = PRESS_TABLE_INERTIA * np.gradient(w_out, t) + fric + gen3._torque_loop(press, fs)
    return n_in, tout


def _pump(rng, t, fs, i, settle=0.0):
    """A centrifugal pump or fan: holds of 3-8 s at 600-3000 r/min joined by ramps of
    400-900 r/min/s; the load torque 0.3 N*m (bearings, seals) + 8 N*m (n/3000 r/min)^2 (the
    affinity laws: torque ~ speed^2, power ~ speed^3); forward. settle: a leading standstill
    [s], unloaded, before the first ramp."""
    dur = t[-1]
    pts = [(0.0, 0.0), (settle, 0.0)] if settle else [(0.0, rng.uniform(600, 1500))]
    tt = pts[-1][0]
    while tt < dur:
        n = rng.uniform(600, 3000)
        tt += abs(n - pts[-1][1]) / rng.uniform(400, 900)
        pts.append((tt, n))
        tt += rng.uniform(3, 8)
        pts.append((tt, n))
    ts, vs = gen3._knots(pts)
    n_in = gen3._speed_loop(np.interp(t, ts, vs), fs)
    if settle:
        n_in[t < settle] = 0.0
    n_in[np.abs(n_in) < 1e-6] = 0.0
    L = 0.3 * np.tanh(n_in / 20.0) + 8.0 * (n_in / 3000.0) ** 2
    return n_in, gen3._torque_loop(L, fs) * np.sign(i)


def plan_pump(rng, t, fs, i):
    return _pump(rng, t, fs, i)


def plan_settlepump(rng, t, fs, i):
    """The pump after a leading standstill of 6-10 s (the logger started before the drive)."""
    return _pump(rng, t, fs, i, settle=rng.uniform(6, 10))


def plan_sineoffset(rng, t, fs, i):
    """A sinusoidal speed around an offset that never stops: n = n0 + a sin(2 pi f t), n0
    1400-1700, a 600-900 r/min, f 0.15-0.35 Hz (fixed); the load 4.5 + 3 sin(2 pi f g t + phi)
    N*m with g = 0.618 (incommensurate): forward, continuously accelerating."""
    f = rng.uniform(0.15, 0.35)
    n_set = rng.uniform(1400, 1700) + rng.uniform(600, 900) * np.sin(
        2 * np.pi * f * t + rng.uniform(0, 2 * np.pi))
    L = 4.5 + 3.0 * np.sin(2 * np.pi * f * 0.618 * t + rng.uniform(0, 2 * np.pi))
    return gen3._speed_loop(n_set, fs), gen3._torque_loop(L, fs) * np.sign(i)


def plan_robot(rng, t, fs, i):
    """A robot joint (the output shaft) moving back and forth: moves of 0.2-0.6 s at
    500-2000 r/min of the input as S-curves (0.12 s, 0.03 s), the direction reversed after 80 %
    of the moves, pauses of 0.1-0.5 s at standstill. The load: gravity G cos(q) (G 4-7 N*m,
    q the joint angle from a random start) + ROBOT_LINK_INERTIA * the joint's acceleration +
    a joint-side viscous damping 0.5 N*m s/rad: every quadrant, back-driven when the link
    falls or brakes."""
    dur = t[-1]
    pulse = np.zeros_like(t)
    tt, sgn = 0.3, 1.0
    while tt < dur:
        D = rng.uniform(0.2, 0.6)
        pulse[(t >= tt) & (t < tt + D)] = sgn * rng.uniform(500, 2000)
        tt += D + 0.15 + rng.uniform(0.1, 0.5)
        if rng.random() < 0.8:
            sgn = -sgn
    n_in = scurve(pulse, fs, 0.12, 0.03)
    n_in[np.abs(n_in) < 1e-6] = 0.0
    w_out = rpm_to_rad_s(n_in) / i
    q = rng.uniform(0, 2 * np.pi) + np.concatenate(
        [[0.0], np.cumsum(0.5 * (w_out[1:] + w_out[:-1]) * np.diff(t))])
    G = rng.uniform(4, 7)
    tout = G * np.cos(q) + ROBOT_LINK_INERTIA * np.gradient(w_out, t) + 0.5 * w_out
    return n_in, tout


def plan_effmap(rng, t, fs, i):
    """An efficiency map: six speeds (300-3000 r/min, ascending, ramps of 1000 r/min/s), at each
    five loads 0.5-9 N*m in a random order, held alike (the recording's length shared
    equally), load steps over 50 ms."""
    dur = t[-1]
    speeds = np.sort(rng.uniform(300, 3000, 6))
    seg = dur / 6
    sp, ld = [(0.0, speeds[0])], [(0.0, 1.0)]
    for k, n in enumerate(speeds):
        t0 = k * seg
        if k:
            sp.append((t0 + abs(n - speeds[k - 1]) / 1000.0, n))
        sp.append((t0 + seg, n))
        for j, L in enumerate(rng.permutation(np.linspace(0.5, 9.0, 5))):
            ts = t0 + j * seg / 5
            ld += [(ts, ld[-1][1]), (ts + 0.05, L)]
    n_in, L = gen3._levels_plan(t, fs, sp, ld)
    return n_in, L * np.sign(i)


PLANS6 = {"scurve": plan_scurve, "press": plan_press, "pump": plan_pump,
          "settlepump": plan_settlepump, "sineoffset": plan_sineoffset, "robot": plan_robot,
          "effmap": plan_effmap}
gen4.PLANS.update(PLANS6)


# ----------------------------------------------------------------------------- hidden physics
_prev_extra = gen4.extra_loss_shapes           # gen5's (itself wrapping gen4's)
_prev_transducer = gen4.transducer4            # gen5's
_prev_effect_sizes = gen4.effect_sizes
_prev_colour = gen4.colour_noise
_prev_logger = gen3.logger


def extra_loss_shapes6(case, s):
    """gen5's additive input torques plus this batch's (each scaled to rms_mNm):
    ``seal_temp_speed``  sign(w) (|w|/300 rad/s)^0.6 exp(-theta/SEAL_THETA): a lip seal's drag
                    rising with speed (film shear) and falling as the oil warms (theta the
                    housing's rise, K, recorded);
    ``preload_sqrt``  sign(w) |torque_out|^0.5: a bearing whose preload grows with the load
                    under a Hertzian contact (contact width ~ load^0.5);
    ``resonant_1x``   the input shaft's unbalance (1x) through a structural mode at STRUCT_HZ:
                    H(r) sin(theta - phi(r)), r = f_1x/STRUCT_HZ, H = 1/sqrt((1-r^2)^2 +
                    (2 zeta r)^2) (no loss on average);
    ``motor_ripple``  (0.3 + |T|/rms|T|) sin(6 p theta + 0.7): the motor's 6th electrical
                    harmonic (p pole pairs), its amplitude with the current (no loss on average);
    ``skid``          sign(w) |w|/300 exp(-|torque_out|/SKID_T0): rollers skidding at light load
                    and high speed."""
    out = _prev_extra(case, s)
    w, tout = s["w"], s["tout"]
    sg = np.tanh(w / 2.0)
    for e in case["effects"]:
        k = e["kind"]
        if k == "seal_temp_speed":
            x = sg * (np.abs(w) / 300.0) ** 0.6 * np.exp(-s["temp_rise"] / SEAL_THETA)
        elif k == "preload_sqrt":
            x = sg * np.sqrt(np.abs(tout))
        elif k == "resonant_1x":
            r = np.abs(w) / (2 * np.pi) / STRUCT_HZ
            H = 1.0 / np.sqrt((1 - r * r) ** 2 + (2 * STRUCT_ZETA * r) ** 2)
            phi = np.arctan2(2 * STRUCT_ZETA * r, 1 - r * r)
            x = H * np.sin(s["theta"] + 0.3 - phi)
        elif k == "motor_ripple":
            a = np.abs(s["T_gear_in"])
            x = (0.3 + a / gen3._rms(a)) * np.sin(6 * MOTOR_POLE_PAIRS * s["theta"] + 0.7)
        elif k == "skid":
            x = sg * np.abs(w) / 300.0 * np.exp(-np.abs(tout) / SKID_T0)
        else:
            continue
        c = e["rms_mNm"] * 1e-3 / gen3._rms(x)
        out[k] = (x * c, c)
    return out


SENSOR6 = {"speed_gain", "sign_gain"}


def transducer6(case, T, fs, t, w):
    """gen5's transducer, then
    ``speed_gain``  T (1 + c (w/300 rad/s)^2): a rotating (telemetry) transducer whose bridge
                    gain changes with the centrifugal strain, c scaled to rms_mNm;
    ``sign_gain``   T + g |T|: a bridge whose gain differs by g between the two torque
                    directions (gain 1 + g for T > 0, 1 - g for T < 0)."""
    effs = case["effects"]
    T = _prev_transducer(dict(case, effects=[e for e in effs if e["kind"] not in SENSOR6]),
                         T, fs, t, w)
    for e in effs:
        if e["kind"] == "speed_gain":
            x = T * (w / 300.0) ** 2
            T = T + e["rms_mNm"] * 1e-3 * x / gen3._rms(x)
        elif e["kind"] == "sign_gain":
            T = T + e["g"] * np.abs(T)
    return T


def effect_sizes6(case, s, design, q0, extra_c, T_shaft, stick):
    sub = dict(case, effects=[e for e in case["effects"] if e["kind"] not in SENSOR6])
    out = _prev_effect_sizes(sub, s, design, q0, extra_c, T_shaft, stick)
    for e in case["effects"]:
        if e["kind"] in SENSOR6:
            x = transducer6(dict(effects=[e]), T_shaft, case["fs"], s["t"], s["w"]) - T_shaft
            out.append(dict(e, rms_mNm_actual=round(1e3 * gen3._rms(x), 2)))
    return out


#: [Hz] the mains frequency of the pickup noise
MAINS_HZ = 50.0


def colour_noise6(rng, n, sigma, colour, fs):
    """gen4's colours plus
    ``t3``      Student t with 3 degrees of freedom scaled to the standard deviation sigma
                (heavy tails: a few samples at 5-10 sigma);
    ``mains50`` white noise sigma plus a 50 Hz pickup of amplitude sigma (a fixed level);
    ``spikes``  white noise sigma plus one sample in 2000 hit by a spike of 20-40 sigma (EMI
                from a contactor)."""
    if colour == "t3":
        return sigma * rng.standard_t(3, n) / np.sqrt(3.0)
    if colour in ("mains50", "spikes"):
        x = sigma * rng.normal(0, 1, n)
        if colour == "mains50":
            x += sigma * np.sin(2 * np.pi * MAINS_HZ * np.arange(n) / fs + rng.uniform(0, 6.3))
        else:
            hit = rng.random(n) < 1 / 2000
            x[hit] += sigma * rng.uniform(20, 40, hit.sum()) * rng.choice([-1, 1], hit.sum())
        return x
    return _prev_colour(rng, n, sigma, colour, fs)


def logger6(case, rng, data, stats):
    """gen3's logger faults plus ``drop``: that share of samples lost at random (a logger
    skipping samples when its buffer is busy: irregular intervals, stamps exact)."""
    if case.get("drop"):
        keep = rng.random(data["time_s"].size) >= case["drop"]
        keep[0] = True
        data = {k: v[keep] for k, v in data.items()}
        stats["dropped_samples"] = int((~keep).sum())
    return _prev_logger(case, rng, data, stats)


gen4.extra_loss_shapes = extra_loss_shapes6
gen4.transducer4 = transducer6
gen4.effect_sizes = effect_sizes6
gen4.colour_noise = colour_noise6
gen3.logger = logger6


# ----------------------------------------------------------------------------- file dialects
def write6(path, data, dialect):
    """This batch's dialects; gen5's (and through it gen4's, gen.py's) for the rest."""
    path.parent.mkdir(parents=True, exist_ok=True)
    has_T = "temperature_C" in data
    tab = gen5._table
    if dialect == "ws_bom":              # whitespace, UTF-8 with BOM, bare names
        order = [("t", "time_s", 1.0), ("n_in", "speed_in_rpm", 1.0),
                 ("n_out", "speed_out_rpm", 1.0), ("T_in", "torque_in_Nm", 1.0),
                 ("T_out", "torque_out_Nm", 1.0)]
        path.write_text("  ".join(o[0] for o in order) + "\n" + tab(order, data, "%.6f", "  "),
                        encoding="utf-8-sig")
        return
    if dialect == "catman_tab_nmm":      # metadata lines, tab, a units row with N·mm, cp1252
        order = [("Zeit", "time_s", 1.0, "s"), ("Drehzahl_An", "speed_in_rpm", 1.0, "1/min"),
                 ("Drehzahl_Ab", "speed_out_rpm", 1.0, "1/min"),
                 ("Drehmoment_An", "torque_in_Nm", 1e3, "N·mm"),
                 ("Drehmoment_Ab", "torque_out_Nm", 1.0, "N·m")]
        if has_T:
            order.append(("Temperatur", "temperature_C", 1.0, "°C"))
        meta = "catman Export\r\nPrüfstand 2 / Getriebe Z15\r\nDatum\t26.11.2026\r\n"
        head = "\t".join(o[0] for o in order) + "\r\n" + "\t".join(o[3] for o in order) + "\r\n"
        body = tab([o[:3] for o in order], data, "%.5f", "\t")
        path.write_bytes((meta + head + body.replace("\n", "\r\n")).encode("cp1252"))
        return
    if dialect == "neg_out":             # the output torque with the dyno's sign convention
        order = [(c, c, 1.0) for c in ("time_s", "speed_in_rpm", "speed_out_rpm",
                                       "torque_in_Nm")] + [("torque_out_Nm", "torque_out_Nm",
                                                            -1.0)]
        path.write_text(",".join(o[0] for o in order) + "\n" + tab(order, data, "%.6f"),
                        encoding="utf-8")
        return
    if dialect == "extra_cols6":         # bracketed units among unrelated channels
        d2 = dict(data, counter=np.arange(data["time_s"].size, dtype=float),
                  i_q=np.abs(data["torque_in_Nm"]) / 0.3, u_dc=565.0 + 0 * data["time_s"],
                  p_el=np.abs(data["torque_in_Nm"] * data["speed_in_rpm"]) * np.pi / 30 + 40)
        order = [("time [s]", "time_s", 1.0), ("Counter", "counter", 1.0),
                 ("n_in [rpm]", "speed_in_rpm", 1.0), ("I_q [A]", "i_q", 1.0),
                 ("T_in [N*m]", "torque_in_Nm", 1.0), ("U_dc [V]", "u_dc", 1.0),
                 ("P_el [W]", "p_el", 1.0), ("n_out [rpm]", "speed_out_rpm", 1.0),
                 ("T_out [N*m]", "torque_out_Nm", 1.0)]
        path.write_text(",".join(o[0] for o in order) + "\n" + tab(order, d2, "%.6f"),
                        encoding="utf-8")
        return
    if dialect == "mdf_rads":            # MDF4, speeds in rad/s
        from asammdf import MDF, Signal
        t = data["time_s"]
        k = np.pi / 30.0
        sigs = [Signal(data["speed_in_rpm"] * k, t, name="speed_in", unit="rad/s"),
                Signal(data["speed_out_rpm"] * k, t, name="speed_out", unit="rad/s"),
                Signal(data["torque_in_Nm"], t, name="torque_in", unit="N*m"),
                Signal(data["torque_out_Nm"], t, name="torque_out", unit="N*m")]
        mdf = MDF(version="4.10")
        mdf.append(sigs, comment="bench")
        mdf.save(path, overwrite=True)
        return
    if dialect == "tsv_rads_nmm":        # tab, speeds in rad/s, input torque in N·mm
        k = np.pi / 30.0
        order = [("time [s]", "time_s", 1.0), ("speed_in [rad/s]", "speed_in_rpm", k),
                 ("speed_out [rad/s]", "speed_out_rpm", k),
                 ("torque_in [N·mm]", "torque_in_Nm", 1e3),
                 ("torque_out [N*m]", "torque_out_Nm", 1.0)]
        path.write_text("\t".join(o[0] for o in order) + "\n" + tab(order, data, "%.6f", "\t"),
                        encoding="utf-8")
        return
    gen5.write5(path, data, dialect)


EXT = dict(gen5.EXT, ws_bom=".txt", catman_tab_nmm=".txt", neg_out=".csv", extra_cols6=".csv",
           mdf_rads=".mf4", tsv_rads_nmm=".tsv")
#: command-line options a user would give for a dialect (the documented override)
EXTRA_ARGS6 = dict(gen.EXTRA_ARGS, neg_out=["--units", "torque_out_Nm=-N*m"])


# ----------------------------------------------------------------------------- the cases
# Fields as in gen3/gen4/gen5: expect (groups; any id of a group names the effect right),
# tolerate (ids that may be named besides), unexplained (True must be reported, False must
# not, None either), proposal (powers of |speed| and |torque| a proposed form must carry);
# note: the physics behind an expectation. Library sizes near EFFECTS' synth defaults
# (T_drag 12 mN*m, J 1.5e-4, T_stribeck 25 mN*m at 40 rad/s, offset 6 mN*m, drift 10 mN*m,
# gain 2 %, k 0.003, load scale +12 %).
E, CAL, LIB, RUN_IN = gen3.E, gen3.CAL, gen3.LIB, gen3.RUN_IN
DRAG, STRIB, OFFS = gen5.DRAG, gen5.STRIB, gen5.OFFS
GAIN, INER, RIPPLE, DRIFT, WARM = gen5.GAIN, gen5.INER, gen5.RIPPLE, gen5.DRIFT, gen5.WARM
MESH = ["mesh_loss", "friction_miscalibrated"]
IDLE = ["idle_loss_scale", "load_independent_loss"]
T3 = dict(colour="t3", sigma_mNm=3.0)
MAINS = dict(colour="mains50", sigma_mNm=3.0)
SPIKES = dict(colour="spikes", sigma_mNm=3.0)
QUANT = (2.0, 10.0, 0.5, 0.05)
N2 = dict(sigma_mNm=2.0)


def _case(cid, plan, mode, fs, dialect, effects=(), expect=(), tolerate=(), unexplained=False,
          duration=None, note="", **kw):
    if duration is None:
        duration = 60 if fs <= 1000 else 40 if fs <= 4000 else 20
    return dict(id=cid, plan=plan, mode=mode, fs=fs, duration=duration, dialect=dialect,
                effects=[dict(e) for e in effects], expect=[list(g) for g in expect],
                tolerate=list(tolerate), unexplained=unexplained, note=note, **kw)


CASES = [
    # --- clean: new plans, rates, timing, noise and dialects; nothing named, nothing left
    _case("clean_scurve_S1_750Hz_csv", "scurve", "S1", 750, "csv"),
    _case("clean_press_S1_1k_wsbom", "press", "S1", 1000, "ws_bom",
          note="standstill under the press's torque 40-60 % of the time: friction has no sign "
          "there; nothing to claim"),
    _case("clean_pump_S2_250Hz_catman", "pump", "S2", 250, "catman_tab_nmm"),
    _case("clean_sineoffset_S1_16k_mdfrads_quant", "sineoffset", "S1", 16000, "mdf_rads",
          quantise=QUANT),
    _case("clean_robot_S2_1k_negout", "robot", "S2", 1000, "neg_out",
          note="the output torque written with the opposite sign; the user says so with "
          "--units torque_out_Nm=-N*m"),
    _case("clean_effmap_S1_3k_extracols_mains", "effmap", "S1", 3000, "extra_cols6",
          noise=MAINS, unexplained=None,
          note="a 50 Hz pickup of 3 mN*m amplitude on both torques: not the reducer; reporting "
          "it as a fixed-frequency line is fair, naming a library effect is not"),
    _case("clean_settlepump_S1_500Hz_t3", "settlepump", "S1", 500, "tsv", noise=T3,
          note="heavy-tailed noise (t, 3 dof) and a leading unloaded standstill of 6-10 s"),
    _case("clean_scurve_S2_2k_spikes", "scurve", "S2", 2000, "csv", noise=SPIKES,
          note="one sample in 2000 hit by a spike of 20-40 sigma: outliers, not physics"),
    _case("clean_effmap_S2_750Hz_drop_tsvrads", "effmap", "S2", 750, "tsv_rads_nmm", drop=0.1,
          note="10 % of the samples dropped at random: irregular intervals, stamps exact"),
    # --- library effects alone, in the new plans
    _case("lib_inertia_scurve_S1_2k", "scurve", "S1", 2000, "csv", [E("inertia", J=1.5e-4)],
          [INER]),
    _case("lib_stribeck_robot_S1_1k", "robot", "S1", 1000, "csv",
          [E("stribeck", rms_mNm=8.0, ws=40.0)], [STRIB],
          note="every move passes through low speed twice, in both directions"),
    _case("lib_drag_pump_S1_750Hz", "pump", "S1", 750, "catman_tab_nmm",
          [E("drag", rms_mNm=12.0)], [DRAG]),
    _case("lib_offset_robot_S2_1k", "robot", "S2", 1000, "csv", [E("offset", mNm=6.0)],
          [OFFS], note="reversals of speed and torque separate an offset from a drag"),
    _case("lib_gain_robot_S1_750Hz", "robot", "S1", 750, "ws_bom", [E("gain", g=0.02)],
          [GAIN], note="back-driven half the time: a gain separates from a loss level"),
    _case("lib_ripple_sineoffset_S1_3k", "sineoffset", "S1", 3000, "csv",
          [E("ripple", rms_mNm=7.0)], [RIPPLE]),
    _case("lib_rippleload_effmap_S2_3k", "effmap", "S2", 3000, "csv",
          [E("ripple_load", rms_mNm=8.0)], [RIPPLE]),
    _case("lib_zero_drift_effmap_S1_1k", "effmap", "S1", 1000, "csv",
          [E("zero_drift", mNm=10.0, tau=25.0)], [DRIFT], OFFS),
    _case("lib_meshloss_k003_effmap_S1_1k", "effmap", "S1", 1000, "extra_cols6",
          [E("mesh_loss", k=0.003)], [MESH], GAIN,
          note="forward only: a share of the mesh power and a gain error look alike (tolerated)"),
    _case("lib_idle075_pump_S2_1k", "pump", "S2", 1000, "csv",
          [E("idle_scale", factor=0.75)], [IDLE]),
    _case("lib_thermal_temp_scurve_S1_1k", "scurve", "S1", 1000, "csv",
          [E("thermal", beta_per_K=-0.008, tau=30.0, R_K_per_W=1.5)], [WARM],
          temperature=True),
    _case("lib_runin_sineoffset_S1_1k", "sineoffset", "S1", 1000, "csv",
          [E("run_in", a=0.25, revs0=400.0, distance=True)], [RUN_IN], CAL + GAIN,
          note="the load-dependent losses +25 % decaying over 400 revolutions run"),
    # --- calibration-type errors: the load-dependent losses 10-15 % off, both ways
    _case("cal_lossscale_p12_pump_S1_1k", "pump", "S1", 1000, "csv",
          [E("loss_scale", factor=1.12)], [CAL], GAIN,
          note="forward only: a gain error is its look-alike (tolerated)"),
    _case("cal_lossscale_m13_robot_S1_1k", "robot", "S1", 1000, "csv",
          [E("loss_scale", factor=0.87)], [CAL],
          note="back-driven moves separate it from a gain"),
    _case("cal_lossscale_p15_effmap_S2_750Hz", "effmap", "S2", 750, "csv",
          [E("loss_scale", factor=1.15)], [CAL], GAIN),
    # --- pairs and triples
    _case("pair_inertia+gain_robot_S2_250Hz", "robot", "S2", 250, "csv",
          [E("inertia", J=1.5e-4), E("gain", g=0.02)], [INER, GAIN]),
    _case("pair_stribeck+offset_robot_S1_1k", "robot", "S1", 1000, "csv",
          [E("stribeck", rms_mNm=8.0, ws=40.0), E("offset", mNm=6.0)], [STRIB, OFFS]),
    _case("pair_rippleload+lossscale_effmap_S1_3k", "effmap", "S1", 3000, "csv",
          [E("ripple_load", rms_mNm=8.0), E("loss_scale", factor=1.12)], [RIPPLE, CAL], GAIN),
    _case("pair_drag+zero_drift_pump_S1_750Hz", "pump", "S1", 750, "csv",
          [E("drag", rms_mNm=10.0), E("zero_drift", mNm=-10.0, tau=20.0)], [DRAG, DRIFT], OFFS),
    _case("tri_inertia+meshloss+offset_scurve_S1_2k", "scurve", "S1", 2000, "csv",
          [E("inertia", J=1.5e-4), E("mesh_loss", k=0.003), E("offset", mNm=6.0)],
          [INER, MESH, OFFS], GAIN + DRAG,
          note="reversals and back-driven steps in the S-curve plan separate the three"),
    _case("tri_stribeck+gain+ripple_robot_S2_1k", "robot", "S2", 1000, "csv",
          [E("stribeck", rms_mNm=8.0, ws=40.0), E("gain", g=0.02), E("ripple", rms_mNm=6.0)],
          [STRIB, GAIN, RIPPLE]),
    # --- outside the library
    _case("out_sealtemp_scurve_S1_1k", "scurve", "S1", 1000, "csv",
          [E("seal_temp_speed", rms_mNm=12.0)], [DRAG + WARM], ["thermal_drift",
                                                             "viscosity_drift"] + DRAG,
          None, temperature=True,
          note="a drag ~ |w|^0.6 falling with the recorded temperature: the idle loss (a drag) "
          "with a warm-up is its library look-alike; a remainder may or may not stay"),
    _case("out_preloadsqrt_robot_S1_1k", "robot", "S1", 1000, "csv",
          [E("preload_sqrt", rms_mNm=15.0)], [], DRAG + CAL + OFFS, True,
          proposal=dict(torque=0.5),
          note="sgn(w)|T_out|^0.5: gravity takes the output torque through zero at every "
          "swing, where the square root's cusp departs from any a + b|T|"),
    _case("out_resonant1x_pump_S1_3k", "pump", "S1", 3000, "csv",
          [E("resonant_1x", rms_mNm=8.0)], [], RIPPLE, True,
          note="the 1x ripple grows tenfold near 1500 r/min: a constant- or load-scaled 1x "
          "amplitude takes only part of it"),
    _case("out_motorripple_sineoffset_S1_16k", "sineoffset", "S1", 16000, "csv",
          [E("motor_ripple", rms_mNm=8.0)], [], [], True,
          note="a 24x order of the input shaft (1200 Hz at 3000 r/min): no library order"),
    _case("out_speedgain_effmap_S1_1k", "effmap", "S1", 1000, "csv",
          [E("speed_gain", rms_mNm=8.0)], [], GAIN + CAL + DRAG, True,
          proposal=dict(speed=2, torque=1),
          note="a gain ~ w^2: at six held speeds the gain differs per speed; a constant gain "
          "or a speed*load loss takes part"),
    _case("out_skid_effmap_S2_1k", "effmap", "S2", 1000, "csv",
          [E("skid", rms_mNm=10.0)], [], DRAG + CAL, True,
          note="|w| exp(-|T|/1 N*m): large at light load, gone at heavy load, at every speed"),
    _case("out_signgain_robot_S1_1k", "robot", "S1", 1000, "csv",
          [E("sign_gain", g=0.03)], [], GAIN + OFFS, True,
          note="T + 0.03|T|: with the torque through zero a kink no gain or offset makes"),
    _case("out_motorripple+drag_pump_S2_3k", "pump", "S2", 3000, "csv",
          [E("motor_ripple", rms_mNm=6.0), E("drag", rms_mNm=10.0)], [DRAG], [], True,
          note="the drag named; the 24x motor order left unexplained"),
]
SEED_SHIFT = int(os.environ.get("CYCLO_INDEPENDENT_SEED_SHIFT", "0"))
for c in CASES:
    c.setdefault("seed", 61000 + sum(ord(ch) * (k + 13) for k, ch in enumerate(c["id"]))
                 + SEED_SHIFT)
_ids = [c["id"] for c in CASES]
if len(set(_ids)) != len(_ids):
    raise RuntimeError("duplicate case ids")


def main(argv):
    sel = set(argv)
    RECS.mkdir(parents=True, exist_ok=True)
    cj = HERE / "cases6.json"
    old = {c["id"]: c for c in json.loads(cj.read_text())} if cj.exists() else {}
    out = []
    for c in CASES:
        if sel and c["id"] not in sel:
            if c["id"] in old:
                out.append(old[c["id"]])
            continue
        data, truth, _ = gen4.build(c)
        path = RECS / (c["id"] + EXT[c["dialect"]])
        write6(path, data, c["dialect"])
        rec = {k: v for k, v in c.items() if k != "effects"}
        rec.update(file=str(path), truth=truth, args=EXTRA_ARGS6.get(c["dialect"], []))
        out.append(rec)
        print(f"{c['id']:44s} {truth['plan']['samples_written']:8d}  back "
              f"{truth['plan']['back_driven_share']:.2f}  "
              + ", ".join(f"{tr['kind']}={tr.get('rms_mNm_actual')}" for tr in truth["effects"]),
              flush=True)
    cj.write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main(sys.argv[1:])
