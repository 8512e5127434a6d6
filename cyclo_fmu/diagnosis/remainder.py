"""Stage ``remainder``: what the selected effects leave, each claim judged against twins.

Claims and their statistics (``twins`` for the false-alarm rate and the fitted tails):

- *smooth structure* (the generic basis, whole or one of its groups, beside the selection):
  the largest residual sum of squares a group removes, each over the mean its twins remove
  (``standardised_max``); twins: the same maximum over the groups on the twins' noise;
  judged at ``FALSE_ALARM``. Reported when it also explains at least
  ``MIN_EXPLAINED_NM`` (a physical limit, not a significance one).
- *a named effect next to that structure* (does it keep its place, or could the unknown hold
  it?): its drop-one statistic beside the selection and the group of the basis that best
  stands in for it, judged as in stage twins; an
  effect whose statistic the twins reach there, and that explains less than the basis adds, is
  withdrawn unless it explains ``DOMINANCE`` times the RMS the basis adds (then named and the
  rest reported as unexplained).
- *shaft orders*: the amplitude at an order of the input speed; twins: the amplitudes at
  ``OFF_ORDERS`` nearby non-orders of the same residual and speed (no shaft is phase-locked to
  them, their noise has the same colour), an exponential tail (a sine-cosine amplitude squared
  in noise is chi-square with 2 degrees of freedom) fitted to them; judged at FALSE_ALARM
  over the orders analysed.
- *bursts at events* (speed reversals, reversals of the model's input torque and of the
  output torque, load or speed steps; ``residual.burst_events``): the mean rank
  of the squared block residual within ``residual.EVENT_WINDOW`` of the events minus its
  mean rank in their flanks (``FLANK_WINDOW``: a transient is local, a slow change of level
  is as high beside the events); twins: the recording's own block residual shifted
  cyclically in time by every offset from a tenth to nine tenths of the recording (colour,
  spikes and tails kept, only the tie to the events broken), the p-value their share at or
  beyond the recording's (``burst_claims``); judged at FALSE_ALARM over the event kinds.
- *fixed-frequency peaks*: ``residual.peak_claims``: the height of a bin's three bins over the
  residual's null spectrum (its running median and flanks: smooth coloured noise, no line
  within the Hann main lobe), a normal score; twins: ``N_TWINS`` Welch spectra of Gaussian
  noise with that null spectrum, the same largest height over the frequencies searched, a
  Gumbel tail; judged at FALSE_ALARM for "a line somewhere" (family-wise). Shaft orders are
  excluded from the segments they reach; a line is reported from ``PEAK_MIN_AMPLITUDE_NM``.
- *lines at any other order* (``order_scan``): the same judgement on the residual resampled
  at uniform steps of the input shaft's travelled angle (Welch in angle, the abscissa the
  order), the listed orders left out; family-wise at FALSE_ALARM over the orders searched. A
  line that is both an order and a fixed frequency (held speeds) is reported once
  (``one_domain``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from model_core.effects import EFFECTS, SENSOR_EFFECTS
from model_core.kinematics import speed_ratio

from . import residual as R
from .select_effects import MIN_EXPLAINED_NM, fit_rms
from .selection import Term, explained
from .twins import FALSE_ALARM, N_TWINS, Check, mixes, with_mixes

#: [N*m] the smallest amplitude of a narrow spectral peak reported as unexplained: 1 mN*m (RMS
#: 0.7 mN*m, above MIN_EXPLAINED_NM). A size, not a significance: a long recording makes a
#: 0.3 mN*m line stand beyond its twins
PEAK_MIN_AMPLITUDE_NM = 1e-3
#: [1] an effect that the generic basis could stand in for (its statistic beside the basis
#: within its twins) keeps its name when it explains at least this many times the RMS the
#: basis adds beside the selection: 3, i.e. 90 % of the variance of the two together, the rest
#: reported as unexplained; below it the effect is withdrawn (``could_include``). Not a
#: significance threshold (both parts are beyond their twins), but the share of an explanation
#: at which the library's shape is taken for the answer and the rest for a remainder: the
#: twins cannot decide which of two explanations of the same residual to name
DOMINANCE = 3.0
#: [1] held-out errors of two structure groups within this relative difference are a tie:
#: float64 least squares on 1e4-1e6 blocks round at about 1e-12 relative (two groups whose
#: columns coincide, e.g. the reading's terms and the loss's where the speed never reverses,
#: measured equal to 12 digits), while a difference of evidence is many orders larger
TIE_REL = 1e-9
#: relative offsets of the off-order twins of an order k (k (1 + d)): wider than the order
#: resolution of a 5 s hold at 10 Hz shaft speed (2 %), inside the neighbourhood whose noise
#: level the order shares
OFF_ORDERS = (-0.21, -0.18, -0.15, -0.12, -0.09, -0.06, 0.06, 0.09, 0.12, 0.15, 0.18, 0.21)


@dataclass
class Remainder:
    """Stage ``remainder``: the final selection ``S`` and what it leaves (``unexplained``, the
    JSON contract's dict), with the claims' checks."""
    S: object
    with_g: object
    unexplained: dict
    withdrawn: list
    dominant: list
    friction_doubted: bool
    gain_alone: tuple
    step_transient: bool
    smooth: bool
    orders_all: dict
    residual_raw: np.ndarray = field(repr=False, default=None)
    claims: dict = field(default_factory=dict)


def structure(P, prob, S, tw, mix=None):
    """(present, best fit with a group of the generic basis, Check, RMS in the fit).

    The statistic is the largest standardised RSS drop any group makes beside the selection
    (``standardised_max``), each named
    effect at the mix of adjacent shapes it fits best (``twins.mixes``: the effect's own
    form between its grid's shapes is no remainder); the twins take the same maximum. The
    group reported (what the remainder is, its RMS) is the one with the smallest held-out
    error (the whole basis always fits best in sample, and would report its overfit)."""
    base = with_mixes(S.terms, mix or {})
    S0 = prob.fit(base, cv=False) if len(base) > len(S.terms) else S
    fits = [prob.fit(base + (b,)) for b in P.structure]
    stat, samples = standardised_max(tw, base, P.structure, [S0.rss - f.rss for f in fits])
    chk = tw.check(stat, samples, FALSE_ALARM)
    lo = min(f.cv_mse for f in fits)
    # equal held-out errors (two groups holding the same columns) go to the smaller group,
    # then the first listed: not to whichever the BLAS's rounding happens to favour
    best = min((f for f in fits if f.cv_mse <= lo * (1 + TIE_REL)),
               key=lambda f: len(f.terms[-1].cols))
    rms = fit_rms(prob, S0, best)
    if len(base) > len(S.terms):    # the fit reported: the selection and the group alone
        best = prob.fit(S.terms + (best.terms[-1],))
    return chk.stands and rms >= MIN_EXPLAINED_NM, best, chk, rms


def standardised_max(tw, base, groups, drops) -> tuple:
    """(the statistic, its twins) of the structure claim: the largest RSS drop ``drops`` of
    the ``groups`` beside ``base``, each over the mean drop the same group makes on the twins
    (its noise level: a group of k columns takes about k times the noise variance out of
    pure noise). The twins take the same maximum of their own standardised drops.

    Over raw drops the whole basis (27 columns) decides every claim: its drop on the noise
    alone is about 7 times a two-column group's, so a remainder that one small group holds
    whole stands within the whole basis's twins (batch 5's transducer hysteresis: the
    load-change direction took 0.69 of the RSS, the whole basis 0.69 too; 15.5 times the
    group's own twins' mean, 2.4 times the whole basis's; over raw drops p = 0.08).
    Standardised, each group is judged by its own evidence and the maximum over the groups
    keeps the stated rate (the twins maximise alike)."""
    r0 = tw.rss(tuple(base))
    D = np.array([r0 - tw.rss(tuple(base) + (b,)) for b in groups])
    scale = np.maximum(D[:, :tw.n].mean(1), 1e-300)
    return float(np.max(np.asarray(drops) / scale)), np.max(D / scale[:, None], 0)


def withdraw(P, prob, S, with_g, tw, alpha, forced):
    """Effects that the generic basis could stand in for: (S, withdrawn, dominant,
    friction_doubted). An effect keeps its place beside the group of the generic basis that
    best stands in for it (the group with which the rest of the selection fits best without
    it) when its drop-one statistic there lies beyond its twins and is of a reportable size (``MIN_EXPLAINED_NM``: a long recording makes a shape
    difference of no practical size significant); otherwise it is named only if it explains
    ``DOMINANCE`` times the RMS the basis adds beside the selection, and withdrawn if not (one
    at a time, the weakest first: a withdrawal changes what the others explain)."""
    groups = [g for g in P.structure if g != P.generic]
    g_adds = S.rss - with_g.rss
    weak, dominant, doubted = [], [], False
    for t in S.terms:
        if t.effect in forced and t.effect != "friction_miscalibrated":
            continue
        others = tuple(x for x in S.terms if x != t)
        b = min(groups, key=lambda g: prob.fit(others + (g,), cv=False).rss)
        beside = tuple(S.terms) + (b,)
        rest = tuple(x for x in beside if x != t)
        stat = prob.fit(rest, cv=False).rss - prob.fit(beside, cv=False).rss
        chk = tw.check(stat, tw.rss(rest) - tw.rss(beside), alpha)
        if chk.stands and math.sqrt(max(stat, 0.0) / prob.swt) >= MIN_EXPLAINED_NM:
            continue
        explains = prob.fit(tuple(x for x in S.terms if x != t), cv=False).rss - S.rss
        if t.effect == "friction_miscalibrated":
            doubted = True        # the model's own coefficient: stays in the fit, not named
        elif explains >= DOMINANCE ** 2 * g_adds:      # RSS: squares of the RMS
            dominant.append(t.effect)
        else:
            weak.append((explains, t))
    withdrawn = []
    if weak:
        t = min(weak, key=lambda x: x[0])[1]
        withdrawn = [t.effect]
        S = prob.fit(tuple(x for x in S.terms if x != t))
        while not S.admissible:
            out = [t for t in S.terms if t.effect not in forced and not np.all(
                (S.of(t)[0] >= t.lower) & (S.of(t)[0] <= t.upper))]
            if not out:
                break
            withdrawn += [t.effect for t in out]
            S = prob.fit(tuple(t for t in S.terms if t not in out))
    return S, withdrawn, dominant, doubted


def gain_alone(P, sel, S, tw, alpha):
    """The gain error not selectable (no back-driven blocks, or they do not tell it from its
    look-alike losses: ``select_effects.flow_told_apart``): would it explain what is left?
    (gain, held-out RMS it explains, whether structure is left beside it) or None."""
    if ("torque_sensor_gain" in sel.selectable or "torque_sensor_gain" not in sel.opts
            or "torque_sensor_gain" in S.ids):
        return None
    prob = sel.prob
    g = sel.opts["torque_sensor_gain"][0]
    fg = prob.fit(S.terms + (g,))
    chk = tw.check(S.rss - fg.rss, tw.rss(S.terms) - tw.rss(fg.terms), alpha)
    rms = max(explained(S, fg), fit_rms(prob, S, fg))
    if not (fg.admissible and chk.stands and rms >= MIN_EXPLAINED_NM):
        return None
    left = structure(P, prob, fg, tw)[0]
    return float(fg.of(g)[0][0]), rms, left


def order_claims(r, sig, orders, dt, rng):
    """{name: (amplitude, Check)} of the shaft orders, each against its off-order twins."""
    amps = R.order_amplitudes(r, sig, orders, dt)
    alpha = FALSE_ALARM / max(len(amps), 1)
    ks = np.array(list(orders.values()))
    out = {}
    for name, (a, se) in amps.items():
        if a < MIN_EXPLAINED_NM:
            out[name] = (a, None)
            continue
        k = orders[name]
        off = {f"{name} {d:+.2f}": k * (1 + d) for d in OFF_ORDERS
               if np.all(np.abs(k * (1 + d) - ks) > 0.03 * ks)}
        twins = np.array([x for x, _ in R.order_amplitudes(r, sig, off, dt,
                                                            others=ks).values()])
        if len(twins) < 4:
            out[name] = (a, None)
            continue
        mu = float(np.mean(twins ** 2))
        thr = math.sqrt(mu * math.log(1 / alpha))
        p = math.exp(-a * a / mu) if mu > 0 else 0.0
        out[name] = (a, Check(a, thr, p, alpha, len(twins), a > thr))
    return out


#: [1] the shortest cyclic shift of a burst twin, as a share of the recording: a shift of less
#: would keep the residual's own burst at the events' neighbours (the events of a plan recur
#: every few seconds; a tenth of the recording is tens of seconds)
MIN_SHIFT_SHARE = 0.1


#: [s] the flanks of an event: the blocks within this time of it but beyond
#: ``residual.EVENT_WINDOW``, the residual's own level around it. Five event windows: longer
#: than the transients a burst is (backlash, compliance, a filter: tens of ms), shorter than
#: the slow changes of level that are no transient (a 1/f noise's excursions, a slow
#: remainder that follows the operating phase: seconds)
FLANK_WINDOW = 0.5
#: [1] the burst windows, as multiples of ``residual.EVENT_WINDOW`` (0.1, 0.2 and 0.4 s), each
#: with its flanks scaled alike (to 0.5, 1 and 2 s): a transient lasts from tens of ms (a
#: filter, a delay, a lost motion taken up) to a few tenths of a second (a compliant shaft
#: ringing out at 10 Hz with light damping: batch 2's x05, 12 Hz decaying in 80 ms, stands
#: 4 mN*m above 1/f noise 0.3 s after each reversal). A window shorter than the transient puts
#: its tail in the flanks, where it reads as the residual's own level. The claim takes the
#: window with the smallest p-value and is judged on the same smallest p-value over the
#: windows of every shift (a min-p permutation test, Westfall and Young 1993): its rate stays
#: the stated one
BURST_SCALES = (1.0, 2.0, 4.0)


def shift_twins(rk, weights) -> tuple:
    """(the statistic, its twins): ``sum(weights * rk)`` and the same sum with ``rk`` shifted
    cyclically by every offset from ``MIN_SHIFT_SHARE`` of the recording to one minus it (one
    circular cross-correlation, an FFT; every shift a twin). On a plan that repeats with a
    fixed period, the shifts by multiples of it bring the events back onto themselves and are
    twins as well: the test keeps its rate there but loses power (a transient of 8 mN*m
    decaying in 50 ms at load steps every 3 s, in 4 mN*m of 1/f noise: p = 0.02-0.03; at
    steps 1.5-4.5 s apart, p = 0.0001-0.02 over four draws). Leaving those shifts out was
    tried: 1.3-4 % false alarms at the stated 0.33 % on a periodic start-stop plan."""
    n = len(rk)
    c = np.fft.irfft(np.conj(np.fft.rfft(weights)) * np.fft.rfft(rk), n)
    lo = int(math.ceil(MIN_SHIFT_SHARE * n))
    return float(c[0]), c[lo:n - lo + 1]


def burst_claims(P, r, spikes, rng):
    """R.bursts' account of the spike blocks, with ``tied`` the event kinds whose residual
    stands out against time-shifted twins; {kind: (Check, RMS of the burst excess)}.

    A burst is a transient at the events: the statistic is the mean rank of the squared
    block residual within ``residual.EVENT_WINDOW`` of the events minus its mean rank in
    their flanks (``FLANK_WINDOW``), and its size the mean square there beyond the flanks'.
    A slow change of level (a 1/f noise's excursion over a phase of the plan that holds many
    events, a slow remainder larger in some phases) is as high in the flanks and is no
    burst: the clean start-stop recording of batch 4 (1/f noise, 30 % of its blocks within
    0.1 s of a ramp) had its events' residual above the recording's level at p = 0.0015
    (the noise alone, without the physics, gives p = 0.0008 there), above their flanks at
    p = 0.016.

    The twins are the recording's own block residual shifted cyclically against the events by
    every offset from a tenth of the recording to nine tenths (``shift_twins``): the residual's
    colour, its slow changes of level, spikes and tails are kept, only the tie to the events
    is broken. The p-value is the share of shifts whose statistic reaches the recording's (an
    exact permutation test for a stationary residual, no tail fitted). The former twins (64
    random shifts, a normal tail) put the p-value of that recording at 0.00025."""
    t, w, T = P.blocks["t"], P.blocks["w_in"], P.blocks["T_out"]
    T_in = P.blocks["T_in"] - P.y       # the model's input torque (block means of the replay)
    b = R.bursts(t, spikes, w, T, T_in)
    ev = R.burst_events(t, w, T, T_in)
    # only the blocks compared (a block whose samples the replay cannot judge, at rest or
    # through a jump, keeps its plain mean for the record, not as evidence; the series of the
    # kept blocks is shifted against its events)
    valid = getattr(P, "valid", None)
    keep = np.ones(len(t), bool) if valid is None else np.asarray(valid) > 0
    r2 = (r * r)[keep]
    n = len(r2)
    # the statistic is the mean rank of |r| near the events (a few random spikes move a rank
    # mean by little, a transient at every event by much; no clipping constant needed)
    from .twins import average_ranks
    rk = average_ranks(r2) / max(n, 1)
    alpha = FALSE_ALARM / len(ev)
    taken = np.zeros(len(t), bool)
    claims, windows = {}, {}
    for kind, times in ev.items():
        before = taken.copy()
        taken |= R._near(t, times, R.EVENT_WINDOW) & ~before
        claim = _burst_claim(t, times, rk, r2, before, alpha, keep)
        if claim is not None:
            claims[kind], windows[kind] = claim[:2], claim[2]
    b["tied"] = [k for k, (c, e) in claims.items() if c.stands and e >= MIN_EXPLAINED_NM]
    b["checks"] = {k: dict(c.to_json(), rms_Nm=e, window_s=windows[k])
                   for k, (c, e) in claims.items()}
    return b, claims


def _burst_claim(t, times, rk, r2, taken, alpha, keep):
    """(Check, RMS of the burst excess, the window [s]) of the events at ``times`` over
    ``BURST_SCALES``, or None where the blocks are too few. Each window's statistic and its
    shift twins as in ``burst_claims``; the claim's p-value is the share of shifts whose
    smallest p-value over the windows is at or below the recording's (each shift's p-values
    from its rank among the shifts of the same window), the size and the reported statistic
    those of the recording's best window. ``rk`` and ``r2`` hold the kept blocks (``keep``,
    over all blocks ``t``) only."""
    n = len(rk)
    per = []
    for k in BURST_SCALES:
        near = R._near(t, times, k * R.EVENT_WINDOW) & ~taken
        flank = (R._near(t, times, k * FLANK_WINDOW) & ~near & ~taken)[keep]
        near = near[keep]
        if near.sum() < 3 or flank.sum() < 3 or n <= 20:
            return None
        stat, twins = shift_twins(rk, near / near.sum() - flank / flank.sum())
        per.append((stat, twins, near, flank, k))
    m = len(per[0][1])
    # each shift's p-value in each window: the share of shifts at or beyond it (descending ranks)
    q_twins = np.ones(m)
    q_rec = []
    for stat, twins, *_ in per:
        srt = np.sort(twins)
        q_twins = np.minimum(q_twins, (m - np.searchsorted(srt, twins, side="left")) / m)
        q_rec.append((1 + m - np.searchsorted(srt, stat, side="left")) / (1 + m))
    best = int(np.argmin(q_rec))
    q = q_rec[best]
    p = float((1 + np.count_nonzero(q_twins <= q)) / (1 + m))
    stat, twins, near, flank, k = per[best]
    # the window's threshold at the claim's rate: its twins' quantile at the smallest p-value
    # the shifts reach with probability alpha
    q_star = float(np.quantile(q_twins, alpha))
    thr = float(np.quantile(twins, max(0.0, 1.0 - q_star)))
    idx = np.flatnonzero(near)
    ref = float(np.mean(r2[flank]))
    excess = math.sqrt(max(float(np.sum(r2[idx])) - len(idx) * ref, 0.0) / n)
    return Check(stat, thr, p, alpha, m, p <= alpha), excess, k * R.EVENT_WINDOW


def _orders(design, mode, sig):
    k = sig["order_roller"]
    # the driven shaft's own rotation (runout, a coupling's misalignment, the brake) at 1x and
    # 2x of the output speed, as orders of the input speed
    k_out = 1.0 / abs(speed_ratio(mode, design.z1))
    return {"1x": 1.0, "2x": 2.0, "3x": 3.0, f"order {k:g} (roller pass)": k,
            f"order {2 * k:g} (2x roller pass)": 2 * k,
            f"output 1x (order {k_out:.4g})": k_out,
            f"output 2x (order {2 * k_out:.4g})": 2 * k_out}


def _sample_residual(P, S, with_g, rec):
    """Sample-level residual after the selection's fitted torque and the slow structure the
    generic basis holds (taken out before the order and spectral analysis: its changes between
    holds would leak into them)."""
    from .replay import first_order
    sig, dt = P.sig, P.dt
    fitted = np.zeros(len(rec.time))
    for t in S.terms:
        v, _ = S.of(t)
        fitted += first_order(EFFECTS[t.effect].basis(sig, t.shape), dt, P.bandwidth) @ v
    r_raw = rec.torque_in - P.T_model_f - fitted
    g = with_g.terms[-1]
    v, _ = with_g.of(g)
    slow = P.X[:, list(g.cols)] @ v
    r = r_raw.copy()
    n = min(len(slow) * P.m, len(r))
    r[:n] -= np.repeat(slow, P.m)[:n]
    return r_raw, r, fitted


def _smooth_part(P, prob, S, with_g, present, rms, dominant, sel_min):
    """The statement of the smooth remainder and what it follows (the held-out RMS lost
    without each group of the basis)."""
    parts, follows = [], {}
    if not present:
        return parts, follows
    g = with_g.terms[-1]
    ref = prob.fit(with_g.terms)
    for group in dict.fromkeys(g.names):
        idx = tuple(c for c, n in zip(g.cols, g.names) if n != group)
        names = tuple(n for n in g.names if n != group)
        sub = Term("generic", None, idx, names, ("N*m",) * len(idx),
                   (-np.inf,) * len(idx), (np.inf,) * len(idx))
        follows[group] = fit_rms(prob, prob.fit(S.terms + (sub,), cv=False), ref)
    main = [k for k, v in sorted(follows.items(), key=lambda kv: -kv[1]) if v >= 0.5 * sel_min]
    parts.append(f"a mismatch of {1e3 * rms:.2f} mN*m (in the fit, beyond its twins) remains "
                 "that no effect of the library explains"
                 + (f"; it follows {', '.join(R.GROUP_READING.get(k, k) for k in main)}"
                    if main else "")
                 + (f" (beside {', '.join(dominant)}, which the generic basis could stand in "
                    "for but which explain more than it adds)" if dominant else ""))
    return parts, follows


def _burst_parts(b, claims, P):
    parts = []
    rev = [e for e in b["tied"] if "reversal" in e]
    if rev:
        parts.append(f"the residual stands out at {' and '.join(rev)} ("
                     + ", ".join(f"{1e3 * claims[e][1]:.2f} mN*m" for e in rev)
                     + " over the recording; "
                     f"{sum(b['at'].get(e, 0) for e in rev)} spike blocks there): a transient "
                     "such as backlash or compliance, not in the library")
    step = "load or speed steps" in b["tied"]
    if step:
        parts.append(f"the residual stands out at load or speed steps "
                     f"({1e3 * claims['load or speed steps'][1]:.2f} mN*m over the recording): "
                     "the input torque settles more slowly than the quasi-static reducer and "
                     "the recorded speed allow (a filter or a delay of the torque channel, "
                     "compliance, a controller's transient), not in the library")
    rms = math.sqrt(sum(claims[e][1] ** 2 for e in b["tied"]))
    return parts, step, bool(rev), rms


def orders_part(orders) -> str:
    """The statement's part for the shaft orders that stand ({name: amplitude [N*m]}): one
    wording, which ``sample_orders.name_ripple`` finds again when it names the ripple."""
    return "the residual holds shaft orders: " + ", ".join(
        f"{n} ({1e3 * a:.2f} mN*m)" for n, a in orders.items())


def scan_part(lines, k_out, speed_range, claims=None) -> str:
    """The statement's part for the orders the order scan found ({name: (order, amplitude
    [N*m])}); ``k_out`` the output shaft's order of the input; ``speed_range`` the input
    speed's 5-95 % range over the scan's samples [rad/s]: where an order's frequency stays
    within the line search's resolution over it (one speed held), a fixed frequency would
    make the same line, which the recording cannot tell apart; so where ``claims`` (the
    scan's) name fixed-frequency lines the order was kept over (``one_domain``)."""
    out = []
    for n, (k, a) in lines.items():
        txt = (f"an order {k:.4g} of the input shaft ({k / k_out:.3g}x the output shaft), "
               f"{1e3 * a / math.sqrt(2):.1f} mN*m RMS (amplitude {1e3 * a:.1f} mN*m)")
        lo, hi = speed_range
        fixed = (claims or {}).get(n, {}).get("could_be_fixed_Hz")
        if fixed:
            txt += (" (or a fixed frequency of " + ", ".join(f"{f:.2f} Hz" for f in fixed)
                    + ": at the speeds held the recording cannot tell them apart)")
        elif k * (hi - lo) / (2 * math.pi) < 2 * R.ORDER_EXCLUSION_HZ:
            f = k * 0.5 * (lo + hi) / (2 * math.pi)
            txt += (f" (the recording turns at one speed: a fixed frequency of {f:.2f} Hz "
                    "would make the same line)")
        out.append(txt)
    return ("the residual holds " + ", ".join(out) + ", not in the library: a belt, a "
            "coupling or a bearing turning with a shaft")


#: [1] a listed order folded about the Nyquist frequency is left out of the scan's segments
#: where it could make a line of the reported size: where its amplitude, measured where it
#: is resolved (``order_claims``), is at least this share of ``PEAK_MIN_AMPLITUDE_NM`` (an
#: amplitude that changes with the operating point, e.g. with the load, by up to a factor
#: of two), or where it is resolved nowhere. A roller pass swept through several Nyquist
#: zones by a plan through zero folds onto every order; left out everywhere it would leave
#: nothing to scan for a ripple the order analysis measured at 0.1 mN*m
FOLDED_SHARE = 0.5


def _scan(P, r, orders, k_out, oc=None):
    """The order scan (``order_scan.order_scan``) of the sample-level residual ``r``, the
    listed ``orders`` left to the order analysis (``oc``: its {name: (amplitude, Check)}):
    ({name: (order, amplitude)}, {name: Check} with the family's ``search``, the scan or
    None)."""
    from .order_scan import order_scan
    oc = oc or {}
    folded = [k for n, k in orders.items()
              if n not in oc or oc[n][0] >= FOLDED_SHARE * PEAK_MIN_AMPLITUDE_NM]
    sc = order_scan(r, P.sig["theta_in"], P.sig["w_in"], P.dt, listed=list(orders.values()),
                    min_amplitude=PEAK_MIN_AMPLITUDE_NM, folded=folded)
    if sc is None:
        return {}, {}, None
    sc.extra["by_name"] = {f"order {x.order:.4g} ({x.order / k_out:.3g}x output)": x
                           for x in sc.lines}
    lines = {n: (x.order, x.amplitude) for n, x in sc.extra["by_name"].items()}
    checks = dict({"search": sc.search.to_json()},
                  **{n: dict(x.check.to_json(), order=x.order, amplitude_Nm=float(x.amplitude),
                             seen_at_order=x.seen_at,
                             segment_turns=sc.turns, orders_searched=list(sc.order_range))
                     for n, x in sc.extra["by_name"].items()})
    return lines, checks, sc


def one_domain(P, r, sc, scanned, scan_claims, peaks, pc, listed):
    """Each line once: an order of the scan and a fixed-frequency line touch where the
    order's frequency comes within ``residual.ORDER_EXCLUSION_HZ`` of the line in some
    segment (at one held speed everywhere; over a plan of holds at one of the holds' speeds).
    Each pair that touches is judged again each without the other's segments: the order on
    the scan's segments where it stays away from the frequency (``order_scan.Scan.
    stands_without``), the frequency with the order left out of the line search as the listed
    orders are. Where one stands without the other and the other does not, the other is made
    by it and is dropped (a fixed frequency seen at one of several held speeds is no order;
    an order lingering where the speed turns, or seen at one hold, is no fixed frequency).
    Where neither stands without the other (one speed held throughout), the one higher over
    its twins is kept and the statement says that the recording cannot tell them apart.
    Returns the scan's lines, the peaks and their checks kept, and {frequency: [orders]} of
    the fixed-frequency lines kept over orders that could make them; the scan's claims
    record the decision."""
    if not scanned or not peaks:
        return scanned, peaks, pc, {}
    ks = {n: k for n, (k, _) in scanned.items()}
    touch = [(n, f) for n in ks for f, _ in peaks if sc.reaches(ks[n], f).any()]
    if not touch:
        return scanned, peaks, pc, {}
    f_without = {}            # per order: the fixed lines that stand with it left out
    for n in dict.fromkeys(m for m, _ in touch):
        f_without[n] = [g for g, _ in R.peak_claims(
            r, P.dt, min_amplitude=PEAK_MIN_AMPLITUDE_NM, speed=P.sig["w_in"],
            orders=listed + [ks[n]])[0]]
    drop, tied = {}, []
    for n, f in touch:
        k_alone = sc.stands_without(ks[n], [f], sc.extra["by_name"][n].seen_at)
        f_alone = any(abs(g - f) <= R.ORDER_EXCLUSION_HZ for g in f_without[n])
        if f_alone and not k_alone:
            drop[n] = f
        elif k_alone and not f_alone:
            drop[f] = n
        elif not (k_alone or f_alone):
            tied.append((n, f))

    def margin(x):
        c = scan_claims[x] if x in scan_claims else pc[x].to_json()
        return c["statistic"] - c["twin_threshold"]
    amb = {}
    for n, f in tied:
        if n in drop or f in drop:
            continue
        if margin(n) >= margin(f):
            drop[f] = n
            scan_claims[n].setdefault("could_be_fixed_Hz", []).append(f)
        else:
            drop[n] = f
            amb.setdefault(f, []).append(ks[n])
    for n in ks:
        if n in drop:
            scan_claims[n]["dropped"] = f"the fixed-frequency line at {drop[n]:.2f} Hz makes it"
    scanned = {n: v for n, v in scanned.items() if n not in drop}
    peaks = [(f, a) for f, a in peaks if f not in drop]
    pc = {f: c for f, c in pc.items() if f not in drop}
    return scanned, peaks, pc, amb


def _lines(P, S, r, design, mode, rng):
    """Shaft orders (judged against their off-order twins), the order scan's lines at other
    orders, and fixed-frequency peaks (against twins of the residual's null spectrum) of the
    sample-level residual ``r``: (statement parts, library orders left, other orders, peaks,
    {order: (amplitude, Check)}, the peaks' claims for the JSON, the scan's lines {name:
    (order, amplitude)} and its claims).

    A line at an order of a held speed is a line at a fixed frequency too: it is reported
    once; ``one_domain`` decides where a line is both."""
    orders = _orders(design, mode, P.sig)
    k = P.sig["order_roller"]
    k_out = 1.0 / abs(speed_ratio(mode, design.z1))
    # the orders the library's mesh_ripple fits (model_core.effects.RIPPLE_ORDERS): 1x, 2x,
    # the roller pass, 1x and 2x of the driven shaft
    lib = ("1x", "2x", f"order {k:g} (roller pass)") + tuple(
        n for n in orders if n.startswith("output "))
    oc = order_claims(r, P.sig, orders, P.dt, rng)
    standing = {n: a for n, (a, c) in oc.items() if c is not None and c.stands}
    outside = {n: a for n, a in standing.items() if n not in lib}
    inside = {n: a for n, a in standing.items() if n in lib}
    if {"mesh_ripple"} & set(S.ids) or design.extra.has_ripple:
        inside = {}       # the library's orders, fitted: what is left is phase tracking
    parts = []
    if outside or inside:
        parts.append(orders_part({**inside, **outside}))
    peaks, search, pc = R.peak_claims(r, P.dt, min_amplitude=PEAK_MIN_AMPLITUDE_NM,
                                      speed=P.sig["w_in"], orders=list(orders.values()))
    scanned, scan_claims, sc = _scan(P, r, orders, k_out, oc)
    scanned, peaks, pc, amb = one_domain(P, r, sc, scanned, scan_claims, peaks, pc,
                                         list(orders.values()))
    if scanned:
        parts.append(scan_part(scanned, k_out, sc.speed_range, scan_claims))
    if peaks:
        parts.append("the residual spectrum peaks at " + ", ".join(
            f"{f:.2f} Hz ({1e3 * a:.2f} mN*m)" + (
                f" (or an order {', '.join(f'{k:.4g}' for k in amb[f])} of the input shaft: "
                "at the speeds held the recording cannot tell them apart)" if f in amb else "")
            for f, a in peaks)
            + " (narrow lines at fixed frequencies, beyond its twins)")
    claims = {} if search is None else dict(
        {"search": search.to_json()}, **{f"{f:.2f} Hz": c.to_json() for f, c in pc.items()})
    return parts, inside, outside, peaks, oc, claims, scanned, scan_claims, sc


def remainder(P, sel, J, rec, design, mode) -> Remainder:
    """Stage ``remainder`` on the problem ``P``, the selection ``sel`` and the twins ``J``."""
    prob, tw, S = sel.prob, J.twins, J.S
    rng = np.random.default_rng(20261127)
    mix = mixes(prob, S, sel.opts)
    present, with_g, chk, rms = structure(P, prob, S, tw, mix)
    withdrawn, dominant, doubted = [], [], False
    while present:     # withdrawn effects change what the others hold: judged again
        S, out, dom, doubt = withdraw(P, prob, S, with_g, tw, J.alpha_effect, sel.forced)
        withdrawn += out
        dominant, doubted = dom, doubted or doubt
        if not out:
            break
        mix = mixes(prob, S, sel.opts)
        present, with_g, chk, rms = structure(P, prob, S, tw, mix)
    dominant = [e for e in dominant if e in S.ids]
    claims = {"structure": chk.to_json()}
    ga = gain_alone(P, sel, S, tw, J.alpha_effect)
    parts, follows = _smooth_part(P, prob, S, with_g, present, rms, dominant, sel.min_expl)
    smooth = present
    r_raw, r, _ = _sample_residual(P, S, with_g, rec)
    lparts, inside, outside, peaks, oc, claims["peaks"], scanned, claims["order_scan"], sc = \
        _lines(P, S, r, design, mode, rng)
    claims["orders"] = {n: c.to_json() for n, (a, c) in oc.items() if c is not None}
    present = present or bool(lparts)
    parts += lparts
    # the bursts are judged beside the named effects' shape mixes too (a named low-speed
    # friction's shape between its grid's values leaves its misfit at the speed reversals)
    Sx = prob.fit(with_mixes(S.terms, mix), cv=False)
    y_after = P.y - (P.X[:, [i for t in Sx.terms for i in t.cols]] @ Sx.coef
                     if Sx.terms else 0.0)
    b, bc = burst_claims(P, y_after, sel.spikes, rng)
    claims["bursts"] = b["checks"]
    bparts, step_transient, rev, burst_rms = _burst_parts(b, bc, P)
    present = present or bool(bparts)
    parts += bparts
    if withdrawn:
        parts.append("withdrawn because the unexplained mismatch could hold them: "
                     + ", ".join(withdrawn))
    set_aside = [c for c in dict.fromkeys(sel.confounded) if c not in withdrawn] \
        if present else []
    if set_aside:
        parts.append("it could be a drift set aside because a steady function of the "
                     "operating point explains the same change over time: "
                     + ", ".join(set_aside))
    doubted = doubted and present
    if doubted:
        parts.append("the friction level stays in the fit as the model's own coefficient "
                     "but is not named: the unexplained mismatch could hold part of it")
    statement = ("; ".join(parts) + ".") if present else \
        "nothing the model and the selected effects leave is structured beyond the noise."
    lines = list({**inside, **outside}.values()) + [a for _, a in peaks] + [
        a for _, a in scanned.values()]
    total = math.sqrt((rms if smooth else 0.0) ** 2 + sum(a * a / 2 for a in lines)
                      + burst_rms ** 2)
    unexplained = {
        "present": present, "rms_Nm": total if present else 0.0, "statement": statement,
        "follows": follows, "orders": {**outside, **{n: a for n, (_, a) in scanned.items()}},
        "library_orders_left": inside,
        "peaks_Hz_Nm": peaks,
        "could_include": list(withdrawn) + set_aside + (
            ["friction_miscalibrated"] if doubted else []),
        "bursts": b, "false_alarm_rate": FALSE_ALARM, "n_twins": tw.n, "claims": claims,
        "proposed": None}
    amps = {n: (a, c) for n, (a, c) in oc.items()}
    for n in scanned:
        x = sc.extra["by_name"][n]
        amps[n] = (x.amplitude, x.check)
    return Remainder(S=S, with_g=with_g, unexplained=unexplained, withdrawn=withdrawn,
                     dominant=[(e, fit_rms(prob, prob.fit(tuple(x for x in S.terms
                                                                   if x.effect != e)), S),
                                fit_rms(prob, S, with_g)) for e in dominant],
                     friction_doubted=doubted, gain_alone=ga, step_transient=step_transient,
                     smooth=smooth, orders_all=amps, residual_raw=r_raw, claims=claims)
