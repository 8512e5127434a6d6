"""Plausibility of a recording before any fit: is it what its header says?

``check_plausibility(rec, mode, design)`` returns ``(mode, findings)``: each finding a one-line
statement with its evidence (``{"id", "status": "ok"|"warning"|"error", "message"}``), and
raises ``RecordingError`` (message: the finding, the likely cause, the override) on the first
error, so that no fit runs on data that cannot be what the header says.

What is judged, in this order: the sample interval (time in ms), standstill, the input-torque
level (N*mm), the sign of each shaft's power, the power balance per direction of power flow
(N*mm torque_out, a speed in the wrong unit, a wrong mode), and the measured speed ratio against
``--mode`` (``auto``: the mode whose ratio and sign match).
"""
from __future__ import annotations

import math

import numpy as np

from ..recordings import RecordingError

# --- named thresholds (unit, why) -------------------------------------------------------------
#: [r/min] a shaft below this is standing still: well below any test run, above encoder noise
STANDSTILL_RPM = 1.0
#: [1] driven samples needed to judge anything (and to diagnose): 100 samples
MIN_DRIVEN = 100
#: [1] loaded samples (both shafts above POWER_SHARE of their peak power) needed to judge the
#: torque signs and the power balance: fewer are a warning, not a verdict
MIN_LOADED = 10
#: [r/min] the output shaft turns when faster than this: STANDSTILL_RPM / MAX_Z1 (a driven
#: input at the standstill bound reaches the output through a ratio of up to z1 <= 1000)
OUTPUT_STANDSTILL_RPM = STANDSTILL_RPM * 1e-3
#: [N*m] an input torque above this looks like N*mm: 1000 N*m at the fast shaft of a
#: speed reducer is 10 times the largest drives of this kind (paper drive: ~1.3 N*m in)
N_MM_SUSPECT_NM = 1000.0
#: [1] share of a peak power below which a sample carries no power worth judging
POWER_SHARE = 0.05
#: [1] output/input power above this on samples where power flows in->out is impossible for a
#: loss-making drive; 5 % leaves room for torque-transducer gain errors of a few per cent.
#: Judged at a steady speed (``STEADY_WINDOW_S``), where at least MIN_LOADED such samples are
#: loaded (else not judged): while the speed changes, an inertia between the transducers
#: gives back what it stored (a robot joint back-driven only while it brakes: 1.38)
EFFICIENCY_MAX = 1.05
#: [s] the speed's derivative for the steady-speed samples of the power balance is the central
#: difference over +- this: 10 ms, the diagnosis's block, averages the speed reading's noise
#: while a move's acceleration phase (tens of ms and more) stays resolved. A sample is at a
#: steady speed where |dw/dt| is within POWER_SHARE of its robust peak: an inertia's power
#: J w dw/dt is at most 5 % of its peak there
STEADY_WINDOW_S = 0.01
#: [1] output/input power below this: even an idling reducer passes more than 1 % of its input
#: power at the loads where both shafts carry > 5 % of their peak; a factor 1000 (N*mm) lands far
#: outside
POWER_RATIO_MIN = 0.01
#: [1] relative tolerance of the measured speed ratio against the mode's (Table 1): the six
#: modes' ratios of a z1 >= 8 drive differ by at least 1/(z1-1) (>= 7 %); slip-free kinematics
#: and averaging over driven samples leave < 1 %
RATIO_TOL = 0.03
#: [s] a median sample interval at least this long with a duration >= MS_SUSPECT_DURATION looks
#: like time in ms: 1 kHz written in ms gives 1 s steps
MS_SUSPECT_DT = 0.2
#: [s] 2 h: with >= 0.2 s steps a genuine recording would be a slow logger, not a bench run
MS_SUSPECT_DURATION = 7200.0
#: [r/min] peak input speed below which r/min and rad/s are both plausible (only a warning:
#: a genuine low-speed run must pass)
LOW_SPEED_RPM = 350.0
#: [1] the measured input torque at loaded forward samples may differ from the design's (its
#: input torque for the measured output torque and speeds) by up to this factor either way:
#: a working drive's losses take 5-40 % of its input power, so a model missing all of them, or
#: twice too lossy, is within a factor 2; a torque unit (x1000 N*mm, x100 N*cm) or another
#: drive's design lands far outside
MODEL_TORQUE_FACTOR = 10.0
#: [1] loaded samples the model is evaluated at for that comparison (an even subsample)
MODEL_SAMPLES = 64
#: absolute limits of a measurement at the edge units: beyond them a cell is not a reading
ABSURD = {"time_s": 1e9, "speed_in_rpm": 1e6, "speed_out_rpm": 1e6, "torque_in_Nm": 1e7,
          "torque_out_Nm": 1e7, "temperature_C": 1e4}
