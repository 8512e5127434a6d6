"""What remains: robust weights, the structure test of a residual, shaft orders and spectral
peaks, and where a mismatch sits on the operating map.

The structure test fits the residual left by the selected effects with a *generic* basis that
no library term is: smooth functions of the operating point (odd in the direction of motion,
as a loss is, and even, as a reading error is), of time, of acceleration and of the
temperature column. When that basis explains a held-out RMS above the practical threshold
with very strong evidence, physics is missing that the library does not hold, and the
diagnosis says where it sits and what it follows instead of naming the nearest library term.
"""
from __future__ import annotations

import math

import numpy as np

#: Huber's tuning constant (95 % efficiency under Gaussian noise), in robust standard deviations
HUBER_C = 1.345
#: [robust standard deviations] a block this far from the all-candidates fit is a spike: excluded
SPIKE_SIGMA = 8.0
#: [1] at most this share of blocks is excluded as spikes; beyond it the tails are structure
MAX_SPIKE_SHARE = 0.02
#: [1] a block-mean speed below this share of the recording's peak speed is standstill
MOVING_SHARE = 0.05


def robust_sigma(r) -> float:
    """Standard deviation from the median absolute deviation (1.4826 MAD)."""
    r = np.asarray(r, float)
    return float(1.4826 * np.median(np.abs(r - np.median(r)))) if len(r) else 0.0


def robust_weights(X, y, iterations=4):
    """Spike exclusion and Huber weights from the fit of every candidate column at once.

    Returns (weights, n_spikes, sigma): weight 0 for blocks beyond ``SPIKE_SIGMA`` robust
    standard deviations (when they are at most ``MAX_SPIKE_SHARE`` of the blocks), Huber
    weights min(1, c sigma / |r|) for the others; sigma is the robust scale of the residual."""
    n = len(y)
    w = np.ones(n)
    # (X * X).mean(0) without its n x k temporary: einsum sums the rows in the same order
    Xs = X / np.maximum(np.sqrt(np.einsum("ij,ij->j", X, X) / n), 1e-300)
    spikes = np.zeros(n, bool)
    sigma = 0.0
    Xw = np.empty_like(Xs)          # one buffer for the weighted columns of every iteration
    for _ in range(iterations):
        np.multiply(Xs, w[:, None], out=Xw)
        b = np.linalg.lstsq(Xw.T @ Xs, Xw.T @ y, rcond=1e-12)[0]   # normal equations
        r = y - Xs @ b
        sigma = robust_sigma(r[~spikes]) or float(np.std(r)) or 1e-12
        out = np.abs(r) > SPIKE_SIGMA * sigma
        spikes = out if out.mean() <= MAX_SPIKE_SHARE else np.zeros(n, bool)
        w = np.minimum(1.0, HUBER_C * sigma / np.maximum(np.abs(r), 1e-300))
        w[spikes] = 0.0
    return w, int(spikes.sum()), sigma


def _legendre(x, deg):
    """Legendre polynomials P1..Pdeg of x in [-1, 1]."""
    from numpy.polynomial import legendre
    return np.stack([legendre.legval(x, [0] * k + [1]) for k in range(1, deg + 1)], -1)


