"""The diagnosis as an estimator: ``Diagnoser(design, mode).fit(recording)`` returns itself with
the result in ``diagnosis_``. It orchestrates the stages, each a module of this package with a
typed result:

1. ``replay`` (``problem.build_problem`` -> ``Problem``): the model replayed per sample, block
   means of measurement and model taken alike, the samples where the model jumps not compared;
2. ``select`` (``select_effects.select`` -> ``Selected``): robust weights, stepwise selection
   on BIC and blocked cross-validation, stability across folds, drifts set aside; the friction
   level re-linearised once (the two stages run again at the corrected level) when it is off by
   more than ``FRICTION_RELINEARISE``;
3. ``twins`` (``twins.judge`` -> ``Judged``): twins of the recording (its inputs through the
   fitted model, noise from its own residual), every named effect judged against them at the
   false-alarm rate ``twins.FALSE_ALARM``;
4. ``remainder`` (``remainder.remainder`` -> ``Remainder``): smooth structure, shaft orders,
   bursts at events and spectral peaks, each judged against twins; effects the unknown could
   hold withdrawn;
5. ``discover`` (``discover.discover``, when that module exists): a closed form for a
   confirmed remainder, put in ``unexplained.proposed``. Before it, the library's steady loss
   laws (``RIVALLED``: the calibration effects and the drag) are chosen again side by side
   with the dictionary's load laws (``_calibration_against_rivals``): one the joint selection
   does not keep stood in for a loss of another law and stages 2-5 run again without it; then a
   calibration effect
   (``mesh_loss``, ``idle_loss_scale``: candidates unless ``calibrate=False``) that stands is
   put against the dictionary's closed form for what it holds (``_calibration_against_forms``,
   BIC): where the form wins, the calibration effects stood in for a loss of another law and
   stages 2-5 run again without them; the calibration effects that stand and moved far are
   then re-linearised (``_relinearise_calibration``: replay at the corrected calibration,
   stages 2-5 again with them forced, Gauss-Newton; a whole change that does not earn its
   place there is taken back, ``_whole_change_unsupported``);
6. ``report`` (``result.report`` -> ``Diagnosis``).
"""
from __future__ import annotations

import math
import re
from dataclasses import replace

import numpy as np

from model_core import DriveDesign
from model_core.errors import CycloidInputError
from model_core.effects import (CALIBRATION_EFFECTS, CALIBRATION_FIELDS, DEFAULT_CANDIDATES,
                                HeatBalanceTau,
                                EFFECTS)
from model_core.kinematics import parse_mode

from . import residual as R
from .problem import MIN_LOAD, build_problem, refine_problem
from .remainder import PEAK_MIN_AMPLITUDE_NM, remainder
from .replay import Replay, block_means, first_order, replay
from .result import Diagnosis, DiagnosisError, headline, report, zeta_d
from .sample_orders import name_ripple
from .select_effects import MIN_EXPLAINED_NM, select
from .selection import DELTA_BIC
from .twins import FALSE_ALARM, N_TWINS, judge

#: [1] re-linearise the friction level (replay again at the corrected mu) beyond this error
FRICTION_RELINEARISE = 0.02
#: [1] re-linearise a calibration effect (replay again at the corrected calibration, its
#: sensitivities taken there) beyond these changes. The mesh loss enters the model as
#: 1/(1 - k): a step dk taken from the slope at k misses by about dk^2 (4e-6 at 0.002, below
#: the interval of k that a minute of recording gives, about 1e-5). The idle losses enter
#: linearly but share their speed laws with the gear's flow direction: 0.1 of the scale; the
#: load-loss scale enters through the fixed point (nearly linear, replay.LOAD_SCALE_STEP): 0.05
CAL_RELINEARISE = {"mesh_loss": 0.002, "idle_loss_scale": 0.1, "load_loss_scale": 0.05}
#: the dictionary's families (discover.Library) whose forms grow with the load: a form that a
#: calibration effect may have stood in for must hold one of them (a form of speed alone is a
#: drag, a library effect the selection weighs against the idle-loss scale itself)
LOAD_FAMILIES = ("load", "speed*load")
#: the dictionary's families (discover.Library) a closed form put against the calibration
#: effects holds: what a free loss scale can stand in for. A calibration effect scales the
#: model's own losses, a steady function of the operating point (speed, load and, through the
#: viscosity, temperature) with the sign of the motion. It cannot make a shaft-order ripple, a
#: drift of the reading or in time at a fixed operating point, or an inertia torque (a form
#: with the roller-pass ripple that the selection's mesh_ripple already carried won on BIC
#: against the mesh loss it did not replace)
STAND_IN_FAMILIES = ("coulomb", "speed", "load", "speed*load", "temperature")
#: the families of laws of speed alone: the load-independent losses. Held to the sign of a
#: loss in a form put against the calibration effects: a negative law of speed alone removes
#: load-independent loss the model has, which is the idle-loss scale's own physics (its change
#: below zero), not a loss outside the library (the model's idle losses removed as a negative
#: Coulomb and speed law beside a load-cubed term beat a true idle-loss scale of -1)
SPEED_FAMILIES = ("coulomb", "speed")
#: the library's steady loss laws chosen again beside the dictionary's load laws
#: (``Diagnoser._calibration_against_rivals``): the free scales of the model's own losses and
#: the drag, a law of speed alone. Their laws over speed and load are fixed by the physics;
#: a loss of another law that grows with the load is taken up by them in part
RIVALLED = CALIBRATION_EFFECTS + ("load_independent_loss",)
#: the note of a loss law withdrawn beside the load laws (kept over the viscosity's passes)
RIVAL_NOTE = "chosen again side by side with the load laws of the discovery's dictionary"
#: of those, the effects with a shape chosen on a grid (all shapes are candidates there)
SHAPED_LAWS = ("load_independent_loss",)
#: re-linearisation passes of the calibration at most (Gauss-Newton on the replay; the
#: preset mackic-rig from the default design, k 0 -> 0.027 and the idle scale 1 -> 0.03,
#: settles in two)
CAL_PASSES = 3
#: pairs of effects that are two forms of one physics (the first as the selection may name
#: it, the other tried in its place): the load-independent losses as the model's own laws
#: scaled (idle_loss_scale, one parameter) or as a drag of free speed law
#: (load_independent_loss); ``Diagnoser._other_form``. One way only: the free law is the
#: more general form; a drag that leaves a remainder is not replaced by the model's own laws
#: (which then meet the closed forms of ``_calibration_against_forms`` and, withdrawn there,
#: left a worse selection on an independent recording of a gain error beside a drag)
SAME_PHYSICS = (("idle_loss_scale", "load_independent_loss"),)
#: [1] re-linearise the viscosity drift beyond this difference between its fitted change of
#: ln(viscosity) and the size its basis was taken at (0 first: the design's viscosity). The
#: input torque is not linear in ln(nu): a drift of ln 0.5 leaves a term beyond the linear one
#: of about a fifth of it (1.1-1.3 mN*m unexplained on independent recordings). Re-linearised,
#: the drift's basis is the secant of the model's response at the fitted size (a quadratic in
#: ln(nu) through replays at the drift's middle and end: ``effects._viscosity``,
#: ``lossmap.viscosity_steps``); the secant iteration stops within 0.01 of its fixed point:
#: twice the 95 % half-width of the fitted change on the independent recordings (0.005 on
#: 3-5 minutes), and below 1.5 % of a drift of ln 0.5
VISCOSITY_RELINEARISE = 0.01
#: re-linearisation passes of the viscosity drift at most (a secant iteration; two settle a
#: drift of ln 0.5 on the independent recordings)
NU_PASSES = 3
#: [1 per 10 K] a warm-up driven by the loss power (``effects.HeatBalanceTau``) is evaluated
#: again at its fitted size c where it lies this far from the size its columns were built at:
#: the heat that warms the housing is the loss, warm-up included, so the rise of a warm-up of
#: size c is the model's rise times about (1 + c g) (g the rise per 10 K). 0.005 per 10 K
#: changes the rise by at most 0.5 % per 10 K of it, below the 95 % half-width of the fitted
#: size on the independent recordings (0.0004-0.002 per 10 K); passes at most: NU_PASSES
HEAT_RELINEARISE = 0.005
#: [s] at least this much moving recording (below it nothing can be separated)
MIN_MOVING_S = 2.0
#: [rad/s] a recording whose input never exceeds this speed (about 10 r/min) stands still
MIN_SPEED = 1.0

