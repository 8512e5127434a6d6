"""Model the unknown: a sparse closed form for a confirmed remainder (issue 18, item 4).

When the diagnosis confirms a mismatch that no library effect explains, this stage fits a
sparse closed form to it from a dictionary of physically named features and proposes it, with
units, intervals, a reading of what such a form usually is, and its held-out improvement; its
steady part goes into the design (``[[extra.discovered]]``, :mod:`model_core.discovered`),
which the core, both FMUs and the synthesiser evaluate, so that a co-simulation with the
updated design reproduces the recording.

The dictionary (:class:`Library`, PySINDy-style: a list of :class:`Feature` objects with name,
unit, evaluate and reading) holds families of features; within a family the features differ by
a shape (an exponent, a time constant), and a form holds each family at most once:

- ``coulomb``  sgn(w) - a constant loss opposing motion;
- ``speed``    sgn(w) (|w|/300 rad/s)^p, p in ``SPEED_EXPONENTS`` (incl. 2);
- ``load``     sgn(w) (|tau_out|/10 N*m)^q, q in ``LOAD_EXPONENTS`` (incl. 2);
- ``speed*load`` sgn(w) (|w|/300 rad/s)^p (|tau_out|/10 N*m)^q over both grids;
- ``temperature`` sgn(w) (T - T0) and ``temperature (reading)`` (T - T0), with a column;
- ``time``     sgn(w) (t - t0), ``time (reading)`` (t - t0), ``run-in`` sgn(w) exp(-(t-t0)/tau);
- ``acceleration`` dw/dt; ``input torque (reading)`` the model's input torque (with ``model_T_in``);
- ``order 1x`` and ``order roller pass``: (a + b |tau_out|/10 N*m) sin/cos of the order angle.

The sign convention of the loss features is the one of every loss referred to the driving
shaft: the torque takes the sign of the driving speed, so its power T w >= 0 in all four
quadrants (forward, reverse, driving, back-driven); the ``(reading)`` features have no sign
(a transducer's zero does not follow the motion).

Selection (:class:`SparseDiscovery`): forward then backward stepwise selection
(``selection.stepwise``, the library's own rule: a term enters when it lowers the BIC by at
least ``DELTA_BIC`` and explains at least ``min_explained`` N*m of held-out RMS in time-ordered
blocked cross-validation), on block means of the features computed per sample and averaged
exactly as the measurement is. Stability: the selection is repeated with each fold left out
(BIC rule); a term is *stable* when a leave-one-fold-out selection holds the same family at
the same shape or its neighbour on the grid (the grid's resolution: neighbouring exponents are
not told apart by a fold less of data) in more than half of the runs (``MIN_STABILITY``). Only
stable terms are proposed; if none is, nothing is proposed and the remainder stays an honest
"unexplained".
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from model_core.discovered import MAX_TERMS, T_REF, W_REF, DiscoveredTerm
from model_core.effects import roller_pass_order

from . import residual as R
from .replay import SPEED_SMOOTHING, block_means, first_order
from .selection import DELTA_BIC, GramProblem, Term, explained, stepwise

#: exponents of driving speed in the dictionary: 2 is windage/churning, 1 viscous, 1/2 the
#: hydrodynamic film (Petroff at constant load), 3 a fan's power law in torque*speed
SPEED_EXPONENTS = (0.5, 1.0, 1.5, 2.0, 3.0)
#: exponents of the load torque: 1 a load-proportional (Coulomb-in-the-mesh) loss, 2 load
#: squared (deformation, edge loading), 1/2 and 3/2 the Hertzian contact laws
LOAD_EXPONENTS = (0.5, 1.0, 1.5, 2.0, 3.0)
#: grid of the products |w|^p |tau|^q
PRODUCT_EXPONENTS = (0.5, 1.0, 1.5, 2.0)
#: [s] time constants of the run-in features (minutes, as the contacts of a new drive settle)
RUN_IN_TAUS = (60.0, 180.0, 600.0)
#: [1] a term is stable when its family is selected, at its shape or a neighbouring one, in
#: more than this share of the leave-one-fold-out selections ("in most folds")
MIN_STABILITY = 0.5
#: [1] the proposed form must remove at least this share of the remainder's structured held-out
#: RMS (above the noise): 0.5. A form that leaves more than half of it is a fragment, not a
#: model of the unknown, and the structure it leaves (correlated blocks) breaks the
#: independence the BIC assumes, so its evidence and stability are overstated (a loss that is
#: random per hold gets a "stable" linear time trend that removes 3 % of it)
MIN_REMOVED_SHARE = 0.5
#: [N*m] default of the smallest held-out RMS a term must explain (the estimator's
#: ``MIN_EXPLAINED_NM``: 0.5 mN*m, a sixth of the paper bench's transducer noise)
MIN_EXPLAINED_NM = 0.5e-3
#: families the design (core and both FMUs) carries: steady power laws in speed and load
DESIGN_FAMILIES = ("coulomb", "speed", "load", "speed*load")


# -- the dictionary ------------------------------------------------------------------------------
@dataclass(frozen=True)
class Feature:
    """One feature of the dictionary: columns over samples from the signals.

    ``family``: features of one family are alternatives (a form holds one of them);
    ``shape``: the value that tells them apart (exponent(s), time constant) or None;
    ``n_shape``: shape values chosen on a grid (charged in the BIC); ``unit``: the unit of its
    coefficient(s); ``coef_names``: one name per column."""

    family: str
    name: str
    unit: str
    reading: str
    shape: object = None
    n_shape: int = 0
    coef_names: tuple = ("c",)

    def evaluate(self, s: dict) -> np.ndarray:
        """Columns (n_samples, len(coef_names)) of the feature for signals ``s``."""
        return _EVAL[self.family](s, self.shape)


def _sgn(s):
    return np.sign(s["w_in"])


def _u(s):
    return np.abs(s["w_in"]) / W_REF


def _v(s):
    return np.abs(s["tau_out"]) / T_REF


def _order(s, k, q):
    amp = _v(s) ** q if q else 1.0
    th = k * s["theta_in"]
    return np.stack([amp * np.sin(th), amp * np.cos(th)], -1)


_EVAL = {
    "coulomb": lambda s, sh: _sgn(s)[:, None],
    "speed": lambda s, p: (_sgn(s) * _u(s) ** p)[:, None],
    "load": lambda s, q: (_sgn(s) * _v(s) ** q)[:, None],
    "speed*load": lambda s, pq: (_sgn(s) * _u(s) ** pq[0] * _v(s) ** pq[1])[:, None],
    "temperature": lambda s, sh: (_sgn(s) * (s["temperature"] - s["temperature"][0]))[:, None],
    "temperature (reading)": lambda s, sh: (s["temperature"] - s["temperature"][0])[:, None],
    "time": lambda s, sh: (_sgn(s) * (s["t"] - s["t"][0]))[:, None],
    "time (reading)": lambda s, sh: (s["t"] - s["t"][0])[:, None],
    "run-in": lambda s, tau: (_sgn(s) * np.exp(-(s["t"] - s["t"][0]) / tau))[:, None],
    "acceleration": lambda s, sh: s["alpha_in"][:, None],
    "input torque (reading)": lambda s, sh: s["T_in_model"][:, None],
    "order 1x": lambda s, q: _order(s, 1.0, q),
    "order roller pass": lambda s, q: _order(s, s["order_roller"], q),
}


def _speed_reading(p):
    if p >= 2.5:
        return ("grows faster than speed squared: fan-like windage or splash losses of a "
                "large rotating part")
    if p >= 1.75:
        return "grows with speed squared: windage or churning"
    if p >= 1.25:
        return "grows with speed to the 3/2: churning in the transition to turbulent shear"
    if p >= 0.75:
        return "grows in proportion to speed: viscous shear (seals, a bearing's viscous drag)"
    return "grows with the square root of speed: a hydrodynamic film (Petroff-like shear)"


def _load_reading(q):
    if q >= 2.5:
        return "grows steeply with load (cube): a contact or mesh that is overloaded"
    if q >= 1.75:
        return ("grows with load squared: deformation losses, edge loading or misalignment "
                "that grows with the load, or a load-dependent friction coefficient")
    if q >= 1.25:
        return "grows with load to the 3/2: Hertzian rolling resistance (elastic hysteresis)"
    if q >= 0.75:
        return ("grows in proportion to load: a load-dependent (mesh or bearing) friction the "
                "model under-estimates")
    return "grows with the square root of load: rolling resistance of line contacts"


def _reading(family, shape) -> str:
    if family == "coulomb":
        return "a constant loss opposing motion: seal or Coulomb friction"
    if family == "speed":
        return _speed_reading(shape)
    if family == "load":
        return _load_reading(shape)
    if family == "speed*load":
        p, q = shape
        if abs(p - 1) < 0.3 and abs(q - 1) < 0.3:
            return ("grows with speed times load (a share of the transmitted power): a mesh or "
                    "bearing loss in mixed/full-film lubrication, whose friction rises with "
                    "sliding speed")
        return (f"grows with speed^{p:g} and load^{q:g} together: a friction coefficient that "
                "depends on sliding speed under load (elastohydrodynamic or mixed film)")
    return {
        "temperature": "a loss that changes with temperature: lubricant viscosity",
        "temperature (reading)": "the torque reading drifts with temperature: a transducer's "
                                 "zero",
        "time": "a loss that drifts in time at a fixed operating point: wear or warming",
        "time (reading)": "the torque reading drifts in time: a transducer's zero",
        "run-in": "a loss that decays in time with no temperature change: run-in of the "
                  "contacts",
        "acceleration": "proportional to acceleration: an unmodelled inertia",
        "input torque (reading)": "in proportion to the input torque, with its sign: a gain "
                                  "error of the torque transducer, or a loss in proportion to "
                                  "the transmitted torque (alike in forward driving; "
                                  "back-driven runs separate them: a loss changes side, a gain "
                                  "error does not)",
        "order 1x": "once per turn of the driving shaft, its amplitude scaled by the load: "
                    "eccentricity or runout times mesh stiffness",
        "order roller pass": "at the roller-pass order, its amplitude scaled by the load: "
                             "transmission error times mesh stiffness (pitch errors)",
    }[family]


class Library:
    """The dictionary: a list of :class:`Feature` (``features``), grouped into families."""

    def __init__(self, features):
        self.features = list(features)

    @classmethod
    def default(cls, temperature=False, input_torque=False) -> "Library":
        """The physically named dictionary (module docstring); temperature features only when
        the recording has a temperature column, the input torque's reading feature only when
        the model's input torque is given."""
        f = [Feature("coulomb", "sgn(w_in)", "N*m", _reading("coulomb", None))]
        f += [Feature("speed", f"sgn(w_in)*(|w_in|/{W_REF:g} rad/s)^{p:g}", "N*m",
                      _reading("speed", p), p, 1) for p in SPEED_EXPONENTS]
        f += [Feature("load", f"sgn(w_in)*(|tau_out|/{T_REF:g} N*m)^{q:g}", "N*m",
                      _reading("load", q), q, 1) for q in LOAD_EXPONENTS]
        f += [Feature("speed*load", f"sgn(w_in)*(|w_in|/{W_REF:g} rad/s)^{p:g}"
                      f"*(|tau_out|/{T_REF:g} N*m)^{q:g}", "N*m",
                      _reading("speed*load", (p, q)), (p, q), 2)
              for p in PRODUCT_EXPONENTS for q in PRODUCT_EXPONENTS]
        if temperature:
            f += [Feature("temperature", "sgn(w_in)*(T - T0)", "N*m/K",
                          _reading("temperature", None)),
                  Feature("temperature (reading)", "(T - T0)", "N*m/K",
                          _reading("temperature (reading)", None))]
        f += [Feature("time", "sgn(w_in)*(t - t0)", "N*m/s", _reading("time", None)),
              Feature("time (reading)", "(t - t0)", "N*m/s", _reading("time (reading)", None))]
        f += [Feature("run-in", f"sgn(w_in)*exp(-(t - t0)/{tau:g} s)", "N*m",
                      _reading("run-in", tau), tau, 1) for tau in RUN_IN_TAUS]
        f += [Feature("acceleration", "dw_in/dt", "kg*m^2", _reading("acceleration", None))]
        if input_torque:
            f += [Feature("input torque (reading)", "T_in (model)", "1",
                          _reading("input torque (reading)", None))]
        for fam, arg in (("order 1x", "theta_in"), ("order roller pass", "k*theta_in")):
            f += [Feature(fam, (f"(|tau_out|/{T_REF:g} N*m)*" if q else "")
                          + f"[sin, cos]({arg})", "N*m", _reading(fam, q), q, 1,
                          ("sin", "cos")) for q in (0, 1)]
        return cls(f)

    def families(self) -> list:
        return list(dict.fromkeys(x.family for x in self.features))

    def block_columns(self, s: dict, m: int, bandwidth: float = 0.0) -> list:
        """Every feature's columns, computed per sample, filtered like the torque channel
        (first order, ``bandwidth`` Hz) and averaged over blocks of ``m`` samples exactly as the
        measurement is."""
        dt = float(np.median(np.diff(s["t"]))) if len(s["t"]) > 1 else 1.0
        return [block_means(first_order(x.evaluate(s), dt, bandwidth), m)
                for x in self.features]