def generic_basis(blocks: dict) -> tuple:
    """Columns of the generic structure basis and their group names.

    Groups: ``operating point (losses)`` sign(w) P(u, v) with u = |w|/max|w|, v = |T_out|/max,
    total degree <= 3; ``operating point (reading)`` the even terms (u, v, u v, u^2, v^2);
    ``time`` Legendre P1..P5 of time; ``acceleration`` u dw/dt and v dw/dt; the library's
    exact signatures (a constant, dw/dt) are left out: the basis holds what the library does not;
    ``temperature`` (T - T0) and its square, with a temperature column."""
    w, T = blocks["w_in"], blocks["T_out"]
    u = np.abs(w) / max(np.max(np.abs(w)), 1e-12)
    v = np.abs(T) / max(np.max(np.abs(T)), 1e-12)
    s = np.sign(w)
    odd = [s * u ** i * v ** j for i in range(4) for j in range(4) if i + j <= 3]
    # no constant: a zero offset is a library term (the basis holds what the library does not)
    even = [u, v, u * v, u * u, v * v]
    t = blocks["t"]
    tn = 2 * (t - t[0]) / max(t[-1] - t[0], 1e-12) - 1
    cols, groups = [], []
    for name, arr in (("operating point (losses)", odd), ("operating point (reading)", even)):
        cols += arr
        groups += [name] * len(arr)
    P = _legendre(tn, 5)
    cols += list(P.T)
    groups += ["time"] * P.shape[1]
    # acceleration beyond a plain inertia (J dw/dt is a library term): growing with speed or
    # with load
    a = blocks["alpha"]
    cols += [a * u, a * v]
    groups += ["acceleration"] * 2
    if blocks.get("temperature") is not None:
        dT = blocks["temperature"] - blocks["temperature"][0]
        cols += [dT, dT * dT]
        groups += ["temperature"] * 2
    return np.stack(cols, -1), groups


#: [1] an order is analysed only where its frequency stays below this share of the sampling
#: rate (below Nyquist with margin: an aliased order looks like a slow signal or another order)
ORDER_NYQUIST_SHARE = 0.4


def order_amplitudes(r, sig, orders, dt, others=()) -> dict:
    """Amplitudes (N*m) of the sample-level residual ``r`` at orders of the input speed, by
    least squares on sin/cos of the shaft angle over the moving samples where the order's
    frequency stays below ``ORDER_NYQUIST_SHARE`` of the sampling rate and where no other order
    (of ``orders`` and ``others``), folded about the Nyquist frequency, comes within
    ``ORDER_EXCLUSION_HZ`` of it (at 200 Hz the roller pass of a 1000 r/min shaft folds onto
    its 2x), with the standard error of one amplitude: {name: (amplitude, se)}.

    The fit of the three columns (1, sin, cos) is solved from their 3 x 3 normal equations
    (the columns are near-orthogonal over the many turns of a recording; ``GramProblem._solve``'s
    cut-off for a singular one): the same least squares as an SVD of the sample-level columns
    to ~1e-13 relative, five times cheaper."""
    th = sig["theta_in"]
    w = np.abs(sig["w_in"])
    f1 = w / (2 * math.pi)
    fs = 1.0 / dt
    moving = w > MOVING_SHARE * max(np.max(w), 1e-12)
    del w
    ks = sorted(set(list(orders.values()) + list(others)))
    out = {}
    for name, k in orders.items():
        idx = np.flatnonzero(moving & (k * f1 < ORDER_NYQUIST_SHARE * fs))
        f = f1[idx]
        f_max = np.max(f, initial=0.0)
        for k2 in ks:
            if abs(k2 - k) > 1e-9 * k and k2 * f_max >= fs / 2:
                keep = np.abs(folded(k2 * f, fs) - k * f) > ORDER_EXCLUSION_HZ
                idx, f = idx[keep], f[keep]
                f_max = np.max(f, initial=0.0)
        del f
        n = idx.size
        if n < 100:
            continue
        # (the columns as rows of one array, filled in place: the temporaries of a 600 000
        # sample recording stay at a few of its length)
        B = np.empty((3, n))
        B[0] = 1.0
        ang = k * th[idx]
        np.sin(ang, out=B[1])
        np.cos(ang, out=B[2])
        del ang
        rr = r[idx]
        coef = np.linalg.lstsq(B @ B.T, B @ rr, rcond=1e-12)[0]
        e = coef @ B
        del B
        np.subtract(rr, e, out=e)
        sigma = float(np.std(e))
        out[name] = (math.hypot(coef[1], coef[2]), sigma * math.sqrt(2.0 / n))
    return out


def folded(f, fs):
    """Frequencies ``f`` [Hz] as they appear after sampling at ``fs`` [Hz] (folded about the
    Nyquist frequency)."""
    return np.abs((np.asarray(f, float) + fs / 2) % fs - fs / 2)


