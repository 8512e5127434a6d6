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
   confirmed remainder, put in ``unexplained.proposed``;
6. ``report`` (``result.report`` -> ``Diagnosis``).
"""
from __future__ import annotations

import math

import numpy as np

from model_core import DriveDesign
from model_core.effects import CALIBRATION_EFFECTS, DEFAULT_CANDIDATES
from model_core.kinematics import parse_mode

from . import residual as R
from .problem import MIN_LOAD, build_problem
from .remainder import PEAK_MIN_AMPLITUDE_NM, remainder
from .replay import Replay, block_means, first_order, replay
from .result import Diagnosis, DiagnosisError, report, zeta_d
from .select_effects import MIN_EXPLAINED_NM, select
from .twins import FALSE_ALARM, N_TWINS, judge

#: [1] re-linearise the friction level (replay again at the corrected mu) beyond this error
FRICTION_RELINEARISE = 0.02
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
        Effect ids to consider (default: ``DEFAULT_CANDIDATES``, and with ``calibrate`` the
        ``CALIBRATION_EFFECTS`` too).
    calibrate : bool
        Also fit the calibration effects (mesh loss k, idle-loss scale: model_core.effects).
    progress : bool
        A progress bar over the fit's stages on stderr (terminals only).
    """

    def __init__(self, design: DriveDesign = None, mode: str = "S1", bandwidth: float = 1000.0,
                 block: float = 0.01, n_folds: int = 5, candidates=None, progress=False,
                 calibrate=False):
        self.design = design or DriveDesign()
        self.mode = "".join(parse_mode(mode)[:2])
        self.bandwidth = bandwidth
        self.block = block
        self.n_folds = n_folds
        self.candidates = tuple(c for c in (candidates or DEFAULT_CANDIDATES + (
            CALIBRATION_EFFECTS if calibrate else ())) if c != "none")
        self.progress = progress
        self._bar = None

    def _stage(self, name):
        if self._bar is not None:
            self._bar.set_description(name)
            self._bar.update(1)

    def problem(self, rec):
        """The regression problem of ``rec`` under the Diagnoser's design (stage ``replay``)."""
        return build_problem(rec, self.design, self.mode, self.candidates, self.bandwidth,
                             self.block)

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
        self._bar = tqdm(total=6, leave=False, unit=" stages", desc="replay",
                         disable=not (self.progress and sys.stderr.isatty()))
        P0 = self.problem(rec)
        self._stage("select")
        first = select(P0, self.n_folds)
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
                              (P0.sig["sens_mu"], None), reuse=P0)
            # of the first replay's sample-level signals only the friction and viscosity
            # sensitivities are read again (residual_rms, the report's friction torque): the
            # others (~50 MB at 600 000 samples) are released before the later stages' peaks
            P0.sig = {k: P0.sig[k] for k in ("sens_mu", "sens_nu")}
            P0.rp = Replay(P0.rp.T_model, P0.sig)
            sel = select(P, self.n_folds, forced=("friction_miscalibrated",))
        self._stage("twins")
        J = judge(P, sel)
        self._stage("remainder")
        rem = remainder(P, sel, J, rec, self.design, self.mode)
        self._stage("discover")
        self._discover(rec, P, sel, rem, rel1)
        rem.unexplained["_rejected"] = J.rejected
        self._stage("report")
        d = report(rec, first, sel, J, rem, P, rel1, P0)
        d.stages = {"replay": P, "select": sel, "twins": J, "remainder": rem}
        self.diagnosis_ = d
        self._bar.close()
        self._bar = None
        self._rec, self._P0, self._weights = rec, P0, first.weights
        return self

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
