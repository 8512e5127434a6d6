"""Export one operating mode of the reducer as a Modelica package around the Modelica Standard
Library's ``Modelica.Mechanics.Rotational.Components.LossyGear``.

LossyGear (MSL 4.0, its documentation and equations) describes a gear by

    flange_a.phi = i * flange_b.phi,            i = ratio = w_a / w_b
    -flange_b.tau = i * (eta_mf * flange_a.tau - tau_bf)

with, at |w_a| interpolated linearly in ``lossTable = [|w_a|, eta_mf1, eta_mf2, |tau_bf1|,
|tau_bf2|]``:

- flange_a drives (power flows a -> b; quadrants 1 and 3):  eta_mf = eta_mf1, tau_bf = tau_bf1
  (with the sign of w_a: -flange_b.tau = i (eta_mf1 tau_a - sign(w_a) tau_bf1));
- flange_b drives (b -> a; quadrants 2 and 4): eta_mf = 1/eta_mf2, tau_bf = tau_bf2
  (-flange_b.tau = i (tau_a / eta_mf2 - sign(w_a) tau_bf2)).

The physics core gives, at each speed, the torque relation of the reducer; LossyGear's is affine
in the torque, i.e. its efficiency is eta_mf - tau_bf / tau. Per speed and flow direction the
columns are the minimax (Chebyshev) fit of that form to the core's efficiency over the torque
band, so the table's largest efficiency error is as small as the form allows: forward,
eta = y / x = eta_mf1 - tau_bf1 / x with y = -tau_out / i, x = tau_in; backward,
eta = x / y = eta_mf2 + eta_mf2 tau_bf2 / y. Where the core's efficiency curves over the torque
(the physical profile's Stribeck transition and roll-or-skid switch) the form cannot follow it
exactly; the package states the error that remains. flange_a is the driving
shaft of the mode, flange_b the driven one, the flange torques are the torques the outside
applies (the FMUs' convention: tau_in on flange_a, tau_out on flange_b).

The table is valid in the band it was fitted in (driving-shaft torque and speed, default the
bench envelope of ``model_core.paper.BenchEnvelope``); the package documentation states the band
and the largest efficiency error of the LossyGear formula against the core there.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from model_core import DriveDesign, kinematics
from model_core.efficiency import operating_point
from model_core.paper import BenchEnvelope

from . import __version__

#: rows of the lossTable over the speed band (linear in speed, as LossyGear interpolates)
N_SPEED_ROWS = 12
#: torque points per speed in the minimax fit
N_TORQUE_FIT = 24
#: grid on which the error against the core is reported (finer than the fit's, off its nodes)
N_CHECK = 17


@dataclass
class LossTableFit:
    mode: str
    ratio: float                  # i = w_a / w_b
    table: np.ndarray             # (n, 5): |w_a| rad/s, eta_mf1, eta_mf2, |tau_bf1|, |tau_bf2| N*m
    speed_band: tuple             # rad/s, driving shaft
    torque_band: tuple            # N*m, |tau_in| at the driving shaft
    max_error_forward: float      # efficiency error, fraction (points/100)
    max_error_backward: float
    backward_runs: bool           # False: the core self-locks in back-drive in the band


def _core_forward(design, mode, w, tau_in):
    """Core's y = -tau_out/i (torque out referred to the driving shaft) for tau_in, w (arrays)."""
    a, b, _ = kinematics.parse_mode(mode)
    op = operating_point(design, mode, w, T_in=tau_in)
    return op


def lossy_gear_tau_out(table, ratio, w_a, tau_a):
    """LossyGear's rolling equations (w_a != 0): the torque on flange_b for speed w_a and
    flange_a torque tau_a, with the driving side as LossyGear decides it (tau_eta = tau_a -+
    tau_bf_a; here with tau_bf_a from the table as LossyGear computes it)."""
    w = np.abs(w_a)
    eta1 = np.interp(w, table[:, 0], table[:, 1])
    eta2 = np.interp(w, table[:, 0], table[:, 2])
    bf1 = np.abs(np.interp(w, table[:, 0], table[:, 3]))
    bf2 = np.abs(np.interp(w, table[:, 0], table[:, 4]))
    with np.errstate(divide="ignore", invalid="ignore"):
        ideal = np.isclose(eta1, 1.0) & np.isclose(eta2, 1.0)
        bf_a = np.where(ideal, bf1 / 2, (bf1 - bf2) / (eta1 - 1.0 / eta2))
    sgn = np.sign(w_a)
    tau_eta = tau_a - sgn * bf_a
    a_drives = tau_eta * sgn > 0          # quadrants 1 (w > 0) and 3 (w < 0)
    tau_loss = np.where(a_drives, (1 - eta1) * tau_a + sgn * bf1,
                        (1 - 1 / eta2) * tau_a + sgn * bf2)
    return -ratio * (tau_a - tau_loss)    # 0 = flange_b.tau + ratio (flange_a.tau - tauLoss)