#: [1] a fixed-frequency peak stands in at least this share of the recording's quarters (a shaft
#: order held at one speed appears in one quarter only)
PEAK_PERSISTENCE = 0.75
#: [bins] a narrow peak also stands ``factor`` times above the spectrum on each side of it, in
#: the three bins from this many bins away: a sinusoid's power under the Hann
#: window stays within about 1.5 bins of it (at 1.5 bins 3 % of its peak, at 2.5 bins 0.06 %),
#: while the edge of a broad rise (the low-frequency plateau of coloured noise, a resonance's
#: skirt) stands over a median of the falling side only
PEAK_FLANK_BINS = 2
#: [Hz] a spectral peak this close to a shaft order of the input speed is left to the order
#: analysis (the Welch bins are 0.5 Hz wide; a held speed wanders by a few r/min)
ORDER_EXCLUSION_HZ = 1.0


def _order_coverage(speed, orders, fs, freqs, n_seg, nper):
    """Which frequency bins ``freqs`` (Hz) a shaft order reaches within each of ``n_seg``
    half-overlapping segments of ``nper`` samples of the sample-level input speed (rad/s):
    boolean (n_freq, n_seg), widened by ``ORDER_EXCLUSION_HZ`` (the orders folded about the
    Nyquist frequency). A segment is two half-segments; within a half-segment the speed moves
    continuously (a motor's speed has no jumps), so an order reaches every frequency between
    its values at the half's lowest and highest speed; a half-segment with a speed that is not
    finite is taken to reach every bin. (Intervals, one per order and half-segment, marked in a
    difference array: no per-sample temporaries.)"""
    df = freqs[1] - freqs[0]
    nf = freqs.size
    h = nper - nper // 2
    n_half = n_seg + 1
    w = np.abs(np.asarray(speed, float))[:n_half * h]
    if w.size < n_half * h:
        w = np.concatenate([w, np.full(n_half * h - w.size, w[-1] if w.size else 0.0)])
    w = w.reshape(n_half, h)
    bad = ~np.isfinite(w).all(1)
    w = np.where(np.isfinite(w), w, 0.0)
    lo_w, hi_w = w.min(1), w.max(1)
    fn = fs / 2
    pad = ORDER_EXCLUSION_HZ
    marks = np.zeros((n_half, nf + 1), np.int32)
    for k in np.abs(np.asarray(orders, float)):
        a_all, b_all = k * lo_w / (2 * math.pi), k * hi_w / (2 * math.pi)
        for i in range(n_half):
            a, b = a_all[i], b_all[i]
            for z in range(int(a // fn), int(b // fn) + 1):
                lo, hi = max(a, z * fn) - z * fn, min(b, (z + 1) * fn) - z * fn
                if z % 2:                       # an odd Nyquist zone folds back
                    lo, hi = fn - hi, fn - lo
                i0 = max(int(math.floor((lo - pad) / df + 0.5)), 0)
                i1 = min(int(math.floor((hi + pad) / df + 0.5)), nf - 1)
                if i1 >= i0:
                    marks[i, i0] += 1
                    marks[i, i1 + 1] -= 1
    half = np.cumsum(marks, 1)[:, :nf] > 0
    half[bad] = True
    return (half[:-1] | half[1:]).T


def _level(S, cols, width):
    """Mean spectrum over the segments ``cols`` of the spectrogram ``S`` and its local level:
    the larger of the median over ``width`` bins (+-5 Hz) and the medians of the two flanks
    (NaN where the lower flank would reach the DC bin)."""
    from scipy.ndimage import median_filter
    P = S[:, cols].mean(1)
    base = median_filter(P, size=width, mode="nearest")
    m3 = np.median(np.lib.stride_tricks.sliding_window_view(P, 3), axis=-1)  # P[j:j+3]
    flank = np.full((2, P.size), np.nan)
    k = PEAK_FLANK_BINS
    i = np.arange(P.size)
    low_ok = i - k - 2 >= 1
    flank[0, low_ok] = m3[i[low_ok] - k - 2]
    high_ok = i + k + 2 <= P.size - 1
    flank[1, high_ok] = m3[i[high_ok] + k]
    return P, np.where(low_ok, np.fmax(base, np.fmax(flank[0], flank[1])), np.nan)


def hann_spectrogram(x, fs, nper):
    """(frequencies [Hz], power spectral density [x^2/Hz] of each segment (n_freq, n_seg)) of
    ``x`` in Hann-windowed segments of ``nper`` samples, half overlapping, each segment's mean
    removed: ``scipy.signal.spectrogram(x, fs, window="hann", nperseg=nper,
    noverlap=nper // 2, detrend="constant", scaling="density")`` written out with its own
    operations (the same numbers; scipy.signal's import costs more than the spectrogram)."""
    from scipy import fft as sp_fft
    fac = np.linspace(-np.pi, np.pi, nper + 1)      # the periodic Hann window, as scipy's
    win = np.zeros(nper + 1)
    for k, a in enumerate((0.5, 0.5)):
        win += a * np.cos(k * fac)
    win = win[:-1]
    scale = 1.0 / (fs * (win * win).sum())
    seg = np.lib.stride_tricks.sliding_window_view(x, nper)[::nper - nper // 2]
    seg = win * (seg - np.mean(seg, -1, keepdims=True))
    P = sp_fft.rfft(seg, n=nper)
    del seg
    P = np.conjugate(P) * P
    P *= scale
    if nper % 2:
        P[..., 1:] *= 2
    else:
        P[..., 1:-1] *= 2                    # (the Nyquist bin is not paired)
    return sp_fft.rfftfreq(nper, 1 / fs), np.moveaxis(P.real, -1, -2)


def spectral_peaks(r, dt, factor=4.0, min_amplitude=1e-3, f_min=2.5, speed=None,
                   orders=()) -> list:
    """Narrow peaks of the residual's spectrum at fixed frequencies (Welch: 2 s Hann segments,
    half overlapping): bins standing ``factor`` times above the local median level (+-5 Hz)
    over the recording, with an amplitude of at least ``min_amplitude`` N*m, that also stand
    at least half as high in ``PEAK_PERSISTENCE`` of the recording's quarters (a fixed
    frequency persists; a shaft order moves with the speed). Shaft orders are left to the order
    analysis: with ``speed`` (sample-level input speed, rad/s) and ``orders`` (orders of it), a
    peak of the whole recording's spectrum is judged again on the segments in which none of
    these orders comes within ``ORDER_EXCLUSION_HZ`` of it (its height over the local level of
    their mean spectrum, its persistence over the quarters and its amplitude, all from that one
    set of segments). So a fixed frequency is found where an order at one held speed shares it
    (50 Hz mains and the fifth order at 600 r/min), from the segments at the other speeds, and
    a peak of the orders checked is not taken for one.

    The local level of a bin is the larger of the median over +-5 Hz and the medians of its two
    flanks (the three bins from ``PEAK_FLANK_BINS`` away on each side): a peak must be narrow.
    A bin whose lower flank would reach the DC bin (below 2.5 Hz with 2 s segments) is not
    judged: a line there cannot be told from a low-frequency rise at this resolution.

    Returns [(frequency Hz, amplitude N*m)], largest first."""
    r = np.asarray(r, float)
    orders = list(orders)
    n = len(r)
    fs = 1.0 / dt
    nper = int(round(2.0 * fs))
    if n < 8 * nper or nper < 64:
        return []
    if speed is not None and len(speed) < n:
        raise ValueError(f"speed: {len(speed)} samples for a residual of {n}")
    f, S = hann_spectrogram(r - np.mean(r), fs, nper)
    df = f[1] - f[0]
    n_seg = S.shape[1]
    width = max(3, int(round(10.0 / df)) | 1)
    # the quarter of each segment, by its centre
    centres = np.arange(n_seg) * (nper - nper // 2) + nper / 2
    quarter_of = np.minimum(centres * 4 // n, 3).astype(int)
    judged = speed is not None and len(orders) > 0
    usable = _order_coverage(speed, orders, fs, f, n_seg, nper) if judged else None

    def level(cols):
        return _level(S, cols, width)

    def stands(P, base, i, share):
        return bool(np.max(P[i - 1:i + 2]) > share * factor * base[i])
    P_all, base_all = level(slice(None))
    spectra = {}   # the spectra of one set of segments (peaks often share it)
    peaks = []
    for i in range(1, len(f) - 1):
        if f[i] < f_min or not (P_all[i] >= P_all[i - 1] and P_all[i] >= P_all[i + 1]):
            continue
        if not P_all[i] > factor * base_all[i]:
            continue
        cols = np.flatnonzero(~usable[i - 1:i + 2].any(0)) if judged else np.arange(n_seg)
        if cols.size == 0:
            continue
        key = cols.tobytes()
        if key not in spectra:
            by_quarter = [cols[quarter_of[cols] == q] for q in range(4)]
            spectra[key] = (level(cols), [level(c) if c.size else None for c in by_quarter])
        (P, base), quarters = spectra[key]
        if not stands(P, base, i, 1.0):
            continue
        seen = np.mean([q is not None and stands(q[0], q[1], i, 0.5) for q in quarters])
        # amplitude of a sinusoid from the power in the peak's bins: with a Hann window a
        # sinusoid at a bin's centre puts 2/3 of its power A^2/2 in that bin and 1/6 in each
        # neighbour (the density's peak is A^2/2 over the window's noise bandwidth, 1.5 bins)
        power = (P[i - 1:i + 2].sum() - 3 * base[i]) * df
        amp = math.sqrt(max(2 * power, 0.0))
        if amp >= min_amplitude and seen >= PEAK_PERSISTENCE:
            peaks.append((float(f[i]), amp))
    return sorted(peaks, key=lambda p: -p[1])[:5]


#: [s] a residual burst within this time of an event (a reversal, a step) belongs to it: the
#: transients of backlash and compliance last tens of milliseconds
EVENT_WINDOW = 0.1
#: [1] share of the peak speed or torque below which a sign is not judged (noise about zero)
SIGN_SHARE = 0.02
#: binomial tail probability below which bursts are tied to events, not chance
BURST_P = 1e-6
#: [1] share of the reversals of one kind that must carry a burst before the bursts are called
#: a transient of the drive (lost motion, compliance): such a transient is taken up at every
#: reversal; bursts at a part of them are the transients of a quasi-static replay at a hard
#: reversal (the model's own inertia and losses through a fast speed change), not missing physics
REVERSAL_SHARE = 0.75


def _near(t, events, window):
    if not len(events):
        return np.zeros(len(t), bool)
    i = np.searchsorted(events, t)
    lo = np.abs(t - events[np.clip(i - 1, 0, len(events) - 1)])
    hi = np.abs(events[np.clip(i, 0, len(events) - 1)] - t)
    return np.minimum(lo, hi) <= window


def _reversals(t, x):
    """Times where x changes sign (ignoring values within SIGN_SHARE of its peak of zero)."""
    big = np.abs(x) > SIGN_SHARE * max(np.max(np.abs(x)), 1e-300)
    tt, sx = t[big], np.sign(x[big])
    k = np.flatnonzero(sx[1:] != sx[:-1])
    return 0.5 * (tt[k] + tt[k + 1])


def _steps(t, x, factor=20.0):
    """Times of steps: block-to-block changes ``factor`` times the median change."""
    d = np.abs(np.diff(x))
    ref = np.median(d) or 1e-300
    return t[1:][d > factor * ref]


def burst_events(t, w, T_out) -> dict:
    """The events residual bursts are judged against, {kind: sorted times}: speed reversals,
    torque reversals, steps of load or speed."""
    return {"speed reversals": np.sort(_reversals(t, w)),
            "torque reversals": np.sort(_reversals(t, T_out)),
            "load or speed steps": np.union1d(_steps(t, T_out), _steps(t, w))}


def near_events(t, w, T_out, kinds) -> np.ndarray:
    """Blocks (times ``t``) within EVENT_WINDOW of an event of the given ``kinds``."""
    ev = burst_events(t, w, T_out)
    times = np.sort(np.concatenate([ev[k] for k in kinds])) if kinds else np.zeros(0)
    return _near(t, times, EVENT_WINDOW)


def bursts(t, spikes, w, T_out) -> dict:
    """Where the excluded spike blocks sit: at speed reversals, at torque reversals, at steps of
    load or speed, or elsewhere; ``tied``: the events whose bursts are too many for chance
    (binomial tail below ``BURST_P``) and, for reversals, that sit at ``REVERSAL_SHARE`` of
    them at least; ``events_with_burst``: {kind: (events with a burst, events)};
    ``burst_blocks``: {kind: mean length of its bursts, in blocks (runs of consecutive spike
    blocks)}."""
    n = int(spikes.sum())
    out = {"count": n, "at": {}, "tied": []}
    if n == 0:
        return out
    left = spikes.copy()
    out["events_with_burst"] = {}
    for name, events in burst_events(t, w, T_out).items():
        near = _near(t, events, EVENT_WINDOW)
        k = int((left & near).sum())
        out["at"][name] = k
        # mean length of the runs of consecutive spike blocks (a burst's duration, in blocks)
        idx = np.flatnonzero(left & near)
        runs = 1 + int(np.count_nonzero(np.diff(idx) > 1)) if idx.size else 0
        out.setdefault("burst_blocks", {})[name] = k / runs if runs else 0.0
        # how many of the events carry a burst
        hit = np.zeros(len(events), bool)
        for tb in t[left & near]:
            hit |= np.abs(events - tb) <= EVENT_WINDOW
        out["events_with_burst"][name] = (int(hit.sum()), len(events))
        every = "reversal" not in name or hit.sum() >= REVERSAL_SHARE * len(events)
        if k >= 3 and every:
            from scipy.special import bdtrc      # binomial P(X >= k): scipy.stats.binom.sf
            p0 = max(float(near.mean()), 1e-12)
            if bdtrc(k - 1, n, p0) < BURST_P:
                out["tied"].append(name)
        left &= ~near
    out["at"]["elsewhere"] = int(left.sum())
    return out


def locate(t, r, w, T_out, T_in, alpha, temperature=None) -> dict:
    """Where the residual (measured - model input torque, N*m, block means) concentrates and
    what it follows; a plain statement with the numbers behind it."""
    aw, aT = np.abs(w), np.abs(T_out)
    p = np.abs(T_in * w)

    def corr(a, b):
        if len(a) < 3 or np.std(a) == 0 or np.std(b) == 0:
            return 0.0
        return float(np.corrcoef(a, b)[0, 1])
    moving = aw > MOVING_SHARE * max(aw.max(), 1e-12)
    if moving.sum() < 10:
        return {"statement": "the recording hardly moves: no operating region to locate."}
    rs = np.where(w >= 0, r, -r)       # residual in the sense of the motion (a loss > 0)
    c_speed = corr(rs[moving], aw[moving])
    c_load = corr(rs[moving], aT[moving])
    c_time = corr(r, t)
    c_acc = corr(r, alpha)
    c_temp = corr(r, temperature) if temperature is not None else 0.0
    fwd, rev = moving & (w > 0), moving & (w < 0)
    mean_fwd = float(np.mean(r[fwd])) if fwd.any() else 0.0
    mean_rev = float(np.mean(r[rev])) if rev.any() else 0.0
    qs, qt = np.quantile(aw[moving], [1 / 3, 2 / 3]), np.quantile(aT[moving], [1 / 3, 2 / 3])
    cells = {}
    for i, sl in enumerate(("low", "mid", "high")):
        for j, tl in enumerate(("low", "mid", "high")):
            sel = moving & (np.digitize(aw, qs) == i) & (np.digitize(aT, qt) == j)
            if sel.sum() > 5:
                cells[f"speed {sl}, load {tl}"] = float(np.mean(rs[sel]))
    worst = max(cells, key=lambda c: abs(cells[c])) if cells else ""
    light, heavy = [], []
    for i in range(3):
        sp = moving & (np.digitize(aw, qs) == i)
        if sp.sum() > 10:
            lo_t, hi_t = np.quantile(aT[sp], [1 / 3, 2 / 3])
            for sel, acc in ((sp & (aT <= lo_t), light), (sp & (aT >= hi_t), heavy)):
                if sel.any():
                    acc.append(np.mean(rs[sel]) / max(np.mean(np.abs(T_in[sel])), 1e-12))
    rel_light = float(np.mean(light)) if light else float("nan")
    rel_heavy = float(np.mean(heavy)) if heavy else float("nan")
    low_p = moving & (p < np.quantile(p[moving], 0.33))
    high_p = moving & (p > np.quantile(p[moving], 0.67))
    rel_low = float(np.mean(rs[low_p]) / max(np.mean(np.abs(T_in[low_p])), 1e-12)) \
        if low_p.any() else float("nan")
    rel_high = float(np.mean(rs[high_p]) / max(np.mean(np.abs(T_in[high_p])), 1e-12)) \
        if high_p.any() else float("nan")
    parts = []
    under = np.mean(rs[moving]) > 0
    parts.append(f"the model {'under' if under else 'over'}-predicts the input torque, most "
                 f"at {worst}" if worst else "no operating region stands out")
    parts.append(f"relative to the input torque the mismatch is {100 * rel_low:+.1f} % at low "
                 f"and {100 * rel_high:+.1f} % at high input power")
    if math.isfinite(rel_light) and abs(rel_light) > 1.5 * abs(rel_heavy):
        parts.append(f"at a given speed it is larger at light load ({100 * rel_light:+.1f} % "
                     f"against {100 * rel_heavy:+.1f} % at heavy load)")
    parts.append(("the missing torque grows with speed" if c_speed > 0.3 else
                  "it falls with speed" if c_speed < -0.3 else "it does not follow speed")
                 + (", scales with load" if abs(c_load) > 0.3 else ", does not scale with load"))
    if abs(c_time) > 0.3:
        parts.append("it drifts with time")
    if abs(c_temp) > 0.3:
        parts.append("it follows the temperature")
    if abs(c_acc) > 0.3:
        parts.append("it follows acceleration")
    if fwd.any() and rev.any():
        parts.append("it keeps its sign when the rotation reverses (like an offset)"
                     if mean_fwd * mean_rev > 0 else
                     "it flips with the rotation (like friction)")
    return {"statement": "; ".join(parts) + ".",
            "corr_speed": c_speed, "corr_load": c_load, "corr_time": c_time,
            "corr_acceleration": c_acc, "corr_temperature": c_temp,
            "mean_forward_Nm": mean_fwd,
            "mean_reverse_Nm": mean_rev, "by_region_Nm": cells, "worst_region": worst,
            "relative_low_power": rel_low, "relative_high_power": rel_high,
            "relative_light_load_same_speed": rel_light,
            "relative_heavy_load_same_speed": rel_heavy}


def ljung_box_p(x, lags=20):
    """p-value of the Ljung-Box test that x is white (small p: structure left)."""
    from scipy.special import chdtrc     # the chi-square tail: scipy.stats.chi2.sf
    x = np.asarray(x, float) - np.mean(x)
    n = len(x)
    denom = np.dot(x, x)
    if denom == 0 or n <= lags + 1:
        return 1.0
    q = 0.0
    for k in range(1, lags + 1):
        r = np.dot(x[k:], x[:-k]) / denom
        q += r * r / (n - k)
    return float(chdtrc(lags, n * (n + 2) * q))