RPM = math.pi / 30
#: samples per chunk: long recordings are judged chunk by chunk (few temporaries in memory)
CHUNK = 1 << 20
#: samples a median is taken over (an evenly strided subsample of longer recordings)
MEDIAN_SAMPLES = 1 << 20


def _slices(n):
    for a in range(0, n, CHUNK):
        yield slice(a, min(n, a + CHUNK))


def _peak(x) -> float:
    return max((float(np.max(np.abs(x[s]))) for s in _slices(len(x))), default=0.0)


def _stride(n) -> int:
    return max(1, -(-n // MEDIAN_SAMPLES))


#: [1] the "peak" that shares such as POWER_SHARE refer to: this quantile of |x| (over an
#: evenly strided subsample of long recordings), so that one corrupt cell (a spike of 1e5 in a
#: speed column) cannot make every other sample look idle and switch the checks off
PEAK_QUANTILE = 0.999


def _robust_peak(x) -> float:
    x = np.abs(np.asarray(x)[::_stride(len(x))])
    return float(np.quantile(x, PEAK_QUANTILE)) if x.size else 0.0


def check_magnitudes(data: dict, where) -> None:
    """Refuse finite but absurd cells (e.g. 1e308) before anything computes with them."""
    for key, lim in ABSURD.items():
        v = data.get(key)
        if v is None or not len(v):
            continue
        count, first = 0, None
        for s in _slices(len(v)):
            with np.errstate(invalid="ignore"):
                bad = np.abs(v[s]) > lim
            if bad.any():
                count += int(bad.sum())
                first = s.start + int(np.flatnonzero(bad)[0]) if first is None else first
        if count:
            raise RecordingError(
                f"column {key!r}, {where(first)}: {v[first]:.6g} is not a measurement (|value| > "
                f"{lim:g} in the schema's unit); {count} such cell(s); blank them to exclude them")


def _finding(id_, status, message):
    return {"id": id_, "status": status, "message": message}


def _error(f, findings):
    findings.append(f)
    raise RecordingError(f["message"])


def check_units(rec, units_given=(), findings=None, balance=True) -> list:
    """The mode-independent checks (time unit, standstill, N*mm, power signs and balance).
    Raises on the first error; returns the findings."""
    findings = [] if findings is None else findings
    t = rec.time
    if rec.n > 1:
        st = _stride(rec.n)                    # consecutive pairs, every st-th one
        dt = float(np.median(t[1::st] - t[0:-1:st]))
        if dt >= MS_SUSPECT_DT and rec.duration >= MS_SUSPECT_DURATION and \
                "time_s" not in units_given:
            _error(_finding("time_unit", "error",
                   f"time_s: samples every {dt:.6g} s over {rec.duration / 3600:.3g} h look like "
                   f"time in ms ({1 / dt:.3g} Hz, {rec.duration / 3.6e6:.3g} h if ms); give "
                   "--units time_s=ms, or --units time_s=s if it really is seconds"), findings)
        findings.append(_finding("time_unit", "ok", f"time_s: median interval {dt:.6g} s "
                                 f"({1 / dt:.6g} Hz) over {rec.duration:.6g} s"))
    w = rec.speed_in
    peak = _peak(w) / RPM
    n_driven = sum(int(np.count_nonzero(np.abs(w[s]) > STANDSTILL_RPM * RPM))
                   for s in _slices(rec.n))
    if n_driven < MIN_DRIVEN:
        _error(_finding("standstill", "error",
               f"speed_in_rpm: only {n_driven} samples turn faster than "
               f"{STANDSTILL_RPM:g} r/min (peak {peak:.3g} r/min): the input shaft stands still, "
               f"nothing to diagnose (needs >= {MIN_DRIVEN} driven samples)"), findings)
    if peak < LOW_SPEED_RPM and "speed_in_rpm" not in units_given:
        findings.append(_finding("speed_unit", "warning",
                        f"speed_in_rpm peaks at {peak:.4g} r/min: a slow run, or rad/s written "
                        "as r/min, which torques and powers cannot tell apart; if rad/s, give "
                        "--units speed_in_rpm=rad/s,speed_out_rpm=rad/s"))
    T_peak = _peak(rec.torque_in)
    if T_peak > N_MM_SUSPECT_NM and "torque_in_Nm" not in units_given:
        _error(_finding("torque_unit", "error",
               f"torque_in_Nm peaks at {T_peak:.6g}: that looks like N*mm, not N*m (give "
               "--units torque_in_Nm=N*mm, or --units torque_in_Nm=N*m if it is right)"),
               findings)
    if balance:
        _power_balance(rec, units_given, findings)
    return findings


#: [Pa] contact pressure at which a hardened steel roller's line contact takes a permanent
#: set (ISO 76's 4000 MPa static limit for roller bearings)
P_STATIC_LIMIT = 4.0e9
#: [Pa] effective modulus E* = E / (2 (1 - nu^2)) of steel on steel, E = 210 GPa, nu = 0.3
E_STAR_STEEL = 210e9 / (2 * (1 - 0.3 ** 2))


def torque_capacity_out(design) -> float:
    """Output torque [N*m] at which the most loaded ring roller reaches the static contact
    limit: an upper bound of any plausible reading, used to spot torques in N*mm.

    Line contact (Hertz): F = pi * b1 * R * p^2 / E*, R the ring roller's radius (the conforming
    tooth flank only enlarges the contact, so this is the small end); load sharing after
    Blanche & Yang (1989), F_max = 4 T / (z1 r_p), r_p = lambda e z1 the pitch radius."""
    R = design.d_v1 / 2
    F = math.pi * design.b1 * R * P_STATIC_LIMIT ** 2 / E_STAR_STEEL
    return F * design.z1 * design.r_p / 4


def _acceleration(rec, idx):
    """|d speed_in / dt| [rad/s^2] at the samples ``idx``: the central difference over
    +-``STEADY_WINDOW_S`` (the speed's noise averaged over the window)."""
    n = rec.n
    dt = max((float(rec.time[-1]) - float(rec.time[0])) / max(n - 1, 1), 1e-12)
    k = max(1, int(round(STEADY_WINDOW_S / dt)))
    a, b = np.maximum(idx - k, 0), np.minimum(idx + k, n - 1)
    span = np.maximum(rec.time[b] - rec.time[a], 1e-12)
    return np.abs(rec.speed_in[b] - rec.speed_in[a]) / span


def _power_balance(rec, units_given, findings):
    if not rec.n:
        return
    sl = list(_slices(rec.n))
    P_in = lambda s: rec.torque_in[s] * rec.speed_in[s]           # noqa: E731
    P_out = lambda s: rec.torque_out[s] * rec.speed_out[s]        # noqa: E731
    max_in = _robust_peak(rec.torque_in * rec.speed_in)
    max_out = _robust_peak(rec.torque_out * rec.speed_out)
    # the samples at a steady speed: the power an inertia stores or gives back (J w dw/dt)
    # is small there, so the efficiency is judged on them where there are enough
    max_acc = _robust_peak(_acceleration(rec, np.arange(0, rec.n, _stride(rec.n))))
    n_loaded = n_mismatch = n_in_pos = 0
    # count, |P_in|, |P_out|: over the loaded samples, and over the loaded steady ones
    sums = {"forward": [0, 0.0, 0.0], "back-driven": [0, 0.0, 0.0]}
    steady_sums = {"forward": [0, 0.0, 0.0], "back-driven": [0, 0.0, 0.0]}
    for s in sl:
        pi, po = P_in(s), P_out(s)
        loaded = (np.abs(pi) > POWER_SHARE * max_in) & (np.abs(po) > POWER_SHARE * max_out)
        steady = _acceleration(rec, np.arange(s.start, s.stop)[loaded]) <= POWER_SHARE * max_acc
        pi, po = pi[loaded], po[loaded]
        n_loaded += pi.size
        n_mismatch += int(np.count_nonzero(np.sign(pi) != np.sign(po)))
        n_in_pos += int(np.count_nonzero(pi > 0))
        for name, sel in (("forward", (pi > 0) & (po > 0)), ("back-driven", (pi < 0) & (po < 0))):
            for acc, use in ((sums[name], sel), (steady_sums[name], sel & steady)):
                acc[0] += int(np.count_nonzero(use))
                acc[1] += float(np.sum(np.abs(pi[use])))
                acc[2] += float(np.sum(np.abs(po[use])))
    if n_loaded < MIN_LOADED:
        findings.append(_finding("power_balance", "warning",
                        f"only {n_loaded} samples where both shafts carry power: "
                        "power balance and torque signs not judged"))
        return
    mismatch = n_mismatch / n_loaded
    if mismatch > 0.5:
        # which one is wrong: the motor normally delivers power (input power positive)
        col = "torque_out_Nm" if n_in_pos >= 0.5 * n_loaded else "torque_in_Nm"
        if col not in units_given:
            _error(_finding("torque_sign", "error",
                   f"{col} has the opposite sign: input and output power differ in sign on "
                   f"{100 * mismatch:.0f} % of the {n_loaded} loaded samples (convention: "
                   "torque_in delivered into the input shaft, torque_out delivered by the output "
                   f"shaft to the load); negate it with --units {col}=-N*m"), findings)
    msgs = []
    for name, (count, pi, po) in sums.items():
        if count < MIN_LOADED:
            continue
        r = po / pi if name == "forward" else pi / po     # power leaving / power entering
        msgs.append(f"{name}: {count} samples, efficiency {r:.3g}")
        if r > 1 / POWER_RATIO_MIN or r < POWER_RATIO_MIN:
            big = (r > 1) == (name == "forward")     # torque_out too large (forward)
            col = "torque_out_Nm" if big else "torque_in_Nm"
            if col not in units_given:
                _error(_finding("power_balance", "error",
                       f"{col}: on {name} samples the power leaving is {r:.3g} times the power "
                       f"entering; a torque in N*mm (x1000) would do that (give --units "
                       f"{col}=N*mm, or --units {col}=N*m if it is right)"), findings)
        sc, spi, spo = steady_sums[name]
        if sc < MIN_LOADED:
            # every such sample is taken while the speed changes (a robot joint is back-driven
            # only while it brakes): what an inertia gives back can exceed the loss there
            if r > EFFICIENCY_MAX:
                msgs[-1] += (f" (above 1, all while the speed changes: an inertia giving back "
                             f"its energy; not judged, {sc} samples at a steady speed)")
            continue
        r_st = spo / spi if name == "forward" else spi / spo     # inertia power small here
        if r_st > EFFICIENCY_MAX and not ({"torque_in_Nm", "torque_out_Nm"} & set(units_given)):
            _error(_finding("power_balance", "error",
                   f"power balance: on {name} samples at a steady speed the power leaving the "
                   f"reducer is {r_st:.3g} times the power entering (a loss-making drive passes "
                   "at most 1); a torque or speed unit or the mode is off (check --units and "
                   "--mode; --units torque_in_Nm=N*m,torque_out_Nm=N*m accepts the data as it "
                   "is)"), findings)
        if r > EFFICIENCY_MAX:
            msgs[-1] += (f" (above 1 while the speed changes: an inertia giving back its "
                         f"energy; {r_st:.3g} at a steady speed)")
    findings.append(_finding("power_balance", "ok", "power balance: " + "; ".join(msgs)))


def check_mode(rec, mode: str, z1: int, findings=None, units_given=()):
    """Measured speed ratio speed_in/speed_out (median over driven samples) against the mode's
    (``model_core.kinematics.speed_ratio``); ``mode='auto'`` picks the matching mode."""
    from model_core.kinematics import MODES, parse_mode, speed_ratio
    findings = [] if findings is None else findings
    st = _stride(rec.n)                       # an evenly strided subsample of long recordings
    n_in, n_out = rec.speed_in[::st] / RPM, rec.speed_out[::st] / RPM
    peak = _robust_peak(n_in)
    sel = (np.abs(n_in) > max(STANDSTILL_RPM, POWER_SHARE * peak)) & \
          (np.abs(n_out) > OUTPUT_STANDSTILL_RPM)
    if sel.sum() < MIN_DRIVEN / st:
        _error(_finding("speed_ratio", "error",
               f"speed_out_rpm: only {int(sel.sum()) * st} samples where both shafts turn; the "
               f"mode cannot be checked (is speed_out_rpm the output shaft?)"), findings)
    ratio = float(np.median(n_in[sel] / n_out[sel]))
    ratios = {m: speed_ratio(m, z1) for m in MODES}
    match = [m for m, r in ratios.items() if abs(ratio / r - 1) <= RATIO_TOL]
    table = ", ".join(f"{m} {r:.4g}" for m, r in ratios.items())
    if str(mode).strip().lower() == "auto":
        if not match:
            _error(_finding("speed_ratio", "error", _no_mode(ratio, z1, ratios, None, table)),
                   findings)
        mode = match[0]
        findings.append(_finding("speed_ratio", "ok",
                        f"mode auto: measured speed ratio {ratio:.5g} (median over "
                        f"{int(sel.sum()) * st} driven samples) matches mode {mode} ({ratios[mode]:.5g}) "
                        f"of a z1 = {z1} drive"))
        return mode, findings
    mode = "".join(parse_mode(mode)[:2])
    if mode not in match:
        _error(_finding("speed_ratio", "error", _no_mode(ratio, z1, ratios, mode, table, match)),
               findings)
    findings.append(_finding("speed_ratio", "ok",
                    f"speed ratio {ratio:.5g} (median over {int(sel.sum()) * st} driven samples) "
                    f"matches mode {mode} ({ratios[mode]:.5g})"))
    return mode, findings


def check_capacity(rec, mode, design, findings, units_given=()):
    """Input and output torque against the drive's static contact capacity (N*mm readings)."""
    from model_core.kinematics import speed_ratio
    cap_out = torque_capacity_out(design)
    cap_in = cap_out / abs(speed_ratio(mode, design.z1))
    for col, v, cap in (("torque_in_Nm", rec.torque_in, cap_in),
                        ("torque_out_Nm", rec.torque_out, cap_out)):
        peak = _peak(v)
        if peak > cap and col not in units_given:
            _error(_finding("torque_unit", "error",
                   f"{col} peaks at {peak:.6g} N*m, above the {cap:.3g} N*m at which this drive's "
                   f"rollers would take a permanent set (mode {mode}): that looks like N*mm; "
                   f"give --units {col}=N*mm, or --units {col}=N*m if it is right"), findings)
    findings.append(_finding("torque_level", "ok",
                    f"torques below the static contact capacity ({cap_in:.3g} N*m in, "
                    f"{cap_out:.3g} N*m out, mode {mode})"))



def _no_mode(ratio, z1, ratios, mode, table, match=()):
    head = (f"speed ratio speed_in/speed_out measured {ratio:.5g}" +
            (f" does not match mode {mode} ({ratios[mode]:.5g})" if mode else
             " matches no mode"))
    if match:
        return (f"{head} but mode {match[0]} ({ratios[match[0]]:.5g}): the recording is "
                f"{match[0]}; pass --mode {match[0]} (or --mode auto)")
    k = 30 / math.pi
    for m, r in ratios.items():
        for f, col in ((k, "speed_out_rpm"), (1 / k, "speed_in_rpm")):
            if abs(ratio / (r * f) - 1) <= RATIO_TOL:
                return (f"{head}: {ratio:.5g} = {r:.4g} (mode {m}) x {f:.4g}, so {col} looks "
                        f"like rad/s, not r/min; give --units {col}=rad/s")
    return (f"{head} of a z1 = {z1} drive ({table}): is --design right, or a speed column "
            "mapped to the wrong shaft?")


def check_plausibility(rec, mode, design=None, units_given=()):
    """All checks; returns ``(mode, findings)`` (mode resolved when 'auto') or raises
    ``RecordingError`` naming the likely cause and the override."""
    from model_core import DriveDesign
    design = design or DriveDesign()
    findings = check_units(rec, units_given, balance=False)
    mode, findings = check_mode(rec, mode, design.z1, findings, units_given)
    check_capacity(rec, mode, design, findings, units_given)
    _power_balance(rec, units_given, findings)
    check_model_level(rec, mode, design, findings, units_given)
    return mode, findings


def check_model_level(rec, mode, design, findings, units_given=()):
    """Measured input torque against the design's at loaded forward samples (median ratio over
    an even subsample): beyond ``MODEL_TORQUE_FACTOR`` either way the torques' units (even
    ones given with --units) or the design cannot be right. Needs >= 10 such samples."""
    from model_core import operating_point
    P_in = rec.torque_in * rec.speed_in
    P_out = rec.torque_out * rec.speed_out
    peak_in, peak_out = _robust_peak(P_in), _robust_peak(P_out)
    loaded = np.flatnonzero((P_in > POWER_SHARE * peak_in) & (P_out > POWER_SHARE * peak_out))
    if loaded.size < MIN_LOADED:
        findings.append(_finding("model_level", "warning", f"only {loaded.size} loaded forward "
                                 "samples: the torque level is not compared with the design"))
        return findings
    k = loaded[np.linspace(0, loaded.size - 1, min(MODEL_SAMPLES, loaded.size)).astype(int)]
    with np.errstate(all="ignore"):
        try:
            op = operating_point(design, mode, rec.speed_in[k], T_out=-rec.torque_out[k])
            model = np.abs(np.asarray(op.torques[mode[0]], float))
        except ValueError:       # the design cannot carry these points: check_capacity's job
            return findings
    ok = np.isfinite(model) & (model > 0)
    if ok.sum() < MIN_LOADED:
        return findings
    ratio = float(np.median(np.abs(rec.torque_in[k][ok])) / np.median(model[ok]))
    given = ", ".join(f"{c}={rec.units[c][0]}" for c in ("torque_in_Nm", "torque_out_Nm")
                      if c in getattr(rec, "units", {}))
    if not 1 / MODEL_TORQUE_FACTOR <= ratio <= MODEL_TORQUE_FACTOR:
        _error(_finding("model_level", "error",
               f"torque_in_Nm: the measured input torque is {ratio:.3g} times what the design "
               f"needs for the measured output torque and speeds (median over {int(ok.sum())} "
               f"loaded samples; a drive's losses account for less than {MODEL_TORQUE_FACTOR:g}"
               f"x): a torque unit is off{f' (read as {given})' if given else ''}, or --design "
               "is not this drive; check --units and --design"), findings)
    findings.append(_finding("model_level", "ok", f"measured input torque {ratio:.3g} times the "
                             f"design's at {int(ok.sum())} loaded samples"))
    return findings
