"""The order scan: lines of the residual at any order of the input shaft, in the angle domain.

The remainder's order analysis (``remainder.order_claims``) judges a fixed list of orders (1x,
2x, 3x of the input, the roller pass and its 2x, 1x and 2x of the output shaft), and the
line search (``residual.peak_claims``) finds lines at fixed frequencies. A part turning with
a shaft at any other ratio (a belt, a coupling, a bearing's cage or rolling elements, a
motor-side gear stage, a pump) puts a line at its own order, and wherever the speed varies
its frequency smears over the time spectrum: neither finds it.

Here the sample-level residual is resampled at uniform steps of the angle the input shaft
has travelled (|angle|: a reversal keeps an order an order) over the moving stretches,
cut into segments of ``SCAN_TURNS`` turns and judged exactly as the fixed-frequency lines are
(``residual.judged_spectrum``, ``residual.judge_lines``: Welch in angle, each segment at its
own level, the null spectrum from a running median and flanks, Gaussian twins of it, a
Gumbel tail, the family-wise rate ``twins.FALSE_ALARM`` over every order searched). The
abscissa is the order: cycles per turn of the input shaft.

Resampling: each angle sample is the mean of the residual over its step of angle (the
difference of the residual's cumulative trapezoidal integral, interpolated linearly between
samples, at the step's two ends, over the time between them). Where a step spans several time
samples (below the top speed) this box mean is the decimation's anti-aliasing filter; it
attenuates but does not remove what lies above the angle sampling's Nyquist order, and the
interpolation between time samples makes an image of a line near the Nyquist frequency. So
the scan only detects: a line's order and amplitude are measured at sample level, where
nothing folds (``_unfold``, ``chunk_amplitude``: least squares on sin/cos of the shaft angle
in chunks of a segment's turns, at the order seen and at its images), and an image, which has
no amplitude at its own order there, is not reported.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from . import residual as R
from .twins import FALSE_ALARM, N_TWINS, Check, gumbel_tail

#: [turns] length of a scan segment: an order resolution of 1/128 (the Hann main lobe +-2/128),
#: fine enough to keep an order of the output shaft apart from its neighbours (1/ratio apart,
#: 0.07 at a ratio of 14: 9 bins); a stretch of motion shorter than a segment is not used
SCAN_TURNS = 128
#: [turns] shortest segment where the recording holds fewer turns than ``SCAN_MIN_SEGMENTS``
#: segments of ``SCAN_TURNS`` (the length halved down to this): a coarser resolution rather
#: than no scan
SCAN_MIN_TURNS = 32
#: [1] Welch needs this many segments for a mean spectrum whose null level is estimated from
#: the recording itself (as the line search requires eight segments)
SCAN_MIN_SEGMENTS = 8
#: [cycles per segment] the lowest order searched repeats this many times within a segment
#: (1/16 of an input turn's order at 128 turns): below it a line is hardly narrower than the
#: slow changes of the residual with the operating point, which the generic basis fits on
#: block means (the line search's lower bound, 2.5 Hz in 2 s segments, is 5 cycles)
SCAN_MIN_CYCLES = 8
#: [samples per turn] the most angle samples per input turn: orders up to
#: ``ORDER_NYQUIST_SHARE`` of it (51 at 128) are searched; a bearing's or a belt's orders
#: are below it, a gear mesh of a motor-side stage usually too. Bounds the scan's cost on a
#: slow shaft sampled fast
SCAN_MAX_PER_TURN = 128
#: [bins] the null level's running median (five main lobes) and each segment's level band:
#: the bin counts of the line search (10 Hz and 64 Hz over its 0.5 Hz bins)
SCAN_LEVEL_BINS = 21
SCAN_BAND_BINS = 128
#: [bins] a scan bin this close to a listed order (``remainder._orders``) is left to the
#: order analysis: the Hann main lobe (+-2 bins) and one bin beside it
SCAN_EXCLUSION_BINS = 3


@dataclass
class ScanLine:
    """A line of the scan: its order of the input shaft, amplitude [N*m] and ``Check``;
    ``seen_at`` the order of the scan's bin (the order itself, or its image where an order
    above the angle sampling's Nyquist order folded into the band, ``_unfold``)."""
    order: float
    amplitude: float
    check: Check
    seen_at: float = None


