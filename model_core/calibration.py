"""Calibration of a design to measured efficiency statistics: the two loss parameters of
``design.calibration`` (mesh_loss_k, idle_loss_scale) fitted by least squares.

What a published bench test gives is often only min / mean / max of the efficiency per mode
(Mackic et al., Section 5: S1 61.50 / 63.49 / 64.85 %, S2 58.21 / 60.90 / 63.00 %). Two
parameters with different signatures can be learned from them:

- ``mesh_loss_k``, a loss proportional to the mesh power, eta0 -> eta0 (1 - k): it lowers the
  efficiency about uniformly over the envelope and enters S2 once more than S1 (Kreines:
  eta_S2 = eta0 eta_S1 at equal input points);
- ``idle_loss_scale``, a scale on the load-independent losses: they weigh most at light load
  and high speed, so it sets the spread (min against max).

The fit evaluates the full model (``model_core.paper.envelope_statistics``: every operating
point of the envelope solved with the calibration inside the physics), not a linearisation.
It is a calibration, not physics: the result says what it was fitted to (``source``), and
:attr:`CalibrationResult.residual` says how far two parameters get; if they cannot reach the
targets, the remainder is reported, not tuned away.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from .design import (IDLE_LOSS_SCALE_BOUNDS, MESH_LOSS_K_BOUNDS, Calibration, DriveDesign)
from .paper import PAPER_EXPERIMENT, BenchEnvelope, envelope_statistics

#: the statistics a target gives per mode
STATISTICS = ("min", "mean", "max")
#: start of the fit (k [1], idle scale [1]): a small mesh loss and half the catalogue idle
#: losses; the least squares is smooth in both, so the start only saves iterations
_START = (0.02, 0.5)


@dataclass(frozen=True)
class CalibrationResult:
    """The outcome of :func:`calibrate`.

    Attributes
    ----------
    design : DriveDesign
        The calibrated design (``design.calibration`` carries k, the scale and ``source``).
    mesh_loss_k, idle_loss_scale : float
        The fitted values [1].
    targets, predicted : dict
        ``{mode: {"min", "mean", "max"}}`` as fractions: what was fitted to, and what the
        calibrated model gives over the envelope.
    residual : dict
        predicted - target per mode and statistic [1] (fractions, not points).
    ci95 : dict
        Approximate 95 % half-widths of the values [1] from the fit's Jacobian J and its
        residual r: cov = (|r|^2 / (n - p)) (J^T J)^-1 (the residual taken as the scatter of
        the statistics; NaN with as many statistics as parameters).
    ratio_check : dict
        The Kreines check S2/S1 = eta0 at equal input points: ``experiment`` (mean S2 over
        mean S1 of the targets), ``model`` (the same of the calibrated model), ``eta0_model``
        (the model's mean basic efficiency in S1 over the envelope).
    """

    design: DriveDesign
    mesh_loss_k: float
    idle_loss_scale: float
    targets: dict
    predicted: dict
    residual: dict
    ci95: dict = field(default_factory=dict)
    ratio_check: dict = field(default_factory=dict)

    @property
    def max_abs_residual(self) -> float:
        """The largest |predicted - target| over modes and statistics [1]."""
        return max(abs(v) for r in self.residual.values() for v in r.values())

    def within(self, tol: float) -> bool:
        """Whether every statistic is reproduced within ``tol`` [1]."""
        return self.max_abs_residual <= tol

    def report(self) -> dict:
        """A JSON-ready summary."""
        return {"mesh_loss_k": self.mesh_loss_k, "idle_loss_scale": self.idle_loss_scale,
                "source": self.design.calibration.source, "targets": self.targets,
                "predicted": self.predicted, "residual": self.residual,
                "max_abs_residual": self.max_abs_residual, "ci95": self.ci95,
                "ratio_check": self.ratio_check}


def with_calibration(design: DriveDesign, mesh_loss_k=None, idle_loss_scale=None,
                     source=None, load_loss_scale=None) -> DriveDesign:
    """``design`` with its calibration changed (validated, bounds included); None keeps a
    value."""
    cal = design.calibration
    changes = {k: v for k, v in (("mesh_loss_k", mesh_loss_k),
                                 ("idle_loss_scale", idle_loss_scale),
                                 ("load_loss_scale", load_loss_scale),
                                 ("source", source)) if v is not None}
    return replace(design, calibration=replace(cal, **changes))


def _source_text(targets, envelope, modes) -> str:
    t = "; ".join(f"{m} " + "/".join(f"{100 * targets[m][q]:.2f}" for q in STATISTICS) + " %"
                  for m in modes)
    return (f"model_core.calibration.calibrate: least squares of the model's min/mean/max "
            f"efficiency over the bench envelope ({envelope.speed_min_rpm:g}-"
            f"{envelope.speed_max_rpm:g} r/min x {envelope.torque_min:g}-"
            f"{envelope.torque_max:g} N*m input, {envelope.n_speed}x{envelope.n_torque} grid, "
            f"an assumption) to the targets {t} (min/mean/max)")


def calibrate(design: DriveDesign, targets=PAPER_EXPERIMENT, envelope=BenchEnvelope(),
              modes=("S1", "S2"), source=None) -> CalibrationResult:
    """Fit ``mesh_loss_k`` and ``idle_loss_scale`` so that the design's efficiency statistics
    over ``envelope`` match ``targets``.

    Parameters
    ----------
    design : DriveDesign
        The design to calibrate, in the profile and loss scope it is to be used in (the
        idle-loss scale acts only in the physical profile with ``losses = "all"``; elsewhere it
        is kept at its value and only k is fitted). Its own calibration is replaced.
    targets : dict
        ``{mode: {"min", "mean", "max"}}`` efficiencies as fractions (default: the paper's
        experiment, Section 5).
    envelope : BenchEnvelope
        The operating points the statistics are taken over (the paper's bench: an
        **assumption**, model_core.paper).
    modes : tuple of str
        The modes fitted (each must be in ``targets``).
    source : str, optional
        What the values were fitted to (default: a description of this fit).

    Returns
    -------
    CalibrationResult
        The calibrated design, the values and the residual per statistic.

    Notes
    -----
    Residuals r = eta_model(k, s) - eta_target for the 3 statistics of each mode, minimised in
    the least-squares sense (scipy.optimize.least_squares, trust-region reflective) within the
    design's bounds (MESH_LOSS_K_BOUNDS, IDLE_LOSS_SCALE_BOUNDS). Each evaluation solves the
    whole envelope with the calibration inside the physics (model_core.efficiency).
    """
    from scipy.optimize import least_squares

    for m in modes:
        if m not in targets or any(q not in targets[m] for q in STATISTICS):
            from .errors import CycloidInputError
            raise CycloidInputError("targets", m, "needs min, mean and max for every fitted "
                                    "mode")
    idle_active = design.profile == "physical" and design.losses == "all"
    scale0 = design.calibration.idle_loss_scale

    def designed(p):
        k, s = (p[0], p[1]) if idle_active else (p[0], scale0)
        return with_calibration(design, float(k), float(s))

    def stats(d):
        return {m: envelope_statistics(d, m, envelope) for m in modes}

    def resid(p):
        st = stats(designed(p))
        return [st[m][q] - targets[m][q] for m in modes for q in STATISTICS]

    lo = [MESH_LOSS_K_BOUNDS[0]] + ([IDLE_LOSS_SCALE_BOUNDS[0]] if idle_active else [])
    hi = [MESH_LOSS_K_BOUNDS[1]] + ([IDLE_LOSS_SCALE_BOUNDS[1]] if idle_active else [])
    x0 = list(_START[:len(lo)])
    sol = least_squares(resid, x0=x0, bounds=(lo, hi), x_scale=[0.01, 0.1][:len(lo)],
                        xtol=1e-10, ftol=1e-12, gtol=1e-12)
    k = float(sol.x[0])
    s = float(sol.x[1]) if idle_active else scale0
    text = source if source is not None else _source_text(targets, envelope, modes)
    calibrated = with_calibration(design, k, s, text)
    pred = stats(calibrated)
    residual = {m: {q: pred[m][q] - targets[m][q] for q in STATISTICS} for m in modes}
    names = ["mesh_loss_k", "idle_loss_scale"][:len(lo)]
    n, p = len(sol.fun), len(sol.x)
    ci95 = {name: float("nan") for name in names}
    if n > p:
        J = np.asarray(sol.jac, float)
        with np.errstate(all="ignore"):
            try:
                cov = np.linalg.inv(J.T @ J) * float(sol.fun @ sol.fun) / (n - p)
                ci95 = {name: float(1.96 * np.sqrt(cov[i, i])) for i, name in enumerate(names)}
            except np.linalg.LinAlgError:
                pass
    ratio = {}
    if "S1" in modes and "S2" in modes:
        from .maps import efficiency_map
        m1 = efficiency_map(calibrated, "S1", envelope.speeds(), envelope.torques())
        ratio = {"experiment": targets["S2"]["mean"] / targets["S1"]["mean"],
                 "model": pred["S2"]["mean"] / pred["S1"]["mean"],
                 "eta0_model": float(np.nanmean(m1.eta0))}
    return CalibrationResult(design=calibrated, mesh_loss_k=k, idle_loss_scale=s,
                             targets={m: dict(targets[m]) for m in modes}, predicted=pred,
                             residual=residual, ci95=ci95, ratio_check=ratio)
