"""Third independent batch of bench recordings for cyclo-fmu's diagnosis (issue 18's plans).

Written without reading the diagnosis (cyclo_fmu/diagnosis), the synthesiser (cyclo_fmu/synth.py)
or the effect registry's code (model_core/effects.py): every hidden effect is implemented here from
its physical description (README's diagnosis section, issues 18 and 19). The reducer's nominal
torques come from the physics core (``model_core.operating_point``) in modes S1 and S2, in all
four quadrants. File writers, AR(1) and 1/f noise come from batches 1 and 2 (gen.py, gen2.py).

Plans (issue 18): ``stairs`` (speed stairs up and down, load stairs at each, forward only),
``4q`` (four quadrants: speed reversals with the load held, load reversals at a held speed,
back-driving, low-speed holds), ``held`` (one speed for the whole recording, load stairs and
ramps), ``duty`` (a continuous duty cycle without holds: raised-cosine speed moves, some through
zero, into a load of inertia plus friction, which back-drives the reducer while it brakes).
Sample rates 200 Hz to 10 kHz; white, AR(1) and 1/f noise; quantisation; a logger gap;
duplicated time stamps; seven file dialects.

Sign conventions of the files (README "test bench"): torque_in = delivered into the input
shaft (S); torque_out = delivered by the output shaft to the load in the output shaft's sense
of rotation (output power = torque_out * speed_out; in S2 the output turns backwards).  In
model_core's terms T_out (applied by the outside on the driven shaft) = -torque_out.

Energy bookkeeping: the loss power at every sample is the core's (load-dependent PL1..PL6 plus
the load-independent drag) modified by the hidden physics, and the input torque follows from
the power balance  T_in w_in = P_out + P_loss (+ d/dt of stored energy, + a ripple's power), so
    T_in = sign(w_in) * P_loss/|w_in| + torque_out / i   (i = w_in/w_out of the mode).
P_loss/|w_in| is evaluated by the core on a 2 ms grid and interpolated in time where the grid's
neighbours lie on the same side of every discontinuity of the model (sign of the speed, the
gear's power-flow direction, locking); every sample between neighbours on different sides is
evaluated by the core itself (tests/test_independent_gen3.py checks the result against the core
at random samples).

    python benchmarks/independent/gen3.py [case_id ...]      # writes OUT/recs, OUT/cases3.json

OUT: the environment variable CYCLO_INDEPENDENT_OUT (default out/independent3).
"""
from __future__ import annotations

import json
import os
import sys
from pathlib import Path

os.environ.setdefault("CYCLO_INDEPENDENT_OUT", "out/independent3")
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import gen   # noqa: E402  (file dialects, AR(1) noise)
import gen2  # noqa: E402  (1/f noise)

import numpy as np  # noqa: E402
from scipy import signal  # noqa: E402

from model_core import DriveDesign, operating_point, rpm_to_rad_s, speed_ratio  # noqa: E402
from model_core.design import scale_friction_level, scale_viscosity  # noqa: E402
from model_core.kinematics import shaft_speeds  # noqa: E402
from model_core.losses import LOSS_NAMES  # noqa: E402

HERE = Path(os.environ["CYCLO_INDEPENDENT_OUT"]).resolve()
RECS = HERE / "recs"

#: [s] the core is evaluated on this time grid (finer where the sample rate is lower)
MODEL_GRID_S = 0.002
#: [rad/s] the core is evaluated at |w_in| >= this (0.5 r/min: the model has no standstill)
W_MIN = rpm_to_rad_s(0.5)
#: below these |w_in| [rad/s] and |torque_out| [N*m] the core is evaluated at every sample:
#: the loss torques bend sharply there (pin law and drag near a standstill, the kink of the
#: losses at zero load), more than a 2 ms grid follows (measured: up to 1.9 mN*m off); and
#: where the output torque moves more than DT_EXACT [N*m] within a grid step (a load step:
#: the losses are not linear in the torque over it; measured: up to 4 mN*m off)
W_EXACT, T_EXACT, DT_EXACT = 10.0, 1.5, 0.02
#: speed loop of the motor's drive: critically damped, natural frequency [Hz]
SPEED_LOOP_HZ = 6.0
#: torque loop of the load machine (dynamometer): first order, bandwidth [Hz]
TORQUE_LOOP_HZ = 25.0


# ----------------------------------------------------------------------------- kinematics
def mode_ratio(mode, design):
    """i = w_in / w_out of the mode (S1: +15, S2: -14 for the paper's drive), Table 1."""
    return float(speed_ratio(mode, design.z1))


def roller_pass_order(mode, design):
    """Ring rollers passed per input revolution: z1 |w_S - w_1| / |w_S| (the contact wave turns
    with the eccentric relative to the ring). S1: 14, S2: 15 for z1 = 15."""
    w = shaft_speeds(mode, 1.0, design.z1)
    return float(design.z1 * abs(w["S"] - w["1"]) / abs(w["S"]))


# ----------------------------------------------------------------------------- plans
def _knots(points):
    t = np.array([p[0] for p in points], float)
    v = np.array([p[1] for p in points], float)
    return t, v


def _speed_loop(x, fs):
    """Causal response of a critically damped speed loop (SPEED_LOOP_HZ), started settled."""
    wn = 2 * np.pi * SPEED_LOOP_HZ
    b, a = signal.bilinear([wn * wn], [1.0, 2 * wn, wn * wn], fs)
    return signal.lfilter(b, a, x, zi=signal.lfilter_zi(b, a) * x[0])[0]


