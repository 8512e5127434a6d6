"""The model along a recording: replay, the model's sensitivities, block means.

The replay drives the reducer model the FMU carries (``model_core.lossmap.ModeMap``) with the
measured input speed and output torque and returns the input torque the model predicts, the
design's own extra physics included (after an earlier diagnosis), read through the transducer
corrections the design carries. The sensitivities of that torque to the model's uncertain
parameters (the friction level ln mu_boundary, the lubricant's ln viscosity; the calibration's
mesh loss k and idle-loss scale) are finite differences of the full model: the columns of the
candidates that act through the model's own parameters.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from model_core import DriveDesign
from model_core.effects import effect_signals, extra_torque, reading_model
from model_core.filters import linear_filter as _linear_filter
from model_core.lossmap import replay_input_torque

#: relative step of the central finite differences of the model's sensitivities (a 5 % change
#: of mu_boundary or of the viscosity: large against the map's interpolation error, small
#: against the curvature of the losses in ln mu)
SENSITIVITY_STEP = 0.05
#: map points (torque x speed) of the sensitivity replays: a quarter of the base replay's
#: 36 x 28; a sensitivity is smooth over the map, and both sides of its difference share the
#: grid, so their interpolation errors cancel to first order
SENSITIVITY_GRID = (18, 14)
#: steps of the calibration's sensitivities (on SENSITIVITY_GRID; k forward from the design's
#: value, as k >= 0; the scale central where it can be). k [1] 0.002: the input torque is not
#: linear in k (S2: 1/eta_S2 grows as 1/(1 - k), the slope's relative curvature about 2 per
#: unit k), so a forward secant over h misjudges a change dk by about (h - dk) relative: 0.2 %
#: at h = 0.002 for the changes of a few thousandths a recording resolves best; a larger dk
#: (the paper's 0.027: about 2.5 %) is finished by re-diagnosing with design_updated.toml (a
#: Gauss-Newton step). Idle-loss scale [1] 0.5: the idle torques are linear in it (the gear's
#: losses respond through the driven shaft's drag, smoothly)
MESH_LOSS_STEP = 0.002
IDLE_SCALE_STEP = 0.5
#: [1] step of the load-loss scale (central, on SENSITIVITY_GRID): the gear's losses are
#: proportional to it at fixed forces and respond through the force balance smoothly (eta0
#: shifts by a few thousandths per 0.1), so the input torque is linear in it to ~1e-4 over
#: the +-15 % a recording asks for
LOAD_SCALE_STEP = 0.1
#: [s] window of the moving mean of the measured speed before it is differentiated (20 ms:
#: the transducer noise of a 0.1 r/min encoder differentiated at 1 kHz would swamp J dw/dt)
SPEED_SMOOTHING = 0.02


def _pole(bandwidth, dt):
    """The sampled first-order low pass's pole a = exp(-2 pi f_c dt) (``bandwidth`` f_c Hz,
    sample interval ``dt`` s): y[k] = a y[k-1] + (1 - a) x[k]."""
    return math.exp(-2 * math.pi * bandwidth * dt)


def first_order(x, dt, bandwidth, before=None):
    """A first-order low pass (the transducer's bandwidth, Hz) along axis 0, started in steady
    state (``scipy.signal.lfilter``, see ``_linear_filter``); ``before``: its output at the
    sample before ``x`` (``x[None, 0]``'s shape), where ``x`` continues a filtered series (the
    same numbers as the whole series filtered: the recursion's state is ``a`` times it)."""
    if bandwidth <= 0:
        return x
    a = _pole(bandwidth, dt)
    zi = a * (x[:1] if before is None else before)
    return _linear_filter()(np.atleast_1d([1 - a]), np.atleast_1d([1, -a]), x, 0, zi)[0]


def transducer_delay(bandwidth, dt):
    """Delay [s] of :func:`first_order` (``bandwidth`` Hz, sample interval ``dt`` s) at low
    frequency: a ramp comes out this much late. y[k] = a y[k-1] + (1 - a) x[k] with
    a = exp(-2 pi f_c dt) lags a ramp by a dt / (1 - a): 1/(2 pi f_c) - dt/2 where the
    samples are dense (dt << 1/(2 pi f_c)), near 0 where they are sparse (a 1 kHz transducer
    sampled at 200 Hz: 2e-14 s, not 0.16 ms)."""
    if bandwidth <= 0:
        return 0.0
    a = _pole(bandwidth, dt)
    return a * dt / (1 - a)


def block_means(x, m):
    """Means over consecutive blocks of ``m`` samples along axis 0 (a partial tail dropped)."""
    n = (len(x) // m) * m
    xb = x[:n].reshape(-1, m, *x.shape[1:])
    if xb[0, 0].size == 1:   # one column: numpy sums each block's contiguous samples
        return xb.reshape(xb.shape[:2]).mean(1).reshape(xb.shape[:1] + xb.shape[2:])
    return _block_sum(xb, lambda i: xb[:, i]) / m


def _block_sum(xb, item):
    """Sum over axis 1 of blocks ``xb`` (blocks, m, columns...) of ``item(i)`` (the block
    position i of every block), added in the order numpy's sum over that axis adds them, so
    the same numbers to the bit; ten times faster than numpy walking the middle axis, and its
    temporaries have the size of the result."""
    s = np.array(item(0), dtype=float, copy=True)
    for i in range(1, xb.shape[1]):
        s += item(i)
    return s


def calibration_sensitivities(design, mode, w_in, tau_out, located=None):
    """d T_in_model / d mesh_loss_k, / d idle_loss_scale and / d load_loss_scale along a
    recording [N*m], finite differences on SENSITIVITY_GRID (k forward, backward at its upper
    bound; the scales central, one-sided at their bounds); the second None where the
    design has no load-independent losses (paper profile, losses = "load_dependent").
    ``located``: ``replay_input_torque``'s look-ups of these speeds, shared."""
    from model_core.design import (IDLE_LOSS_SCALE_BOUNDS, LOAD_LOSS_SCALE_BOUNDS,
                                   MESH_LOSS_K_BOUNDS)
    from dataclasses import replace as _replace
    g = SENSITIVITY_GRID
    cal = design.calibration

    def T(grid=g, **changes):
        d = _replace(design, calibration=_replace(cal, **changes)) if changes else design
        return replay_input_torque(d, mode, w_in, tau_out, grid, located)[0]
    base = T()
    hk = MESH_LOSS_STEP if cal.mesh_loss_k + MESH_LOSS_STEP <= MESH_LOSS_K_BOUNDS[1] \
        else -MESH_LOSS_STEP
    sens_k = (T(mesh_loss_k=cal.mesh_loss_k + hk) - base) / hk
    sens_idle = None
    if design.profile == "physical" and design.losses == "all":
        # central where both sides lie in the bounds (the fit moves the scale either way)
        s0, h = cal.idle_loss_scale, IDLE_SCALE_STEP
        lo, hi = IDLE_LOSS_SCALE_BOUNDS
        up, dn = min(s0 + h, hi), max(s0 - h, lo)
        # on the base replay's grid: the drag is kept over the speed alone, and its
        # interpolation between SENSITIVITY_GRID's fewer speed nodes is off by ~0.2 %
        T_up = T(None, idle_loss_scale=up)
        T_dn = T(None, idle_loss_scale=dn)
        sens_idle = (T_up - T_dn) / (up - dn)
    s0, h = cal.load_loss_scale, LOAD_SCALE_STEP
    lo, hi = LOAD_LOSS_SCALE_BOUNDS
    up, dn = min(s0 + h, hi), max(s0 - h, lo)
    sens_load = (T(load_loss_scale=up) - T(load_loss_scale=dn)) / (up - dn)
    return sens_k, sens_idle, sens_load


def _scaled(design, mu=1.0, nu=1.0):
    from model_core.design import scale_friction_level, scale_viscosity
    return scale_viscosity(scale_friction_level(design, mu), nu)


@dataclass
class Replay:
    """The model along one recording (sample level, SI).

    ``T_model``: the input torque the transducer should read by the model (N*m), the design's
    extra physics and transducer corrections included; ``signals``: the dict the effects read
    (``model_core.effects.effect_signals``), with ``loss_in``, ``T_in_model``, ``sens_mu``,
    ``sens_nu``."""

    T_model: np.ndarray
    signals: dict


def replay(design: DriveDesign, mode: str, rec, bandwidth: float = 0.0,
           sensitivities=None, calibration: bool = True) -> Replay:
    """Replay ``rec`` (measured input speed and output torque) through the model of ``design``.

    ``bandwidth`` [Hz]: the speed transducer's first-order bandwidth; the shaft angle is
    advanced by the delay of that filter as sampled (``transducer_delay``: 1/(2 pi f_c) -
    dt/2 where dt << 1/(2 pi f_c); at the roller-pass order of 2800 r/min the 0.16 ms of a
    1 kHz transducer are 0.65 rad of phase). ``sensitivities``: (sens_mu,
    sens_nu) or (sens_mu, sens_nu, sens_k, sens_idle[, sens_load]) of an earlier replay to reuse (a
    re-linearised replay at a nearby design); one given as None, or the calibration's when
    only two are given, is computed at ``design``. ``calibration=False``: the calibration's
    sensitivities (four replays; read only by the calibration effects' columns, never by the
    model's torque) are not computed unless given, and are None in the signals."""
    t, w_in, T_out = rec.time, rec.speed_in, rec.torque_out
    tau_out = -T_out
    located = {}      # the speeds' places on the maps' speed grids, looked up once per grid
    # (with the gear's load-dependent loss torque, which the run-in scales)
    T_in, loss, load_loss = replay_input_torque(design, mode, w_in, tau_out, located=located,
                                                load_loss=True)
    h = SENSITIVITY_STEP
    dln = math.log(1 + h) - math.log(1 - h)
    g = SENSITIVITY_GRID

    def diff(**k):
        up = {n: 1 + h for n in k}
        dn = {n: 1 - h for n in k}
        return (replay_input_torque(_scaled(design, **up), mode, w_in, tau_out, g, located)[0]
                - replay_input_torque(_scaled(design, **dn), mode, w_in, tau_out, g,
                                      located)[0]) / dln
    given = tuple(sensitivities) if sensitivities is not None else ()
    sens_mu, sens_nu, sens_k, sens_idle, sens_load = given + (None,) * (5 - len(given))
    # (a sensitivity passed as None is computed at this design)
    sens_mu = diff(mu=1) if sens_mu is None else sens_mu
    sens_nu = diff(nu=1) if sens_nu is None else sens_nu
    if calibration and (sens_k is None or sens_idle is None or sens_load is None):
        sens_k, sens_idle, sens_load = calibration_sensitivities(design, mode, w_in, tau_out,
                                                                 located)
    dt = float(np.median(np.diff(t))) if len(t) > 1 else 1.0
    from scipy.ndimage import uniform_filter1d
    # an odd window, centred: an even one (20 samples at 1 kHz) is centred half a sample late,
    # and the angle integrated from it lags by w dt/2 (0.06 rad at the 2x order of 600 r/min,
    # 0.2 rad at the roller pass of 300 r/min: a ripple's phase rotated)
    w_s = uniform_filter1d(w_in, 2 * int(round(SPEED_SMOOTHING / (2 * dt))) + 1, mode="nearest")
    sig = effect_signals(t, w_s, loss, mode, design.z1, getattr(rec, "temperature", None),
                         T_in_model=T_in, sens_mu=sens_mu, sens_nu=sens_nu, sens_k=sens_k,
                         sens_idle=sens_idle, tau_out=tau_out, sens_load=sens_load,
                         load_loss_in=load_loss)
    if bandwidth > 0:
        # the measured speed lags the shaft's by the transducer's delay, the angle integrated
        # from it by that delay times the speed: advanced by the delay of the same filter the
        # torque is compared through (first_order), not the continuous 1/(2 pi f_c)
        sig["theta_in"] = sig["theta_in"] + w_s * transducer_delay(bandwidth, dt)
    # the design's housing: the heat balance the warm-up driven by the loss power integrates
    # (effects.heat_balance_rise), and where a design's warm-up per 10 K meets a recording
    # without a temperature column, the FMUs' own from T_oil_start (effects.extra_torque)
    from model_core import thermal
    sig["housing_R"] = thermal.housing_resistance(design)
    sig["housing"] = (design.operating_temperature, design.ambient_temperature,
                      design.housing_heat_capacity, sig["housing_R"])
    ex = design.extra
    per_10K = bool(ex.viscosity_ln_per_10K) and sig.get("temperature") is not None
    if bool(ex.viscosity_ln_change) != per_10K:
        # the design's viscosity drift at its size (effects.extra_torque, effects._viscosity;
        # one form only: the replays are taken over one span)
        from model_core.effects import viscosity_span
        from model_core.lossmap import viscosity_steps
        c, shape = ((ex.viscosity_ln_per_10K, None) if per_10K
                    else (ex.viscosity_ln_change, ex.viscosity_tau))
        sig["nu_steps"] = viscosity_steps(design, mode, w_in, tau_out,
                                          c * viscosity_span(sig, shape))
    T_true = T_in + extra_torque(design.extra, sig)
    sig["T_in_model"] = T_true
    return Replay(reading_model(design.extra, T_true, sig), sig)