# -- the sparse fit ------------------------------------------------------------------------------
def _neighbours(library, feature) -> set:
    """Shapes of the feature's family within one grid step of its shape (itself included)."""
    fam = [x.shape for x in library.features if x.family == feature.family]
    if feature.shape is None:
        return {None}
    if isinstance(feature.shape, tuple):
        ps = sorted({s[0] for s in fam})
        qs = sorted({s[1] for s in fam})
        ip, iq = ps.index(feature.shape[0]), qs.index(feature.shape[1])
        return {(ps[a], qs[b]) for a in range(max(ip - 1, 0), min(ip + 2, len(ps)))
                for b in range(max(iq - 1, 0), min(iq + 2, len(qs)))}
    grid = sorted(set(fam))
    i = grid.index(feature.shape)
    return set(grid[max(i - 1, 0):i + 2])


class SparseDiscovery:
    """Sparse selection of dictionary terms for a remainder (module docstring); scikit-learn
    style: ``fit`` returns ``self``; results in ``terms_``, ``fit_``, ``stability_``,
    ``heldout_rms_before_``, ``heldout_rms_after_``, ``refused_``."""

    def __init__(self, library: Library, n_folds: int = 5,
                 min_explained: float = MIN_EXPLAINED_NM, delta_bic: float = DELTA_BIC,
                 min_stability: float = MIN_STABILITY):
        self.library = library
        self.n_folds = n_folds
        self.min_explained = min_explained
        self.delta_bic = delta_bic
        self.min_stability = min_stability

    def fit(self, columns, y, weights=None, nuisance=None) -> "SparseDiscovery":
        """``columns``: per feature of the library, its block-level columns (n_blocks, k);
        ``y``: the block-level remainder (N*m); ``weights``: the blocks' weights (0 excludes a
        spike block; default: ``residual.robust_weights`` of the remainder alone); ``nuisance``:
        block-level columns (n_blocks, k) of the library effects already fitted, refitted
        with every candidate form (a library term that took up part of the unknown gives it
        back; its change is ``nuisance_change_``)."""
        X = np.hstack(columns)
        y = np.asarray(y, float)
        k_n = 0 if nuisance is None else np.asarray(nuisance).reshape(len(y), -1).shape[1]
        if k_n:
            X = np.hstack([np.asarray(nuisance, float).reshape(len(y), -1), X])
        if weights is None:     # spikes and Huber weights judged on the remainder itself
            weights = R.robust_weights(np.ones((len(y), 1)), y)[0]
        prob = GramProblem(X, y, weights, self.n_folds)
        forced = (Term("library", None, tuple(range(k_n)), tuple(f"n{i}" for i in range(k_n)),
                       ("",) * k_n, (-np.inf,) * k_n, (np.inf,) * k_n),) if k_n else ()
        self._forced = forced
        options, self._feature = {}, {}
        k0 = k_n
        for feat, c in zip(self.library.features, columns):
            t = Term(feat.family, feat.shape, tuple(range(k0, k0 + c.shape[1])),
                     feat.coef_names, (feat.unit,) * c.shape[1], (-np.inf,) * c.shape[1],
                     (np.inf,) * c.shape[1], feat.n_shape)
            k0 += c.shape[1]
            options.setdefault(feat.family, []).append(t)
            self._feature[t] = feat
        sel = stepwise(prob, options, self.min_explained, delta_bic=self.delta_bic,
                       forced=forced).fit
        self.selected_ = [t for t in sel.terms if t not in forced]
        # stability: leave one fold out at a time (BIC rule), the same family at the same or a
        # neighbouring shape
        hits = {t: 0 for t in self.selected_}
        for f in range(self.n_folds):
            keep = [g for g in range(self.n_folds) if g != f]
            s = stepwise(prob, options, self.min_explained, folds=keep, cv=False,
                         delta_bic=self.delta_bic, forced=forced).fit
            for t in self.selected_:
                near = _neighbours(self.library, self._feature[t])
                if any(x.effect == t.effect and x.shape in near for x in s.terms):
                    hits[t] += 1
        self.stability_ = {t: hits[t] / self.n_folds for t in self.selected_}
        stable = tuple(t for t in self.selected_ if self.stability_[t] > self.min_stability)
        base = prob.fit(forced)
        self.heldout_rms_before_ = base.cv_rmse
        self.refused_ = ""
        fit = prob.fit(forced + stable) if stable else base
        if stable and not (base.bic - fit.bic >= self.delta_bic
                           and explained(base, fit) >= self.min_explained):
            stable, fit = (), base
            self.refused_ = ("the terms stable across folds do not explain the remainder "
                             "together (BIC and held-out RMS)")
        elif not stable:
            self.refused_ = ("no term of the dictionary is stable across folds"
                             if self.selected_ else "no term of the dictionary explains the "
                             "remainder (BIC and held-out RMS)")
        self.terms_ = list(stable)
        self.nuisance_change_ = (np.asarray(fit.of(forced[0])[0], float) if forced
                                 else np.zeros(0))
        # their standard errors beside the form (wider than alone where the form and a
        # library term share a direction)
        self.nuisance_se_ = (np.asarray(fit.of(forced[0])[1], float) if forced
                             else np.zeros(0))
        self.fit_ = fit
        self.heldout_rms_after_ = fit.cv_rmse
        self.problem_ = prob
        return self

    def feature(self, term) -> Feature:
        return self._feature[term]