def _torque_loop(x, fs):
    b, a = signal.bilinear([1.0], [1.0 / (2 * np.pi * TORQUE_LOOP_HZ), 1.0], fs)
    return signal.lfilter(b, a, x, zi=signal.lfilter_zi(b, a) * x[0])[0]


def _levels_plan(t, fs, speed_pts, load_pts):
    """Piecewise-linear set points through the drive's speed loop and the dyno's torque loop."""
    ts, vs = _knots(speed_pts)
    tl, vl = _knots(load_pts)
    return _speed_loop(np.interp(t, ts, vs), fs), _torque_loop(np.interp(t, tl, vl), fs)


def plan_stairs(rng, t, fs, i):
    """Speed stairs 400 -> 2700 r/min and back (forward only), three load levels per stair.
    (Every plan: rng, sample times t [s], rate fs [Hz], the mode's ratio i = w_in/w_out;
    returns the input speed [r/min] and the delivered output torque torque_out [N*m].)"""
    sign_out = np.sign(i)
    dur = t[-1]
    up = np.sort(rng.uniform(400, 2700, 5))
    up[0], up[-1] = rng.uniform(400, 480), rng.uniform(2620, 2700)
    levels = np.r_[up, up[-2::-1][:3]]
    seg = dur / levels.size
    sp, ld = [(0.0, levels[0])], [(0.0, rng.uniform(2, 8))]
    for k, n in enumerate(levels):
        t0 = k * seg
        if k:
            sp.append((t0 + abs(n - levels[k - 1]) / rng.uniform(600, 1200), n))
        sp.append((t0 + seg, n))
        for j in range(3):
            tj = t0 + (j + 0.5) * seg / 3
            ld += [(tj, ld[-1][1]), (tj + 0.05, rng.uniform(1.0, 9.0))]
    n_in, L = _levels_plan(t, fs, sp, ld)
    return n_in, L * sign_out


def plan_four_quadrant(rng, t, fs, i):
    """Holds at speeds of both signs (two of them slow, 80-250 r/min); within each hold the
    load machine sets an absorbing and a back-driving torque (random order, 2-9 and 2-6 N*m);
    the torque of a hold's end is kept through the next speed ramp, so speed reversals happen
    at a held torque (the power flow changes with the speed's sign) and torque reversals at a
    held speed."""
    sign_out = np.sign(i)
    dur = t[-1]
    n_holds = max(4, int(round(dur / 10.0)))
    mags = rng.uniform(500, 2600, n_holds)
    slow = rng.choice(np.arange(1, n_holds), size=min(2, n_holds - 1), replace=False)
    mags[slow] = rng.uniform(80, 250, slow.size)
    signs = np.ones(n_holds)
    s = 1.0
    for k in range(n_holds):   # reverse after every one or two holds
        signs[k] = s
        if k % 3 != 1:
            s = -s
    speeds = mags * signs
    seg = dur / n_holds
    sp, ld = [(0.0, speeds[0])], []
    L_prev = rng.uniform(2, 9)
    ld.append((0.0, L_prev * sign_out))
    for k, n in enumerate(speeds):
        t0 = k * seg
        tr = 0.0
        if k:
            tr = abs(n - speeds[k - 1]) / rng.uniform(500, 1500)
            sp.append((t0 + tr, n))
        sp.append((t0 + seg, n))
        dirn = np.sign(n) * sign_out          # sign of the output speed
        loads = [rng.uniform(2, 9) * dirn, -rng.uniform(2, 6) * dirn]
        if rng.random() < 0.5:
            loads = loads[::-1]
        for j, L in enumerate(loads):
            tj = t0 + tr + (j + 0.5) * (seg - tr) / 2
            ld += [(tj, ld[-1][1]), (tj + 0.05, L)]
    n_in, torque_out = _levels_plan(t, fs, sp, ld)
    return n_in, torque_out


def plan_held(rng, t, fs, i):
    """One speed (1200-2400 r/min) for the whole recording; load stairs and slow ramps 1-9 N*m."""
    sign_out = np.sign(i)
    n0 = rng.uniform(1200, 2400)
    dur = t[-1]
    ld, tt = [(0.0, rng.uniform(1, 9))], 0.0
    while tt < dur:
        d = rng.uniform(3, 8)
        if rng.random() < 0.5:
            ld += [(tt + d, ld[-1][1]), (tt + d + 0.05, rng.uniform(1, 9))]
        else:
            ld += [(tt + d, rng.uniform(1, 9))]
        tt += d
    n_in, L = _levels_plan(t, fs, [(0.0, n0), (dur + 1, n0)], ld)
    return n_in, L * sign_out


#: [kg*m^2] the duty cycle's load inertia on the output shaft (it back-drives while braking)
DUTY_LOAD_INERTIA = 0.8


