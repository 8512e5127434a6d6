"""Stage ``twins``: every claim checked against twins of the recording.

A twin is the recording's own measured inputs replayed through the fitted model (the
selection's prediction, block level) plus noise drawn from the recording's own residual. The
fits are linear in the block means with the recording's weights, so a statistic that compares
two nested fits which both hold the selection (the improvement a term or the generic basis
makes beside it) does not depend on the fitted part: on a twin it is the same statistic of the
twin's noise alone. The twins therefore cost one matrix product ``X' W E`` for all of them and
a few small solves per claim, never a replay.

Noise model (Gaussian noise with the residual's own spectrum): the spectrum of the block
residual is estimated by ``TAPERS`` sine-tapered periodograms averaged (Riedel & Sidorenko
1995), spike blocks set to zero; a twin's noise is a stationary Gaussian series of that
spectrum (independent normal real and imaginary parts at every frequency, an inverse FFT). It
holds the residual's whole spectrum, its lowest frequencies included: a 1/f (flicker) noise,
whose power sits in the few slowest frequencies, is kept.

The residual it is estimated on is *cross-fitted* (``cross_fitted_residual``): the selection
and the operating-point part of the generic basis fitted on the other time folds, the
residual taken on the fold left out. What repeats across the recording (a remainder that is a
function of the operating point) is taken out, so it does not make the twins noisier; what
does not repeat (noise of any colour, its slow wander included) is kept whole. The residual
of an in-sample fit of the basis would lose exactly the noise's slowest part (the basis's
time and operating-point columns absorb it), and twins drawn from it pass a slowly wandering
noise off as structure. Measured on a clean four-quadrant recording with 4 mN*m of 1/f noise:
the former AR(12) twins of the basis's residual put the structure statistic's mean at a
quarter of what the true noise gives (p = 2e-6 for a clean recording); these twins: p = 0.1 -
1. The prediction error of a fit on four fifths of the recording only adds to the noise: the
twins are noisier, never quieter, and the false-alarm rate holds.

Decision: a claim stands where the recording's statistic lies beyond the twins' at the stated
false-alarm rate ``FALSE_ALARM`` (1 %). ``N_TWINS`` twins (64) cannot resolve a 1 % quantile
empirically, so the twins' statistics are fitted with the tail their distribution has under
Gaussian noise, its scale and shape measured on the twins: the improvement in the residual sum
of squares a linear term makes is a scaled chi-square (scale and effective degrees of freedom
by the method of moments: colour and weights change both), divided by the spectrum's own
error at the frequencies the statistic lives at (each twin drawn again from the same normal
numbers under a redrawn spectrum, ``spectrum_draws``): a scaled F tail (``f_tail``); a claim
chosen among K candidates
is judged at FALSE_ALARM / K (Bonferroni), a claim that already maximises over its options
(the best group of the generic basis) at FALSE_ALARM, its twins maximising alike.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

#: [1] the false-alarm rate every claim is judged at: the share of twins (recordings the fitted
#: model explains within the recording's own noise) in which the claim would stand
FALSE_ALARM = 0.01
#: number of twins (the tail fitted to them: 64 give the moments to about 20 %)
N_TWINS = 64
#: number of sine tapers of the noise spectrum: the spectrum at each frequency is the mean of
#: 7 tapered periodograms (a chi-square of 14 degrees of freedom, the usual multitaper
#: compromise), a frequency resolution of +-4 bins of the recording's block series
TAPERS = 7
#: twins per chunk of the matrix product (memory: blocks x chunk doubles)
CHUNK = 16


@dataclass
class Check:
    """One claim against the twins: the recording's statistic, the twins' threshold at the
    false-alarm rate, the tail's p-value of the recording; ``stands``."""
    statistic: float
    threshold: float
    p_value: float
    false_alarm: float
    n_twins: int
    stands: bool

    def to_json(self) -> dict:
        return {"false_alarm_rate": self.false_alarm, "n_twins": self.n_twins,
                "p_value": self.p_value, "statistic": self.statistic,
                "twin_threshold": self.threshold}


