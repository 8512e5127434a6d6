"""What remains: robust weights, the structure test of a residual, shaft orders and spectral
peaks, and where a mismatch sits on the operating map.

The structure test fits the residual left by the selected effects with a *generic* basis that
no library term is: smooth functions of the operating point (odd in the direction of motion,
as a loss is, and even, as a reading error is), of time, of acceleration and of the
temperature column, the direction of the last load change (a play operator's state: a
hysteresis) and the acceleration against the motion (a loss while the speed changes). When
that basis explains a held-out RMS above the practical threshold with very strong evidence,
physics is missing that the library does not hold, and the diagnosis says where it sits and
what it follows instead of naming the nearest library term.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .twins import FALSE_ALARM, N_TWINS, Check, gumbel_tail

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


def robust_weights(X, y, iterations=4, spare=None):
    """Spike exclusion and Huber weights from the fit of every candidate column at once.

    Returns (weights, n_spikes, sigma): weight 0 for blocks beyond ``SPIKE_SIGMA`` robust
    standard deviations (when they are at most ``MAX_SPIKE_SHARE`` of the blocks), Huber
    weights min(1, c sigma / |r|) for the others; sigma is the robust scale of the residual.
    ``spare``: a list its work array of ``X``'s shape is appended to (free for the caller's
    next array of that shape: a 600 000-sample recording's matrix is 68 MB, and fresh memory
    costs the kernel's zeroing of its pages).

    Each iteration's weighted normal equations are the unweighted ones (formed once, as a
    symmetric product) less the blocks whose weight is below 1, (1 - w) x x^T: the Huber
    weights leave about four blocks in five at 1 under Gaussian noise, so an iteration forms
    the products of the others only. The same equations summed in another order: a
    selection's candidate columns are nearly collinear (a refined Stribeck friction's widths),
    the normal equations' small singular values are cut at ``rcond`` 1e-12, and the weights
    move by up to ~1e-5 (a 600 000-sample four-quadrant recording) where the order of
    summation changes, as they do between BLAS builds."""
    n = len(y)
    w = np.ones(n)
    # (X * X).mean(0) without its n x k temporary: einsum sums the rows in the same order
    Xs = X / np.maximum(np.sqrt(np.einsum("ij,ij->j", X, X) / n), 1e-300)
    spikes = np.zeros(n, bool)
    sigma = 0.0
    G1, c1 = Xs.T @ Xs, Xs.T @ y          # (numpy forms X^T X as a symmetric product)
    from .selection import lstsq
    for _ in range(iterations):
        down = np.flatnonzero(w < 1.0)
        if len(down):
            s = 1.0 - w[down]
            Xd = Xs[down]
            c = c1 - Xd.T @ (s * y[down])
            Xd *= np.sqrt(s)[:, None]
            G = G1 - Xd.T @ Xd
            del Xd
        else:
            G, c = G1, c1
        b = lstsq(G, c)                   # normal equations
        r = y - Xs @ b
        sigma = robust_sigma(r[~spikes]) or float(np.std(r)) or 1e-12
        out = np.abs(r) > SPIKE_SIGMA * sigma
        spikes = out if out.mean() <= MAX_SPIKE_SHARE else np.zeros(n, bool)
        w = np.minimum(1.0, HUBER_C * sigma / np.maximum(np.abs(r), 1e-300))
        w[spikes] = 0.0
    if spare is not None:
        spare.append(Xs)
    return w, int(spikes.sum()), sigma


def _legendre(x, deg):
    """Legendre polynomials P1..Pdeg of x in [-1, 1]."""
    from numpy.polynomial import legendre
    return np.stack([legendre.legval(x, [0] * k + [1]) for k in range(1, deg + 1)], -1)


#: [1] the load-change direction's play has a half width of this share of the range of the
#: output torque's block means (its 0.5 to 99.5 percentiles): a reversal of the load by a
#: tenth of the range switches the state, a smaller one does not. An assumption: a hysteresis
#: loop (a transducer's, a pre-sliding friction's) moves from one branch to the other over a
#: part of the span its load sweeps, and the measured torque's own wander must not switch it:
#: the output torque's noise enters the residual through the model's input torque (errors in
#: the variable), so a state that follows the noise correlates with the residual on a clean
#: recording (measured with a play of 5 noise standard deviations, from second differences,
#: on batch 4's clean pink and AR(1) recordings: 0.5-0.7 mN*m "structure", the state
#: switching on up to 11 815 of 52 500 blocks; at this share 4-6 times on the same recording,
#: the plan's own load reversals)
PLAY_RANGE_SHARE = 0.05
#: [robust standard deviations of the block means' noise] and at least this many standard
#: deviations of the output torque's block-mean noise (about its 1 s running median: a
#: recording whose load only wanders, held all along, has no range but noise): within a hold
#: of N blocks white noise spans about 2 sqrt(2 ln N) standard deviations (7.4 at 3000
#: blocks, a 30 s hold of 10 ms blocks), so a hold keeps its state, as a hysteresis does. The
#: same rule sets the acceleration at which a loss while the speed changes is fully on
PLAY_NOISE_SIGMAS = 5.0
#: [1] both widths are at least this share of the largest block mean (a noise-free or
#: quantised channel, whose block means may not differ at all in a hold, would otherwise
#: switch on rounding)
PLAY_MIN_SHARE = 1e-3
#: [s] the running median the noise of the block means is measured about
NOISE_MEDIAN_S = 1.0

#: what each group of the generic basis stands for, as the remainder's statement reads it
#: (the group's name is the key of ``unexplained.follows``)
GROUP_READING = {
    "operating point (losses)": "the operating point (a loss: odd in the direction of motion)",
    "operating point (reading)": "the operating point (a reading error: even in the direction "
                                 "of motion)",
    "time": "time",
    "acceleration": "the acceleration, growing with speed or load",
    "temperature": "the temperature",
    "load-change direction": "the direction of the last load change (a hysteresis of the "
                             "torque reading, pre-sliding friction or lost motion; not in the "
                             "library)",
    "acceleration against the motion": "the speed's changes, against the motion (a loss "
                                       "while the speed changes, growing with the "
                                       "acceleration or at a slip level: a dynamic mesh load, "
                                       "a slipping coupling, a controller's current limit; not "
                                       "in the library)",
}


def play_state(x, r) -> np.ndarray:
    """State s in [-1, 1] of a play (backlash) operator of half width ``r`` driven by ``x``:
    the play's output p follows x only where x leaves [p - r, p + r] (Krasnosel'skii and
    Pokrovskii 1989; the elementary hysteron of the Prandtl-Ishlinskii model), and
    s = (x - p) / r: +1 after x rose by 2 r, -1 after it fell by 2 r; while x is held it keeps
    its branch (a wander within the play moves s linearly, as the hysteron's output does, and
    switches nothing). Starts at p = x[0] (s = 0: no direction known yet)."""
    x = np.asarray(x, float)
    if r <= 0 or not len(x):
        return np.zeros(len(x))
    out = np.empty(len(x))
    p = float(x[0])
    for i, xi in enumerate(x.tolist()):     # (a recurrence: a loop over the block means)
        if xi > p + r:
            p = xi - r
        elif xi < p - r:
            p = xi + r
        out[i] = (xi - p) / r
    return out


def noise_width(x, dt_block, sigmas=PLAY_NOISE_SIGMAS, min_share=PLAY_MIN_SHARE) -> float:
    """``sigmas`` robust standard deviations of the noise of the block means ``x`` (every
    ``dt_block`` s) about their running median over ``NOISE_MEDIAN_S`` (a ramp or a step of
    the plan stays in the median; a coloured noise's wander faster than a second does not),
    and at least ``min_share`` of the largest |x|: a change of ``x`` its noise does not make
    (the acceleration, in rad/s^2, at which a loss while the speed changes is taken as fully
    on; with ``PLAY_RANGE_SHARE`` the load-change direction's play)."""
    from scipy.ndimage import median_filter
    x = np.asarray(x, float)
    k = max(3, int(round(NOISE_MEDIAN_S / max(dt_block, 1e-12))) | 1)
    sigma = robust_sigma(x - median_filter(x, k, mode="nearest")) if len(x) > 2 else 0.0
    return max(sigmas * sigma, min_share * float(np.max(np.abs(x), initial=0.0)))


def play_width(T, dt_block) -> float:
    """[N*m] the half width of the load-change direction's play on the output torque's block
    means ``T``: ``PLAY_RANGE_SHARE`` of their range (0.5 to 99.5 percentiles), at least
    ``noise_width``."""
    T = np.asarray(T, float)
    span = float(np.subtract(*np.percentile(T, [99.5, 0.5]))) if len(T) else 0.0
    return max(PLAY_RANGE_SHARE * span, noise_width(T, dt_block))


def generic_basis(blocks: dict) -> tuple:
    """Columns of the generic structure basis and their group names (``GROUP_READING``).

    Groups: ``operating point (losses)`` sign(w) P(u, v) with u = |w|/max|w|, v = |T_out|/max,
    total degree <= 3; ``operating point (reading)`` the even terms (u, v, u v, u^2, v^2);
    ``time`` Legendre P1..P5 of time; ``acceleration`` u dw/dt and v dw/dt; ``temperature``
    (T - T0) and its square, with a temperature column; ``load-change direction`` s and s v,
    s the state of a play operator (``play_state``, half width ``play_width``) on the output
    torque's block means: a hysteresis of the reading or a loss that remembers whether the
    load last rose or fell; ``acceleration against the motion`` sign(w) |dw/dt|,
    sign(w) sat(|dw/dt|) and sat(dw/dt) (sat: clipped to +-1 at ``noise_width`` of the
    acceleration): a loss while the speed changes, growing with it or at a slip level, and
    different speeding up and slowing down. The library's
    exact signatures (a constant, dw/dt) are left out: the basis holds what the library does
    not."""
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
    # the direction of the last load change: a play on the output torque (its state, and the
    # state times the load: a hysteresis in per cent of the reading or of the load)
    dtb = float(np.median(np.diff(t))) if len(t) > 1 else 1.0
    h = play_state(T, play_width(T, dtb))
    cols += [h, h * v]
    groups += ["load-change direction"] * 2
    # a loss against the motion while the speed changes (inertia J dw/dt is linear in the
    # acceleration; these are not): growing with |dw/dt| (even in it, odd in the direction of
    # motion), at a level once the speed changes beyond its noise (a slip torque, a current
    # limit: the acceleration saturated at ``noise_width``), and that level's part that
    # differs between speeding up and slowing down (odd in the acceleration, saturated)
    a0 = noise_width(a, dtb)
    sat = np.clip(a / a0, -1.0, 1.0) if a0 > 0 else np.zeros(len(a))
    cols += [s * np.abs(a), s * np.abs(sat), sat]
    groups += ["acceleration against the motion"] * 3
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


#: [s] Welch segments of the peak analysis (Hann window, half overlapping): 0.5 Hz bins. A
#: sinusoid's power stays within the Hann main lobe, +-1 Hz (+-2 bins): the resolution that
#: "narrow" refers to. Long enough to tell 50 Hz pick-up from an order 1 Hz away, short enough
#: that a held speed wandering by a few r/min keeps an order within its excluded band
PEAK_SEGMENT_S = 2.0
#: [bins] a narrow line lies within the main lobe; the null spectrum at a bin (no narrow line
#: there) is at least the spectrum on each side of it, in the three bins from this many bins
#: away: a sinusoid's power under the Hann window stays within about 1.5 bins of it (at 1.5
#: bins 3 % of its peak, at 2.5 bins 0.06 %), while the edge of a broad rise (the
#: low-frequency plateau of coloured noise, a resonance wider than the main lobe) stands over a
#: median of its falling side only
PEAK_FLANK_BINS = 2
#: [Hz] the null spectrum's running median spans this width (21 bins, five main lobes): a
#: line fills 3 of its bins, and the median ignores up to 10 (three lines within 10 Hz)
PEAK_LEVEL_HZ = 10.0
#: [Hz] each segment's own noise level is measured in bands this wide (128 bins of 2 s
#: segments: the median of 128 bins gives it to about 15 %, and one line changes it by less
#: than 1 %): a residual whose noise changes over the recording (transients at reversals,
#: noise that grows with load) has each segment weighed by its own level
PEAK_BAND_HZ = 64.0
#: [1] squared correlation of the Hann periodograms of two half-overlapping segments (Welch
#: 1967; Percival & Walden 1993, eq. 292b: c(1/2) = 1/6): Welch's equivalent degrees of
#: freedom
HANN_OVERLAP_RHO2 = 1.0 / 36.0
#: [1] correlation of the Hann periodogram at adjacent bins of one segment: the windowed DFT
#: is 0.5 Y_k - 0.25 (Y_k-1 + Y_k+1) of independent Y, a complex correlation of -2/3
HANN_ADJACENT_RHO2 = 4.0 / 9.0
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


def _med3(a, b, c):
    """Elementwise median of three arrays."""
    return np.maximum(np.minimum(a, b), np.minimum(np.maximum(a, b), c))


def _running_median(P, width):
    """Running median over ``width`` (odd) bins of the last axis of ``P``, the ends padded with
    the edge values; taken every ``width // 4`` bins and interpolated linearly between (the
    level is smooth over its window; a quarter of the cost of the full filter)."""
    n = P.shape[-1]
    h = width // 2
    step = max(1, width // 4)
    pad = np.concatenate([np.repeat(P[..., :1], h, -1), P, np.repeat(P[..., -1:], h, -1)], -1)
    c = np.arange(0, n, step)
    if c[-1] != n - 1:
        c = np.append(c, n - 1)
    win = np.lib.stride_tricks.sliding_window_view(pad, width, axis=-1)[..., c, :]
    m = np.partition(win, h, -1)[..., h] if width % 2 else np.median(win, -1)
    if c.size == 1:
        return np.repeat(m, n, -1)
    i = np.arange(n)
    j = np.minimum(np.searchsorted(c, i, "right") - 1, c.size - 2)
    frac = (i - c[j]) / (c[j + 1] - c[j])
    return m[..., j] * (1 - frac) + m[..., j + 1] * frac


def _line_free_level(P, width):
    """The null spectrum (no narrow line) of the spectra ``P`` (last axis: frequency bins): at
    each bin the larger of the running median over ``width`` bins and the medians of its two
    flanks (the three bins from ``PEAK_FLANK_BINS`` away on each side). NaN where a flank
    would reach the DC or the Nyquist bin (real-valued, of half the degrees of freedom): a
    line there cannot be told from the rise of the spectrum's edge (measured: lines of
    0.1 mN*m 2 bins below the Nyquist frequency of three independent recordings stood beyond
    their twins when the upper flank was not required)."""
    base = _running_median(P, width)
    nf = P.shape[-1]
    k = PEAK_FLANK_BINS
    m3 = _med3(P[..., :-2], P[..., 1:-1], P[..., 2:])       # median of P[j:j+3] at j
    i = np.arange(nf)
    flank = np.full((2,) + P.shape, np.nan)
    low_ok = i - k - 2 >= 1
    flank[0][..., low_ok] = m3[..., i[low_ok] - k - 2]
    high_ok = i + k + 2 <= nf - 2
    flank[1][..., high_ok] = m3[..., i[high_ok] + k]
    return np.where(low_ok & high_ok, np.fmax(base, np.fmax(flank[0], flank[1])), np.nan)


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


def _level(S, cols, width):
    """Mean spectrum over the segments ``cols`` of the spectrogram ``S`` and its line-free
    level (``_line_free_level``)."""
    P = S[:, cols].mean(1)
    return P, _line_free_level(P, width)


def _normal_score(Z, h):
    """Wilson-Hilferty normal score of ``Z``, a mean-one Gamma variable of shape ``h``: the
    heights of bins averaged over different numbers of segments made comparable."""
    v = 1.0 / (9.0 * h)
    return (np.cbrt(Z) - (1.0 - v)) / np.sqrt(v)


def _ratios(Q, level):
    """The mean of ``Q`` over each bin and its two neighbours (where a line's power lies, 98 %
    of it wherever the line sits between bins) over the level (bins 1 .. n-2)."""
    return (Q[..., :-2] + Q[..., 1:-1] + Q[..., 2:]) / (3.0 * level[..., 1:-1])


def _heights(Q, level, h3):
    """Normal scores of ``_ratios``: the heights compared across bins and with the twins."""
    return _normal_score(_ratios(Q, level), h3[1:-1])


def _twin_heights(Lq, h, h3, ok, width, n_twins, rng):
    """Per twin, the largest height (``_heights``) over the bins ``ok`` of a spectrum whose
    expected level is ``Lq``: the Welch spectrum of Gaussian noise without a line, drawn
    directly (a mean of ``h`` periodograms is a Gamma variable of shape ``h``; adjacent bins
    share ``HANN_ADJACENT_RHO2`` of it, as the Hann window makes them), then the same level
    and heights as the recording's."""
    e = HANN_ADJACENT_RHO2 * np.minimum(h[:-1], h[1:])     # shape shared by bins i, i+1
    own = h.copy()
    own[1:] -= e
    own[:-1] -= e
    T = rng.standard_gamma(own, size=(n_twins, h.size))
    sh = rng.standard_gamma(e, size=(n_twins, e.size))
    T[:, 1:] += sh
    T[:, :-1] += sh
    T *= Lq / h
    z = _heights(T, _line_free_level(T, width), h3)
    return np.max(np.where(ok[1:-1], z, -np.inf), 1)


@dataclass
class _LineSpectrum:
    """The residual's Welch spectrogram ``S`` (bins x segments) at frequencies ``f``, each
    segment divided by its own level (``N``); the segments each bin may use (``M``, None: all;
    ``K`` of them); the mean spectra over them, plain (``P``, for amplitudes) and of ``N``
    (``Q``, for heights); the Gamma shape ``h`` of a bin's mean; the level's ``width``."""
    f: np.ndarray
    S: np.ndarray
    N: np.ndarray
    M: object
    K: np.ndarray
    P: np.ndarray
    Q: np.ndarray
    h: np.ndarray
    width: int


def _segment_levels(S, base, nb):
    """Each segment's own level (bins x segments): the median of its periodogram over
    ``base`` in bands of ``nb`` bins, mean one over the segments, interpolated linearly
    between the bands' centres (a step at a band's edge would make an edge in the spectrum)."""
    nf, n_seg = S.shape
    n_bands = max(1, nf // nb)
    edges = np.append(np.arange(n_bands) * nb, nf)
    lev = np.empty((n_bands, n_seg))
    Rt = (S / base[:, None]).T.copy()          # segments x bins: the bands contiguous
    for b in range(n_bands):
        m = (edges[b + 1] - edges[b]) // 2     # the (upper) median
        lev[b] = np.partition(Rt[:, edges[b]:edges[b + 1]], m, 1)[:, m]
    del Rt
    lev /= np.maximum(lev.mean(1, keepdims=True), 1e-300)
    pos = np.interp(np.arange(nf), 0.5 * (edges[:-1] + edges[1:] - 1), np.arange(n_bands))
    b0 = np.minimum(pos.astype(int), n_bands - 1)
    b1 = np.minimum(b0 + 1, n_bands - 1)
    wb = (pos - b0)[:, None]
    return lev[b0] * (1 - wb) + lev[b1] * wb


def _line_spectrum(r, fs, nper, speed, orders) -> _LineSpectrum:
    """The spectra ``peak_claims`` judges (``_LineSpectrum``)."""
    f, S = hann_spectrogram(r - np.mean(r), fs, nper)
    df = f[1] - f[0]
    M = None
    if speed is not None and orders:
        cov = _order_coverage(speed, orders, fs, f, S.shape[1], nper)
        near = cov.copy()
        near[1:] |= cov[:-1]
        near[:-1] |= cov[1:]
        M = (~near).astype(float)
    return judged_spectrum(f, S, M, max(3, int(round(PEAK_LEVEL_HZ / df)) | 1),
                           max(1, int(round(PEAK_BAND_HZ / df))))


def judged_spectrum(f, S, M, width, band, pairs=None) -> _LineSpectrum:
    """``_LineSpectrum`` of the spectrogram ``S`` (bins x segments, at the abscissa ``f``:
    frequencies or orders) with ``M`` (bins x segments, 1 where a bin may use a segment; None:
    all): the null level's running median over ``width`` (odd) bins, each segment's own level
    in bands of ``band`` bins; ``pairs`` the number of half-overlapping neighbour segments
    (default: every consecutive pair, as one Welch run makes them)."""
    nf, n_seg = S.shape
    pairs = n_seg - 1.0 if pairs is None else float(pairs)
    if M is not None:
        K = M.sum(1)
        adj = np.einsum("ij,ij->i", M[:, 1:], M[:, :-1])
    else:
        K = np.full(nf, float(n_seg))
        adj = np.full(nf, pairs)

    def mean_over(A):       # over the segments each bin may use (all where none may)
        if M is None:
            return A.mean(1)
        return np.where(K > 0, np.einsum("ij,ij->i", A, M) / np.maximum(K, 1), A.mean(1))
    P = mean_over(S)
    base = np.maximum(_running_median(P, width), 1e-300)
    N = S / np.maximum(_segment_levels(S, base, band), 1e-12)
    # the Gamma shape of a bin's mean over its K segments (Welch's equivalent degrees of
    # freedom / 2: half-overlapping neighbours share HANN_OVERLAP_RHO2 of their variance)
    Ka = np.where(K > 0, K, n_seg)
    h = Ka * Ka / (Ka + 2 * HANN_OVERLAP_RHO2 * np.where(K > 0, adj, pairs))
    return _LineSpectrum(f, S, N, M, K, P, mean_over(N), h, width)


def _near_max(a):
    """The largest of ``a`` within +-2 bins."""
    ap = np.concatenate([np.full(2, -np.inf), a, np.full(2, -np.inf)])
    return np.max(np.lib.stride_tricks.sliding_window_view(ap, 5), -1)


def _lines(sp, z, ratio, ok, thr, h3):
    """{bin of a line's centre: its score} beyond ``thr``, and the family's statistic (the
    largest score of a line). A line's centre is the bin of the largest ratio within +-2 bins
    (not of the largest score: a neighbour averaged over more segments has a larger score for
    a smaller ratio); its score the largest within +-2 of it."""
    z_line = _near_max(z)
    cand = (z_line > thr) & (ratio >= _near_max(ratio)) & ok
    # the bins within +-2 of a candidate's centre count through it, as judged on its segments
    away = ok & ~(_near_max(cand.astype(float)) > 0)
    stat = float(np.max(z[away])) if away.any() else -np.inf
    spectra, out = {}, {}
    for i in np.flatnonzero(cand):
        zi = float(z_line[i])
        if sp.M is not None:
            # judged again on the spectrum of the bin's own segments at every bin: an order
            # excluded from some segments next to the bin leaves a low band there, and its
            # skirt in the others, beside that band, would stand over a flank taken without it
            cols = np.flatnonzero(sp.M[i] > 0)
            key = cols.tobytes()
            if key not in spectra:
                Qc = sp.N[:, cols].mean(1)
                spectra[key] = (Qc, _line_free_level(Qc, sp.width))
            Qc, Lc = spectra[key]
            zc = _heights(Qc[i - 1:i + 2], Lc[i - 1:i + 2], h3[i - 1:i + 2])[0]
            zi = min(zi, float(zc)) if np.isfinite(zc) else -np.inf
        stat = max(stat, zi)
        if zi > thr:
            out[i] = zi
    return out, (stat if np.isfinite(stat) else float(np.min(z[ok])))


def judge_lines(sp, search, alpha=FALSE_ALARM, n_twins=N_TWINS, rng=None):
    """The narrow lines of the spectrum ``sp`` (``_LineSpectrum``) among the bins ``search``
    (bool), judged family-wise against twins: None where no bin can be judged, else ({bin of a
    line's centre: its score}, the family's statistic, the twins' threshold at ``alpha``, the
    twins' statistics, the plain spectrum's null level ``Lp``). The one implementation of the
    null spectrum, its twins and their Gumbel tail, for lines in frequency
    (``peak_claims``) and in order (``order_scan``)."""
    f, K = sp.f, sp.K
    Lq, Lp = _line_free_level(sp.Q, sp.width), _line_free_level(sp.P, sp.width)
    h3 = 9.0 * sp.h / (3.0 + 4.0 * HANN_ADJACENT_RHO2)    # of the mean of three adjacent bins
    ok = np.asarray(search, bool) & np.isfinite(Lq) & np.isfinite(Lp)
    ok[[0, -1]] = False
    ok[1:-1] &= (K[:-2] > 0) & (K[1:-1] > 0) & (K[2:] > 0)
    if not ok.any():
        return None
    ratio = np.full(f.size, -np.inf)
    ratio[1:-1] = np.where(ok[1:-1], _ratios(sp.Q, np.where(ok, Lq, 1.0)), -np.inf)
    z = np.full(f.size, -np.inf)
    z[1:-1] = np.where(ok[1:-1], _normal_score(ratio[1:-1], h3[1:-1]), -np.inf)
    # the twins' spectrum: the running median of the recording's, narrow lines removed (a
    # line fills 3 of its 21 bins); not the flank level, which stands high beside a line
    twins = _twin_heights(_running_median(sp.Q, sp.width), sp.h, h3, ok, sp.width, n_twins,
                          rng or np.random.default_rng(20261128))
    thr = gumbel_tail(twins, 0.0, alpha)[0]
    lines, stat = _lines(sp, z, ratio, ok, thr, h3)
    return lines, stat, thr, twins, Lp


def line_amplitude(sp, Lp, i) -> float:
    """Amplitude of a sinusoid at bin ``i`` of ``sp`` from the power in its three bins above
    the null level ``Lp``: with a Hann window a sinusoid at a bin's centre puts 2/3 of its
    power A^2/2 in that bin and 1/6 in each neighbour (the density's peak is A^2/2 over the
    window's noise bandwidth, 1.5 bins)."""
    df = sp.f[1] - sp.f[0]
    return math.sqrt(max(2 * (sp.P[i - 1:i + 2].sum() - 3 * Lp[i]) * df, 0.0))


def peak_claims(r, dt, min_amplitude=1e-3, f_min=2.5, speed=None, orders=(),
                alpha=FALSE_ALARM, n_twins=N_TWINS, rng=None):
    """Narrow peaks of the residual's spectrum at fixed frequencies, judged against twins.

    The spectrum: Welch, ``PEAK_SEGMENT_S`` Hann segments, half overlapping. Shaft orders are
    left to the order analysis: with ``speed`` (sample-level input speed, rad/s) and
    ``orders`` (orders of it), a bin is averaged over the segments in which none of these
    orders comes within ``ORDER_EXCLUSION_HZ`` of it or its neighbours (``_order_coverage``);
    a bin that every segment's orders reach is not judged. So a fixed frequency is found
    where an order at one held speed shares it, from the segments at the other speeds.

    The statistic of a bin is the height of its three bins' mean over the null spectrum
    (``_line_free_level``: smooth coloured noise, no line within the main lobe), in the
    spectrum of the segments each divided by its own noise level in its band of
    ``PEAK_BAND_HZ`` (a loud stretch of the recording does not make a line), as a normal score
    (``_normal_score``). The claim "a line somewhere" takes the largest over the bins searched
    (f >= ``f_min``); its twins are ``n_twins`` spectra of Gaussian noise with the recording's
    null spectrum (``_twin_heights``: drawn as Welch spectra, the cost of a spectrum, not of
    a recording), the same maximum taken; a Gumbel tail (the maximum of many exponential-
    tailed heights) fitted to them gives the threshold at ``alpha``, the family-wise rate of
    any line reported in a recording without one. Every line centre beyond it (``_lines``) is
    a peak; reported when its amplitude (from the power of its three bins above the level) is
    at least ``min_amplitude`` N*m.

    Returns ([(frequency Hz, amplitude N*m)] largest first, ``Check`` of the largest height or
    None, {frequency Hz: ``Check``} of the peaks reported)."""
    r = np.asarray(r, float)
    orders = list(orders)
    n = len(r)
    nper = int(round(PEAK_SEGMENT_S / dt))
    if n < 8 * nper or nper < 64:
        return [], None, {}
    if speed is not None and len(speed) < n:
        raise ValueError(f"speed: {len(speed)} samples for a residual of {n}")
    sp = _line_spectrum(r, 1.0 / dt, nper, speed, orders)
    judged = judge_lines(sp, sp.f >= f_min, alpha, n_twins, rng)
    if judged is None:
        return [], None, {}
    lines, stat, thr, twins, Lp = judged
    peaks, checks = [], {}
    for i, zi in lines.items():
        amp = line_amplitude(sp, Lp, i)
        if amp >= min_amplitude:
            peaks.append((float(sp.f[i]), amp))
            checks[float(sp.f[i])] = Check(zi, thr, gumbel_tail(twins, zi, alpha)[1],
                                           float(alpha), int(n_twins), True)
    search = Check(stat, thr, gumbel_tail(twins, stat, alpha)[1], float(alpha),
                   int(n_twins), bool(stat > thr))
    return sorted(peaks, key=lambda x: -x[1]), search, checks


def spectral_peaks(r, dt, min_amplitude=1e-3, f_min=2.5, speed=None, orders=()) -> list:
    """[(frequency Hz, amplitude N*m)] of the fixed-frequency peaks that stand against their
    twins (``peak_claims``), largest first."""
    return peak_claims(r, dt, min_amplitude, f_min, speed, orders)[0]


#: [s] a residual burst within this time of an event (a reversal, a step) belongs to it: the
#: transients of backlash and compliance last tens of milliseconds
EVENT_WINDOW = 0.1
#: [1] share of the peak speed or torque below which a sign is not judged (noise about zero)
SIGN_SHARE = 0.02


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


def burst_events(t, w, T_out, T_in=None) -> dict:
    """The events residual bursts are judged against, {kind: sorted times}: speed reversals,
    reversals of the input torque ``T_in`` (when given: pass the model's, a function of the
    measured inputs; a measured one would put events where its own noise crosses zero), of
    the output torque ``T_out`` ("torque reversals"), steps of load or speed.

    A lost motion is taken up where the torque through it reverses: on the input side (the
    motor coupling, the input shaft) with the input torque, on the output side with
    the output torque. The losses between the shafts part the two sign changes (back-driving
    through a slow load ramp: up to 0.9 s apart in batch 1's ``o04``), so the two are kinds of
    their own: either alone dilutes the other's transients with events that carry none."""
    ev = {"speed reversals": np.sort(_reversals(t, w))}
    if T_in is not None:
        ev["input torque reversals"] = np.sort(_reversals(t, T_in))
    ev["torque reversals"] = np.sort(_reversals(t, T_out))
    ev["load or speed steps"] = np.union1d(_steps(t, T_out), _steps(t, w))
    return ev


def near_events(t, w, T_out, kinds, T_in=None) -> np.ndarray:
    """Blocks (times ``t``) within EVENT_WINDOW of an event of the given ``kinds``."""
    ev = burst_events(t, w, T_out, T_in)
    times = np.sort(np.concatenate([ev[k] for k in kinds])) if kinds else np.zeros(0)
    return _near(t, times, EVENT_WINDOW)


def bursts(t, spikes, w, T_out, T_in=None) -> dict:
    """Where the excluded spike blocks sit: at speed reversals, at reversals of the input
    torque ``T_in`` (the model's; when given) or of the output torque, at steps of load or
    speed, or elsewhere; ``events_with_burst``: {kind: (events with a burst, events)};
    ``burst_blocks``: {kind: mean length of its bursts, in blocks (runs of consecutive spike
    blocks)}. ``tied`` (the event kinds a transient is tied to) is left empty here: it is
    decided against twins of the residual (``remainder.burst_claims``), not by counting
    spike blocks."""
    n = int(spikes.sum())
    out = {"count": n, "at": {}, "tied": []}
    if n == 0:
        return out
    left = spikes.copy()
    out["events_with_burst"] = {}
    for name, events in burst_events(t, w, T_out, T_in).items():
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