__all__ = ["Diagnoser", "Diagnosis", "DiagnosisError", "zeta_d", "FALSE_ALARM", "N_TWINS",
           "MIN_EXPLAINED_NM", "MIN_LOAD", "PEAK_MIN_AMPLITUDE_NM"]


class Diagnoser:
    """Locate, explain and model the mismatch between a recording and the model.

    Parameters
    ----------
    design : DriveDesign
        The model (its ``[extra]`` physics and transducer corrections included).
    mode : str
        Operating mode of the recording, e.g. ``"S1"``.
    bandwidth : float
        Transducer bandwidth [Hz] the model's torque is filtered with before comparing.
    block : float
        Block length [s] of the means the fits work on.
    n_folds : int
        Time-ordered folds of the cross-validation.
    candidates : sequence of str, optional
        Effect ids to consider (default: ``DEFAULT_CANDIDATES``, the whole registry; without
        ``calibrate`` less the ``CALIBRATION_EFFECTS``).
    calibrate : bool
        The calibration effects (mesh loss k, idle-loss scale: model_core.effects) are
        candidates (default True; False leaves them out, ``diagnose --no-calibrate``).
    progress : bool
        A progress bar over the fit's stages on stderr (terminals only).
    """

    def __init__(self, design: DriveDesign = None, mode: str = "S1", bandwidth: float = 1000.0,
                 block: float = 0.01, n_folds: int = 5, candidates=None, progress=False,
                 calibrate=True):
        self.design = design or DriveDesign()
        self.mode = "".join(parse_mode(mode)[:2])
        self.bandwidth = bandwidth
        self.block = block
        self.n_folds = n_folds
        self.candidates = tuple(c for c in (candidates or DEFAULT_CANDIDATES)
                                if c != "none" and (calibrate or c not in CALIBRATION_EFFECTS))
        self.progress = progress
        self._bar = None
        #: set on the second pass of ``_decide_beside_form`` (the design carries the proposed
        #: form; no discovery and no closed-form competition there)
        self._beside_form = False
        #: effects selected on their coarse shape grid whose finer one (``Effect.refine``) is
        #: scanned from then on (``_refine``)
        self._refined = {}

    def _stage(self, name):
        if self._bar is not None:
            self._bar.set_description(name)
            self._bar.update(1)

    def problem(self, rec):
        """The regression problem of ``rec`` under the Diagnoser's design (stage ``replay``)."""
        return build_problem(rec, self.design, self.mode, self.candidates, self.bandwidth,
                             self.block, refined=self._refined)

    def _check(self, rec):
        t, w = rec.time, rec.speed_in
        if len(t) < 10:
            raise DiagnosisError(f"nothing to diagnose: {len(t)} samples")
        peak = float(np.max(np.abs(w)))
        if peak < MIN_SPEED:
            raise DiagnosisError(f"nothing to diagnose: the input shaft stands still (peak "
                                 f"|speed| {peak * 30 / math.pi:.3g} r/min)")
        dt = float(np.median(np.diff(t)))
        moving = float(np.count_nonzero(np.abs(w) > R.MOVING_SHARE * peak)) * dt
        if moving < MIN_MOVING_S:
            raise DiagnosisError(f"nothing to diagnose: {moving:.3g} s of moving recording "
                                 f"(at least {MIN_MOVING_S:g} s needed)")
        if len(t) * dt < 5 * self.block * self.n_folds:
            raise DiagnosisError(f"nothing to diagnose: {len(t) * dt:.3g} s is too short for "
                                 f"{self.n_folds} folds of {self.block:g} s blocks")

    def fit(self, rec) -> "Diagnoser":
        """Diagnose ``rec`` (a ``cyclo_fmu.recordings.Recording`` in SI units); the result is
        ``self.diagnosis_``.

        The linear algebra runs on one BLAS thread: a multi-threaded BLAS sums in an order that
        depends on the thread count, and a diagnosis must give the same numbers in a terminal,
        on a dask worker and on another machine (the fits are small; one thread costs little)."""
        from threadpoolctl import threadpool_limits
        with threadpool_limits(limits=1, user_api="blas"):
            return self._fit(rec)

    def _fit(self, rec) -> "Diagnoser":
        import sys
        from tqdm import tqdm
        self._check(rec)
        self._bar = tqdm(total=7, leave=False, unit=" stages", desc="replay",
                         disable=not (self.progress and sys.stderr.isatty()))
        self._refined = {}
        #: calibration effects that stood in for a loss of another law (``_judge``): no
        #: candidates of the later passes (the calibration's re-linearisation among them)
        self._stood_in = set()
        P0 = self.problem(rec)
        self._stage("select")
        first = select(P0, self.n_folds)
        P0, first = self._refine(rec, P0, first)
        P, sel, rel1 = P0, first, 0.0
        fr = first.friction
        if fr is not None and abs(fr[0]) > FRICTION_RELINEARISE:
            from model_core.design import scale_friction_level
            rel1 = float(fr[0])
            # the first analysis's columns are not needed again (its fits keep their Gram
            # matrices): freed before the second replay, which would hold both at its peak
            P0.X, first.prob.Xs = None, None
            P = build_problem(rec, scale_friction_level(self.design, 1 + rel1), self.mode,
                              self.candidates, self.bandwidth, self.block,
                              # the friction level's own sensitivity is reused (forced, it
                              # is a nuisance there); the viscosity's is taken again at the
                              # corrected level (a drift acting through it changes with it)
                              (P0.sig["sens_mu"], None), reuse=P0, refined=self._refined)
            # of the first replay's sample-level signals only the sensitivities are read again
            # (residual_rms, the report's friction and calibration torques): the
            # others (~50 MB at 600 000 samples) are released before the later stages' peaks
            P0.sig = {k: P0.sig[k] for k in ("sens_mu", "sens_nu", "sens_k", "sens_idle",
                                             "sens_load") if k in P0.sig}
            P0.rp = Replay(P0.rp.T_model, P0.sig)
            sel = select(P, self.n_folds, forced=("friction_miscalibrated",))
        self.calibration_offsets_ = {}
        P, sel, J, rem = self._judge(rec, P, sel, rel1)
        if self._relinearise_needed(rem):
            # the claims are judged (twins, remainder, discovery) at the first linearisation;
            # the calibration effects that stand there are re-linearised for their values and
            # the stages run again around the corrected calibration
            notes = self._notes
            P, sel, self.calibration_offsets_ = self._relinearise_calibration(
                rec, P, sel, rem, rel1)
            P, sel, J, rem = self._judge(rec, P, sel, rel1, compete=False)
            self._notes = notes + [n for n in self._notes if n not in notes]
        if self._viscosity_far(P, rem.S):
            notes = self._notes
            P, sel, J_nu, rem = self._relinearise_viscosity(rec, P, sel, rem, rel1)
            J = J_nu or J       # None where no pass could be replayed
            self._notes = notes + [n for n in self._notes if n not in notes]
        if self._heat_far(P, rem.S):
            notes = self._notes
            P, sel, J, rem = self._relinearise_heat(rec, P, sel, rem, rel1)
            self._notes = notes + [n for n in self._notes if n not in notes]
        rem.unexplained["_rejected"] = J.rejected
        self._stage("report")
        d = report(rec, first, sel, J, rem, P, rel1, P0, self.calibration_offsets_)
        # stage ``orders``: the library's orders the block means cannot resolve, at sample level
        self._stage("orders")
        d = name_ripple(d, P, rem, self.n_folds)
        d.notes += self._notes
        d.stages = {"replay": P, "select": sel, "twins": J, "remainder": rem}
        if not self._beside_form:
            self._decide_beside_form(rec, d)
        self.diagnosis_ = d
        self._bar.close()
        self._bar = None
        self._rec, self._P0, self._weights = rec, P0, first.weights
        return self

    def _refine(self, rec, P0, first):
        """An effect selected on its coarse shape grid that has a finer one (``Effect.refine``:
        the Stribeck friction's transition width through a speed reversal) is scanned on the
        finer grid from here on, its other shape parameters chosen again: the problem gets
        those columns (the same replay, the other columns reused) and the selection is
        repeated. The whole finer grid stays a candidate of every later selection, so that
        the twins (stage ``twins``) are judged by the same scan as the recording (measured:
        keeping only the best refined shape made the twins stiffer than the recording's own
        fit and a 0.64 mN*m remainder of a drag of another law stood out). Returns ``(P0,
        first)``, unchanged where nothing is refined."""
        refined = {t.effect: EFFECTS[t.effect].shapes(P0.sig, around=t.shape)
                   for t in first.S.terms if EFFECTS[t.effect].refine is not None}
        if not refined:
            return P0, first
        self._refined = refined
        P1 = refine_problem(P0, self.candidates, refined)
        # the coarse problem's matrix and its selection's scaled columns are not read again
        # (the refined problem holds its own copy): freed before the selection's peak, which
        # would hold both (about 100 MB at 600 000 samples)
        P0.X, first.prob.Xs = None, None
        return P1, select(P1, self.n_folds)

    def _judge(self, rec, P, sel, rel1, compete=True):
        # compete: True (the loss laws against the dictionary's load laws and the calibration
        # effects against the closed form), "rivals" (the former only), False (neither)
        """Stages ``twins``, ``remainder`` and ``discover`` on one selection (with
        ``compete``, the calibration effects against the closed forms before the discovery);
        returns ``(P, sel, J, rem)``."""
        self._stage("twins")
        J = judge(P, sel)
        self._stage("remainder")
        rem = remainder(P, sel, J, rec, self.design, self.mode)
        alt = self._other_form(rec, P, sel, rem)
        if alt is not None:
            P, sel, J, rem = alt
        self._stage("discover")
        self._prob, self._notes = sel.prob, []
        if self._beside_form:
            return P, sel, J, rem
        out = self._calibration_against_forms(rec, P, sel, rem, forms=compete is True) \
            if compete else None
        if out is not None:
            # the calibration effects stood in for a form outside the library: the stages run
            # again without them as candidates (what a diagnose --no-calibrate sees), and the
            # discovery stage proposes the form
            ids, note, text, drop = out
            self._stood_in |= set(drop)
            P = replace(P, options={k: v for k, v in P.options.items() if k not in drop})
            sel = select(P, self.n_folds, forced=tuple(f for f in sel.forced
                                                      if f not in drop))
            P, sel, J, rem = self._judge(rec, P, sel, rel1, compete=False)
            rem.withdrawn += [e for e in ids if e not in rem.withdrawn]
            un = rem.unexplained
            if un.get("present"):
                un["statement"] = un["statement"].rstrip(".") + "; " + text + "."
            self._notes.append(note)
            return P, sel, J, rem
        self._discover(rec, P, sel, rem, rel1)
        return P, sel, J, rem

    def _other_form(self, rec, P, sel, rem):
        """Two forms of one physics (``SAME_PHYSICS``): where the selection's form of it leaves
        a remainder beyond the twins, the other form is tried in its place (the selection run
        again without the first as a candidate); it is taken where the recording then lies
        within its twins. The selection's BIC chooses between forms that both (or neither)
        leave the recording within its twins. Returns ``(P, sel, J, rem)`` or None."""
        if not rem.unexplained.get("present"):
            return None
        ids = set(rem.S.ids)
        for first, other in SAME_PHYSICS:
            if first not in ids or other in ids or not P.options.get(other):
                continue
            P2 = replace(P, options={k: v for k, v in P.options.items() if k != first})
            sel2 = select(P2, self.n_folds, forced=tuple(f for f in sel.forced if f != first))
            if other not in sel2.S.ids:
                continue
            J2 = judge(P2, sel2)
            rem2 = remainder(P2, sel2, J2, rec, self.design, self.mode)
            if not rem2.unexplained.get("present"):
                return P2, sel2, J2, rem2
        return None

    def _calibration_against_forms(self, rec, P, sel, rem, forms=True):
        """A calibration effect against the closed forms of the discovery's dictionary.

        The calibration effects are free scales of the model's own losses; a loss outside
        the library that grows with the load or the speed (a load-squared or speed-times-load
        loss) is taken up by them in large part, and what is left may lie within the twins.
        So the recording is asked which explains it better: the selection as it is (model A),
        or the selection without its calibration effects and with the sparse closed form the
        discovery stage fits to what they held (model B, its own effects refitted beside the
        form). B replaces them only where its BIC is lower by ``selection.DELTA_BIC``
        ("very strong" evidence; its parameters counted as two per coefficient, a value and a
        shape chosen on a grid, so that a tie keeps the library's physical effect). The
        calibration effects are then withdrawn, the remainder is reported as unexplained and
        the discovery stage proposes the form. The dictionary holds only what a loss scale
        can stand in for (``STAND_IN_FAMILIES``), its laws of speed alone with the sign of a
        loss (``SPEED_FAMILIES``: a negative one is fitted again without them)."""
        S = rem.S
        cal = [t for t in S.terms if t.effect in CALIBRATION_EFFECTS]
        # a calibration effect fitted beyond its re-linearisation step meets the laws as a
        # fixed part of the model: at that distance its column's error is a smooth function
        # of the operating point that a generic law takes up (the mackic-rig preset, k 0 ->
        # 0.027 and the idle scale 1 -> 0.03, lost its mesh loss to |tau_out|^1 by 2844 in
        # BIC); its whole change is judged at the corrected calibration
        # (``_whole_change_unsupported``)
        far = {e for e, v in self._calibration_values(S).items() if abs(v) > CAL_RELINEARISE[e]}
        named = [t for t in S.terms if t.effect in RIVALLED and t.effect not in far]
        if not named or rem.residual_raw is None:
            return
        try:
            from .discover import Library, discover  # noqa: F401 (the stage is optional)
        except ImportError:
            return
        fr = sel.opts.get("friction_miscalibrated")
        extra = [fr[0]] if fr and "friction_miscalibrated" not in S.ids else []
        # the model's own friction level beside them (a loss scale of the whole gear is in
        # large part a friction level; it must not count for the form). Not while a
        # viscosity drift is fitted far from the size its column was taken at: its
        # linearisation error is a smooth function of the operating point that a generic law
        # takes up (a drag lost to a speed*load law by 40 000 in BIC beside a drift of
        # ln 0.21); the drift's passes meet the laws at its fitted size
        if not self._viscosity_far(P, S):
            beaten = self._calibration_against_rivals(
                rec, P, sel, extra + [t for t in S.terms if t not in named], named)
            if beaten is not None:
                return beaten
        if not cal or not forms:
            return
        other = extra + [t for t in S.terms if t not in cal]
        ocols = [c for t in other for c in t.cols]
        back = np.zeros(len(rec.time))
        for t in cal:
            v, _ = S.of(t)
            back += first_order(EFFECTS[t.effect].basis(P.sig, t.shape), P.dt,
                                self.bandwidth) @ v
        d = self._stand_in_form(rec, P, sel, rem.residual_raw + back, ocols)
        if d is None:
            return
        # model A holds the whole calibration family (the pair the design carries), B the form
        for eid in CALIBRATION_EFFECTS:
            if eid not in S.ids and sel.opts.get(eid):
                cal = cal + [sel.opts[eid][0]]
        fit_a, fit_b = _form_against(P, sel, other, cal, d, self.n_folds)
        gap = fit_a.bic - fit_b.bic
        if gap < DELTA_BIC:
            return
        ids = [t.effect for t in cal if t.effect in S.ids]
        rms = float(np.sqrt(np.mean(block_means(back, P.m) ** 2)))
        text = (f"{' and '.join(ids)} ({1e3 * rms:.2f} mN*m) stood in for it: the proposed "
                f"closed form explains that part better (BIC lower by {gap:.0f})")
        note = (f"{', '.join(ids)} withdrawn: the sparse closed form of the discovery's "
                f"dictionary explains what {'it' if len(ids) == 1 else 'they'} held better (BIC "
                f"{fit_b.bic:.1f} against {fit_a.bic:.1f}, at least {DELTA_BIC:g} lower "
                "needed); a free loss scale stands in for a loss of another law")
        return ids, note, text, CALIBRATION_EFFECTS

    def _calibration_against_rivals(self, rec, P, sel, other, named):
        """The library's steady loss laws chosen again with generic load laws as rivals.

        A calibration effect scales the model's own loss map and the drag is a law of speed
        alone: their laws over speed and load are fixed by the physics (``RIVALLED``). A loss
        of another law that grows with the load (the load or speed*load families of the
        discovery's dictionary, ``LOAD_FAMILIES``) is taken up by them in part, and beside them
        what is left can lie within the twins. So the selection is run once more from the
        other named effects (``other``, forced; the friction level among them), with the
        rivalled effects and the dictionary's load laws as candidates side by side
        (``selection.stepwise``: BIC by ``DELTA_BIC`` and ``min_explained`` of held-out RMS to
        enter or stay). A law of the dictionary counts its exponent(s) as parameters chosen on
        a grid, and it must be a loss (coefficient >= 0: a negative one removes loss the model
        has, the loss scales' own physics). The laws replace the library's effects only on
        very strong evidence: the joint selection's BIC must be lower by ``DELTA_BIC`` than
        that of the same selection with the library's effects alone as candidates (a tie, a
        law that is a scale's own look-alike in this recording, keeps the library's effect).
        A named effect (``named``) not chosen there stood in for a loss of another law:
        ``(ids, note, text, drop)`` for the stages to run again without the rivalled effects
        the joint selection did not choose (``drop``: another scale would take the withdrawn
        one's place), else None."""
        from dataclasses import replace as _replace
        from .discover import Library, _signals
        from .selection import GramProblem, Term, stepwise
        s, m = _signals(rec.time, rec.speed_in, rec.torque_out, P.m, self.block, None, None,
                        self.mode, self.design.z1)
        feats = [f for f in Library.default().features if f.family in LOAD_FAMILIES]
        cols = Library(feats).block_columns(s, m, self.bandwidth)
        n = min(len(P.y), len(cols[0]))
        ids = {t.effect for t in named}
        family = {}
        for e in RIVALLED:      # a named one at its shape, or over its grid where it has one
            if any(t.effect == e for t in other):
                continue
            mine = [t for t in named if t.effect == e]
            grid = list(sel.opts.get(e) or ()) if (e in SHAPED_LAWS or not mine) else []
            family[e] = list(dict.fromkeys(mine + grid))
        family = {e: v for e, v in family.items() if v}
        own = list(dict.fromkeys(c for t in other for c in t.cols))
        own += list(dict.fromkeys(c for v in family.values() for t in v for c in t.cols
                                  if c not in own))
        at = {c: i for i, c in enumerate(own)}
        X = np.column_stack([P.X[:n, own]] + [c[:n].reshape(n, -1) for c in cols])
        prob = GramProblem(X, P.y[:n], np.asarray(sel.weights, float)[:n], self.n_folds)

        def moved(t):
            return _replace(t, cols=tuple(at[c] for c in t.cols))
        forced = tuple(moved(t) for t in other)
        mine = {e: [moved(t) for t in v] for e, v in family.items()}
        options, i = dict(mine), len(own)
        for f in feats:
            options.setdefault(f"law: {f.family}", []).append(
                Term(f"law: {f.family}", f.shape, (i,), (f.name,), ("N*m",), (0.0,),
                     (np.inf,), f.n_shape))
            i += 1
        got = stepwise(prob, options, sel.min_expl, cv=True, forced=forced).fit
        gone = [e for e in ids if e not in got.ids]
        laws = [x for x in got.terms if x.effect.startswith("law: ")]
        if not gone or not laws:
            return None
        lib_only = stepwise(prob, mine, sel.min_expl, cv=True, forced=forced).fit
        gap = lib_only.bic - got.bic
        if gap < DELTA_BIC:
            return None
        drop = tuple(e for e in RIVALLED if e not in got.ids)
        law = ", ".join(x.names[0] for x in laws)
        text = (f"{' and '.join(gone)} stood in for it: a load law of another form ({law}) "
                "takes its place when both are candidates (BIC and held-out error)")
        note = (f"{', '.join(gone)} withdrawn: {RIVAL_NOTE}, the recording prefers {law} to "
                f"{'it' if len(gone) == 1 else 'them'} (BIC lower by {gap:.0f} than with the "
                f"library's effects alone, at least {DELTA_BIC:g} needed; held-out error); a "
                "steady loss law of the library stood in for a loss of another law")
        return gone, note, text, drop

    def _stand_in_form(self, rec, P, sel, resid, ocols):
        """The discovery's sparse closed form of what the calibration effects held
        (``resid``: the remainder with their part added back), from the families a loss scale
        can stand in for (``STAND_IN_FAMILIES``; a negative law of speed alone is fitted again
        without ``SPEED_FAMILIES``); None where no form holding a law of the load is proposed
        (a law of speed alone is the library's drag, which the selection already put against
        the idle-loss scale on the recording's BIC)."""
        from .discover import Library, discover
        temperature = getattr(rec, "temperature", None)
        features = Library.default(temperature is not None).features

        def closed_form(families):
            # without the feature in proportion to the model's input torque: it is a library
            # effect (torque_sensor_gain, the calibration's look-alike where power flows one
            # way: LOOKALIKE_GROUPS), not a form outside the library
            return discover(resid, rec.time, rec.speed_in, rec.torque_out,
                            samples_per_block=P.m, weights=sel.weights,
                            temperature=temperature, mode=self.mode, z1=self.design.z1,
                            bandwidth=self.bandwidth, n_folds=self.n_folds,
                            min_explained=sel.min_expl, noise=P.noise_sample / math.sqrt(P.m),
                            library=Library([f for f in features if f.family in families]),
                            nuisance=P.X[:, ocols] if ocols else None, model_T_in=None)

        d = closed_form(STAND_IN_FAMILIES)
        if d.proposed and any(t["family"] in SPEED_FAMILIES and t["coefficient"] < 0
                              for t in d.terms):
            d = closed_form(tuple(f for f in STAND_IN_FAMILIES if f not in SPEED_FAMILIES))
        if not d.proposed or d.prediction is None:
            return None
        if not {t["family"] for t in d.terms} & set(LOAD_FAMILIES):
            return None
        return d

    def _decide_beside_form(self, rec, d):
        """The named effects decided again with the proposed closed form in the model.

        The selection names library effects before the discovery stage exists: an effect that
        only took up part of a loss outside the library (a free loss scale such as the friction
        level takes up a share of any loss that grows with the load, and its re-linearisation
        then carries that share into every later stage) stands there beside a remainder the
        form explains. So the form is put into the design (``[[extra.discovered]]``, as the
        updated design carries it: replayed through the same core, not a linear column beside
        a stale linearisation) and the stages replay, select, twins and remainder run again on
        the recording; an effect named before that is not named there (nor, for the friction
        level, kept in its calibration) stood in for the form and is withdrawn. The
        unexplained remainder, its claims and the proposal stay the first pass's (they are the
        evidence for the form). Skipped where the form holds terms the design cannot carry."""
        prop = d.unexplained.get("proposed") or {}
        named = [e["id"] for e in d.effects]
        if d.calibration and "friction_miscalibrated" not in named:
            named.append("friction_miscalibrated")
        if (not d.unexplained.get("present") or not prop.get("formula") or not named
                or not prop.get("design_terms") or prop.get("not_in_design")):
            return
        from .report import _discovered
        design, _ = _discovered(self.design, prop)
        two = Diagnoser(design, self.mode, self.bandwidth, self.block, self.n_folds,
                        candidates=self.candidates)
        two._beside_form = True
        try:
            d2 = two.fit(rec).diagnosis_
        except DiagnosisError:
            return
        kept = {e["id"] for e in d2.effects} | ({"friction_miscalibrated"}
                                                if d2.calibration else set())
        gone = [e for e in named if e not in kept]
        if not gone:
            return
        d.effects = [e for e in d.effects if e["id"] not in gone]
        if "friction_miscalibrated" in gone:
            d.calibration = {}
        close = d.effects[0].get("indistinguishable_from", []) if d.effects else []
        (d.effect, d.effect_description, d.parameters, d.indistinguishable_from,
         d.suggested_test) = headline(d.effects, d.calibration, close)
        d.withdrawn = list(d.withdrawn) + [e for e in gone if e not in d.withdrawn]
        change = prop.get("library_change") or {}
        prop["library_change"] = {k: v for k, v in change.items() if k not in gone}
        un = d.unexplained
        un["statement"] = un["statement"].rstrip(".") + "; " + ", ".join(gone) + (
            " stood in for it: not named beside the proposed form (the stages run again with "
            "the form in the design).")
        d.notes.append(f"{', '.join(gone)} withdrawn: with the proposed closed form in the "
                       "design (replayed through the core) the selection, its twins and the "
                       "remainder do not name " + ("it" if len(gone) == 1 else "them")
                       + "; it took up part of the loss the form describes")

    @staticmethod
    def _viscosity_far(P, S):
        c = next((float(S.of(t)[0][0]) for t in S.terms if t.effect == "viscosity_drift"),
                 None)
        return (c is not None and bool(P.options.get("viscosity_drift"))
                and abs(c - (P.sig.get("nu_secant") or 0.0)) > VISCOSITY_RELINEARISE)

    def _relinearise_viscosity(self, rec, P, sel, rem, rel1):
        """The viscosity drift evaluated at its fitted size: its columns become the secant of
        the model's second-order response in ln(viscosity) through 0 and the fitted change
        (``effects._viscosity``: the quadratic in ln(nu) through replays at the design's
        viscosity, half the fitted change and the whole of it, ``lossmap.viscosity_steps``),
        the selection and the stages after it run again; repeated while the fitted change
        moves by more than ``VISCOSITY_RELINEARISE`` (``NU_PASSES`` at most). The replay of
        the recording itself is not repeated: two replays on the sensitivity grid per pass,
        the columns rebuilt in place. Returns ``(P, sel, J, rem)``."""
        from model_core.design import scale_friction_level
        from model_core.effects import viscosity_span
        from model_core.lossmap import viscosity_steps
        from .problem import masked_means
        eff = EFFECTS["viscosity_drift"]
        J = None
        kept, gone = [], []
        for _ in range(NU_PASSES):
            if not self._viscosity_far(P, rem.S):
                break
            t = next(t for t in rem.S.terms if t.effect == "viscosity_drift")
            c = float(rem.S.of(t)[0][0])
            design = scale_friction_level(self.design, 1 + rel1) if rel1 else self.design
            try:
                P.sig["nu_steps"] = viscosity_steps(design, self.mode, rec.speed_in,
                                                    -rec.torque_out,
                                                    c * viscosity_span(P.sig, t.shape))
            except CycloidInputError as err:
                # the fitted change takes the lubricant where the design refuses it (thinner
                # than any oil): the drift stays at its linearisation, and the note says so
                self._notes.append(
                    f"viscosity_drift kept at its linearisation: its fitted change of "
                    f"ln(viscosity) {c:+.3g} cannot be replayed ({err}); a drift that large "
                    "is doubtful")
                break
            P.sig["nu_secant"] = c
            n = len(P.y) * P.m
            sig = {k: (v[:n] if isinstance(v, np.ndarray) and v.shape[:1] == rec.time.shape
                       else v) for k, v in P.sig.items()}
            for t in P.options["viscosity_drift"]:
                P.X[:, list(t.cols)] = masked_means(first_order(
                    eff.basis(sig, t.shape), P.dt, P.bandwidth), P.mask[:n], P.m)
            sel = select(P, self.n_folds, forced=sel.forced)
            # the loss laws meet the dictionary's load laws here, once the drift's column is
            # taken at its fitted size (``_calibration_against_rivals``)
            P, sel, J, rem = self._judge(rec, P, sel, rel1, compete="rivals")
            # a loss law withdrawn beside the load laws in an earlier pass stays reported
            # (each pass starts its notes anew)
            kept += [x for x in self._notes if RIVAL_NOTE in x and x not in kept]
            gone += [e for e in rem.withdrawn if e in self._stood_in and e not in gone]
        rem.withdrawn += [e for e in gone if e not in rem.withdrawn and e not in rem.S.ids]
        self._notes += [x for x in kept if x not in self._notes]
        return P, sel, J, rem

    @staticmethod
    def _heat_far(P, S):
        c = next((float(S.of(t)[0][0]) for t in S.terms if t.effect == "thermal_drift"
                  and isinstance(t.shape, HeatBalanceTau)), None)
        return c is not None and abs(c - (P.sig.get("heat_secant") or 0.0)) > HEAT_RELINEARISE

    def _relinearise_heat(self, rec, P, sel, rem, rel1):
        """The warm-up driven by the loss power evaluated at its fitted size c: its columns
        become the rise of the heat balance heated by the loss with that warm-up in it
        (``effects.heat_balance_rise``, ``heat_secant``: what the FMUs' heat balance does),
        the selection and the stages after it run again; repeated while c moves by more than
        ``HEAT_RELINEARISE`` (``NU_PASSES`` at most). Returns ``(P, sel, J, rem)``."""
        from .problem import masked_means
        eff = EFFECTS["thermal_drift"]
        J = None
        for _ in range(NU_PASSES):
            if not self._heat_far(P, rem.S):
                break
            t = next(t for t in rem.S.terms if t.effect == "thermal_drift")
            P.sig["heat_secant"] = float(rem.S.of(t)[0][0])
            n = len(P.y) * P.m
            sig = {k: (v[:n] if isinstance(v, np.ndarray) and v.shape[:1] == rec.time.shape
                       else v) for k, v in P.sig.items()}
            for t in P.options["thermal_drift"]:
                if isinstance(t.shape, HeatBalanceTau):
                    P.X[:, list(t.cols)] = masked_means(first_order(
                        eff.basis(sig, t.shape), P.dt, P.bandwidth), P.mask[:n], P.m)
            sel = select(P, self.n_folds, forced=sel.forced)
            P, sel, J, rem = self._judge(rec, P, sel, rel1, compete=False)
        return P, sel, J, rem

    @staticmethod
    def _calibration_values(S):
        return {t.effect: float(S.of(t)[0][0]) for t in S.terms
                if t.effect in CALIBRATION_EFFECTS}

    def _relinearise_needed(self, rem):
        return any(abs(v) > CAL_RELINEARISE[e]
                   for e, v in self._calibration_values(rem.S).items())

    def _relinearise_calibration(self, rec, P, sel, rem, rel1):
        """Gauss-Newton on the calibration: the calibration effects that stand after the
        judged stages (``rem.S``) are applied to the design, the replay taken again there
        (its sensitivities with it) and the selection run again with them forced (their claim
        was judged at the first linearisation; here they carry the correction); repeated
        while a change exceeds ``CAL_RELINEARISE`` (at most ``CAL_PASSES``). A calibration
        effect the stages withdrew is no candidate any more; one whose whole change does not
        earn its place at the corrected linearisation (``_whole_change_unsupported``) is taken
        back out of the design and the selection run once more. Returns ``(P, sel, offsets)``,
        ``offsets`` {effect: change applied to the design}: the reported value is the offset
        plus the last pass's change."""
        from model_core.design import scale_friction_level
        base = scale_friction_level(self.design, 1 + rel1) if rel1 else self.design
        design = base
        values = self._calibration_values(rem.S)
        dropped = set(self._calibration_values(sel.S)) - set(values)
        candidates = tuple(c for c in self.candidates
                           if c not in dropped and c not in self._stood_in)
        offsets = {}
        # the selection is taken at the design that carries ``offsets`` (else the whole
        # changes cannot be judged there: a change clipped at its bounds ends the passes
        # before the replay)
        at_offsets = False
        for _ in range(CAL_PASSES):
            moved = False
            for eid, v in values.items():
                name = CALIBRATION_FIELDS[eid]
                old = getattr(design.calibration, name)
                design, _ = EFFECTS[eid].apply(design, {EFFECTS[eid].parameters[0].name: v})
                applied = getattr(design.calibration, name) - old   # clipped at the bounds
                if abs(applied) > 0:
                    offsets[eid] = offsets.get(eid, 0.0) + applied
                    moved = moved or abs(applied) > CAL_RELINEARISE[eid]
                    at_offsets = False
            if not moved:
                break
            sens = (P.sig["sens_mu"], None) if P.sig.get("sens_mu") is not None else None
            P.X, sel.prob.Xs = None, None
            P = build_problem(rec, design, self.mode, candidates, self.bandwidth,
                              self.block, sens, refined=self._refined)
            forced = tuple(dict.fromkeys(tuple(sel.forced) + tuple(offsets)))
            sel = select(P, self.n_folds, forced=forced)
            at_offsets = True
            values = {e: v for e, v in self._calibration_values(sel.S).items()
                      if e in offsets}
            if not any(abs(v) > CAL_RELINEARISE[e] for e, v in values.items()):
                break
        gone = self._whole_change_unsupported(sel, offsets) if at_offsets else []
        if gone:
            # the replay at the corrected calibration does not support these changes: the
            # design goes back to its own value of them, and they are no candidates any more
            offsets = {e: v for e, v in offsets.items() if e not in gone}
            design = base
            for eid, v in offsets.items():
                design, _ = EFFECTS[eid].apply(design, {EFFECTS[eid].parameters[0].name: v})
            candidates = tuple(c for c in candidates if c not in gone)
            P.X, sel.prob.Xs = None, None
            P = build_problem(rec, design, self.mode, candidates, self.bandwidth, self.block,
                              (P.sig["sens_mu"], None) if P.sig.get("sens_mu") is not None
                              else None, refined=self._refined)
            forced = tuple(f for f in dict.fromkeys(tuple(sel.forced) + tuple(offsets))
                           if f not in gone)
            sel = select(P, self.n_folds, forced=forced)
            self._notes.append(
                f"{', '.join(gone)} not named: at the corrected calibration (the replay "
                "re-linearised there) the whole change it was given no longer earns its place "
                "(BIC and the explained RMS, as any effect must to be proposed); it held what "
                "the first linearisation of the other effects left")
        return P, sel, offsets

    @staticmethod
    def _whole_change_unsupported(sel, offsets):
        """The re-linearised calibration effects (``offsets``: their changes applied to the
        design) whose whole change, the offset plus the last pass's correction, the recording
        does not support at the corrected linearisation. A claim made at the first
        linearisation may have held what that linearisation got wrong of the others (a
        run-in scales the model's losses, a mesh loss among them: their product is second
        order and appears once the mesh loss is in the replay); so the whole change is judged
        there by the rule every effect meets to be proposed (``selection.DELTA_BIC`` against
        the fit with the effect at the design's own value, the correction ``-offset``, and at
        least ``select_effects.MIN_EXPLAINED_NM`` explained). Returns the effect ids."""
        prob, S = sel.prob, sel.S
        gone = []
        for t in S.terms:
            if t.effect not in offsets or len(t.cols) != 1:
                continue
            rss0 = prob.rss_fixed(S.terms, t, -offsets[t.effect])
            n = max(prob.n, 3)
            gain = n * math.log(rss0 / S.rss) - math.log(n)
            rms = math.sqrt(max(rss0 - S.rss, 0.0) / max(prob.swt, 1e-300))
            if gain < DELTA_BIC or rms < sel.min_expl:
                gone.append(t.effect)
        return gone

    def _discover(self, rec, P, sel, rem, rel1):
        """Stage ``discover``: a sparse closed form fitted to a confirmed smooth remainder by
        ``cyclo_fmu.diagnosis.discover.discover`` when that module exists (else skipped), its
        JSON with ``library_change`` (what the selected effects' values become next to it) in
        ``unexplained.proposed``."""
        if not (rem.unexplained["present"] and rem.smooth):
            return
        try:
            from .discover import discover
        except ImportError:
            return
        S = rem.S
        cols = [c for t in S.terms for c in t.cols]
        self.discovery_ = d = discover(
            rem.residual_raw, rec.time, rec.speed_in, rec.torque_out, samples_per_block=P.m,
            weights=sel.weights, temperature=getattr(rec, "temperature", None),
            mode=self.mode, z1=self.design.z1, bandwidth=self.bandwidth,
            n_folds=self.n_folds, min_explained=sel.min_expl,
            noise=P.noise_sample / math.sqrt(P.m), nuisance=P.X[:, cols] if cols else None,
            model_T_in=P.T_model_f)
        out = d.to_json()
        if d.proposed:
            self._withdraw_stand_ins(P, rem, d, S)
            S = rem.S
        change, i = {}, 0
        for t in S.terms:      # the selected effects' parameter changes next to the form
            k = len(t.cols)
            scale = (1 + rel1) if (t.effect == "friction_miscalibrated" and rel1) else 1.0
            if d.proposed and not d.not_in_design:   # applied with a form the design carries
                change[t.effect] = {n: scale * v for n, v in
                                    zip(t.names, d.nuisance_change[i:i + k])}
            i += k
        out["library_change"] = change
        rem.unexplained["proposed"] = out

    def _withdraw_stand_ins(self, P, rem, d, S):
        """A calibration effect refitted beside the proposed form (the discovery's nuisance
        change) that falls within its 95 % interval of zero, its re-linearisation offset
        included, stood in for the form (a free loss scale takes up part of any loss that
        grows with the load): withdrawn, and its columns' change dropped from the form's
        ``library_change``. The interval is the joint fit's of the form and the library
        terms (noise only)."""
        out, i, keep = [], 0, []
        for t in S.terms:
            k = len(t.cols)
            v, _ = S.of(t)
            if t.effect in CALIBRATION_EFFECTS and k == 1:
                whole = self.calibration_offsets_.get(t.effect, 0.0) + float(v[0])
                beside = whole + d.nuisance_change[i]
                if abs(beside) <= 1.96 * d.nuisance_se[i]:
                    out.append((t.effect, whole, beside))
                    i += k
                    continue
            keep.append((t, i))
            i += k
        if not out:
            return
        idx = [j for t, i0 in keep for j in range(i0, i0 + len(t.cols))]
        d.nuisance_change = [d.nuisance_change[j] for j in idx]
        d.nuisance_se = [d.nuisance_se[j] for j in idx]
        rem.S = self._prob.fit(tuple(t for t, _ in keep))
        gone = {e for e, _, _ in out}
        rem.dominant = [x for x in rem.dominant
                        if (x if isinstance(x, str) else x[0]) not in gone]
        un = rem.unexplained
        un["statement"] = re.sub(r" \(beside [^)]*\)", "", un["statement"])
        un["statement"] = un["statement"].rstrip(".") + "; " + ", ".join(sorted(gone)) + (
            " stood in for it and is withdrawn (a form is proposed).")
        for eid, whole, beside in out:
            rem.withdrawn.append(eid)
            self._notes.append(
                f"{eid} withdrawn: it stood in for the proposed form (its change "
                f"{whole:+.4g} falls to {beside:+.2g} beside the form, within its 95 % "
                "interval of zero); a free loss scale takes up part of any loss that grows "
                "with the load")

    def residual_rms(self, design: DriveDesign) -> float:
        """RMS (N*m) of the block-mean residual of the fitted recording under ``design`` (its
        extra physics and transducer corrections included), robust weights and spike
        exclusions of the diagnosis applied: how well a design explains the recording."""
        rec, P0 = self._rec, self._P0
        w = self._weights
        if design == self.design:          # the first replay's residual
            return float(np.sqrt(np.sum(w * P0.y ** 2) / max(np.sum(w), 1e-300)))
        rp = replay(design, self.mode, rec, self.bandwidth,
                    (P0.sig["sens_mu"], P0.sig["sens_nu"]), calibration=False)
        from .problem import masked_means
        n = len(P0.y) * P0.m
        y = masked_means((rec.torque_in - first_order(rp.T_model, P0.dt, self.bandwidth))[:n],
                         P0.mask[:n], P0.m)
        return float(np.sqrt(np.sum(w * y * y) / max(np.sum(w), 1e-300)))

    def updated_design(self):
        """``(design, notes)``: the diagnosis's design (``report.updated_design``), kept only
        if it explains the recording at least as well as the design the diagnosis started
        from; otherwise the starting design with a note saying why."""
        from .report import updated_design
        fixed, notes = updated_design(self.design, self.diagnosis_)
        if fixed == self.design:
            return fixed, notes
        if fixed.extra.discovered != self.design.extra.discovered:
            # a discovered form (diagnosis.discover): friction level and its coefficients
            # refitted together on the recording (closure)
            from .discover import refine_closure
            fixed = refine_closure(fixed, self._rec, self.mode, self.bandwidth,
                                   self._P0.m, self._weights)
            notes = notes + [
                "refitted with the discovered form on the recording: friction.mu_boundary "
                f"{fixed.friction.mu_boundary:.6g}, discovered coefficients "
                + ", ".join(f"{1e3 * k.coefficient:.4g} mN*m" for k in fixed.extra.discovered)]
        before, after = self.residual_rms(self.design), self.residual_rms(fixed)
        self.diagnosis_.design_check = {"rms_given_Nm": before, "rms_updated_Nm": after}
        if after > before:
            return self.design, notes + [
                f"the updated design would fit worse (residual RMS {1e3 * after:.3f} against "
                f"{1e3 * before:.3f} mN*m): not applied"]
        return fixed, notes


def _form_against(P, sel, other, cal, d, n_folds):
    """(fit A, fit B) on the blocks both cover: A the selection's ``other`` terms with the
    calibration terms ``cal``, B the ``other`` terms with the closed form ``d`` (its
    parameters counted as two per coefficient, a value and a shape chosen on a grid, so that
    a tie keeps the library's physical effect)."""
    from dataclasses import replace as _replace
    from .selection import GramProblem, Term
    n = min(len(P.y), len(d.prediction))
    ocols = [c for t in other for c in t.cols]
    ccols = [c for t in cal for c in t.cols]
    X = np.column_stack([P.X[:n, ocols + ccols], d.prediction[:n]])
    prob = GramProblem(X, P.y[:n], np.asarray(sel.weights, float)[:n], n_folds)
    i, A = 0, []
    for t in other + cal:
        A.append(_replace(t, cols=tuple(range(i, i + len(t.cols)))))
        i += len(t.cols)
    form = Term("form", None, (X.shape[1] - 1,), ("form",), ("N*m",), (-np.inf,),
                (np.inf,), 2 * len(d.terms) - 1)
    return prob.fit(tuple(A), cv=False), prob.fit(tuple(A[:len(other)]) + (form,), cv=False)
