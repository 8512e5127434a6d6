"""Synthetic bench recordings with one hidden effect (``cyclo-fmu synth``).

The recording comes from the bench's components, replayed vectorised at the recording's rate
(an SSP run of ten minutes at 1 kHz would take minutes): the input speed follows the
regulator's setpoints through ramps and the motor's first-order response, the felt brake's law
and the output inertia give the load, the reducer is the FMU's map of the core (ModeMap) built
for a design whose friction coefficient is off by ``friction_error`` (up to 15 %), a hidden
effect from model_core.effects adds its torque at the input shaft, and the transducer model of
the bench (bandwidth, noise, quantisation) makes the readings.

The test plan varies speed (including low speeds), load, direction and time independently, as
the diagnosis needs to tell the effects apart: forward and reverse runs, ramps, a load sweep at
each speed, and (for sizes from "medium" on) long holds for a warm-up.
"""
from __future__ import annotations

import math
import shutil
from pathlib import Path
from dataclasses import dataclass, replace

import numpy as np

from model_core import DriveDesign
from model_core.errors import CycloidInputError
from model_core.effects import (EFFECT_ALIASES, EFFECTS, MODEL_PARAMETER_EFFECTS, effect_signals,
                                HeatBalanceTau, TemperatureScale,
                                resolve_effect, switch_on)
from model_core.kinematics import parse_mode, shaft_speeds
from model_core.lossmap import replay_input_torque

from .bench import RECORDING_COLUMNS, write_recording

SIZES = {"tiny": 42.0, "small": 120.0, "medium": 300.0, "large": 600.0}
ENGINES = ("fast", "bench")
#: effects the bench's FMUs cannot hide: they act through the replay only (the reducer FMU's
#: map is built at the catalogue viscosity). With a temperature column (``temperature_rise``)
#: the bench hides the viscosity drift as what it is in the FMUs: the lubricant's viscosity-
#: temperature slope, the reducer's grease following the recording's temperature
BENCH_CANNOT_HIDE = {"viscosity_drift"}
#: effects the bench hides with a temperature column (``temperature_rise``): the viscosity
#: drift as the true lubricant's slope, the warm-up as the reducer FMU's loss change per 10 K
#: (extra.thermal_loss_per_10K from the column's first value, thermal_T_ref), the input
#: torque transducer's zero drift per 10 K of its temperature input (the reducer's T_oil)
BENCH_TEMPERATURE_EFFECTS = {"viscosity_drift", "thermal_drift", "torque_sensor_drift"}

#: hidden-effect sizes (the registry's synth defaults): comparable with the transducer noise
#: (0.003 N*m), invisible by eye
DEFAULT_EFFECTS = {k: e.synth_default for k, e in EFFECTS.items()}


@dataclass(frozen=True)
class SynthSettings:
    sample_rate: float = 1000.0     # Hz
    torque_noise: float = 0.003     # N*m
    torque_resolution: float = 0.0005
    speed_noise: float = 0.5        # r/min
    speed_resolution: float = 0.1
    bandwidth: float = 1000.0       # Hz, transducers
    speed_time_constant: float = 0.05   # s, motor speed response to the ramped setpoint
    ramp_rate: float = 1500.0       # r/min per s
    brake_w_reg: float = 0.5        # rad/s
    J_out: float = 2.0e-3           # kg m^2


PLANS = ("full", "one_speed", "four_quadrant", "hoist")
#: [r/min] the hoist plan's creeping speeds (input shaft, both senses): from just above the
#: diagnosis's rest bound (1 r/min) through the band where a drive's friction builds up
#: (pre-sliding: a few r/min) to positioning speeds
HOIST_CREEP_SPEEDS = (1.5, 2.0, 3.0, 5.0, 10.0, 30.0)


