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
#: [1] the table's last row sits at this multiple of the band's top speed, repeating the
#: fastest fitted row, so that MSL's extrapolation through the last two rows holds the table
#: (any factor > 1 holds it; 10 keeps the row readable)
HOLD_SPEED_FACTOR = 10.0


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


def msl_interpolate(x, y, xi):
    """MSL's table interpolation of lossTable: linear between the rows, and beyond the first or
    last row linear extrapolation through the first or last two rows (MSL 4.0.0
    ``Modelica.Math.Vectors.interpolate``, used by LossyGear 4.0.0; MSL 4.1
    ``ExternalCombiTable1D`` with ``extrapolation = Extrapolation.LastTwoPoints``, a final
    binding inside LossyGear that a user cannot change)."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    xi = np.asarray(xi, float)
    if x.size == 1:
        return np.full(xi.shape, y[0])
    i = np.clip(np.searchsorted(x, xi, side="right") - 1, 0, x.size - 2)
    x1, x2, y1, y2 = x[i], x[i + 1], y[i], y[i + 1]
    return y1 + (y2 - y1) * (xi - x1) / (x2 - x1)


def lossy_gear_columns(table, w_a):
    """(eta_mf1, eta_mf2, tau_bf1, tau_bf2) LossyGear interpolates at |w_a| (MSL semantics)."""
    w = np.abs(w_a)
    return (msl_interpolate(table[:, 0], table[:, 1], w),
            msl_interpolate(table[:, 0], table[:, 2], w),
            np.abs(msl_interpolate(table[:, 0], table[:, 3], w)),
            np.abs(msl_interpolate(table[:, 0], table[:, 4], w)))


def lossy_gear_tau_out(table, ratio, w_a, tau_a):
    """LossyGear's rolling equations (w_a != 0): the torque on flange_b for speed w_a and
    flange_a torque tau_a, with the driving side as LossyGear decides it (tau_eta = tau_a -+
    tau_bf_a; here with tau_bf_a from the table as LossyGear computes it), the table read as
    MSL reads it (:func:`msl_interpolate`, extrapolating beyond its rows)."""
    eta1, eta2, bf1, bf2 = lossy_gear_columns(table, w_a)
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
    # a row far above the band repeating the fastest one: MSL extrapolates linearly through
    # the last two rows (msl_interpolate), which from a sloped pair would carry eta_mf2 past 1
    # (about 7800 r/min for S1); through two equal rows the table is held at any speed
    table = np.vstack([table, np.concatenate([[HOLD_SPEED_FACTOR * w_hi], table[-1, 1:]])])
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


#: Example model's motor: the paper's bench motor (250 W at 2800 r/min, 0.853 N*m, on a
#: frequency regulator), an induction motor's slip line: at the regulator's setting
#: EXAMPLE_MOTOR_SYNC_RPM it turns at that speed unloaded and EXAMPLE_MOTOR_SLIP_RPM slower at
#: the nominal torque (a 2-pole motor: 3000 - 2800 r/min at 50 Hz), its torque capped at
#: EXAMPLE_MOTOR_TORQUE_CAP times nominal (IEC motors start with about 2-2.5 times). The
#: setting 2500 r/min puts the example's steady state inside the fitted band. **Assumptions**
#: of the example, not of the reducer.
EXAMPLE_MOTOR_SYNC_RPM = 2500.0
EXAMPLE_MOTOR_SLIP_RPM = 200.0
EXAMPLE_MOTOR_NOMINAL_TORQUE = 250.0 / (2800.0 * math.pi / 30.0)
EXAMPLE_MOTOR_TORQUE_CAP = 2.2
#: [kg*m^2] rotor inertia of a 250 W two-pole IEC 71 motor (about 3e-4) and of the brake disc
#: with its coupling at the output. **Assumptions** of the example.
EXAMPLE_MOTOR_INERTIA = 3e-4
EXAMPLE_LOAD_INERTIA = 1e-2
#: [1] the example's brake takes this share of the driving-shaft torque band's top (times the
#: ratio) at the nominal output speed: a viscous brake tau = -tau_n w / w_n (MSL
#: LinearSpeedDependentTorque) whose steady state lies inside the fitted band
EXAMPLE_LOAD_SHARE = 0.75
#: the test model ramps the driving shaft to this multiple of the band's top speed
TEST_SPEED_FACTOR = 12.0


def example_parameters(fit: LossTableFit) -> dict:
    """The example model's parameters (SI): motor slip line, inertias, the brake's nominal
    torque and speed (see the EXAMPLE_* constants)."""
    w_s = EXAMPLE_MOTOR_SYNC_RPM * math.pi / 30
    w_n = (EXAMPLE_MOTOR_SYNC_RPM - EXAMPLE_MOTOR_SLIP_RPM) * math.pi / 30
    w_out_n = w_n / abs(fit.ratio)
    # brake torque at the nominal output speed: the band's top input torque through a typical
    # efficiency of the band (the table's mean forward mesh efficiency) times the share
    eta = float(np.mean(fit.table[1:-1, 1]))
    tau_load = EXAMPLE_LOAD_SHARE * fit.torque_band[1] * abs(fit.ratio) * eta
    return {"w_sync": w_s, "w_nominal": w_n, "tau_nominal": EXAMPLE_MOTOR_NOMINAL_TORQUE,
            "tau_cap": EXAMPLE_MOTOR_TORQUE_CAP * EXAMPLE_MOTOR_NOMINAL_TORQUE,
            "J_motor": EXAMPLE_MOTOR_INERTIA, "J_load": EXAMPLE_LOAD_INERTIA,
            "tau_load": tau_load, "w_load": w_out_n}


def example_steady_state(fit: LossTableFit) -> dict:
    """The example's steady state by LossyGear's equations (forward rolling, w_a > 0): the
    motor speed where the motor's slip line meets the brake's torque carried back through the
    table, by bisection. Returns w_a [rad/s], tau_a [N*m] at flange_a."""
    p = example_parameters(fit)

    def excess(w):         # motor torque minus the torque the loaded gear asks at flange_a
        tau_m = min(p["tau_cap"], p["tau_nominal"] * (p["w_sync"] - w)
                    / (p["w_sync"] - p["w_nominal"]))
        w_b = w / fit.ratio
        tau_b_load = p["tau_load"] * abs(w_b) / p["w_load"]       # brake torque magnitude
        # forward: -flange_b.tau = ratio (eta_mf1 tau_a - tau_bf1) with flange_b.tau the
        # brake's reaction, sign(w_b) tau_b_load
        eta1, _, bf1, _ = lossy_gear_columns(fit.table, w)
        tau_a = (tau_b_load / abs(fit.ratio) + float(bf1)) / float(eta1)
        return tau_m - tau_a, tau_a

    lo, hi = 1.0, p["w_sync"]
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        if excess(mid)[0] > 0:
            lo = mid
        else:
            hi = mid
    w = 0.5 * (lo + hi)
    return {"w_a": w, "tau_a": excess(w)[1]}


def modelica_package(fit: LossTableFit, design_name: str = "the paper's test drive") -> tuple:
    """(package name, Modelica source) of a one-file package with model ``Reducer``, an
    ``Examples`` sub-package (``MotorReducerLoad``: motor inertia, the reducer, a load) and a
    ``Tests`` sub-package (``TableHeldBeyondBand``: back-driven far above the band, asserting
    efficiencies <= 1 and a non-negative loss power)."""
    name = f"CycloidDrive_{fit.mode}"
    rows = ";\n      ".join(", ".join(_fmt(v) for v in r) for r in fit.table)
    w_lo, w_hi = (x * 30 / math.pi for x in fit.speed_band)
    t_lo, t_hi = fit.torque_band
    w_hold = fit.table[-1, 0] * 30 / math.pi
    back = (f"{100 * fit.max_error_backward:.3f} percentage points" if fit.backward_runs
            else "not fitted: the core self-locks in back-drive in this band, eta_mf2 and "
            "tau_bf2 repeat the forward columns and back-drive is NOT represented")
    doc = f"""<html>