# -- the result ----------------------------------------------------------------------------------
@dataclass
class Discovery:
    """What the discovery stage proposes (``to_json``: ``unexplained.proposed``).

    ``proposed`` False: nothing stable was found (``reason`` says why; the remainder stays
    unexplained). ``design_terms``: the steady power-law terms the design carries."""

    proposed: bool
    formula: str | None
    terms: list
    heldout_rms_before_Nm: float
    heldout_rms_after_Nm: float
    noise_Nm: float
    removed_share: float
    reading: str
    reason: str = ""
    design_terms: tuple = ()
    not_in_design: list = field(default_factory=list)
    candidates: list = field(default_factory=list)
    n_folds: int = 5
    prediction: np.ndarray = field(default=None, repr=False)   # block level, N*m
    nuisance_change: list = field(default_factory=list)   # per nuisance column
    nuisance_se: list = field(default_factory=list)       # their standard errors beside it

    def to_json(self) -> dict:
        return {"formula": self.formula, "terms": self.terms,
                "heldout_rms_before_Nm": self.heldout_rms_before_Nm,
                "heldout_rms_after_Nm": self.heldout_rms_after_Nm,
                "noise_Nm": self.noise_Nm, "removed_share": self.removed_share,
                "reading": self.reading, "refused": None if self.proposed else self.reason,
                "stable_share_required": MIN_STABILITY, "n_folds": self.n_folds,
                "candidates": self.candidates,
                "design_terms": [{"coefficient_Nm": t.coefficient,
                                  "speed_exponent": t.speed_exponent,
                                  "load_exponent": t.load_exponent} for t in self.design_terms],
                "not_in_design": self.not_in_design}

    def apply(self, design):
        """``(design, notes)``: ``design`` with the discovered steady terms added to its
        ``[[extra.discovered]]`` (see :func:`apply_terms`)."""
        return apply_terms(design, self.design_terms, self.formula)