def plan_duty(rng, t, fs, i):
    """A continuous duty cycle: the input speed moves between random levels (300-2700 r/min,
    now and then through zero to the other direction, now and then down to 60-200 r/min) by
    raised-cosine moves of 1.5-5 s, one after the other without holds; the load is a slowly
    varying friction (1-5 N*m, raised-cosine too) plus the load inertia DUTY_LOAD_INERTIA
    times the output's acceleration."""
    dur = t[-1]
    tk, nk = [0.0], [rng.uniform(800, 2000)]
    while tk[-1] < dur:
        r = rng.random()
        mag = rng.uniform(60, 200) if r < 0.15 else rng.uniform(300, 2700)
        sgn = -np.sign(nk[-1]) if r > 0.75 else np.sign(nk[-1])
        tk.append(tk[-1] + rng.uniform(1.5, 5.0))
        nk.append(mag * sgn)
    n_in = _cosine_moves(t, np.array(tk), np.array(nk))
    tf, Lf = [0.0], [rng.uniform(1, 5)]
    while tf[-1] < dur:
        tf.append(tf[-1] + rng.uniform(3, 8))
        Lf.append(rng.uniform(1, 5))
    L0 = _cosine_moves(t, np.array(tf), np.array(Lf))
    w_out = rpm_to_rad_s(n_in) / i
    alpha_out = np.gradient(w_out, t)
    torque_out = L0 * np.tanh(w_out / 0.5) + DUTY_LOAD_INERTIA * alpha_out
    return n_in, torque_out


def _cosine_moves(t, tk, vk):
    """Raised-cosine moves between the values vk at the times tk (zero slope only at the
    knots, no plateaus)."""
    i = np.clip(np.searchsorted(tk, t, side="right") - 1, 0, tk.size - 2)
    s = np.clip((t - tk[i]) / (tk[i + 1] - tk[i]), 0, 1)
    return vk[i] + (vk[i + 1] - vk[i]) * 0.5 * (1 - np.cos(np.pi * s))


PLANS = {"stairs": plan_stairs, "4q": plan_four_quadrant, "held": plan_held, "duty": plan_duty}


# ----------------------------------------------------------------------------- the reducer
def _core(design, mode, w_in, torque_out):
    """Loss torques of the core at the points: columns P_gear/|w_in| (load-dependent PL1..PL6),
    P_idle/|w_in| (load-independent drag) and P_mesh/|w_in| (the power through the mesh in the
    relative motion, |T1_gear (w1 - wS)|), all N*m (NaN where the core has no steady state:
    the gear's losses above the power it passes at a vanishing load); and a key of the
    model's discontinuities."""
    ws = np.where(np.abs(w_in) < W_MIN, np.where(w_in < 0, -W_MIN, W_MIN), w_in)
    op = operating_point(design, mode, ws, T_out=-np.asarray(torque_out, float))
    aw = np.abs(ws)
    gear = sum(getattr(op.losses, k) for k in LOSS_NAMES)
    idle = op.losses.idle + np.zeros_like(aw)
    mesh = np.abs(op.gear_torques["1"] * (op.speeds["1"] - op.speeds["S"]))
    q = np.column_stack([gear / aw, idle / aw, mesh / aw])
    key = np.sign(ws) * 4 + op.flow_forward.astype(int) * 2 + op.locked.astype(int)
    return q, key


def reducer_losses(design, mode, t, n_in_rpm, torque_out, grid_s=MODEL_GRID_S):
    """The core's loss torques (see _core) at every sample: on the time grid grid_s, linear in
    time between grid neighbours on the same side of the model's discontinuities, the core
    itself at every sample between neighbours on different sides. Where the core has no steady
    state (a vanishing load passing through zero, see _core) the loss torques are bridged
    linearly in time; returns (q, number of bridged samples)."""
    w_in = rpm_to_rad_s(n_in_rpm)
    n = t.size
    step = max(1, int(round(grid_s / (t[1] - t[0]))))
    g = np.arange(0, n, step)
    if g[-1] != n - 1:
        g = np.r_[g, n - 1]
    qg, kg = _core(design, mode, w_in[g], torque_out[g])
    idx = np.arange(n)
    q = np.empty((n, qg.shape[1]))
    okg = np.isfinite(qg).all(1)
    for j in range(qg.shape[1]):
        q[:, j] = np.interp(idx, g[okg], qg[okg, j])
    # exact: between grid neighbours on different sides, or next to an undefined grid point
    tg = torque_out[g]
    change = np.flatnonzero((kg[1:] != kg[:-1]) | ~okg[1:] | ~okg[:-1]
                            | (np.abs(np.diff(tg)) > DT_EXACT))
    bridged = np.zeros(n, bool)
    bridged[g[~okg]] = True
    near = (np.abs(w_in) < W_EXACT) | (np.abs(torque_out) < T_EXACT)
    near[g] = False
    if change.size or near.any():
        exact = np.concatenate([np.arange(g[c] + 1, g[c + 1]) for c in change]
                               + [np.flatnonzero(near)])
        exact = np.unique(exact)
        if exact.size:
            qe = _core(design, mode, w_in[exact], torque_out[exact])[0]
            q[exact] = qe
            bridged[exact] = ~np.isfinite(qe).all(1)
    if bridged.any():
        good = ~bridged
        for j in range(q.shape[1]):
            q[bridged, j] = np.interp(idx[bridged], idx[good], q[good, j])
    return q, int(bridged.sum())


# ----------------------------------------------------------------------------- hidden physics
def _rms(x):
    return float(np.sqrt(np.mean(np.square(x))))