def chi2_tail(samples, stat, alpha) -> tuple:
    """(threshold at ``alpha``, p-value of ``stat``) of a scaled chi-square fitted by moments
    to ``samples`` (non-negative statistics of the twins). (scipy.special's chi-square tail
    and its inverse: what scipy.stats.chi2's isf and sf evaluate, without importing
    scipy.stats, a third of a second.)"""
    from scipy.special import chdtrc, chdtri
    s = np.asarray(samples, float)
    mu, var = float(np.mean(s)), float(np.var(s, ddof=1)) if len(s) > 1 else 0.0
    if mu <= 0 or var <= 0:
        return max(mu, 0.0), (0.0 if stat > mu else 1.0)
    nu = 2 * mu * mu / var
    c = var / (2 * mu)
    return float(c * chdtri(nu, alpha)), float(chdtrc(nu, max(stat, 0.0) / c))


#: [1] the largest effective degrees of freedom of a spectrum's error taken as finite (beyond
#: it the F tail is the chi-square's to three digits)
MAX_SPECTRUM_DOF = 1e5


def f_tail(samples, redrawn, stat, alpha) -> tuple:
    """(threshold at ``alpha``, p-value of ``stat``) of a statistic whose twins' noise has an
    estimated spectrum: the twins' statistic given the estimate is a scaled chi-square
    (``chi2_tail``'s moments on ``samples``: scale c, degrees of freedom a); the estimate's
    error at the frequencies the statistic lives at scales it by a factor whose relative
    variance the same twins under redrawn spectra show (``redrawn``: the same noise draws,
    the spectrum times ``spectrum_draws``' factors; the variance of the ratio of the two,
    2/nu). The statistic over its chi-square's scale is then F(a, nu) distributed: Student's
    t for a variance estimated from the recording itself, generalised (a claim that lives at
    the few slowest frequencies of a 1/f noise, nu ~ 2 TAPERS, is judged on a tail several
    times as long as the chi-square's; a claim spread over the band, nu large, on the
    chi-square's). (scipy.special's F tail and its inverse.)"""
    from scipy.special import fdtrc, fdtri
    s = np.asarray(samples, float)
    mu, var = float(np.mean(s)), float(np.var(s, ddof=1)) if len(s) > 1 else 0.0
    if mu <= 0 or var <= 0:
        return max(mu, 0.0), (0.0 if stat > mu else 1.0)
    a = 2 * mu * mu / var
    c = var / (2 * mu)
    q = np.asarray(redrawn, float)
    ok = (s > 0) & (q > 0)
    nu = MAX_SPECTRUM_DOF
    if ok.sum() > 2:
        # the factor each twin's statistic took from its redrawn spectrum: q / s with the
        # same noise draws; its relative variance from the spread of log(q / s) (a median
        # absolute deviation: a twin whose statistic is near zero gives a ratio of little
        # weight), at most one band's (a weighted mean of the bands' factors varies less
        # than one of them: nu >= 2 TAPERS)
        lr = np.log(q[ok] / s[ok])
        v = (1.4826 * float(np.median(np.abs(lr - np.median(lr))))) ** 2
        if v > 0:
            nu = float(np.clip(2.0 / v, 2.0 * TAPERS, MAX_SPECTRUM_DOF))
    return (float(c * a * fdtri(a, nu, 1.0 - alpha)),
            float(fdtrc(a, nu, max(stat, 0.0) / (c * a))))


def normal_tail(samples, stat, alpha) -> tuple:
    """(threshold, p-value) of a normal fitted to ``samples`` (a mean over many blocks).
    (scipy.special's normal tail and its inverse, as scipy.stats.norm's sf and isf.)"""
    from scipy.special import ndtr, ndtri
    s = np.asarray(samples, float)
    mu, sd = float(np.mean(s)), float(np.std(s, ddof=1)) if len(s) > 1 else 0.0
    if sd <= 0:
        return mu, (0.0 if stat > mu else 1.0)
    return float(mu + sd * -ndtri(alpha)), float(ndtr(-((stat - mu) / sd)))