<p>Cycloid reducer ({design_name}), mode <strong>{fit.mode}</strong> (driving shaft, driven
shaft; 1 ring, 2 disc, S eccentric), as <code>Modelica.Mechanics.Rotational.Components.LossyGear</code>
with a <code>lossTable</code> fitted to the cyclo-fmu physics core (version {__version__},
Mackic et al.): per speed, the minimax (Chebyshev) fit of LossyGear's efficiency form
eta_mf - tau_bf/tau to the core's efficiency over the torque band (a linear programme: the
largest error is as small as the form allows), forward (flange_a drives: eta_mf1, tau_bf1) and
backward (flange_b drives: eta_mf2, tau_bf2).
flange_a is the driving shaft, flange_b the driven one, <code>ratio</code> = w_a/w_b = {_fmt(fit.ratio)}.</p>
<p><strong>Valid band</strong>: driving-shaft speed {w_lo:.0f} to {w_hi:.0f} r/min (either
sign), driving-shaft torque magnitude {t_lo:g} to {t_hi:g} N.m.</p>
<p><strong>Largest efficiency error</strong> of this model against the core in the band (both
signs of speed, grid {N_CHECK} x {N_CHECK}): forward {100 * fit.max_error_forward:.3f}
percentage points; backward {back}.</p>
<p><strong>Beyond the speed band the table is held</strong>: a row at 0 repeats the slowest
fitted row, a row at {w_hold:.0f} r/min repeats the fastest one. MSL extrapolates a lossTable
linearly through its last two rows (4.0: Modelica.Math.Vectors.interpolate; 4.1:
ExternalCombiTable1D with Extrapolation.LastTwoPoints, fixed inside LossyGear); through two equal
rows that is constant, so no efficiency passes 1 at any speed (test model
Tests.TableHeldBeyondBand).</p>
<p><strong>Limits</strong>: outside the torque band the affine torque law is extrapolated: it
underestimates the core's efficiency there, at light load strongly (several points below a
third of the band's lowest torque); the core's extra physics (drag, Stribeck, inertia, ripple,
warm-up) is not in this model; the support (held shaft) torque follows from LossyGear's
balance; self-locking appears only as LossyGear's stuck mode at zero speed. The package was
parsed with a Modelica grammar but not simulated by the project (no Modelica tool was
available).</p>
</html>""".replace('"', "'")
    p = example_parameters(fit)
    sgn = 1.0 if fit.ratio > 0 else -1.0
    src = f"""within ;