def test_plan(duration: float, rng: np.random.Generator, plan: str = "full"):
    """Setpoints [(t_start, input speed r/min, output brake torque N*m)] over ``duration``.
    ``full`` varies speed (both directions), load and time; ``one_speed`` only steps the load
    at 2000 r/min forward, a poor plan under which some effects look alike;
    ``four_quadrant`` adds back-driven holds (a load machine driving the output: negative
    brake torque), which separate a transducer gain error from a friction level; ``hoist``
    lifts and lowers payloads (a load torque of one sense whatever the motion: lowering is
    back-driven) at creeping speeds (HOIST_CREEP_SPEEDS) and at 300 and 1200 r/min."""
    if plan not in PLANS:
        raise ValueError(f"plan = {plan!r}: must be one of {', '.join(PLANS)}")
    speeds = [300.0, 600.0, 1200.0, 2000.0, 2800.0] if plan != "one_speed" else [2000.0]
    loads = [2.0, 4.5, 7.5]
    steps = [(n, T) for n in speeds for T in loads]
    if plan in ("full", "four_quadrant"):
        steps += [(-n, T) for n in (600.0, 1600.0, 2800.0) for T in (3.0, 7.0)]
    if plan == "four_quadrant":
        steps += [(n, -T) for n in (600.0, 1600.0, -1600.0, 2800.0) for T in (2.0, 5.0)]
    if plan == "one_speed":
        steps = steps * 4
    if plan == "hoist":
        steps = [(s * n, T) for n in HOIST_CREEP_SPEEDS + (300.0, 1200.0) for s in (1, -1)
                 for T in (2.0, 5.0)]
    hold = duration / len(steps)
    order = rng.permutation(len(steps))
    return [(k * hold, steps[i][0], steps[i][1]) for k, i in enumerate(order)], hold


def _first_order(x, dt, tau):
    if tau <= 0:
        return x
    a = math.exp(-dt / tau)
    from scipy.signal import lfilter
    return lfilter([1 - a], [1, -a], x, zi=[a * x[0]])[0]


def signals_for_effects(t, w_in, loss_in, mode, z1, temperature=None):
    """The signal dict model_core.effects expects (``model_core.effects.effect_signals``)."""
    return effect_signals(t, w_in, loss_in, mode, z1, temperature)


def _hidden(effect, effect_values, shape) -> dict:
    """{effect id: (values, shape)} of the hidden effects, defaults from the registry."""
    if isinstance(effect, str):
        effect = {effect: (effect_values, shape)}
    elif not isinstance(effect, dict):
        effect = {e: (None, None) for e in effect}
    out = {}
    for eid, spec in effect.items():
        if eid in EFFECT_ALIASES:      # an id of an earlier version (load_ripple)
            v, sh = spec if spec is not None else (None, None)
            eid, v, sh = resolve_effect(eid, v or {"B1_sin": 0.004, "B1_cos": 0.002,
                                                    "Bz_sin": 0.006, "Bz_cos": 0.0}, sh)
            spec = (v, sh)
        if eid not in EFFECTS:
            raise ValueError(f"effect = {eid!r}: must be one of {', '.join(EFFECTS)}")
        values, sh = spec if spec is not None else (None, None)
        d_values, d_shape = EFFECTS[eid].synth_default
        out[eid] = (dict(d_values, **(values or {})), sh if sh is not None else d_shape)
    return out


