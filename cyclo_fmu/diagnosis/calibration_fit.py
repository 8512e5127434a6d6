"""Calibrate a design's ``[calibration]`` to a recording before it is diagnosed.

A calibration can be far from the design's values (the paper's drive: k from 0 to 0.027, the
idle-loss scale from 1 to 0.02), farther than the diagnosis's linearised columns reach in one
step, and the two act together (one alone leaves a structured remainder that the diagnosis
rightly withdraws as "could be unexplained"). So ``diagnose --calibrate`` first fits the two by
nonlinear least squares on the replay itself, the full model along the recording at each trial
value (``model_core.lossmap.replay_input_torque`` through ``replay``); the diagnosis then looks
at what remains around the calibrated design, with the calibration effects as candidates for a
last linear correction.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from model_core.calibration import with_calibration
from model_core.design import IDLE_LOSS_SCALE_BOUNDS, MESH_LOSS_K_BOUNDS

from .replay import block_means, first_order, replay

#: robust scale of the least squares [1 x the noise of the block means]: residuals beyond about
#: three noise levels (spikes, transients at steps a quasi-static replay does not follow) weigh
#: as their absolute value, not its square (scipy's soft_l1 loss with f_scale = 3 sigma)
ROBUST_SIGMAS = 3.0
#: [rad/s] blocks slower than this are left out of the fit: at a standstill the replay has no
#: direction of motion and the drag's sign is regularised (model_core.drag.DRAG_SIGN_SPEED)
MIN_SPEED = 1.0


@dataclass
class CalibrationFit:
    """The calibration fitted to one recording: the calibrated ``design``, the values, their
    approximate 95 % half-widths (from the Jacobian and the robust residual scale: noise only,
    not model error), the residual RMS before and after [N*m] and whether the recording has
    back-driven blocks (without them k cannot be told from an input transducer gain)."""

    design: object
    mesh_loss_k: float
    idle_loss_scale: float
    ci95: dict
    rms_before_Nm: float
    rms_after_Nm: float
    back_driven_share: float
    notes: list = field(default_factory=list)

    def report(self) -> dict:
        return {"mesh_loss_k": self.mesh_loss_k, "idle_loss_scale": self.idle_loss_scale,
                "ci95": self.ci95, "rms_before_Nm": self.rms_before_Nm,
                "rms_after_Nm": self.rms_after_Nm,
                "back_driven_share": self.back_driven_share, "notes": list(self.notes),
                "source": self.design.calibration.source}


def fit_calibration(design, mode, rec, bandwidth: float = 1000.0, block: float = 0.01,
                    source: str = "a bench recording") -> CalibrationFit:
    """Fit ``mesh_loss_k`` and ``idle_loss_scale`` of ``design`` to the recording ``rec``
    (``time``, ``speed_in``, ``torque_in``, ``torque_out`` in SI) in ``mode``.

    Residual: block means (``block`` s) of the measured input torque less the model's, the
    model filtered by the transducer's first-order ``bandwidth`` [Hz] as the diagnosis does;
    blocks below MIN_SPEED left out; robust least squares (ROBUST_SIGMAS) within the design's
    bounds. The idle-loss scale is fitted only where the design has load-independent losses
    (physical profile, losses = "all").
    """
    from scipy.optimize import least_squares

    t = np.asarray(rec.time, float)
    dt = float(np.median(np.diff(t)))
    m = max(1, int(round(block / dt)))
    moving = block_means(np.abs(np.asarray(rec.speed_in, float)), m) > MIN_SPEED
    meas = block_means(np.asarray(rec.torque_in, float), m)[moving]
    idle_on = design.profile == "physical" and design.losses == "all"
    cal0 = design.calibration
    zero = np.zeros(len(t))

    def model(p):
        d = with_calibration(design, float(p[0]), float(p[1]) if idle_on else None)
        rp = replay(d, mode, rec, bandwidth, sensitivities=(zero,) * 5)
        return block_means(first_order(rp.T_model, dt, bandwidth), m)[moving]

    x0 = [cal0.mesh_loss_k] + ([cal0.idle_loss_scale] if idle_on else [])
    r0 = meas - model(x0)
    # the noise of the block means from their successive differences (robust: MAD)
    d = np.diff(r0)
    sigma = 1.4826 * float(np.median(np.abs(d - np.median(d)))) / math.sqrt(2) if d.size else 0
    sigma = max(sigma, 1e-6)
    lo = [MESH_LOSS_K_BOUNDS[0]] + ([IDLE_LOSS_SCALE_BOUNDS[0]] if idle_on else [])
    hi = [MESH_LOSS_K_BOUNDS[1]] + ([IDLE_LOSS_SCALE_BOUNDS[1]] if idle_on else [])
    sol = least_squares(lambda p: meas - model(p), x0=x0, bounds=(lo, hi),
                        x_scale=[0.01, 0.1][:len(x0)], loss="soft_l1",
                        f_scale=ROBUST_SIGMAS * sigma, diff_step=1e-3)
    k = float(sol.x[0])
    s = float(sol.x[1]) if idle_on else cal0.idle_loss_scale
    names = ["mesh_loss_k", "idle_loss_scale"][:len(x0)]
    ci95 = {n: float("nan") for n in names}
    J = np.asarray(sol.jac, float)
    n_res, n_par = J.shape
    if n_res > n_par:
        with np.errstate(all="ignore"):
            try:
                r = sol.fun
                s2 = float(np.sum(r ** 2)) / (n_res - n_par)
                cov = np.linalg.inv(J.T @ J) * s2
                # block means of a filtered signal are correlated: widen by the lag-1
                # autocorrelation's variance inflation (1 + rho)/(1 - rho)
                rho = float(np.corrcoef(r[:-1], r[1:])[0, 1]) if n_res > 3 else 0.0
                rho = min(max(rho, 0.0), 0.99)
                cov *= (1 + rho) / (1 - rho)
                ci95 = {nm: float(1.96 * math.sqrt(cov[i, i])) for i, nm in enumerate(names)}
            except (np.linalg.LinAlgError, ValueError):
                pass
    # back-driven blocks: the load drives (power flows out of the input shaft)
    w_in = block_means(np.asarray(rec.speed_in, float), m)[moving]
    p_in = meas * w_in
    back = float(np.mean(p_in < 0)) if p_in.size else 0.0
    notes = []
    if back == 0.0:
        notes.append("no back-driven blocks in this recording: the mesh loss k cannot be told "
                     "from a gain error of the input torque transducer (both scale the input "
                     "torque in one forward mode); to separate them run S2 at the same input "
                     "points, or back-driven runs at the same points")
    ci_text = ", ".join(f"{nm} +- {v:.2g}" for nm, v in ci95.items())
    text = (f"cyclo-fmu diagnose --calibrate: nonlinear least squares of the replayed input "
            f"torque to {source} ({mode}, {n_res} blocks of {block * 1e3:g} ms): mesh_loss_k "
            f"{k:.6g}, idle_loss_scale {s:.6g} (95 %: {ci_text}; noise only)")
    fitted = with_calibration(design, k, s if idle_on else None, text)
    rms_after = float(np.sqrt(np.mean((meas - model(sol.x)) ** 2)))
    return CalibrationFit(fitted, k, s, ci95, float(np.sqrt(np.mean(r0 ** 2))), rms_after,
                          back, notes)