def apply_terms(design, terms, formula=None):
    """``(design, notes)``: ``terms`` (DiscoveredTerm) added to the design's discovered terms;
    a term of the same exponents already there is summed with it."""
    from dataclasses import replace
    if not terms:
        return design, []
    have = list(design.extra.discovered)
    for t in terms:
        same = [i for i, h in enumerate(have) if (h.speed_exponent, h.load_exponent)
                == (t.speed_exponent, t.load_exponent)]
        if same:
            h = have[same[0]]
            have[same[0]] = DiscoveredTerm(h.coefficient + t.coefficient, h.speed_exponent,
                                           h.load_exponent)
        else:
            have.append(t)
    notes = []
    if len(have) > MAX_TERMS:
        notes.append(f"only the first {MAX_TERMS} discovered terms kept (a design holds at most "
                     f"{MAX_TERMS})")
        have = have[:MAX_TERMS]
    new = replace(design, extra=replace(design.extra, discovered=tuple(have)))
    notes.append("discovered (outside the library, fitted to the remainder): "
                 + (formula or " + ".join(t.text() for t in terms))
                 + " -> [[extra.discovered]]")
    return new, notes


def _design_term(feature, coef):
    if feature.family == "coulomb":
        return DiscoveredTerm(float(coef[0]), 0.0, 0.0)
    if feature.family == "speed":
        return DiscoveredTerm(float(coef[0]), float(feature.shape), 0.0)
    if feature.family == "load":
        return DiscoveredTerm(float(coef[0]), 0.0, float(feature.shape))
    if feature.family == "speed*load":
        return DiscoveredTerm(float(coef[0]), float(feature.shape[0]), float(feature.shape[1]))
    return None