def synthesize(effect, seed: int, mode: str = "S1", size: str = "small",
               design: DriveDesign = None, settings: SynthSettings = SynthSettings(),
               friction_error: float = None, effect_values: dict = None, shape=None,
               plan: str = "full", engine: str = "fast", fmu_dir=None, added_torque=None,
               temperature_rise: float = None, duration: float = None, progress=False,
               temperature_tau: float = None) -> dict:
    """A recording dict (schema columns, edge units r/min and N*m) plus ``truth``.

    ``effect``: one effect id, a list of ids or {id: (values, shape)} (several hidden at
    once; ``effect_values``/``shape`` apply to a single id). ``added_torque(signals)``: a
    torque (N*m) at the input of physics outside the library (for tests of the diagnosis's
    'unexplained'). ``temperature_rise`` [K]: the recording carries a temperature column
    warming by this much with the first warm-up time constant (25 degC start), or with
    ``temperature_tau`` [s] where given, and temperature-form effects follow it: linearly per
    10 K, or, a warm-up whose shape is a ``model_core.effects.TemperatureScale`` theta, by the
    exponential temperature law (``thermal.loss_temperature_law``). ``duration`` [s]
    overrides the size."""
    hidden = _hidden(effect, effect_values, shape)
    for eid, (_, sh) in hidden.items():
        if isinstance(sh, TemperatureScale) and temperature_rise is None:
            raise ValueError(f"{eid}: a temperature scale (the exponential temperature law) "
                             "needs a temperature column (temperature_rise)")
    if size not in SIZES:
        raise ValueError(f"size = {size!r}: must be one of {', '.join(SIZES)}")
    a, b, h = parse_mode(mode)
    if a != "S":
        raise ValueError(f"mode = {mode!r}: the bench drives the eccentric shaft (S1 or S2)")
    if engine not in ENGINES:
        raise ValueError(f"engine = {engine!r}: must be one of {', '.join(ENGINES)}")
    design = design or DriveDesign()
    rng = np.random.default_rng(seed)
    duration = duration or SIZES[size]
    dt = 1.0 / settings.sample_rate
    t = np.arange(int(round(duration * settings.sample_rate))) * dt
    hoist = plan == "hoist"
    if hoist and engine == "bench":
        raise CycloidInputError("plan", plan, "the bench's load is a brake (its torque "
                                "opposes the motion), not a payload: use engine 'fast'")
    plan, hold = test_plan(duration, rng, plan)
    # speed: ramped setpoints, then the motor's first-order response
    n_set = np.zeros_like(t)
    T_set = np.zeros_like(t)
    for t0, n, T in plan:
        n_set[t >= t0] = n
        T_set[t >= t0] = T
    n_ramp = np.empty_like(n_set)
    cur, step = 0.0, settings.ramp_rate * dt
    for k, target in enumerate(n_set):        # rate limiter (cheap: one pass)
        cur = target if abs(target - cur) <= step else cur + math.copysign(step, target - cur)
        n_ramp[k] = cur
    w_in = _first_order(n_ramp * math.pi / 30, dt, settings.speed_time_constant)
    ratio = float(shaft_speeds(mode, 1.0, design.z1)[b])
    w_out = ratio * w_in
    alpha_out = np.gradient(w_out, t)
    # the brake's torque opposes the motion (regularised through standstill); a hoist's
    # payload pulls one way whatever the motion
    T_load = T_set if hoist else T_set * np.tanh(w_out / settings.brake_w_reg)
    T_deliv = T_load + settings.J_out * alpha_out
    tau_out = -T_deliv
    # the true reducer: friction coefficient off by friction_error
    ids = set(hidden)
    if friction_error is None:
        friction_error = 0.0 if ids <= {"none"} else float(rng.uniform(-0.15, 0.15))
        if "friction_miscalibrated" in ids and abs(friction_error) < 0.06:
            friction_error = math.copysign(0.06 + abs(friction_error), friction_error or 1.0)
    from model_core.design import scale_friction_level
    true_design = scale_friction_level(design, 1 + friction_error)
    # effects that act through the design's calibration (mesh loss k, idle-loss scale): the
    # true reducer has them, as it has the friction error
    for eid in ("mesh_loss", "idle_loss_scale", "load_loss_scale"):
        if eid in hidden:
            true_design, _ = EFFECTS[eid].apply(true_design, hidden[eid][0])
    if engine == "bench":
        if len(hidden) != 1 or added_torque is not None:
            raise ValueError("engine = 'bench' hides exactly one library effect")
        if temperature_rise is not None and not set(hidden) <= BENCH_TEMPERATURE_EFFECTS:
            raise CycloidInputError("effect", next(iter(hidden)), "with a temperature column "
                                    "the bench hides only " + ", ".join(
                                        sorted(BENCH_TEMPERATURE_EFFECTS)) + "; use engine "
                                    "'fast'")
        if temperature_rise is None and set(hidden) & BENCH_CANNOT_HIDE:
            raise CycloidInputError("effect", next(iter(hidden)),
                                    "the bench's FMUs do not carry it in time form (replay "
                                    "only); give a temperature_rise, or use engine 'fast'")
        (eid, (values, eff_shape)), = hidden.items()
        return _through_the_bench(eid, values, eff_shape, true_design, plan, hold, mode,
                                  duration, seed, settings, friction_error, fmu_dir, progress,
                                  temperature_rise, temperature_tau)
    tau_in, loss_in, load_loss_in = replay_input_torque(true_design, mode, w_in, tau_out,
                                                        load_loss=True)
    temperature = None
    if temperature_rise is not None:
        tau_T = temperature_tau or next(
            (sh for e, (v, sh) in hidden.items() if EFFECTS[e].temperature_form
             and not isinstance(sh, TemperatureScale)), None) or 300.0
        temperature = 25.0 + temperature_rise * (1 - np.exp(-t / tau_T))
    sens_nu = None
    if "viscosity_drift" in hidden:
        from model_core.lossmap import replay_input_torque as rp
        from model_core.design import scale_viscosity
        hi = scale_viscosity(true_design, 1.05)
        lo = scale_viscosity(true_design, 0.95)
        sens_nu = (rp(hi, mode, w_in, tau_out)[0] - rp(lo, mode, w_in, tau_out)[0]) / (
            math.log(1.05) - math.log(0.95))
    sig = effect_signals(t, w_in, loss_in, mode, design.z1, temperature, T_in_model=tau_in,
                         sens_nu=sens_nu, tau_out=tau_out, load_loss_in=load_loss_in)
    # the housing whose heat balance a warm-up driven by the loss power integrates
    # (effects.HeatBalanceTau)
    from model_core.thermal import housing_resistance
    sig["housing_R"] = housing_resistance(true_design)
    if "thermal_drift" in hidden and isinstance(hidden["thermal_drift"][1], HeatBalanceTau):
        # the heat is the loss, the warm-up's change included (the FMUs' heat balance):
        # the rise of a warm-up of its size (effects.heat_balance_rise)
        sig["heat_secant"] = hidden["thermal_drift"][0].get("loss_change", 0.0)
    if sens_nu is not None and hidden["viscosity_drift"][0].get("ln_viscosity_change"):
        # the viscosity drift through the core at its size (the quadratic in ln(nu) through
        # replays at the drift's end and middle: effects._viscosity)
        from model_core.effects import viscosity_span
        from model_core.lossmap import viscosity_steps
        c, sh = hidden["viscosity_drift"][0]["ln_viscosity_change"], hidden["viscosity_drift"][1]
        sh = None if temperature is not None else sh
        sig["nu_steps"] = viscosity_steps(true_design, mode, w_in, tau_out,
                                          c * viscosity_span(sig, sh))
        sig["nu_secant"] = c
    if design.extra.discovered:      # a design's discovered loss, as the core evaluates it
        tau_in = tau_in + design.extra.discovered_torque(w_in, tau_out)
    extra = np.zeros_like(t)
    offset = gain = 0.0
    for eid, (values, eff_shape) in hidden.items():
        eff = EFFECTS[eid]
        if eid in MODEL_PARAMETER_EFFECTS:
            continue      # they act through the true design (friction error, calibration)
        if eid == "torque_sensor_offset":
            offset += values["offset"]
            continue
        if eid == "torque_sensor_gain":
            gain += values["gain_error"]
            continue
        sh = eff_shape
        if eff.temperature_form and temperature is not None:
            # the temperature form: linear (None) or the exponential law at its scale theta
            sh = eff_shape if isinstance(eff_shape, TemperatureScale) else None
        extra += eff.torque(sig, [values.get(p.name, 0.0) for p in eff.parameters_for(sh)],
                            sh)
    if added_torque is not None:
        extra = extra + np.asarray(added_torque(sig), float)
    tau_in_total = tau_in + extra
    # transducers: bandwidth, noise, quantisation (readings in r/min and N*m)
    def read(x, noise, res):
        y = _first_order(x, dt, 1 / (2 * math.pi * settings.bandwidth)) + noise * rng.standard_normal(len(x))
        return res * np.round(y / res) if res > 0 else y
    rec = {
        "time_s": t,
        "speed_in_rpm": read(w_in * 30 / math.pi, settings.speed_noise, settings.speed_resolution),
        "torque_in_Nm": read((1 + gain) * tau_in_total + offset, settings.torque_noise,
                             settings.torque_resolution),
        "speed_out_rpm": read(w_out * 30 / math.pi, settings.speed_noise, settings.speed_resolution),
        "torque_out_Nm": read(T_deliv, settings.torque_noise, settings.torque_resolution),
    }
    if temperature is not None:
        rec["temperature_C"] = temperature + 0.05 * rng.standard_normal(len(t))
    hidden_rms = (1 + gain) * tau_in_total + offset - tau_in
    first = next(iter(hidden))
    rec["truth"] = {"effect": first if len(hidden) == 1 else sorted(hidden),
                    "effects": {e: {"values": v, "shape": sh} for e, (v, sh) in hidden.items()},
                    "values": hidden[first][0], "shape": hidden[first][1],
                    "added_torque": added_torque is not None,
                    "friction_error": friction_error, "mode": mode, "seed": seed,
                    "extra_torque_rms_Nm": float(np.sqrt(np.mean(hidden_rms ** 2)))}
    return rec