def lumped_temperature(t, P_loss, tau=60.0, R=1.5):
    """Temperature rise (K) of a lumped housing heated by the loss power P_loss (W):
    C dT/dt = P - T/R with tau = R C [s] and R [K/W], exact for a piecewise-constant power on
    the uniform time stamps. Assumption: a small reducer's housing, 1.5 K/W and 60 s."""
    a = float(np.exp(-(t[1] - t[0]) / tau))
    return signal.lfilter([1 - a], [1, -a], P_loss * R)


def loss_factors(case, s):
    """Factors on the core's gear and idle losses, an extra mesh-loss fraction, and the
    designs the case changes; each hidden loss effect's physics."""
    fg = np.ones_like(s["t"])
    fi = np.ones_like(s["t"])
    k_mesh = 0.0
    for e in case["effects"]:
        k = e["kind"]
        if k == "loss_scale":        # all load-dependent losses off by a factor
            fg = fg * e["factor"]
        elif k == "idle_scale":      # the load-independent losses off by a factor
            fi = fi * e["factor"]
        elif k == "mesh_loss":       # an extra loss, a fraction k of the mesh power
            k_mesh += e["k"]
        elif k == "run_in":          # friction running in with sliding distance (revolutions)
            fg = fg * (1 + e["a"] * np.exp(-s["revs"] / e["revs0"]))
        elif k == "thermal":         # losses falling as the (unrecorded) housing warms
            fg = fg * (1 + e["beta_per_K"] * s["temp_rise"])
            fi = fi * (1 + e["beta_per_K"] * s["temp_rise"])
    return fg, fi, k_mesh


def input_torques(case, s):
    """Additive torques at the input shaft of the hidden effects that are not loss factors
    (N*m, noise-free, before the transducer): dict kind -> (torque, coefficient), the torque
    being the coefficient times the shape written next to each kind (w in rad/s, T in N*m;
    the coefficient scales the shape to the effect's rms_mNm)."""
    t, w, tout = s["t"], s["w"], s["tout"]
    sg = np.tanh(w / 2.0)        # a drag's sign, regularised over +-2 rad/s
    out = {}
    for e in case["effects"]:
        k = e["kind"]
        if k == "drag":          # lip seal (Coulomb) + a bearing's viscous drag ~ |w|^0.5
            x = sg * (0.5 + 0.5 * np.sqrt(np.abs(w) / 300.0))
        elif k == "stribeck":    # boundary friction at low speed, shape exponent 1.3
            x = sg * np.exp(-(np.abs(w) / e["ws"]) ** 1.3)
        elif k == "inertia":     # an unmodelled inertia on the input shaft
            x = e["J"] * s["alpha"]
        elif k == "ripple":      # 1x (runout) and the roller pass, constant amplitude
            x = 0.4 * np.sin(s["theta"] + 0.9) + np.sin(s["z"] * s["theta"] + 2.2)
        elif k == "ripple_load":  # roller-pass ripple growing with the transmitted torque
            a = np.abs(s["T_gear_in"])
            x = (0.25 + a / _rms(a)) * np.sin(s["z"] * s["theta"] + 0.4)
        elif k == "windage":     # churning/windage drag ~ w^2
            x = sg * w ** 2
        elif k == "load2":       # a loss ~ |T|^2 (e.g. a load-squared bearing or mesh term)
            x = sg * tout ** 2
        elif k == "speed_load":  # a loss ~ speed * load
            x = w * np.abs(tout)
        else:
            continue
        c = 1.0 if k == "inertia" else e["rms_mNm"] * 1e-3 / _rms(x)
        out[k] = (x * c, c)
    return out


def transducer(case, T, fs, t):
    """The input torque transducer's errors of the case (offset, gain, zero drift, delay,
    low-pass) applied to the shaft torque T."""
    for e in case["effects"]:
        k = e["kind"]
        if k == "offset":
            T = T + e["mNm"] * 1e-3
        elif k == "gain":
            T = T * (1 + e["g"])
        elif k == "zero_drift":      # the zero following the transducer's own warm-up
            T = T + e["mNm"] * 1e-3 * (1 - np.exp(-t / e["tau"]))
        elif k == "delay":
            d = max(1, int(round(e["ms"] * 1e-3 * fs)))
            T = np.r_[np.full(d, T[0]), T[:-d]]
        elif k == "lowpass":
            b, a = signal.bilinear([1.0], [1.0 / (2 * np.pi * e["fc"]), 1.0], fs)
            T = signal.lfilter(b, a, T, zi=signal.lfilter_zi(b, a) * T[0])[0]
    return T


SENSOR = {"offset", "gain", "zero_drift", "delay", "lowpass"}
FACTOR = {"loss_scale", "idle_scale", "mesh_loss", "run_in", "thermal"}
DESIGN = {"friction", "viscosity"}