def average_ranks(a) -> np.ndarray:
    """Ranks 1..n of the values ``a`` (ties at their mean rank; every rank NaN where a value is
    NaN): scipy.stats.rankdata's default, the same numbers, without importing scipy.stats."""
    a = np.asarray(a, float).ravel()
    n = a.size
    if np.isnan(a).any():
        return np.full(n, np.nan)
    j = np.argsort(a, kind="stable")
    y = a[j]
    first = np.flatnonzero(np.concatenate([[True], y[1:] != y[:-1]]))
    counts = np.diff(first, append=n)
    ranks = np.empty(n)
    ranks[j] = np.repeat((first + 1) + (counts - 1) / 2, counts)
    return ranks


def gumbel_tail(samples, stat, alpha) -> tuple:
    """(threshold, p-value) of a Gumbel distribution fitted by moments to ``samples`` (the
    largest of many statistics with exponential tails, as a spectrum's highest bin is:
    Fisher-Tippett); scale sd sqrt(6)/pi, location mean - 0.5772 scale."""
    s = np.asarray(samples, float)
    mu, sd = float(np.mean(s)), float(np.std(s, ddof=1)) if len(s) > 1 else 0.0
    if sd <= 0:
        return mu, (0.0 if stat > mu else 1.0)
    beta = sd * math.sqrt(6.0) / math.pi
    loc = mu - 0.5772156649 * beta
    return (float(loc - beta * math.log(-math.log1p(-alpha))),
            float(-math.expm1(-math.exp(-(stat - loc) / beta))))