def write_synth(path, rec: dict):
    """Write the recording (schema columns only; the truth stays out of the file)."""
    cols = RECORDING_COLUMNS + (["temperature_C"] if "temperature_C" in rec else [])
    return write_recording(path, {c: rec[c] for c in cols}, cols)


PAPER_ZETA_D = {"S1": 0.0176, "S2": 0.0192}   # the paper's mean additional-loss factors


def paper_like(mode: str = "S1", seed: int = 1, size: str = "small", **kw) -> dict:
    """A recording whose hidden load-independent loss is sized like the paper's discrepancy:
    zeta_d (Eq. 31, over the driven samples) equal to the paper's mean, 1.76 % in S1 and
    1.92 % in S2; as in the paper it weighs most at low input power."""
    from model_core.paper import additional_loss_factor
    target = PAPER_ZETA_D["".join(parse_mode(mode)[:2])]

    def zeta(T_drag):
        rec = synthesize("load_independent_loss", seed, mode, size, friction_error=0.0,
                         effect_values={"T_drag": T_drag}, **kw)
        w_in = rec["speed_in_rpm"] * math.pi / 30
        w_out = rec["speed_out_rpm"] * math.pi / 30
        T_model, _ = replay_input_torque(kw.get("design") or DriveDesign(), mode, w_in,
                                         -rec["torque_out_Nm"])
        return additional_loss_factor(w_in, rec["torque_in_Nm"], w_out, rec["torque_out_Nm"],
                                      T_model, 10), rec

    z1, _ = zeta(0.01)
    z0, _ = zeta(0.0)
    T_drag = 0.01 * (target - z0) / (z1 - z0)       # zeta_d is linear in the drag torque
    friction_error = kw.pop("friction_error", None)
    rec = synthesize("load_independent_loss", seed, mode, size, friction_error=friction_error,
                     effect_values={"T_drag": T_drag}, **kw)
    rec["truth"]["zeta_d_target"] = target
    return rec