# ----------------------------------------------------------------------------- one case
def build(case):
    """(data, truth, audit) of one case. ``audit``: the noise-free shaft quantities and the
    power bookkeeping (W) for tests: P_in, P_out, P_loss (modelled), P_stored (J w alpha),
    P_ripple (a ripple's power, zero mean over revolutions)."""
    rng = np.random.default_rng(case["seed"])
    design = DriveDesign()
    mode, fs, dur = case["mode"], float(case["fs"]), float(case["duration"])
    i = mode_ratio(mode, design)
    t = np.arange(int(round(dur * fs))) / fs
    n_in, tout = PLANS[case["plan"]](rng, t, fs, i)
    w = rpm_to_rad_s(n_in)
    theta = np.concatenate([[0.0], np.cumsum(0.5 * (w[1:] + w[:-1]) / fs)])
    s = dict(t=t, n_in=n_in, w=w, tout=tout, theta=theta, alpha=np.gradient(w, t),
             z=roller_pass_order(mode, design), revs=np.abs(theta) / (2 * np.pi))
    q0, bridged = reducer_losses(design, mode, t, n_in, tout)
    q = hidden_loss_torques(case, s, design, q0)
    fg, fi, k_mesh = loss_factors(case, s)
    L_loss = fg * q[:, 0] + fi * q[:, 1] + k_mesh * q[:, 2]      # P_loss/|w_in| [N*m]
    T_gear_in = np.sign(w) * L_loss + tout / i                   # quasi-static, the gear
    s["T_gear_in"] = T_gear_in
    extra_c = input_torques(case, s)
    extra = {k: v[0] for k, v in extra_c.items()}
    T_shaft = T_gear_in + sum(extra.values()) if extra else T_gear_in.copy()
    truth = effect_sizes(case, s, design, q0, extra_c, T_shaft)
    # ---- energy audit (noise-free, before the transducer)
    ripples = [extra[k] for k in ("ripple", "ripple_load") if k in extra]
    P_loss = L_loss * np.abs(w) + sum(extra[k] * w for k in extra
                                      if k not in ("inertia", "ripple", "ripple_load"))
    audit = dict(t=t, n_in=n_in, torque_out=tout, w_in=w, w_out=w / i, T_in=T_shaft,
                 P_in=T_shaft * w, P_out=tout * w / i, P_loss=P_loss,
                 P_stored=extra.get("inertia", 0.0) * w,
                 P_ripple=sum(ripples) * w if ripples else np.zeros_like(w),
                 ratio=i, loss_torques=q, theta=theta)
    data = measure(case, rng, s, T_shaft, i, q0)
    stats = plan_stats(t, n_in, tout, i)
    stats["model_undefined_samples_bridged"] = bridged
    data = logger(case, rng, data, stats)
    return data, dict(effects=truth, plan=stats), audit


def hidden_loss_torques(case, s, design, q0):
    """The core's loss torques under the case's design changes: the friction level, a
    viscosity drifting in time; and the housing's warm-up (s["temp_rise"], K) a thermal
    effect follows."""
    t, w, n_in = s["t"], s["w"], s["n_in"]
    mode, tout = case["mode"], s["tout"]
    kinds = {e["kind"] for e in case["effects"]}
    q = q0
    for e in case["effects"]:
        if e["kind"] == "friction":      # the sliding friction coefficients off by a factor
            q = reducer_losses(scale_friction_level(design, e["factor"]), mode, t, n_in,
                               tout)[0]
    if "viscosity" in kinds:             # ln(viscosity) drifting as the grease warms
        e = next(e for e in case["effects"] if e["kind"] == "viscosity")
        x = e["ln_change"] * (1 - np.exp(-t / e["tau"]))
        nodes = np.array([0.0, 0.5, 1.0]) * e["ln_change"]
        Q = [q if v == 0 else reducer_losses(scale_viscosity(design, np.exp(v)), mode, t,
                                             n_in, tout)[0] for v in nodes]
        # quadratic (Lagrange) in ln(viscosity) through the three evaluations
        L = [np.prod([(x - nodes[m]) / (nodes[j] - nodes[m]) for m in range(3) if m != j], 0)
             for j in range(3)]
        q = sum(Lj[:, None] * Qj for Lj, Qj in zip(L, Q))
    if "thermal" in kinds:
        e = next(e for e in case["effects"] if e["kind"] == "thermal")
        P_nom = (q[:, 0] + q[:, 1]) * np.abs(w)
        s["temp_rise"] = lumped_temperature(t, P_nom, tau=e["tau"], R=e["R_K_per_W"])
    return q


def effect_sizes(case, s, design, q0, extra_c, T_shaft):
    """The truth: each effect's parameters and its size at the input (RMS, mN*m, the effect
    alone against the nominal model; a transducer fault: the reading error it makes)."""
    i = mode_ratio(case["mode"], design)
    T_nominal = np.sign(s["w"]) * (q0[:, 0] + q0[:, 1]) + s["tout"] / i
    truth = []
    for e in case["effects"]:
        k = e["kind"]
        tr = dict(e)
        if k in extra_c:
            tr["rms_mNm_actual"] = round(1e3 * _rms(extra_c[k][0]), 2)
            if k != "inertia":
                tr["coef_SI"] = float(extra_c[k][1])
        elif k in SENSOR:
            tr["rms_mNm_actual"] = round(1e3 * _rms(
                transducer(dict(effects=[e]), T_shaft, case["fs"], s["t"]) - T_shaft), 2)
        elif k in FACTOR or k in DESIGN:
            single = dict(case, effects=[e])
            tr["rms_mNm_actual"] = round(1e3 * _rms(_loss_torque_alone(single, s, design, q0)
                                                    - T_nominal), 2)
        truth.append(tr)
    return truth