@dataclass
class Scan:
    """What the scan did: the lines that stand (largest first), the family's ``search`` Check,
    the segment length [turns], the orders searched, and the input speed's 5-95 % range
    [rad/s] over the samples used (one held speed: an order and a fixed frequency make the
    same line)."""
    lines: list
    search: Check
    turns: int
    order_range: tuple
    speed_range: tuple
    n_segments: int
    extra: dict = field(default_factory=dict)
    #: per segment the lowest and highest input speed [rad/s] (n_segments x 2)
    seg_speed: np.ndarray = field(default=None, repr=False)
    #: what a line is judged again with (``stands_without``): the spectrum, the bins searched
    state: dict = field(default_factory=dict, repr=False)

    def reaches(self, k, f_hz):
        """Segments in which order ``k`` comes within ``residual.ORDER_EXCLUSION_HZ`` of the
        frequency ``f_hz`` (bool per segment)."""
        lo, hi = k * self.seg_speed.T / (2 * math.pi)
        return (lo - R.ORDER_EXCLUSION_HZ <= f_hz) & (f_hz <= hi + R.ORDER_EXCLUSION_HZ)

    def stands_without(self, k, freqs, seen_at=None):
        """Does the line at order ``k`` (seen in the scan at ``seen_at``, default k) stand on
        the segments in which it comes near none of the fixed frequencies ``freqs`` [Hz]
        (judged as the scan judged it, the same family of orders and rate)? False where no
        segment is left."""
        st = self.state
        f = st["sp"].f
        near = np.zeros(self.seg_speed.shape[0], bool)
        for fz in freqs:
            near |= self.reaches(k, fz)
        if near.all():
            return False
        M = np.ones(st["sp"].S.shape) if st["M"] is None else st["M"].copy()
        seen = k if seen_at is None else seen_at
        band = np.abs(f - seen) <= (SCAN_EXCLUSION_BINS + R.PEAK_FLANK_BINS + 3) * (f[1] - f[0])
        M[np.ix_(band, near)] = 0.0
        sp = R.judged_spectrum(f, st["sp"].S, M, SCAN_LEVEL_BINS, SCAN_BAND_BINS,
                               st["pairs"])
        judged = R.judge_lines(sp, st["search"], st["alpha"], st["n_twins"],
                               np.random.default_rng(20261130))
        if judged is None:
            return False
        df = f[1] - f[0]
        return any(abs(f[i] - seen) <= 2 * df for i in judged[0])


def _runs(moving):
    """[(start, stop)] of the runs of True in ``moving``."""
    d = np.diff(np.concatenate([[0], moving.view(np.int8), [0]]))
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1)))


def _plan(s, runs, per_turn):
    """(turns per segment, the runs long enough for one) with at least ``SCAN_MIN_SEGMENTS``
    half-overlapping segments, the longest from ``SCAN_TURNS`` halving down to
    ``SCAN_MIN_TURNS``; (0, []) where none."""
    turns = SCAN_TURNS
    lengths = [(a, b, (s[b - 1] - s[a]) / (2 * math.pi)) for a, b in runs]
    while turns >= SCAN_MIN_TURNS:
        used = [(a, b) for a, b, L in lengths if L >= turns]
        nper = turns * per_turn
        n_seg = sum((int(L * per_turn) - nper) // (nper // 2) + 1
                    for a, b, L in lengths if L >= turns)
        if n_seg >= SCAN_MIN_SEGMENTS:
            return turns, used
        turns //= 2
    return 0, []


def angle_resample(r, s, a, b, step, index=False):
    """The mean of ``r`` over uniform steps ``step`` [rad] of the travelled angle ``s`` (rad,
    increasing) within the samples a..b-1: the difference of the residual's cumulative
    (trapezoidal) integral over sample index, interpolated at the steps' ends, over the
    samples between them. With ``index``, also the steps' ends as fractional sample indices
    (from a)."""
    ss = s[a:b]
    g = ss[0] + step * np.arange(int((ss[-1] - ss[0]) / step) + 1)
    x = np.interp(g, ss, np.arange(b - a, dtype=float))      # fractional sample index
    del g
    rr = r[a:b]
    C = np.empty(b - a)
    C[0] = 0.0
    np.cumsum(0.5 * (rr[1:] + rr[:-1]), out=C[1:])
    i = np.minimum(x.astype(np.int64), b - a - 2)
    fr = x - i
    Cx = C[i] * (1 - fr) + C[i + 1] * fr
    y = np.diff(Cx) / np.maximum(np.diff(x), 1e-12)
    return (y, x) if index else y