def lossy_gear_efficiency(table, ratio, w_a, tau_a):
    """Efficiency of the actual power flow through LossyGear (output power / input power)."""
    tau_b = lossy_gear_tau_out(table, ratio, w_a, tau_a)
    w_b = w_a / ratio
    p_a, p_b = tau_a * w_a, tau_b * w_b
    return np.where(p_a > 0, -p_b / p_a, -p_a / p_b)


def _core_eta(design, mode, w, tau_in, ratio):
    a, b, _ = kinematics.parse_mode(mode)
    op = operating_point(design, mode, w, T_in=tau_in)
    tau_b = np.asarray(op.torques[b], float)
    w_b = w / ratio
    p_a, p_b = tau_in * w, tau_b * w_b
    eta = np.where(p_a > 0, -p_b / p_a, -p_a / p_b)
    return eta, np.asarray(op.locked, bool), tau_b


def _minimax_eta(x, eta):
    """(s, c) minimising max |s + c / x - eta| over the points (a linear programme)."""
    from scipy.optimize import linprog
    x, eta = np.asarray(x, float).ravel(), np.asarray(eta, float).ravel()
    a = np.column_stack([np.ones_like(x), 1.0 / x, -np.ones_like(x)])
    a_ub = np.vstack([a, -a * np.array([1.0, 1.0, -1.0])])
    b_ub = np.concatenate([eta, -eta])
    res = linprog([0.0, 0.0, 1.0], A_ub=a_ub, b_ub=b_ub,
                  bounds=[(None, None), (None, None), (0.0, None)], method="highs")
    if not res.success:                       # pragma: no cover - a 3-variable LP always solves
        raise RuntimeError(f"LossyGear fit failed: {res.message}")
    return float(res.x[0]), float(res.x[1])


def fit_loss_table(design: DriveDesign, mode: str, envelope: BenchEnvelope = BenchEnvelope()
                   ) -> LossTableFit:
    """Fit LossyGear's lossTable to the core over the envelope (driving-shaft speed and torque
    magnitude), both flow directions, and measure the efficiency error of LossyGear's formula
    against the core on a finer grid of the same band."""
    a, b, _ = kinematics.parse_mode(mode)
    unit = kinematics.shaft_speeds(mode, 1.0, design.z1)
    ratio = float(unit[a]) / float(unit[b])
    w_lo, w_hi = (envelope.speed_min_rpm * math.pi / 30, envelope.speed_max_rpm * math.pi / 30)
    t_lo, t_hi = envelope.torque_min, envelope.torque_max
    speeds = np.linspace(w_lo, w_hi, N_SPEED_ROWS)
    torques = np.linspace(t_lo, t_hi, N_TORQUE_FIT)
    W, T = np.meshgrid(speeds, torques, indexing="ij")
    rows = []
    # forward: a drives, tau_in > 0 at w > 0
    op = operating_point(design, mode, W, T_in=T)
    y = -np.asarray(op.torques[b], float) / ratio
    # backward: b drives; the driving shaft brakes, tau_in < 0 at w > 0
    opb = operating_point(design, mode, W, T_in=-T)
    yb = -np.asarray(opb.torques[b], float) / ratio
    backward_runs = not np.any(np.asarray(opb.locked, bool))
    for j in range(len(speeds)):
        s1, c1 = _minimax_eta(T[j], y[j] / T[j])        # y / x = eta_mf1 - tau_bf1 / x
        eta_mf1, tau_bf1 = s1, -c1
        if backward_runs:
            s2, c2 = _minimax_eta(yb[j], -T[j] / yb[j])  # x / y = eta_mf2 + eta_mf2 tau_bf2 / y
            eta_mf2, tau_bf2 = s2, c2 / s2
        else:
            eta_mf2, tau_bf2 = eta_mf1, tau_bf1
        rows.append((speeds[j], eta_mf1, eta_mf2, max(tau_bf1, 0.0), max(tau_bf2, 0.0)))
    table = np.array(rows)
    # a row at standstill (LossyGear's stuck/start decisions use the table at w = 0): the
    # lowest fitted row held, as the band says nothing below it
    table = np.vstack([np.concatenate([[0.0], table[0, 1:]]), table])
    err_f, err_b = fit_errors(design, mode, table, ratio, envelope)
    return LossTableFit(mode=a + b, ratio=ratio, table=table, speed_band=(w_lo, w_hi),
                        torque_band=(t_lo, t_hi), max_error_forward=err_f,
                        max_error_backward=err_b if backward_runs else float("nan"),
                        backward_runs=backward_runs)