def measure(case, rng, s, T_shaft, i, q0):
    """The transducers' readings: the input torque's faults, noise (white, AR(1) or 1/f),
    optional quantisation and a housing temperature column."""
    t, n_in, tout, fs = s["t"], s["n_in"], s["tout"], float(case["fs"])
    T_meas = transducer(case, T_shaft, fs, t)
    nz = case.get("noise", {})
    sig, col = nz.get("sigma_mNm", 3.0) * 1e-3, nz.get("colour", "white")
    T_meas = T_meas + gen2.noise2(rng, t.size, sig, col, fs)
    To_meas = tout + gen2.noise2(rng, t.size, 3 * sig, col, fs)
    ni_meas = n_in + rng.normal(0, 0.3, t.size)
    no_meas = n_in / i + rng.normal(0, 0.05, t.size)
    if case.get("quantise"):         # 16-bit-like converters: 1 mN*m, 5 mN*m, 0.1, 0.01 r/min
        T_meas, To_meas = np.round(T_meas / 1e-3) * 1e-3, np.round(To_meas / 5e-3) * 5e-3
        ni_meas, no_meas = np.round(ni_meas / 0.1) * 0.1, np.round(no_meas / 0.01) * 0.01
    data = dict(time_s=t.copy(), speed_in_rpm=ni_meas, speed_out_rpm=no_meas,
                torque_in_Nm=T_meas, torque_out_Nm=To_meas)
    if case.get("temperature"):      # a housing thermocouple: lumped warm-up from the losses
        th = s.get("temp_rise")
        if th is None:
            th = lumped_temperature(t, (q0[:, 0] + q0[:, 1]) * np.abs(s["w"]))
        data["temperature_C"] = 23.0 + th + rng.normal(0, 0.05, t.size)
    return data


def logger(case, rng, data, stats):
    """The logger's faults: a lost stretch of samples, time stamps that did not advance."""
    t = data["time_s"]
    keep = np.ones(t.size, bool)
    if case.get("gap"):
        g0, gl = case["gap"]
        keep &= ~((t >= g0) & (t < g0 + gl))
    data = {k: v[keep] for k, v in data.items()}
    if case.get("dup"):
        m = data["time_s"].size
        rows = rng.choice(np.arange(1, m), size=int(case["dup"] * m), replace=False)
        data["time_s"][rows] = data["time_s"][rows - 1]
        stats["duplicated_stamps"] = int(rows.size)
    stats["samples_written"] = int(data["time_s"].size)
    return data


def _loss_torque_alone(case, s, design, q0):
    """Quasi-static input torque with only this case's loss/design effect (for its size)."""
    e = case["effects"][0]
    q = q0
    if e["kind"] == "friction":
        q = reducer_losses(scale_friction_level(design, e["factor"]), case["mode"], s["t"],
                           s["n_in"], s["tout"])[0]
    elif e["kind"] == "viscosity":
        # the drift's end state, blended in by its progress 1 - exp(-t/tau) (linear in
        # ln(viscosity): an estimate of the size; the recording uses the quadratic form)
        qe = reducer_losses(scale_viscosity(design, np.exp(e["ln_change"])), case["mode"],
                            s["t"], s["n_in"], s["tout"])[0]
        r = 1 - np.exp(-s["t"] / e["tau"])
        q = q0 + (qe - q0) * r[:, None]
    fg, fi, k = loss_factors(case, s)
    i = mode_ratio(case["mode"], design)
    return np.sign(s["w"]) * (fg * q[:, 0] + fi * q[:, 1] + k * q[:, 2]) + s["tout"] / i


def plan_stats(t, n_in, tout, i):
    """Shares of time in the four quadrants (input speed sign x output power sign)."""
    w_out = n_in / i
    moving = np.abs(n_in) > 1.0
    p = tout * w_out
    back = moving & (p < 0)
    pos, neg = moving & (n_in > 0), moving & (n_in < 0)
    q = {"Q1_fwd_pos": pos & (p >= 0), "Q2_back_pos": pos & (p < 0),
         "Q3_fwd_neg": neg & (p >= 0), "Q4_back_neg": neg & (p < 0)}
    return dict({k: round(float(v.mean()), 3) for k, v in q.items()},
                back_driven_share=round(float(back.sum() / max(moving.sum(), 1)), 3),
                speed_reversals=int(np.sum(np.diff(np.sign(n_in[moving])) != 0)),
                n_in_range_rpm=[round(float(n_in.min())), round(float(n_in.max()))],
                torque_out_range_Nm=[round(float(tout.min()), 2), round(float(tout.max()), 2)],
                samples=int(t.size))


# ----------------------------------------------------------------------------- the cases
# A case names its plan, mode, rate, length, file dialect, noise and the hidden effects with
# their physical parameters; the expectation is fixed here, before the first diagnosis run:
#   expect     list of groups; each group lists the library ids any one of which names that
#              effect right ("re:<regex>" matches ids by pattern, for a name still to come);
#              an id of a group may also be found under the JSON's `calibration`
#   tolerate   ids that may be named besides without being wrong (the verdict is then
#              "right (alt)"): a calibration that legitimately takes part of an unknown loss
#   unexplained  True (must be reported), False (must not), None (either)
#   proposal   for out-of-library losses: the variables the proposed form must hold
#              ("speed", "torque" and their powers), judged apart from the verdict
CAL = ["friction_miscalibrated", "mesh_loss"]          # a load-dependent loss level
RUN_IN = ["re:run.?in|wear|friction_drift|running", "thermal_drift"]