package {name} "Cycloid reducer, mode {fit.mode}, as LossyGear with a loss table fitted to cyclo-fmu"
  extends Modelica.Icons.Package;

  constant Real lossTable[:, 5] = [
      {rows}]
    "|w_a| (rad/s), eta_mf1, eta_mf2, |tau_bf1| (N.m), |tau_bf2| (N.m); first and last rows hold the band's ends";

  model Reducer "Cycloid reducer, mode {fit.mode} (flange_a: driving shaft, flange_b: driven shaft)"
    extends Modelica.Mechanics.Rotational.Components.LossyGear(
      final ratio = {_fmt(fit.ratio)},
      final lossTable = {name}.lossTable);
    annotation (Documentation(info="{doc}"));
  end Reducer;

  package Examples "Models to simulate"
    extends Modelica.Icons.ExamplesPackage;

    model MotorReducerLoad "Motor inertia, the reducer and a load: a run-up to the steady state"
      extends Modelica.Icons.Example;
      parameter Modelica.Units.SI.AngularVelocity w_sync = {_fmt(p["w_sync"])}
        "Motor speed unloaded (the frequency regulator's setting, 2500 r/min)";
      parameter Modelica.Units.SI.AngularVelocity w_nominal = {_fmt(p["w_nominal"])}
        "Motor speed at nominal torque (200 r/min slip, the paper's 2-pole bench motor)";
      parameter Modelica.Units.SI.Torque tau_nominal = {_fmt(p["tau_nominal"])}
        "Motor nominal torque (250 W at 2800 r/min)";
      parameter Modelica.Units.SI.Torque tau_cap = {_fmt(p["tau_cap"])}
        "Motor torque limit (2.2 x nominal)";
      parameter Modelica.Units.SI.Torque tau_load = {_fmt(p["tau_load"])}
        "Brake torque at the nominal output speed (steady state inside the fitted band)";
      parameter Modelica.Units.SI.AngularVelocity w_load = {_fmt(p["w_load"])}
        "Nominal output speed";
      Modelica.Mechanics.Rotational.Sources.Torque motorTorque "Motor air-gap torque";
      Modelica.Mechanics.Rotational.Components.Inertia motorInertia(
        J = {_fmt(p["J_motor"])}, phi(start = 0, fixed = true), w(start = 0, fixed = true))
        "Rotor (assumption: a 250 W two-pole IEC 71 motor)";
      {name}.Reducer reducer;
      Modelica.Mechanics.Rotational.Components.Inertia loadInertia(J = {_fmt(p["J_load"])})
        "Brake disc and coupling (assumption)";
      Modelica.Mechanics.Rotational.Sources.LinearSpeedDependentTorque brake(
        tau_nominal = -tau_load, TorqueDirection = false, w_nominal = w_load)
        "Viscous brake opposing the motion";
    equation
      motorTorque.tau = min(tau_cap, tau_nominal*(w_sync - motorInertia.w)/(w_sync - w_nominal));
      connect(motorTorque.flange, motorInertia.flange_a);
      connect(motorInertia.flange_b, reducer.flange_a);
      connect(reducer.flange_b, loadInertia.flange_a);
      connect(loadInertia.flange_b, brake.flange);
      annotation (experiment(StopTime = 2.0, Interval = 1e-3), Documentation(info="<html>
<p>The paper's bench in a few components: a motor on its slip line, the reducer, a brake disc
and a viscous brake. It runs up from rest to about {example_steady_state(fit)["w_a"] * 30 / math.pi:.0f} r/min and
{example_steady_state(fit)["tau_a"]:.3f} N.m at flange_a (computed with LossyGear's equations by cyclo-fmu),
inside the fitted band.</p></html>"));
    end MotorReducerLoad;
  end Examples;

  package Tests "Test models: they stop with an assertion if the reducer misbehaves"
    extends Modelica.Icons.Package;

    model TableHeldBeyondBand
      "Back-driven from rest to {TEST_SPEED_FACTOR:g} x the band's top speed: no efficiency above 1, no negative loss"
      extends Modelica.Icons.Example;
      Modelica.Blocks.Sources.Ramp speedRamp(height = {_fmt(TEST_SPEED_FACTOR * fit.speed_band[1])}, duration = 1.0)
        "Driving-shaft speed, far beyond the band";
      Modelica.Mechanics.Rotational.Sources.Speed speed "Driving shaft held at the ramp";
      {name}.Reducer reducer;
      Modelica.Mechanics.Rotational.Sources.ConstantTorque backDrive(
        tau_constant = {_fmt(sgn * 0.5 * (fit.torque_band[0] + fit.torque_band[1]) * abs(fit.ratio))})
        "The load drives the reducer (back-drive), in the driven shaft's direction of motion";
    equation
      connect(speedRamp.y, speed.w_ref);
      connect(speed.flange, reducer.flange_a);
      connect(reducer.flange_b, backDrive.flange);
      assert(reducer.eta_mf1 <= 1 and reducer.eta_mf2 <= 1,
        "a mesh efficiency of the loss table passed 1 beyond the band");
      assert(reducer.lossPower >= -1e-9, "the reducer creates energy (negative loss power)");
      annotation (experiment(StopTime = 1.5, Interval = 1e-3));
    end TableHeldBeyondBand;
  end Tests;

  annotation (uses(Modelica(version="4.0.0")), version="{__version__}",
    Documentation(info="{doc}"));
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
                  f"{cal.idle_loss_scale:.6g}, load_loss_scale = {cal.load_loss_scale:.6g}, "
                  "fitted to: "
                  f"{escape(cal.source or 'not stated').replace(chr(92), '/')}")
    name, src = modelica_package(fit, label)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / f"{name}.mo"
    tmp = path.with_suffix(".mo.tmp")
    tmp.write_text(src)
    tmp.replace(path)
    return path