def fit_errors(design, mode, table, ratio, envelope=BenchEnvelope(), n=N_CHECK):
    """Largest |eta_LossyGear - eta_core| (fractions) on an n x n grid of the band, forward and
    backward flow, both signs of the speed."""
    w = np.linspace(envelope.speed_min_rpm, envelope.speed_max_rpm, n) * math.pi / 30
    t = np.linspace(envelope.torque_min, envelope.torque_max, n)
    W, T = np.meshgrid(w, t, indexing="ij")
    out = []
    for sign_t in (1.0, -1.0):
        worst = 0.0
        for sign_w in (1.0, -1.0):
            ww, tt = sign_w * W, sign_w * sign_t * T
            core, locked, _ = _core_eta(design, mode, ww, tt, ratio)
            lg = lossy_gear_efficiency(table, ratio, ww, tt)
            ok = ~locked
            if ok.any():
                worst = max(worst, float(np.max(np.abs(lg[ok] - core[ok]))))
        out.append(worst)
    return tuple(out)


def _fmt(x):
    return f"{float(x):.10g}"


def modelica_package(fit: LossTableFit, design_name: str = "the paper's test drive") -> tuple:
    """(package name, Modelica source) of a one-file package with model ``Reducer``."""
    name = f"CycloidDrive_{fit.mode}"
    rows = ";\n      ".join(", ".join(_fmt(v) for v in r) for r in fit.table)
    w_lo, w_hi = (x * 30 / math.pi for x in fit.speed_band)
    t_lo, t_hi = fit.torque_band
    back = (f"{100 * fit.max_error_backward:.3f} percentage points" if fit.backward_runs
            else "not fitted: the core self-locks in back-drive in this band, eta_mf2 and "
            "tau_bf2 repeat the forward columns and back-drive is NOT represented")
    doc = f"""<html>
<p>Cycloid reducer ({design_name}), mode <strong>{fit.mode}</strong> (driving shaft, driven
shaft; 1 ring, 2 disc, S eccentric), as <code>Modelica.Mechanics.Rotational.Components.LossyGear</code>
with a <code>lossTable</code> fitted to the cyclo-fmu physics core (version {__version__},
Mackic et al.): per speed, a least-squares line of the core's torque relation over the torque band,
forward (flange_a drives: eta_mf1, tau_bf1) and backward (flange_b drives: eta_mf2, tau_bf2).
flange_a is the driving shaft, flange_b the driven one, <code>ratio</code> = w_a/w_b = {_fmt(fit.ratio)}.</p>
<p><strong>Valid band</strong>: driving-shaft speed {w_lo:.0f} to {w_hi:.0f} r/min (either
sign), driving-shaft torque magnitude {t_lo:g} to {t_hi:g} N.m.</p>
<p><strong>Largest efficiency error</strong> of this model against the core in the band (both
signs of speed, grid {N_CHECK} x {N_CHECK}): forward {100 * fit.max_error_forward:.3f}
percentage points; backward {back}.</p>
<p><strong>Limits</strong>: outside the band the table is held (speed) or the affine torque law is
extrapolated (torque): it underestimates the core's efficiency there, at light load strongly
(several points below a third of the band's lowest torque);
the core's extra physics (drag, Stribeck, inertia, ripple, warm-up) is not in this model; the
support (held shaft) torque follows from LossyGear's balance; self-locking appears only as
LossyGear's stuck mode at zero speed.</p>
</html>"""
    src = f"""within ;
package {name} "Cycloid reducer, mode {fit.mode}, as LossyGear with a loss table fitted to cyclo-fmu"
  extends Modelica.Icons.Package;

  constant Real lossTable[:, 5] = [
      {rows}]
    "|w_a| (rad/s), eta_mf1, eta_mf2, |tau_bf1| (N.m), |tau_bf2| (N.m)";

  model Reducer "Cycloid reducer, mode {fit.mode} (flange_a: driving shaft, flange_b: driven shaft)"
    extends Modelica.Mechanics.Rotational.Components.LossyGear(
      final ratio = {_fmt(fit.ratio)},
      final lossTable = {name}.lossTable);
    annotation (Documentation(info="{doc.replace('"', "'")}"));
  end Reducer;

  annotation (uses(Modelica(version="4.0.0")), version="{__version__}",
    Documentation(info="{doc.replace('"', "'")}"));
end {name};
"""
    return name, src


def export_modelica(mode: str, out_dir, design: DriveDesign | None = None,
                    envelope: BenchEnvelope = BenchEnvelope(), design_name=None) -> Path:
    """Fit and write ``out_dir/CycloidDrive_<mode>.mo``; returns its path."""
    design = design or DriveDesign()
    fit = fit_loss_table(design, mode, envelope)
    label = design_name or "the paper's test drive"
    cal = design.calibration
    if not cal.is_default:   # a calibrated value is reported as calibrated, with its source
        from html import escape
        label += (f"; CALIBRATED: mesh_loss_k = {cal.mesh_loss_k:.6g}, idle_loss_scale = "
                  f"{cal.idle_loss_scale:.6g}, fitted to: "
                  f"{escape(cal.source or 'not stated').replace(chr(92), '/')}")
    name, src = modelica_package(fit, label)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / f"{name}.mo"
    tmp = path.with_suffix(".mo.tmp")
    tmp.write_text(src)
    tmp.replace(path)
    return path