def E(kind, **kw):
    return dict(kind=kind, **kw)


LIB = {   # library effect -> (hidden physics, expected group, tolerated)
    "friction": (E("friction", factor=1.2), CAL, []),
    "mesh_loss": (E("mesh_loss", k=0.002), ["mesh_loss", "friction_miscalibrated"], []),
    "idle_scale": (E("idle_scale", factor=1.25), ["idle_loss_scale", "load_independent_loss"],
                   []),
    "drag": (E("drag", rms_mNm=10.0), ["load_independent_loss", "idle_loss_scale"], []),
    "stribeck": (E("stribeck", rms_mNm=6.0, ws=30.0), ["low_speed_friction"], []),
    "thermal": (E("thermal", beta_per_K=-0.006, tau=60.0, R_K_per_W=1.5),
                ["thermal_drift", "viscosity_drift"], []),
    "viscosity": (E("viscosity", ln_change=float(np.log(0.5)), tau=60.0),
                  ["viscosity_drift", "thermal_drift"], []),
    "inertia": (E("inertia", J=3e-4), ["inertia"], []),
    "ripple": (E("ripple", rms_mNm=8.0), ["mesh_ripple"], []),
    "offset": (E("offset", mNm=8.0), ["torque_sensor_offset"], []),
    "gain": (E("gain", g=0.025), ["torque_sensor_gain"], []),
    "zero_drift": (E("zero_drift", mNm=-12.0, tau=50.0), ["torque_sensor_drift"],
                   ["torque_sensor_offset"]),
}
# the length a drift needs to show its time constant
LONG = {"thermal", "viscosity", "zero_drift", "run_in"}


def _case(cid, plan, mode, fs, dialect, effects=(), expect=(), tolerate=(), unexplained=False,
          duration=None, **kw):
    if duration is None:
        duration = {200: 150, 500: 150, 1000: 120, 2000: 90, 5000: 60, 10000: 40}[fs]
    return dict(id=cid, plan=plan, mode=mode, fs=fs, duration=duration, dialect=dialect,
                effects=[dict(e) for e in effects], expect=[list(g) for g in expect],
                tolerate=list(tolerate), unexplained=unexplained, **kw)


def _lib_case(plan, mode, fs, names, dialect="csv", **kw):
    effs, groups, tol = [], [], []
    for n in names:
        e, g, tl = LIB[n]
        effs.append(e)
        groups.append(g)
        tol += tl
    dur = 180 if LONG & set(names) else None
    cid = f"{plan}_{'+'.join(names)}_{mode}_{fs // 1000 if fs >= 1000 else fs}" + \
        ("k" if fs >= 1000 else "Hz")
    return _case(cid, plan, mode, fs, dialect, effs, groups, tol, False,
                 duration=kw.pop("duration", dur), **kw)


WHITE, AR1, PINK = dict(colour="white"), dict(colour="ar1", sigma_mNm=4.0), \
    dict(colour="pink", sigma_mNm=4.0)

CASES = [
    # --- clean: every plan kind, 200 Hz - 10 kHz, noise colours, quantisation, gap, stamps
    _case("clean_stairs_S1_1k", "stairs", "S1", 1000, "csv"),
    _case("clean_stairs_S2_200Hz_ar1_german", "stairs", "S2", 200, "german", noise=AR1),
    _case("clean_stairs_S1_2k_temp_mdf", "stairs", "S1", 2000, "mdf4", temperature=True),
    _case("clean_4q_S1_1k_pink", "4q", "S1", 1000, "csv", noise=PINK),
    _case("clean_4q_S2_5k_quant_catman", "4q", "S2", 5000, "catman", quantise=True),
    _case("clean_4q_S1_10k", "4q", "S1", 10000, "csv"),
    _case("clean_4q_S2_200Hz_gap_german", "4q", "S2", 200, "german", gap=(61.3, 4.0)),
    _case("clean_held_S1_1k_mdf", "held", "S1", 1000, "mdf4", duration=60),
    _case("clean_held_S2_200Hz_ms", "held", "S2", 200, "ms_plain", duration=90),
    _case("clean_duty_S1_1k_pink_custom", "duty", "S1", 1000, "custom_names", noise=PINK),
    _case("clean_duty_S2_10k_quant", "duty", "S2", 10000, "csv", quantise=True),
    _case("clean_duty_S1_5k_ar1_utf16", "duty", "S1", 5000, "units_in_names_utf16", noise=AR1),
    _case("clean_duty_S2_1k_dupstamps", "duty", "S2", 1000, "csv", dup=0.003),
]
# --- every library effect alone, in the four-quadrant and the duty-cycle plan (modes alternate)
for j, name in enumerate(LIB):
    CASES.append(_lib_case("4q", "S1" if j % 2 == 0 else "S2", 1000 if j % 3 else 2000, [name]))
    CASES.append(_lib_case("duty", "S2" if j % 2 == 0 else "S1", 1000 if j % 3 != 1 else 500,
                           [name], dialect="german" if j % 4 == 0 else "csv"))
# --- pairs
PAIRS_4Q = [("drag", "inertia", "S1"), ("gain", "offset", "S2"), ("friction", "gain", "S1"),
            ("stribeck", "ripple", "S2"), ("thermal", "offset", "S1"),
            ("viscosity", "inertia", "S2")]
