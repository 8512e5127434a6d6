"""Choosing the set of effects the data supports.

Every candidate fit is weighted least squares on block means. All of them come from the
Gram matrices of the full column set, accumulated per time-ordered fold once: a subset's fit,
its residual sum of squares and its blocked cross-validation error then cost a solve of a few
unknowns, so forward and backward stepwise selection, the stability of the selection across
folds and the look-alike tests are cheap even for an hour at 10 kHz.

Proposal rules (named, with their units, in ``select_effects``; the twins of stage
``twins`` then judge every proposed effect): a term enters when it lowers the
BIC by at least ``DELTA_BIC`` ('very strong' evidence on the Kass-Raftery scale) *and* the
held-out RMS it explains is at least ``min_explained`` N*m (long recordings make tiny,
meaningless terms significant), and only while its parameters lie inside their physical
bounds (a fit outside them is not that effect).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

#: 'very strong' evidence on the Kass-Raftery scale (2 ln Bayes factor > 10)
DELTA_BIC = 10.0


@dataclass(frozen=True)
class Term:
    """One candidate column group: an effect at one shape value."""
    effect: str
    shape: float | None
    cols: tuple                # column indices into the problem's matrix
    names: tuple               # parameter names
    units: tuple
    lower: tuple
    upper: tuple
    n_shape: int = 0           # 1 when a shape value was chosen on a grid


@dataclass
class Fit:
    terms: tuple
    coef: np.ndarray           # in column order of the terms
    #: the standard errors (``se``), or what they are computed from when first read:
    #: (G, sigma2, scale) (a selection fits thousands of subsets and reads the errors of a few)
    _se: object
    rss: float                 # weighted
    cv_mse: float              # weighted held-out mean square (blocked folds)
    bic: float
    admissible: bool

    @property
    def se(self) -> np.ndarray:
        """Standard errors of ``coef`` (noise only): sqrt(diag(sigma2 pinv(G))) / scale."""
        if not isinstance(self._se, np.ndarray):
            G, sigma2, scale = self._se
            try:
                cov = sigma2 * np.linalg.pinv(G) if len(G) else np.zeros((0, 0))
                se = np.sqrt(np.clip(np.diag(cov), 0, None))
            except np.linalg.LinAlgError:
                se = np.full(len(G), np.nan)
            self._se = se / scale if len(G) else se
        return self._se

    @property
    def cv_rmse(self) -> float:
        return math.sqrt(max(self.cv_mse, 0.0))

    def of(self, term) -> tuple:
        """(values, standard errors) of one term."""
        i = 0
        for t in self.terms:
            k = len(t.cols)
            if t == term:
                return self.coef[i:i + k], self.se[i:i + k]
            i += k
        raise KeyError(term.effect)

    @property
    def ids(self) -> list:
        return [t.effect for t in self.terms]


def _lstsq_kernel():
    """``numpy.linalg.lstsq``'s compiled loop (LAPACK ``gelsd``), called without the wrapper's
    checks and conversions: a selection fits tens of thousands of subsets of a few unknowns
    (a four-quadrant recording with a refined Stribeck friction: 27 000), and the wrapper
    costs as much as the solve. Checked once against ``numpy.linalg.lstsq`` (the same
    numbers, a full-rank and a rank-deficient matrix); None where it is not found or differs
    (another numpy): then the public function."""
    try:
        from numpy.linalg import _umath_linalg
        kernel = _umath_linalg.lstsq
        A = np.array([[4.0, 1.0, 0.5], [1.0, 3.0, 0.25], [0.5, 0.25, 2.0]])
        D = np.array([[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [3.0, 6.0, 9.5]])
        for G in (A, D, A[:1, :1]):
            c = np.arange(1.0, len(G) + 1)
            x = kernel(G, c[:, None], 1e-12, signature="ddd->ddid")[0][:, 0]
            if not np.array_equal(x, np.linalg.lstsq(G, c, rcond=1e-12)[0]):
                return None
        return kernel
    except (ImportError, AttributeError, TypeError, ValueError, np.linalg.LinAlgError):
        return None


_LSTSQ = []


def _svd_failed(err, flag):
    raise np.linalg.LinAlgError("SVD did not converge in Linear Least Squares")


def lstsq(G, c, rcond=1e-12):
    """``np.linalg.lstsq(G, c, rcond)[0]`` for a float matrix ``G`` (k x k, k >= 1) and vector
    ``c``: the same numbers and the same error (``LinAlgError`` where the SVD does not
    converge), a third of the time for a few unknowns (``_lstsq_kernel``)."""
    if not _LSTSQ:
        _LSTSQ.append(_lstsq_kernel())
    kernel = _LSTSQ[0]
    if kernel is None:
        return np.linalg.lstsq(G, c, rcond=rcond)[0]
    # numpy.linalg.lstsq's floating-point error handling around its loop
    with np.errstate(call=_svd_failed, invalid="call", over="ignore", divide="ignore",
                     under="ignore"):
        return kernel(G, c[:, None], rcond, signature="ddd->ddid")[0][:, 0]


def _sub(G, idx):
    """``G[np.ix_(idx, idx)]``, the same array, in a third of its time (fits are many)."""
    return G.take(idx, 0).take(idx, 1)


class GramProblem:
    """Weighted least squares ``y ~ X b`` over blocks, with time-ordered folds."""

    def __init__(self, X, y, weights, n_folds=5, out=None):
        """``out``: an array of ``X``'s shape and dtype to hold the scaled columns (``Xs``),
        written over (fresh memory costs the kernel's zeroing of its pages)."""
        n = len(y)
        self.n_folds = n_folds
        folds = np.minimum((np.arange(n) * n_folds) // max(n, 1), n_folds - 1)
        w = np.asarray(weights, float)
        # scale columns to unit weighted RMS: the Gram matrices stay well conditioned
        # ((w[:, None] * X * X).sum(0) without its two n x k temporaries: einsum forms the
        # same products and sums the rows in the same order)
        scale = np.sqrt(np.maximum(np.einsum("i,ij,ij->j", w, X, X) / max(w.sum(), 1e-300),
                                   1e-300))
        self.scale = scale
        Xs = X / scale if out is None or out.shape != X.shape or out.dtype != X.dtype \
            or not out.flags.c_contiguous else np.divide(X, scale, out=out)
        self.G, self.c, self.yy, self.sw = [], [], [], []
        # kept for the twins (``twins.make_twins``): scaled and weighted columns, the folds
        self.Xs, self.w = Xs, w
        bounds = np.searchsorted(folds, np.arange(n_folds + 1))
        self.fold_slices = [slice(int(bounds[f]), int(bounds[f + 1])) for f in range(n_folds)]
        for f in range(n_folds):
            sel = self.fold_slices[f]
            Xf, yf, wf = Xs[sel], y[sel], w[sel]
            Xw = Xf * wf[:, None]
            self.G.append(Xw.T @ Xf)
            self.c.append(Xw.T @ yf)
            self.yy.append(float(wf @ (yf * yf)))
            self.sw.append(float(wf.sum()))
        self._sums = {}
        self.Gt, self.ct = sum(self.G), sum(self.c)
        self.yyt, self.swt = sum(self.yy), sum(self.sw)
        self.n = int(np.count_nonzero(w > 0))

    @staticmethod
    def _solve(G, c):
        if len(c) == 0:
            return np.zeros(0)
        return lstsq(G, c)

    def _totals(self, fs):
        """(G, c, yy, sw) summed over the folds ``fs``, once per set of folds (a selection
        fits thousands of subsets on the same folds)."""
        key = tuple(fs)
        got = self._sums.get(key)
        if got is None:
            got = (sum(self.G[f] for f in fs), sum(self.c[f] for f in fs),
                   sum(self.yy[f] for f in fs), sum(self.sw[f] for f in fs))
            self._sums[key] = got
        return got

    def fit(self, terms, folds=None, cv=True) -> Fit:
        """Fit a set of terms; ``folds``: restrict to these folds (stability), else all."""
        idx = np.array([i for t in terms for i in t.cols], int)
        fs = range(self.n_folds) if folds is None else list(folds)
        Gs, cs, yy, sw = self._totals(fs)
        G = _sub(Gs, idx) if len(idx) else np.zeros((0, 0))
        c = cs[idx] if len(idx) else np.zeros(0)
        b = self._solve(G, c)
        rss = max(yy - 2 * b @ c + b @ G @ b, 1e-300)
        k = len(idx) + sum(t.n_shape for t in terms)
        n = max(int(round(self.n * sw / self.swt)), k + 2)
        bic = n * math.log(rss / sw) + k * math.log(n)
        cv_mse = float("nan")
        if cv:
            err = 0.0
            for f in fs:
                Gtr, ctr = G - _sub(self.G[f], idx), c - self.c[f][idx]
                bf = self._solve(Gtr, ctr)
                err += self.yy[f] - 2 * bf @ self.c[f][idx] + bf @ _sub(self.G[f], idx) @ bf
            cv_mse = max(err, 0.0) / sw
        sigma2 = rss / max(sw - len(idx), 1.0)
        coef = b / self.scale[idx] if len(idx) else b
        # the standard errors when first read (``Fit.se``)
        se = (G, sigma2, self.scale[idx] if len(idx) else None)
        lo = [v for t in terms for v in t.lower]
        hi = [v for t in terms for v in t.upper]
        if len(lo) == len(hi) == len(idx):   # (a few values: compared in Python, the same test)
            admissible = all(a <= v <= z for v, a, z in zip(coef.tolist(), lo, hi))
        else:
            admissible = bool(np.all((coef >= np.array(lo)) & (coef <= np.array(hi))))
        return Fit(tuple(terms), coef, se, float(rss), cv_mse, float(bic), admissible)


    def rss_fixed(self, terms, fixed, value: float) -> float:
        """Weighted residual sum of squares of the fit of ``terms`` with the one coefficient of
        ``fixed`` (a term of ``terms`` with one column) held at ``value`` (in its own unit) and
        the others fitted: the same Gram matrices, ``y - value x`` regressed on the rest."""
        (j,) = fixed.cols
        idx = np.array([i for t in terms if t != fixed for i in t.cols], int)
        b = value * self.scale[j]                 # in the scaled columns
        G, c = self.Gt, self.ct
        yy = self.yyt - 2 * b * c[j] + b * b * G[j, j]
        if not len(idx):
            return max(float(yy), 1e-300)
        cr = c[idx] - b * G[idx, j]
        Gr = _sub(G, idx)
        br = self._solve(Gr, cr)
        return max(float(yy - 2 * br @ cr + br @ Gr @ br), 1e-300)


def explained(before: Fit, after: Fit) -> float:
    """Held-out RMS (N*m) a change of the model explains: sqrt(cv_mse before - after)."""
    return math.sqrt(max(before.cv_mse - after.cv_mse, 0.0))


@dataclass
class Selection:
    fit: Fit
    path: list = field(default_factory=list)     # (step, effect, shape, bic, cv_rmse)


def stepwise(problem: GramProblem, options: dict, min_explained: float, folds=None,
             cv=True, delta_bic=DELTA_BIC, forced=(), start=()) -> Selection:
    """Forward selection then backward elimination over the effects in ``options``
    ({effect: [Term, ...] over its shapes}); each effect enters at most once, at its best
    shape. With ``cv=False`` (stability runs) the rule is the BIC alone. ``forced`` terms are
    in from the start and never dropped; ``start`` terms are in from the start and may be
    dropped by the backward pass."""
    def ok(before, after):
        if before.bic - after.bic < delta_bic:
            return False
        return (not cv) or explained(before, after) >= min_explained

    forced = tuple(forced)
    cur = problem.fit(forced + tuple(start), folds, cv)
    path = [("start", "none", None, cur.bic, cur.cv_rmse)]
    while True:
        best = None
        for eid, terms in options.items():
            if eid in cur.ids:
                continue
            here = None
            for term in terms:
                f = problem.fit(cur.terms + (term,), folds, cv=False)
                if f.admissible and (here is None or f.bic < here.bic):
                    here = f
            if here is None:
                continue
            # each candidate is judged with the shapes of the terms already in re-chosen
            # beside it: a shape chosen alone may stand in for the newcomer (a Stribeck speed
            # stretched over a zero offset in a forward-only plan), and the comparison is then
            # between the wrong shape with and without the newcomer
            here = _reshape(problem, here, options, folds, cv=False)
            if best is None or here.bic < best.bic:
                best = here
        if best is None:
            break
        if cv:
            best = problem.fit(best.terms, folds, cv=True)
        if not ok(cur, best):
            break
        cur = best
        # re-choose the shapes of the terms already in, given the new one
        cur = _reshape(problem, cur, options, folds, cv)
        t = cur.terms[-1]
        path.append(("add", t.effect, t.shape, cur.bic, cur.cv_rmse))
    changed = True
    while changed and cur.terms:
        changed = False
        for t in cur.terms:
            if t in forced:
                continue
            rest = problem.fit(tuple(x for x in cur.terms if x != t), folds, cv=False)
            # the others at their best shapes without it (as a newcomer is judged)
            rest = _reshape(problem, rest, options, folds, cv=False)
            if cv:
                rest = problem.fit(rest.terms, folds, cv=True)
            if rest.admissible and not ok(rest, cur):
                cur = rest
                path.append(("drop", t.effect, t.shape, cur.bic, cur.cv_rmse))
                changed = True
                break
    return Selection(cur, path)


def _reshape(problem, cur, options, folds, cv):
    for i, t in enumerate(cur.terms):
        if len(options.get(t.effect, ())) < 2:
            continue
        best = cur
        for alt in options[t.effect]:
            if alt == t:
                continue
            terms = cur.terms[:i] + (alt,) + cur.terms[i + 1:]
            f = problem.fit(terms, folds, cv=False)
            if f.admissible and f.bic < best.bic:
                best = f
        if best is not cur:
            cur = problem.fit(best.terms, folds, cv)
    return cur