def _term_text(feature, coef) -> str:
    if len(coef) == 1 and feature.unit == "1":
        return f"{100 * coef[0]:+.4g} % * {feature.name}"
    if len(coef) == 1:
        unit = feature.unit
        scale, shown = (1e3, "mN*m" + unit[3:]) if unit.startswith("N*m") else (1.0, unit)
        return f"{scale * coef[0]:+.4g} {shown} * {feature.name}"
    a = float(np.hypot(*coef))
    return f"{1e3 * a:.4g} mN*m amplitude * {feature.name} (phase {math.atan2(coef[1], coef[0]):+.3f} rad)"


def removed_share(before, after, noise) -> float:
    """Share of the structured held-out RMS a form removes: 1 - sqrt(after^2 - noise^2) /
    sqrt(before^2 - noise^2) (N*m in, 1 out; the noise is the block-level noise of the
    reading, which no form can remove)."""
    return 1.0 - math.sqrt(max(after ** 2 - noise ** 2, 0.0)
                           / max(before ** 2 - noise ** 2, 1e-300))


def discover(residual, t, w_in, T_out, *, samples_per_block=None, block=0.01,
             residual_blocks=None, weights=None, w_out=None, T_in=None, temperature=None,
             model_T_in=None, mode="S1", z1=15, bandwidth=0.0, n_folds=5,
             min_explained=MIN_EXPLAINED_NM, noise=None, library=None,
             nuisance=None) -> Discovery:
    """Fit a sparse closed form to a confirmed remainder and propose it.

    Parameters
    ----------
    residual : array (n_samples,) or None
        The remainder at sample level [N*m]: measured input torque less the fitted model's
        prediction (library effects included). May be None when ``residual_blocks`` is given.
    t, w_in, T_out : arrays (n_samples,)
        The recording's time [s], driving speed [rad/s] and output torque [N*m] (the torque
        the driven shaft delivers; the load torque is ``tau_out = -T_out``).
    samples_per_block : int, optional
        Samples per block of the block means (default ``round(block / dt)``).
    residual_blocks : array (n_blocks,), optional
        The remainder's block means (used as they are, e.g. after the estimator's own
        averaging); default: block means of ``residual``.
    weights : array (n_blocks,), optional
        The blocks' weights from the estimator (0: a spike block); default Huber weights.
    w_out, T_in : arrays, optional
        The other columns (accepted for the stage's contract; the dictionary's features read
        driving speed, load, time, temperature, acceleration and shaft angle).
    model_T_in : array, optional
        The fitted model's input torque [N*m]: with it the dictionary holds a feature in
        proportion to it (a transducer gain error's look-alike of a load-proportional loss).
    temperature : array, optional
        Temperature column [degC or K] (temperature features only with it).
    mode, z1 : the operating mode and ring-roller count (the roller-pass order).
    bandwidth : float
        Torque transducer bandwidth [Hz] the features are filtered with (0: none).
    min_explained : float
        Smallest held-out RMS [N*m] a term must explain (the estimator's threshold).
    noise : float, optional
        Block-level noise of the torque reading [N*m] (for ``removed_share``); default from
        the remainder's block-to-block differences.
    nuisance : array (n_blocks, k), optional
        Block-level columns of the library effects the estimator selected (as in its
        regression problem). They are refitted next to every candidate form: a library term
        that took up part of the unknown gives it back, and its coefficients' change is
        ``Discovery.nuisance_change`` (add it to the fitted values; it is ~0 when the form is
        unrelated to the library terms).
    """
    s, m = _signals(t, w_in, T_out, samples_per_block, block, temperature, model_T_in,
                    mode, z1)
    lib = library or Library.default(temperature is not None, model_T_in is not None)
    cols = lib.block_columns(s, m, bandwidth)
    y = (np.asarray(residual_blocks, float) if residual_blocks is not None
         else block_means(np.asarray(residual, float), m))
    n = min(len(y), len(cols[0]))
    y, cols = y[:n], [c[:n] for c in cols]
    w = None if weights is None else np.asarray(weights, float)[:n]
    nz = None
    if nuisance is not None:
        nz = np.asarray(nuisance, float).reshape(len(nuisance), -1)[:n]
        nz = nz if nz.shape[1] else None
    sd = SparseDiscovery(lib, n_folds, min_explained).fit(cols, y, w, nz)
    if noise is None:
        noise = R.robust_sigma(np.diff(y)) / math.sqrt(2)
    before, after = sd.heldout_rms_before_, sd.heldout_rms_after_
    removed = removed_share(before, after, noise)
    cand = [{"feature": sd.feature(t_).name, "family": t_.effect,
             "stability": sd.stability_[t_]} for t_ in sd.selected_]
    reason = sd.refused_
    if sd.terms_ and removed < MIN_REMOVED_SHARE:
        reason = (f"the best form stable across folds removes {100 * removed:.0f} % of the "
                  f"remainder's structured held-out RMS (at least {100 * MIN_REMOVED_SHARE:.0f} "
                  "% needed): a fragment, not a model of the unknown")
    if reason:
        return Discovery(False, None, [], before, after, noise, removed, "", reason,
                         candidates=cand, n_folds=n_folds)
    terms, texts, readings, design_terms, not_in, pred = _proposed_terms(sd, cols, nz, n)
    formula = "T_extra at the driving shaft = " + " ".join(texts)
    return Discovery(True, formula, terms, before, after, noise, removed,
                     "; ".join(dict.fromkeys(readings)),
                     design_terms=tuple(design_terms[:MAX_TERMS]), not_in_design=not_in,
                     candidates=cand, n_folds=n_folds, prediction=pred,
                     nuisance_change=[float(x) for x in sd.nuisance_change_],
                     nuisance_se=[float(x) for x in sd.nuisance_se_])


