"""Calibrate a design's ``[calibration]`` to a recording by nonlinear least squares.

A calibration can be far from the design's values (the paper's drive: k from 0 to 0.027, the
idle-loss scale from 1 to 0.02), farther than a linearisation reaches in one step, and the
parameters act together (one alone leaves a structured remainder). :func:`fit_calibration`
fits the chosen ones on the replay itself: the full model along the recording at each trial
value (``model_core.lossmap.replay_input_torque`` through ``replay``). It is a library function
for scripts; the ``diagnose`` command learns the calibration through its re-linearised effects
(``mesh_loss``, ``idle_loss_scale``, ``load_loss_scale``), judged against twins of the
recording and against the discovery's closed forms before it fits far.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from model_core.calibration import with_calibration
from model_core.design import (IDLE_LOSS_SCALE_BOUNDS, LOAD_LOSS_SCALE_BOUNDS,
                               MESH_LOSS_K_BOUNDS)

from .replay import block_means, first_order, replay

#: robust scale of the least squares [1 x the noise of the block means]: residuals beyond about
#: three noise levels (spikes, transients at steps a quasi-static replay does not follow) weigh
#: as their absolute value, not its square (scipy's soft_l1 loss with f_scale = 3 sigma)
ROBUST_SIGMAS = 3.0
#: [rad/s] blocks slower than this are left out of the fit: at a standstill the replay has no
#: direction of motion and the drag's sign is regularised (model_core.drag.DRAG_SIGN_SPEED)
MIN_SPEED = 1.0


#: the parameters :func:`fit_calibration` can fit: {name: (bounds, x_scale)}; x_scale is the
#: size of a change that matters (a point of efficiency: k 0.01, a scale 0.1), the step
#: least_squares normalises by
PARAMETERS = {"mesh_loss_k": (MESH_LOSS_K_BOUNDS, 0.01),
              "idle_loss_scale": (IDLE_LOSS_SCALE_BOUNDS, 0.1),
              "load_loss_scale": (LOAD_LOSS_SCALE_BOUNDS, 0.1)}
#: pairs that cannot be fitted together: both scale the gear's load-dependent losses (k as a
#: share of the mesh power, the load scale as a factor on PL1..PL6), so their columns are
#: nearly collinear on any plan and the fit would trade one for the other
COLLINEAR = (("mesh_loss_k", "load_loss_scale"),)


@dataclass
class CalibrationFit:
    """The calibration fitted to one recording: the calibrated ``design``, the values (those
    not fitted keep the design's), their approximate 95 % half-widths (from the Jacobian and
    the robust residual scale: noise only, not model error), the residual RMS before and after
    [N*m] and whether the recording has back-driven blocks (without them k or the load scale
    cannot be told from an input transducer gain)."""

    design: object
    mesh_loss_k: float
    idle_loss_scale: float
    ci95: dict
    rms_before_Nm: float
    rms_after_Nm: float
    back_driven_share: float
    notes: list = field(default_factory=list)
    load_loss_scale: float = 1.0

    def report(self) -> dict:
        return {"mesh_loss_k": self.mesh_loss_k, "idle_loss_scale": self.idle_loss_scale,
                "load_loss_scale": self.load_loss_scale,
                "ci95": self.ci95, "rms_before_Nm": self.rms_before_Nm,
                "rms_after_Nm": self.rms_after_Nm,
                "back_driven_share": self.back_driven_share, "notes": list(self.notes),
                "source": self.design.calibration.source}


def _check_params(params, design):
    """The parameters to fit, validated (a clear error naming the offending value)."""
    params = tuple(params)
    for p_ in params:
        if p_ not in PARAMETERS:
            raise ValueError(f"params: {p_!r} is not a calibration parameter "
                             f"({', '.join(PARAMETERS)})")
    if not params or len(set(params)) != len(params):
        raise ValueError(f"params: {params!r}: give each calibration parameter at most once, "
                         "at least one")
    for a, b in COLLINEAR:
        if a in params and b in params:
            raise ValueError(f"params: {a} and {b} cannot be fitted together: both scale the "
                             "load-dependent losses (nearly collinear); choose one")
    idle_on = design.profile == "physical" and design.losses == "all"
    # the idle-loss scale only where the design has load-independent losses
    return tuple(p_ for p_ in params if p_ != "idle_loss_scale" or idle_on)


def _ci95(sol):
    """95 % half-widths of the fitted values from the Jacobian and the residual scale, widened
    for the correlation of neighbouring blocks (None where the problem is too small)."""
    J = np.asarray(sol.jac, float)
    n_res, n_par = J.shape
    if n_res <= n_par:
        return None
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
            return [float(1.96 * math.sqrt(cov[i, i])) for i in range(n_par)]
        except (np.linalg.LinAlgError, ValueError):
            return None


def fit_calibration(design, mode, rec, bandwidth: float = 1000.0, block: float = 0.01,
                    source: str = "a bench recording",
                    params=("mesh_loss_k", "idle_loss_scale")) -> CalibrationFit:
    """Fit the calibration ``params`` of ``design`` to the recording ``rec`` (``time``,
    ``speed_in``, ``torque_in``, ``torque_out`` in SI) in ``mode``.

    ``params``: any of ``mesh_loss_k``, ``idle_loss_scale``, ``load_loss_scale`` (not k and
    the load scale together: ``COLLINEAR``). Residual: block means (``block`` s) of the
    measured input torque less the model's, the model filtered by the transducer's first-order
    ``bandwidth`` [Hz] as the diagnosis does; blocks below MIN_SPEED left out; robust least
    squares (ROBUST_SIGMAS) within the design's bounds. The idle-loss scale is fitted only
    where the design has load-independent losses (physical profile, losses = "all").
    """
    from scipy.optimize import least_squares

    names = _check_params(params, design)
    t = np.asarray(rec.time, float)
    dt = float(np.median(np.diff(t)))
    m = max(1, int(round(block / dt)))
    moving = block_means(np.abs(np.asarray(rec.speed_in, float)), m) > MIN_SPEED
    meas = block_means(np.asarray(rec.torque_in, float), m)[moving]
    cal0 = design.calibration
    zero = np.zeros(len(t))

    def calibrated(p, source=None):
        return with_calibration(design, source=source,
                                **{nm: float(v) for nm, v in zip(names, p)})

    def model(p):
        rp = replay(calibrated(p), mode, rec, bandwidth, sensitivities=(zero,) * 5)
        return block_means(first_order(rp.T_model, dt, bandwidth), m)[moving]

    x0 = [getattr(cal0, nm) for nm in names]
    r0 = meas - model(x0)
    # the noise of the block means from their successive differences (robust: MAD)
    d = np.diff(r0)
    sigma = 1.4826 * float(np.median(np.abs(d - np.median(d)))) / math.sqrt(2) if d.size else 0
    sigma = max(sigma, 1e-6)
    lo = [PARAMETERS[nm][0][0] for nm in names]
    hi = [PARAMETERS[nm][0][1] for nm in names]
    sol = least_squares(lambda p: meas - model(p), x0=x0, bounds=(lo, hi),
                        x_scale=[PARAMETERS[nm][1] for nm in names], loss="soft_l1",
                        f_scale=ROBUST_SIGMAS * sigma, diff_step=1e-3)
    half = _ci95(sol)
    ci95 = {nm: (float("nan") if half is None else half[i]) for i, nm in enumerate(names)}
    # back-driven blocks: the load drives (power flows out of the input shaft)
    w_in = block_means(np.asarray(rec.speed_in, float), m)[moving]
    p_in = meas * w_in
    back = float(np.mean(p_in < 0)) if p_in.size else 0.0
    notes = []
    if back == 0.0 and {"mesh_loss_k", "load_loss_scale"} & set(names):
        notes.append("no back-driven blocks in this recording: a scale of the load-dependent "
                     "losses (mesh_loss_k, load_loss_scale) cannot be told from a gain error of "
                     "the input torque transducer (both scale the input torque in one forward "
                     "mode); to separate them run S2 at the same input points, or back-driven "
                     "runs at the same points")
    values = ", ".join(f"{nm} {v:.6g}" for nm, v in zip(names, sol.x))
    ci_text = ", ".join(f"{nm} +- {v:.2g}" for nm, v in ci95.items())
    text = (f"cyclo_fmu.diagnosis.calibration_fit.fit_calibration: nonlinear least squares of the replayed input "
            f"torque to {source} ({mode}, {len(meas)} blocks of {block * 1e3:g} ms): {values} "
            f"(95 %: {ci_text}; noise only)")
    fitted = calibrated(sol.x, text)
    rms_after = float(np.sqrt(np.mean((meas - model(sol.x)) ** 2)))
    c = fitted.calibration
    return CalibrationFit(fitted, c.mesh_loss_k, c.idle_loss_scale, ci95,
                          float(np.sqrt(np.mean(r0 ** 2))), rms_after, back, notes,
                          c.load_loss_scale)