def _through_the_bench(effect, values, shape, true_design, steps, hold, mode, duration, seed,
                       settings, friction_error, fmu_dir, progress=False, temperature_rise=None,
                       temperature_tau=None):
    """The recording from the bench's FMUs (motor, reducer, brake, transducers): the hidden
    effect switched on in the reducer FMU's extra physics (or the transducer's zero offset),
    the setpoints of the plan as the motor's and brake's schedules.

    ``temperature_rise`` [K]: the reducer's grease follows a temperature from the design's
    operating temperature, rising by this much with the time constant ``shape`` (its input
    T_oil_in), and the recording carries it as its temperature column (noise 0.05 K). The
    viscosity drift is then the true lubricant's: its Walther line with d ln(nu)/dT =
    ln_viscosity_change / 10 K at the operating temperature (thermal.lubricant_with_slope, the
    diagnosis's own mapping), in a reducer FMU built with it; the transducer's zero drift is
    per 10 K of its temperature input (the reducer's T_oil) from the operating temperature."""
    import tempfile
    from .bench import COMPONENTS, Scenario, Sensors, bench_parameters, recording_from_result, run_fmus
    from .fmu_build import build_fmu
    ex = true_design.extra
    sensors = Sensors(bandwidth=settings.bandwidth, torque_noise=settings.torque_noise,
                      torque_resolution=settings.torque_resolution,
                      speed_noise=settings.speed_noise, speed_resolution=settings.speed_resolution,
                      seed=seed,
                      torque_in_offset=values.get("offset", 0.0) if effect == "torque_sensor_offset" else 0.0,
                      torque_in_gain_error=values.get("gain_error", 0.0)
                      if effect == "torque_sensor_gain" else 0.0,
                      torque_in_zero_drift=values.get("offset_change", 0.0)
                      if effect == "torque_sensor_drift" and temperature_rise is None else 0.0,
                      torque_in_zero_tau=shape if effect == "torque_sensor_drift"
                      and temperature_rise is None else 300.0,
                      torque_in_zero_per_10K=values.get("offset_change", 0.0)
                      if effect == "torque_sensor_drift" and temperature_rise is not None
                      else 0.0,
                      torque_in_zero_T_ref=true_design.operating_temperature)
    if effect == "viscosity_drift":      # the true lubricant (a temperature column only)
        from model_core.effects import T_STEP
        from model_core.thermal import lubricant_with_slope
        true_design = replace(true_design, lubricant=lubricant_with_slope(
            true_design.lubricant, true_design.operating_temperature,
            values["ln_viscosity_change"] / T_STEP))
    elif effect == "thermal_drift" and temperature_rise is not None:
        # the losses change per 10 K of the grease temperature from where the column starts
        # (the design's operating temperature): the registry's per-10 K form
        ex = EFFECTS[effect].apply(replace(true_design, extra=ex), values,
                                   shape if isinstance(shape, TemperatureScale) else None,
                                   temperature=true_design.operating_temperature)[0].extra
    elif effect == "thermal_drift" and isinstance(shape, HeatBalanceTau):
        # a warm-up driven by the loss power: the reducer FMU's own heat balance (housing's C
        # and ambient, the losses per 10 K of its T_oil: effects._apply_heat_balance)
        true_design = EFFECTS[effect].apply(replace(true_design, extra=ex), values, shape)[0]
        ex = true_design.extra
    elif effect not in ("torque_sensor_offset", "torque_sensor_gain", "torque_sensor_drift"):
        ex = switch_on(ex, effect, values, shape)
    design = replace(true_design, extra=ex)
    pole_pairs = 1
    f_sched = "; ".join(f"{t0:.6g} {n * pole_pairs / 60:.6g}" for t0, n, _ in steps)
    T_sched = "; ".join(f"{t0:.6g} {T:.6g}" for t0, _, T in steps)
    # the plan has more setpoints than the numbered Real schedule parameters hold: the String
    # form, which run_fmus sets
    sc = Scenario("synth", mode=mode,
                  duration=duration, hold=hold, J_out=settings.J_out)
    params = bench_parameters(sc, sensors, design)
    params["motor.frequency_schedule"] = f_sched
    params["brake.torque_schedule"] = T_sched
    params["motor.ramp_rate"] = settings.ramp_rate / 60.0       # r/min per s -> Hz per s
    # the reducer's inertia secants over the acceleration the regulator's ramp gives the
    # two-pole motor's shaft (r/min per s -> rad/s^2; CycloidDrive.alpha_ref)
    params["drive.alpha_ref"] = settings.ramp_rate * 2 * math.pi / 60.0
    dt = 1.0 / settings.sample_rate
    signals = temperature = None
    if temperature_rise is not None:
        from model_core.design import KELVIN
        tau_T = temperature_tau or (None if isinstance(shape, TemperatureScale)
                                    else shape) or 300.0
        grid = np.arange(int(round(duration / dt)) + 1) * dt

        def temperature(t):     # degC
            return (design.operating_temperature - KELVIN
                    + temperature_rise * (1.0 - np.exp(-np.asarray(t) / tau_T)))
        params["drive.use_T_oil_input"] = True
        signals = {"drive.T_oil_in": temperature(grid) + KELVIN}
    with tempfile.TemporaryDirectory() as tmp:
        d = fmu_dir or tmp
        if fmu_dir is None:
            for name in sorted({f for f, _ in COMPONENTS.values()}):
                build_fmu(name, d)
        if effect == "viscosity_drift":   # the reducer built with the true lubricant
            own = Path(tmp) / "true"
            own.mkdir()
            for name in sorted({f for f, _ in COMPONENTS.values()} - {"CycloidDrive"}):
                shutil.copy(Path(d) / f"{name}.fmu", own)
            build_fmu("CycloidDrive", own, design=design)
            d = own
        res = run_fmus(d, params, duration, dt, progress=progress, fmus="python",
                       signals=signals)
    if signals is not None:     # the first row holds the initial values (run_fmus)
        res = res[1:]
        rec = recording_from_result(res)
        rec["time_s"] = rec["time_s"] - dt
        rng = np.random.default_rng(seed + 7919)
        rec["temperature_C"] = (temperature(rec["time_s"])
                                + 0.05 * rng.standard_normal(len(rec["time_s"])))
    else:
        rec = recording_from_result(res)
    rec["truth"] = {"effect": effect, "values": values, "shape": shape,
                    "friction_error": friction_error, "mode": mode, "seed": seed,
                    "engine": "bench"}
    return rec