def _signals(t, w_in, T_out, samples_per_block, block, temperature, model_T_in, mode, z1):
    """The dictionary's sample-level signals of :func:`discover` and the samples per block."""
    t = np.asarray(t, float)
    w_in = np.asarray(w_in, float)
    dt = float(np.median(np.diff(t)))
    m = int(samples_per_block or max(1, int(round(block / dt))))
    from scipy.ndimage import uniform_filter1d
    w_s = uniform_filter1d(w_in, max(1, int(round(SPEED_SMOOTHING / dt))), mode="nearest")
    theta = np.concatenate([[0.0], np.cumsum(0.5 * (w_in[1:] + w_in[:-1]) * np.diff(t))])
    s = {"t": t, "w_in": w_in, "tau_out": -np.asarray(T_out, float),
         "alpha_in": np.gradient(w_s, t), "theta_in": theta,
         "order_roller": roller_pass_order(mode, z1),
         "temperature": None if temperature is None else np.asarray(temperature, float),
         "T_in_model": None if model_T_in is None else np.asarray(model_T_in, float)}
    return s, m


def _proposed_terms(sd, cols, nz, n):
    """The fitted sparse form ``sd`` as report terms, formula texts, readings, design terms,
    the features the design cannot carry, and its block-level prediction."""
    terms, texts, readings, design_terms, not_in = [], [], [], [], []
    pred = np.zeros(n)
    X = np.hstack(([nz] if nz is not None and nz.size else []) + cols)
    for t_ in sd.terms_:
        feat = sd.feature(t_)
        v, se = sd.fit_.of(t_)
        pred += X[:, list(t_.cols)] @ v
        for name, val, e in zip(feat.coef_names, v, se):
            terms.append({"feature": feat.name + ("" if len(v) == 1 else f" [{name}]"),
                          "family": feat.family, "coefficient": float(val), "unit": feat.unit,
                          "ci95": [float(val - 1.96 * e), float(val + 1.96 * e)],
                          "stability": sd.stability_[t_], "reading": feat.reading})
        texts.append(_term_text(feat, v))
        readings.append(feat.reading)
        dt_ = _design_term(feat, v)
        if dt_ is not None:
            design_terms.append(dt_)
        else:
            not_in.append(feat.name)
    return terms, texts, readings, design_terms, not_in, pred