def _folded_listed(f, seg_speed, listed, fs):
    """Which scan bins (orders ``f``) each segment may use (bins x segments, 1 or 0; None
    where all): a listed order above the Nyquist frequency in a segment appears there folded
    about it, at an order that moves with the speed (``residual.folded``), and the bins it
    reaches at the segment's speeds (+-``residual.ORDER_EXCLUSION_HZ`` and
    ``SCAN_EXCLUSION_BINS``) are not averaged over that segment, as the line search leaves
    the folded orders out of its segments."""
    fn = fs / 2
    pad = R.ORDER_EXCLUSION_HZ
    df = f[1] - f[0]
    M = None
    for j, (wl, wh) in enumerate(seg_speed):
        for kl in np.abs(np.asarray(listed, float)):
            a, b = kl * wl / (2 * math.pi), kl * wh / (2 * math.pi)
            if b < fn:
                continue
            # its Nyquist zones above the first (there it is itself, excluded as listed)
            for z in range(max(int(a // fn), 1), int(b // fn) + 1):
                lo, hi = max(a, z * fn) - z * fn, min(b, (z + 1) * fn) - z * fn
                if z % 2:
                    lo, hi = fn - hi, fn - lo
                o_lo = max(lo - pad, 0.0) * 2 * math.pi / max(wh, 1e-12)
                o_hi = (hi + pad) * 2 * math.pi / max(wl, 1e-12)
                cut = (f >= o_lo - SCAN_EXCLUSION_BINS * df) & \
                    (f <= o_hi + SCAN_EXCLUSION_BINS * df)
                if cut.any():
                    if M is None:
                        M = np.ones((f.size, seg_speed.shape[0]))
                    M[cut, j] = 0.0
    return M


#: the images of an order searched: orders m * per_turn +- k for m up to this many
UNFOLD_IMAGES = 2


def chunk_amplitude(r, th, s, moving, dt, k, turns):
    """Amplitude [N*m] of order ``k`` in the residual ``r`` at sample level: least squares on
    (1, sin k th, cos k th) in chunks of ``turns`` turns of the travelled angle ``s`` (each
    chunk its own phase and mean, as each scan segment has them), over the samples
    ``moving[0]`` whose speed ``moving[1]`` keeps the order below
    ``residual.ORDER_NYQUIST_SHARE`` of the sampling rate; the chunks' squared amplitudes
    less their noise bias (2 sigma^2 / n), weighted by their samples. No angle resampling, so
    nothing folds. None where fewer than 100 samples."""
    w_ok = R.ORDER_NYQUIST_SHARE * 2 * math.pi / (dt * k)      # the highest speed [rad/s]
    idx = np.flatnonzero(moving[0] & (moving[1] < w_ok))
    if idx.size < 100:
        return None
    _, c = np.unique((s[idx] // (2 * math.pi * turns)).astype(np.int64), return_inverse=True)
    ang = k * th[idx]
    sn, cs, rr = np.sin(ang), np.cos(ang), r[idx]
    del ang

    def tot(x):
        return np.bincount(c, x)
    n = np.bincount(c).astype(float)
    G = np.empty((n.size, 3, 3))
    G[:, 0, 0] = n
    G[:, 0, 1] = G[:, 1, 0] = tot(sn)
    G[:, 0, 2] = G[:, 2, 0] = tot(cs)
    G[:, 1, 1] = tot(sn * sn)
    G[:, 2, 2] = tot(cs * cs)
    G[:, 1, 2] = G[:, 2, 1] = tot(sn * cs)
    b = np.stack([tot(rr), tot(rr * sn), tot(rr * cs)], -1)
    ok = n >= 16
    if not ok.any():
        return None
    G, b, n = G[ok], b[ok], n[ok]
    coef = np.linalg.solve(G + 1e-12 * np.eye(3), b[..., None])[..., 0]
    rss = np.maximum(tot(rr * rr)[ok] - np.einsum("ij,ij->i", coef, b), 0.0)
    sigma2 = rss / np.maximum(n - 3, 1)
    a2 = coef[:, 1] ** 2 + coef[:, 2] ** 2 - 2 * sigma2 / n
    return math.sqrt(max(float(np.dot(n, a2) / n.sum()), 0.0))


def _unfold(k, r, th, s, moving, dt, per_turn, turns):
    """The true order of a scan line seen at order ``k``, with its amplitude at sample level
    (``chunk_amplitude``): (order, amplitude [N*m]) of the candidate of the largest amplitude,
    or None where none can be fitted. The candidates are k and its images m ``per_turn`` +-
    k (``UNFOLD_IMAGES``): an order above the angle sampling's Nyquist order (``per_turn`` /
    2, reached at speeds below the top, where the time samples still resolve it) folds to
    such an image, which the box mean attenuates but does not remove; so does the image the
    interpolation between time samples makes of a line near the Nyquist frequency. At
    sample level nothing folds: an image has no amplitude at its own order there."""
    cands = [k]
    for m in range(1, UNFOLD_IMAGES + 1):
        cands += [c for c in (m * per_turn - k, m * per_turn + k) if c > k + 1.0 / turns]
    best = None
    for c in cands:
        a = chunk_amplitude(r, th, s, moving, dt, c, turns)
        if a is not None and (best is None or a > best[1]):
            best = (c, a)
    return best


def _angle_spectrogram(r, s, aw, used, per_turn, nper):
    """The Welch spectrogram in angle of the runs ``used``: (orders, spectra (bins x
    segments), the half-overlapping neighbour pairs, each segment's lowest and highest speed
    (segments x 2, rad/s), the 5-95 % range of the speed over the runs), or None where no run
    holds a segment."""
    spectra, pairs, seg_speed, speeds = [], 0, [], []
    f = None
    for a, b in used:
        y, x = angle_resample(r, s, a, b, 2 * math.pi / per_turn, index=True)
        if y.size < nper:
            continue
        f, S = R.hann_spectrogram(y, per_turn, nper)
        spectra.append(S)
        pairs += S.shape[1] - 1
        speeds.append(aw[a:b])
        hop = nper - nper // 2
        for j in range(S.shape[1]):      # each segment's speed range
            i0, i1 = int(x[j * hop]), int(math.ceil(x[j * hop + nper])) + 1
            seg_speed.append((aw[a + i0:a + i1].min(), aw[a + i0:a + i1].max()))
    if not spectra:
        return None
    S = np.concatenate(spectra, 1) if len(spectra) > 1 else spectra[0]
    lo, hi = np.quantile(np.concatenate(speeds), [0.05, 0.95])
    return f, S, pairs, np.array(seg_speed), (float(lo), float(hi))


def _measured(sp, Lp, i, r, th, s, moving, dt, per_turn, turns, listed):
    """(order, amplitude [N*m], order seen) of the scan's line at bin ``i``: seen at the
    power-weighted centre of its three bins over the null level ``Lp``, measured at sample
    level (``_unfold``); None where it cannot be measured or is the image of a listed
    order (left to the order analysis)."""
    f = sp.f
    e = np.maximum(sp.P[i - 1:i + 2] - Lp[i], 0.0)
    k = float(np.dot(e, f[i - 1:i + 2]) / e.sum()) if e.sum() > 0 else float(f[i])
    true = _unfold(k, r, th, s, moving, dt, per_turn, turns)
    if true is None or any(abs(true[0] - abs(kl)) <= 1.0 / turns for kl in listed):
        return None
    return true[0], true[1], k


def order_scan(r, theta, w, dt, listed=(), alpha=FALSE_ALARM, n_twins=N_TWINS, rng=None,
               min_amplitude=1e-3, folded=None):
    """Lines of the residual ``r`` (sample level, N*m) at orders of the input shaft (angle
    ``theta`` [rad], speed ``w`` [rad/s], sampling step ``dt`` [s]) that stand against twins
    of its angle spectrum at ``alpha`` (family-wise over the orders searched), the orders
    within ``SCAN_EXCLUSION_BINS`` of ``listed`` left out, and the orders of ``folded``
    (default: ``listed``) left out of the segments in which they are folded about the Nyquist
    frequency (``_folded_listed``). Returns a ``Scan`` or None where the recording holds too
    few turns in motion.

    Samples used: moving (|w| above ``residual.MOVING_SHARE`` of its top), in runs of at least
    one segment's turns. Orders searched: from ``SCAN_MIN_CYCLES`` per segment up to
    ``residual.ORDER_NYQUIST_SHARE`` of the sampling rate at the top speed of the samples used
    (capped at the band at the top speed: at any lower speed the same order is further below
    the Nyquist frequency, so no order searched aliases anywhere) and of the angle sampling
    (``SCAN_MAX_PER_TURN``)."""
    r = np.asarray(r, float)
    n = min(len(r), len(theta), len(w))
    aw = np.abs(np.asarray(w[:n], float))
    top = float(np.max(aw, initial=0.0))
    if n < 16 or not np.isfinite(top) or top <= 0:
        return None
    moving = aw > R.MOVING_SHARE * top
    runs = [(a, b) for a, b in _runs(moving) if b - a >= 16]
    if not runs:
        return None
    top = max(float(np.max(aw[a:b])) for a, b in runs)
    fs = 1.0 / dt
    # angle samples per turn: one per time sample at the top speed (no finer: the box mean
    # would only interpolate), even, capped
    per_turn = int(min(SCAN_MAX_PER_TURN, 2 * math.ceil(math.pi * fs / top)))
    k_max = R.ORDER_NYQUIST_SHARE * min(2 * math.pi * fs / top, per_turn)
    th = np.asarray(theta[:n], float)
    s = np.empty(n)
    s[0] = 0.0
    np.cumsum(np.abs(np.diff(th)), out=s[1:])
    turns, used = _plan(s, runs, per_turn)
    if not turns:
        return None
    nper = turns * per_turn
    spec = _angle_spectrogram(r, s, aw, used, per_turn, nper)
    if spec is None:
        return None
    f, S, pairs, seg_speed, (lo, hi) = spec
    M = _folded_listed(f, seg_speed, listed if folded is None else folded, fs)
    sp = R.judged_spectrum(f, S, M, SCAN_LEVEL_BINS, SCAN_BAND_BINS, pairs)
    del S
    df = f[1] - f[0]
    search = (f >= SCAN_MIN_CYCLES / turns) & (f <= k_max)
    for k in listed:
        search &= np.abs(f - abs(k)) > SCAN_EXCLUSION_BINS * df
    rng = rng or np.random.default_rng(20261129)
    judged = R.judge_lines(sp, search, alpha, n_twins, rng)
    if judged is None:
        return None
    lines, stat, thr, twins, Lp = judged
    out = []
    for i, zi in lines.items():
        x = _measured(sp, Lp, i, r, th, s, (moving, aw), dt, per_turn, turns, listed)
        if x is not None and x[1] >= min_amplitude:
            out.append(ScanLine(x[0], x[1], Check(zi, thr, gumbel_tail(twins, zi, alpha)[1],
                                                  float(alpha), int(n_twins), True), x[2]))
    # one line per order (a line and its image both measured at the same order)
    kept = []
    for x in sorted(out, key=lambda x: -x.amplitude):
        if all(abs(x.order - y.order) > 1.0 / turns for y in kept):
            kept.append(x)
    out = kept
    return Scan(sorted(out, key=lambda x: -x.amplitude),
                Check(stat, thr, gumbel_tail(twins, stat, alpha)[1], float(alpha),
                      int(n_twins), bool(stat > thr)),
                turns, (float(SCAN_MIN_CYCLES / turns), float(k_max)), (lo, hi),
                int(sp.S.shape[1]), {"per_turn": per_turn}, seg_speed,
                {"sp": sp, "search": search, "alpha": alpha, "n_twins": n_twins,
                 "pairs": pairs, "M": M})