def noise_spectrum(x, tapers=TAPERS, keep=None) -> np.ndarray:
    """Sine-multitaper estimate of the power of ``x`` at the frequencies of its real FFT,
    scaled as |FFT|^2 (a white series of variance s2 has the value N s2 at every frequency);
    the mean removed.

    ``keep`` (bool, optional): the samples that hold the series; the others (a standstill the
    model does not judge, excluded spikes) are set to zero, and each taper's periodogram is
    divided by the taper's energy on the kept samples (sum h_k^2 over them, 1 with none
    left out): a series with a fifth of its blocks zeroed would otherwise read a fifth too
    quiet at every frequency (measured on a start-stop recording with 20 % standstill: twins
    of the slow structure 0.75 - 0.8 of the noise's own)."""
    x = np.asarray(x, float)
    n = len(x)
    m = np.ones(n, bool) if keep is None else np.asarray(keep, bool)
    if not m.any():
        return np.zeros(n // 2 + 1)
    x = np.where(m, x - np.mean(x[m]), 0.0)
    k = np.arange(1, tapers + 1)[:, None]
    h = math.sqrt(2.0 / (n + 1)) * np.sin(math.pi * k * np.arange(1, n + 1)[None, :] / (n + 1))
    energy = np.maximum((h * h) @ m.astype(float), 1e-300)
    return n * np.mean(np.abs(np.fft.rfft(h * x[None, :], axis=1)) ** 2 / energy[:, None], 0)


def spectral_noise(spec, n, k, rng, z=None) -> np.ndarray:
    """``k`` stationary Gaussian series of length ``n`` whose expected |FFT|^2 is ``spec``
    (one spectrum for all, or frequencies x ``k``: one per series); ``z`` (frequencies x
    ``k`` complex standard normals, optional): the draws to use (the same series under
    another spectrum)."""
    spec = np.asarray(spec, float)
    if z is None:
        z = rng.standard_normal((len(spec), k)) + 1j * rng.standard_normal((len(spec), k))
    z = z * (np.sqrt(spec / 2.0) if spec.ndim == 2 else np.sqrt(spec / 2.0)[:, None])
    # the mean: a real normal of the spectrum's level at zero frequency (the multitaper
    # estimate there is the level of the slowest frequencies: how far the noise's mean over
    # the recording wanders, which a constant term such as a zero offset would take)
    z[0] = z[0].real * math.sqrt(2.0)
    if n % 2 == 0:            # the Nyquist frequency is real
        z[-1] = z[-1].real * math.sqrt(2.0)
    return np.fft.irfft(z, n, axis=0)


@dataclass
class Twins:
    """The twins of one recording at block level: ``C[f]`` (columns x twins) and ``yy[f]``
    (twins) per fold, the Gram products of the twins' noise with the problem's columns."""
    prob: object
    n: int
    spectrum: np.ndarray = field(repr=False)
    C: list = field(repr=False)
    yy: list = field(repr=False)
    E: np.ndarray = field(repr=False, default=None)

    def rss(self, terms) -> np.ndarray:
        """Weighted residual sum of squares of the fit of ``terms`` on every twin."""
        idx = np.array([i for t in terms for i in t.cols], int)
        yy = sum(self.yy)
        if not len(idx):
            return yy
        G = self.prob.Gt[np.ix_(idx, idx)]
        C = sum(self.C)[idx]
        B = np.linalg.pinv(G, rcond=1e-12) @ C
        return yy - np.sum(B * C, 0)

    def gain(self, base, extra_options) -> np.ndarray:
        """Per twin: the largest drop of the RSS that one of ``extra_options`` (tuples of terms)
        makes beside ``base`` (the same maximum the recording's claim takes)."""
        r0 = self.rss(tuple(base))
        return np.max([r0 - self.rss(tuple(base) + tuple(o)) for o in extra_options], 0)

    def check(self, stat, samples, alpha=FALSE_ALARM, tail=None) -> Check:
        """``samples``: a statistic of the twins as ``rss`` and ``gain`` give it (the twins
        of the estimated spectrum, then the same twins of the redrawn spectra): judged on a
        scaled F tail (``f_tail``); with ``tail``, that tail on the first half alone."""
        s = np.asarray(samples, float)
        if tail is None:
            thr, p = f_tail(s[:self.n], s[self.n:], stat, alpha)
        else:
            thr, p = tail(s[:self.n], stat, alpha)
        return Check(float(stat), float(thr), float(p), float(alpha), self.n,
                     bool(stat > thr))


def spectrum_draws(spec, k, rng, tapers=TAPERS) -> np.ndarray:
    """``k`` spectra (frequencies x ``k``) as the recording's noise could have had them: the
    multitaper estimate ``spec`` times an independent factor per band of ``tapers + 1``
    frequencies (the estimate's resolution: bands further apart are nearly independent), the
    factor distributed as the estimate's own error, chi-square of 2 ``tapers`` degrees of
    freedom over its mean (mean 1, relative standard deviation 1/sqrt(tapers)).

    One recording holds only a few frequencies below the slowest changes of a plan, and a
    flicker (1/f) noise puts most of its power there: a statistic that lives in those few
    frequencies (a slow drift, a warm-up, an offset between holds) is then as uncertain as
    the spectrum estimated from them. Twins of one fixed estimate treat it as exact and
    state a false-alarm rate they do not hold; twins of these draws carry its uncertainty
    (a parametric bootstrap of the spectrum). A statistic spread over many bands (most
    claims) averages the factors out, its twins unchanged in the mean."""
    spec = np.asarray(spec, float)
    band = tapers + 1
    nb = -(-len(spec) // band)
    f = rng.gamma(tapers, 1.0 / tapers, (nb, k))
    return spec[:, None] * np.repeat(f, band, axis=0)[:len(spec)]


def make_twins(prob, noise_resid, weights, rng=None, n=N_TWINS, keep_noise=False) -> Twins:
    """Twins of ``prob`` (a ``selection.GramProblem``): Gaussian noise with the spectrum of
    ``noise_resid`` (the block residual after the selection; blocks of zero ``weights`` set
    to zero), the Gram products with the problem's columns, per fold."""
    rng = rng or np.random.default_rng(20261126)
    keep = np.asarray(weights) > 0
    N = len(noise_resid)
    spec = noise_spectrum(noise_resid, keep=keep)
    # columns 0..n-1: the twins of the estimated spectrum; n..2n-1: the same draws under
    # redrawn spectra (``spectrum_draws``), for the F tail of every claim (``f_tail``)
    C = [np.zeros((prob.Xs.shape[1], 2 * n)) for _ in range(prob.n_folds)]
    yy = [np.zeros(2 * n) for _ in range(prob.n_folds)]
    keep = [] if keep_noise else None
    for k0 in range(0, n, CHUNK):
        k = min(CHUNK, n - k0)
        z = rng.standard_normal((len(spec), k)) + 1j * rng.standard_normal((len(spec), k))
        for off, sp in ((0, spec), (n, spectrum_draws(spec, k, rng))):
            Y = spectral_noise(sp, N, k, rng, z=z)
            if keep is not None and off == 0:
                keep.append(Y)
            for f, sel in enumerate(prob.fold_slices):
                Yw = Y[sel] * prob.w[sel, None]
                C[f][:, off + k0:off + k0 + k] = prob.Xs[sel].T @ Yw
                yy[f][off + k0:off + k0 + k] = np.einsum("ij,ij->j", Yw, Y[sel])
    return Twins(prob, n, spec, C, yy, np.hstack(keep) if keep else None)


@dataclass
class Judged:
    """Stage ``twins``: the twins, the selection after every named effect was checked against
    them (``S``), each effect's ``checks`` and the effects proposed but ``rejected``."""
    twins: Twins
    S: object
    checks: dict
    rejected: list
    alpha_effect: float
    mix: dict = field(default_factory=dict)


def cross_fitted_residual(prob, y, terms, group) -> np.ndarray:
    """Block residual after ``terms`` (fitted on the whole recording) and ``group`` (the
    operating-point part of the generic basis) fitted, with the terms, on the *other* time
    folds: what repeats across the recording (a function of the operating point, a remainder
    the basis holds) is taken out; what does not repeat (noise of any colour, its slow wander
    included) is kept whole, plus the prediction error of a fit on four fifths of the
    recording (which only makes the twins noisier)."""
    idx_s = [i for t in terms for i in t.cols]
    idx = np.array(idx_s + [i for i in group.cols if i not in idx_s], int)
    r = np.asarray(y, float).copy()
    plain = selection_residual(prob, y, terms)
    w = np.asarray(prob.w, float)
    for f, sl in enumerate(prob.fold_slices):
        G = (prob.Gt - prob.G[f])[np.ix_(idx, idx)]
        c = (prob.ct - prob.c[f])[idx]
        b = np.linalg.lstsq(G, c, rcond=1e-12)[0]
        r[sl] = y[sl] - prob.Xs[sl][:, idx] @ b
        # a fold at operating points the other folds did not visit: the basis fitted there
        # extrapolates and predicts it worse than leaving it out (the selection's residual
        # in sample); the fold then keeps that residual, an upper bound of its noise
        if np.sum(w[sl] * r[sl] ** 2) > np.sum(w[sl] * plain[sl] ** 2):
            r[sl] = plain[sl]
    return r


def selection_residual(prob, y, terms) -> np.ndarray:
    """Block residual after ``terms`` fitted on the whole recording: the noise plus whatever
    remainder the selection leaves. ``cross_fitted_residual`` falls back to it on a fold
    where the basis fitted on the other folds extrapolates (a plan that visits a region of
    its envelope in one fold only: a four-quadrant plan of 60 s gave a cross-fitted residual
    of 134 mN*m against 1.1 mN*m in sample, and twins that hid a 15 % loss error)."""
    idx = np.array([i for t in terms for i in t.cols], int)
    y = np.asarray(y, float)
    if not idx.size:
        return y.copy()
    b = np.linalg.lstsq(prob.Gt[np.ix_(idx, idx)], prob.ct[idx], rcond=1e-12)[0]
    return y - prob.Xs[:, idx] @ b


def _neighbours(options, t) -> list:
    """The terms of ``t``'s effect at the shapes next to ``t``'s on its grid (one step along
    each coordinate of the shape)."""
    opts = [o for o in options.get(t.effect, ()) if o.shape is not None]
    if t.shape is None or len(opts) < 2:
        return []
    vec = lambda s: s if isinstance(s, tuple) else (s,)
    # by value, then by kind: a warm-up's plain time constant and the heat balance's
    # (effects.HeatBalanceTau) of the same value are two shapes, ordered the same in every
    # process (a set's order of equal values follows string hashes, randomised per process)
    axes = [sorted({vec(o.shape)[i] for o in opts}, key=lambda a: (a, type(a).__name__))
            for i in range(len(vec(t.shape)))]
    out = []
    for o in opts:
        d = [abs(axes[i].index(a) - axes[i].index(b))
             for i, (a, b) in enumerate(zip(vec(o.shape), vec(t.shape)))]
        if sorted(d)[-1] == 1 and sum(d) == 1:
            out.append(o)
    return out


def mixes(prob, S, options) -> dict:
    """{term of ``S``: terms of the same effect at other shapes} where the effect fits better
    as a mix of its own law with coefficients of the same sign: at the two grid shapes next to
    its own (a shape between the grid's values), or at any one other shape of its grid (a sum
    of two such laws: a lip seal's Coulomb drag plus a bearing's viscous drag, p = 0 and 1; a
    warm-up of two time constants; two contacts' Stribeck decays). Such a mix is the named
    effect's own form, not physics outside the library: the claims are judged beside it
    (``with_mixes``). The same sign keeps it the effect's own: drag laws of one sign all grow
    with speed and cannot make a Stribeck decay. Only effects of one linear parameter (the
    shaped ones)."""
    out = {}
    for t in S.terms:
        if len(t.cols) != 1:
            continue
        nb = _neighbours(options, t)
        other = [o for o in options.get(t.effect, ()) if o.shape is not None and o != t
                 and len(o.cols) == 1] if t.shape is not None else []
        best = None
        for sub in [(o,) for o in other] + ([tuple(nb)] if len(nb) > 1 else []):
            f = prob.fit(S.terms + sub, cv=False)
            a = f.of(t)[0][0]
            if all(a * f.of(o)[0][0] > 0 for o in sub) and (best is None or f.rss < best[0]):
                best = (f.rss, sub)
        if best is not None:
            out[t] = best[1]
    return out


def with_mixes(terms, mix) -> tuple:
    """``terms`` with the neighbouring-shape term of each that ``mix`` holds."""
    return tuple(terms) + tuple(o for t in terms if t in mix for o in mix[t])


def effect_check(tw, prob, S, t, alpha, options=None, mix=None, mix_t=None) -> Check:
    """Drop-one statistic of term ``t`` of the selection ``S`` (the RSS it removes, with
    ``mix_t`` its own neighbouring shapes, beside the others, each at the mix of adjacent
    shapes it fits best without ``t``, ``mixes``) against the same statistic of the twins."""
    others = tuple(x for x in S.terms if x != t)
    if mix is None:        # the others' mixes as they fit without t
        mix = mixes(prob, prob.fit(others, cv=False), options) if options else {}
    rest = with_mixes(others, mix)
    full = rest + (t,) + tuple(mix_t or ())
    stat = prob.fit(rest, cv=False).rss - prob.fit(full, cv=False).rss
    return tw.check(stat, tw.rss(rest) - tw.rss(full), alpha)


def judge(P, sel) -> Judged:
    """Stage ``twins``: twins of the recording (noise with the spectrum of the residual the
    selection leaves), then every selected effect judged against them at
    ``FALSE_ALARM / K`` (K: the candidate terms the selection chose among); an effect whose
    statistic the twins reach is dropped (the weakest first) and the others judged again."""
    prob, S = sel.prob, sel.S
    tw = make_twins(prob, cross_fitted_residual(prob, P.y, S.terms, P.steady[0]),
                    sel.weights)
    k = max(1, sum(len(v) for v in sel.selectable.values()))
    alpha = FALSE_ALARM / k
    rejected = []
    while True:
        own = mixes(prob, S, sel.opts)
        checks = {t.effect: effect_check(tw, prob, S, t, alpha, sel.opts, mix_t=own.get(t))
                  for t in S.terms}
        # an effect stands beyond its twins and explains, beside the others at their shape
        # mixes, at least the physical limit every term must reach (sel.min_expl, N*m)
        weak = [t for t in S.terms if t.effect not in sel.forced
                and not (checks[t.effect].stands and math.sqrt(
                    max(checks[t.effect].statistic, 0.0) / prob.swt) >= sel.min_expl)]
        if not weak:
            break
        worst = max(weak, key=lambda t: checks[t.effect].p_value)
        rejected.append(worst.effect)
        S = prob.fit(tuple(x for x in S.terms if x != worst))
    return Judged(tw, S, checks, rejected, alpha, mixes(prob, S, sel.opts))