PAIRS_DUTY = [("drag", "ripple", "S2"), ("inertia", "zero_drift", "S1"),
              ("mesh_loss", "stribeck", "S1"), ("gain", "inertia", "S2"),
              ("thermal", "ripple", "S1"), ("offset", "idle_scale", "S2")]
for a, b, m in PAIRS_4Q:
    CASES.append(_lib_case("4q", m, 1000, [a, b]))
for a, b, m in PAIRS_DUTY:
    CASES.append(_lib_case("duty", m, 1000, [a, b], dialect="catman" if a == "gain" else "csv"))
CASES += [
    # --- a loss-scale error on all load-dependent losses: a calibration effect
    _case("lossscale_p12_4q_S1_1k", "4q", "S1", 1000, "csv", [E("loss_scale", factor=1.12)],
          [CAL]),
    _case("lossscale_m12_duty_S2_1k", "duty", "S2", 1000, "csv", [E("loss_scale", factor=0.88)],
          [CAL]),
    _case("lossscale_p15_stairs_S1_500Hz", "stairs", "S1", 500, "german",
          [E("loss_scale", factor=1.15)], [CAL]),
    _case("lossscale_m10_held_S1_1k", "held", "S1", 1000, "csv",
          [E("loss_scale", factor=0.90)], [CAL], duration=90),
    # --- friction running in (sliding distance, no temperature): a run-in / friction drift;
    #     the friction level may be named beside a time drift (it ends at nominal)
    _case("runin_4q_S1_500Hz", "4q", "S1", 500, "csv",
          [E("run_in", a=0.3, revs0=1500.0)], [RUN_IN], CAL, duration=240),
    _case("runin_duty_S2_1k", "duty", "S2", 1000, "csv",
          [E("run_in", a=0.3, revs0=1500.0)], [RUN_IN], CAL, duration=180),
    # --- library forms with physical scaling (issue 18, item 3)
    _case("rippleload_4q_S2_2k", "4q", "S2", 2000, "csv", [E("ripple_load", rms_mNm=8.0)],
          [["mesh_ripple"]]),
    _case("rippleload_duty_S1_2k", "duty", "S1", 2000, "csv", [E("ripple_load", rms_mNm=8.0)],
          [["mesh_ripple"]]),
    _case("windage_w2_4q_S1_1k", "4q", "S1", 1000, "csv", [E("windage", rms_mNm=8.0)],
          [["load_independent_loss"]], ["idle_loss_scale"],
          alt_unexplained=dict(proposal=dict(speed=2))),
    _case("windage_w2_duty_S2_1k", "duty", "S2", 1000, "csv", [E("windage", rms_mNm=8.0)],
          [["load_independent_loss"]], ["idle_loss_scale"],
          alt_unexplained=dict(proposal=dict(speed=2))),
    # --- outside the library: unexplained, with a proposed form
    _case("load2_4q_S2_1k", "4q", "S2", 1000, "csv", [E("load2", rms_mNm=10.0)], [], CAL, True,
          proposal=dict(torque=2)),
    _case("load2_duty_S1_1k", "duty", "S1", 1000, "csv", [E("load2", rms_mNm=10.0)], [], CAL,
          True, proposal=dict(torque=2)),
    _case("speedload_4q_S1_1k", "4q", "S1", 1000, "csv", [E("speed_load", rms_mNm=10.0)], [],
          CAL, True, proposal=dict(speed=1, torque=1)),
    _case("speedload_duty_S2_500Hz", "duty", "S2", 500, "catman",
          [E("speed_load", rms_mNm=10.0)], [], CAL, True, proposal=dict(speed=1, torque=1)),
    # --- the input torque channel late or low-passed (the output's is not)
    _case("delay10ms_Tin_4q_S1_1k", "4q", "S1", 1000, "csv", [E("delay", ms=10.0)], [], [],
          True),
    _case("lowpass6Hz_Tin_4q_S2_1k", "4q", "S2", 1000, "csv", [E("lowpass", fc=6.0)], [], [],
          True),
]
for c in CASES:
    c.setdefault("seed", 31000 + sum(ord(ch) * (k + 5) for k, ch in enumerate(c["id"])))
_ids = [c["id"] for c in CASES]
if len(set(_ids)) != len(_ids):
    raise RuntimeError("duplicate case ids")


def main(argv):
    sel = set(argv)
    RECS.mkdir(parents=True, exist_ok=True)
    cj = HERE / "cases3.json"
    old = {c["id"]: c for c in json.loads(cj.read_text())} if cj.exists() else {}
    out = []
    for c in CASES:
        if sel and c["id"] not in sel:
            if c["id"] in old:
                out.append(old[c["id"]])
            continue
        data, truth, _ = build(c)
        path = RECS / (c["id"] + gen.EXT[c["dialect"]])
        gen.write(path, data, c["dialect"])
        rec = {k: v for k, v in c.items() if k != "effects"}
        rec.update(file=str(path), truth=truth, args=gen.EXTRA_ARGS.get(c["dialect"], []))
        out.append(rec)
        print(f"{c['id']:40s} {truth['plan']['samples_written']:8d}  back "
              f"{truth['plan']['back_driven_share']:.2f}  "
              + ", ".join(f"{tr['kind']}={tr.get('rms_mNm_actual')}" for tr in truth["effects"]),
              flush=True)
    cj.write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main(sys.argv[1:])