# -- closure: the friction level and the discovered coefficients made consistent -------------------
#: Gauss-Newton steps of :func:`refine_closure` (each a replay of the recording with the model's
#: friction sensitivity): the friction level is nonlinear in the model, so a correction of
#: 10 % taken from one linearisation misses by about a percent; two steps settle it
REFINE_STEPS = 2


def refine_closure(design, rec, mode, bandwidth, samples_per_block, weights,
                   steps=REFINE_STEPS):
    """``design`` with its friction level (ln of a factor, ``scale_friction_level``) and the
    coefficients of its discovered terms refitted together on the recording by Gauss-Newton
    (the replay's own sensitivity to ln mu_boundary, the terms' own columns), so that a
    discovered form next to a friction level corrected from one linearisation closes the
    recording. Returns the design (unchanged when it has no discovered terms)."""
    import math as _m
    from dataclasses import replace

    from model_core.design import scale_friction_level
    from model_core.discovered import term_torque

    from .replay import replay
    if not design.extra.discovered:
        return design
    m = samples_per_block
    dt = float(np.median(np.diff(rec.time)))
    w = np.asarray(weights, float)
    for _ in range(steps):
        rp = replay(design, mode, rec, bandwidth, calibration=False)   # (not read here)
        s = rp.signals
        y = block_means(rec.torque_in - first_order(rp.T_model, dt, bandwidth), m)
        g = 1.0 + design.extra.torque_in_gain_error
        cols = [s["sens_mu"] * g] + [g * term_torque(s["w_in"], s["tau_out"], k.speed_exponent,
                                                     k.load_exponent)
                                     for k in design.extra.discovered]
        X = block_means(first_order(np.stack(cols, -1), dt, bandwidth), m)
        n = min(len(y), len(w))
        Xw = X[:n] * w[:n, None]
        delta = np.linalg.lstsq(Xw.T @ X[:n], Xw.T @ y[:n], rcond=1e-12)[0]
        terms = tuple(DiscoveredTerm(k.coefficient + float(d), k.speed_exponent,
                                     k.load_exponent)
                      for k, d in zip(design.extra.discovered, delta[1:]))
        design = replace(scale_friction_level(design, _m.exp(float(delta[0]))),
                         extra=replace(design.extra, discovered=terms))
    return design
