"""Command line: ``cyclo-fmu efficiency|paper``.

Units at this edge: r/min for speeds, N*m for torques, W for powers; converted once on the way
in and out. Errors: one line on stderr, exit status 2.
"""
from __future__ import annotations

import argparse
import contextlib
import json
import math
import sys
from pathlib import Path


from model_core import (CycloidInputError, DriveDesign, LOSS_NAMES, design_from_toml,
                        operating_point, rad_s_to_rpm, rpm_to_rad_s)
from model_core.design import PROFILES
from model_core.kinematics import MODES, parse_mode
from model_core.losses import LOSS_DESCRIPTIONS


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, non-zero exit
        self.exit(2, f"{self.prog}: error: {message}\n")


def _number(name):
    def conv(text):
        try:
            return float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} = {text!r}: not a number")
    return conv


# -- shared robustness helpers (cyclo_fmu.outputs): every command validates its outputs up front
# and writes them so that a failure leaves nothing half-written
from .outputs import (output_dir as _output_dir, output_file as _output_file,  # noqa: E402
                      staged_dir as _staged_dir, staged_file as _staged_file)


def _check_seed(seed):
    if seed is not None and not 0 <= seed < 2 ** 63:
        raise CycloidInputError("seed", seed, "must be a whole number from 0 to 2^63 - 1")


_FMU_ERRORS = []       # the last error-level messages the FMUs logged (instance, message)


def _collect_fmu_log() -> None:
    """Route the FMUs' log through the CLI: errors are kept so that a failing FMU call ends in
    one line with the FMU's own message; other messages stay unprinted, as with logging off
    before. A command that runs FMUs opts in with ``set_defaults(fmus=True)``."""
    try:
        from ctypes import byref
        import fmpy.fmi2 as f2
        from fmpy.logging import addLoggerProxy
    except Exception:          # noqa: BLE001 - no fmpy (or no native logger): fmpy's default
        return

    def logger(component, instance, status, category, message):
        if status >= 3:        # fmi2Error, fmi2Fatal
            _FMU_ERRORS.append(((instance or b"").decode("utf-8", "replace"),
                                (message or b"").decode("utf-8", "replace")))
            del _FMU_ERRORS[:-5]


    cb = f2.fmi2CallbackFunctions()
    cb.logger = f2.fmi2CallbackLoggerTYPE(logger)
    cb.allocateMemory = f2.defaultCallbacks.allocateMemory
    cb.freeMemory = f2.defaultCallbacks.freeMemory
    addLoggerProxy(byref(cb))
    f2.defaultCallbacks = cb
    # pythonfmu passes messages on only with logging on; only errors are kept above
    plain = f2._FMU2.instantiate

    def instantiate(self, visible=False, callbacks=None, loggingOn=True):
        return plain(self, visible=visible, callbacks=callbacks, loggingOn=loggingOn)
    f2._FMU2.instantiate = instantiate
    _collect_fmu_log.keep = (cb, logger)    # ctypes callbacks must outlive every FMU


def _add_profile(p):
    """The model-profile option shared by every command that takes a design."""
    p.add_argument("--profile", choices=PROFILES,
                   help="model profile: physical (default: correct kinematics, roll or skid, "
                   "Stribeck pin law, load-independent losses) or paper (what the paper "
                   "computed, Eq. 24 as printed, calibrated to its theory); overrides the "
                   "design file's [model] profile")


def _with_profile(design, profile):
    """The design in ``profile`` (None: as it is). The paper profile is the paper's model:
    load-dependent losses only."""
    if profile is None:
        return design
    return design.replace(profile=profile,
                          losses="load_dependent" if profile == "paper" else design.losses)


def _load_design(path, profile=None):
    """The design of ``--design``: a design file, or a preset name (model_core.presets)."""
    from model_core.presets import load_design
    return _with_profile(load_design(path), profile)


def _json_num(x):
    x = float(x)
    return None if not math.isfinite(x) else x


def cmd_efficiency(args) -> int:
    design = _load_design(args.design, args.profile)
    a, b, h = parse_mode(args.mode)
    if not math.isfinite(args.speed):
        raise CycloidInputError("speed", args.speed, "must be a finite number of r/min")
    if not math.isfinite(args.torque):
        raise CycloidInputError("torque", args.torque, "must be a finite number of N*m")
    if args.torque == 0:
        raise CycloidInputError("torque", args.torque, "no power flows at zero torque: the "
                                "efficiency is undefined (give the torque of the load case)")
    from model_core import thermal
    from model_core.design import KELVIN
    temperature = None
    if args.temperature is not None and args.ambient is not None:
        raise CycloidInputError("temperature", args.temperature, "give either --temperature "
                                "(fixed grease temperature) or --ambient (heat balance), not both")
    for name in ("temperature", "ambient"):
        v = getattr(args, name)
        if v is not None and not (math.isfinite(v) and -100 < v < 200):
            raise CycloidInputError(name, v, "must lie between -100 and 200 degC")
    if (args.temperature is not None or args.ambient is not None) and design.profile == "paper":
        raise CycloidInputError("profile", "paper", "the paper profile uses the catalogue "
                                "viscosity; --temperature and --ambient need --profile physical")
    if args.temperature is not None:
        design = thermal.at_temperature(design, args.temperature + KELVIN)
    if args.ambient is not None:
        op, temperature = thermal.solve_heat_balance(
            design.replace(ambient_temperature=args.ambient + KELVIN), a + b,
            rpm_to_rad_s(args.speed), args.torque)
        design = thermal.at_temperature(design, temperature)
    else:
        op = operating_point(design, a + b, rpm_to_rad_s(args.speed), args.torque)
    from model_core.contact import ring_torque_rating
    rating = ring_torque_rating(design)
    T_ring = abs(float(op.torques["1"]))
    if math.isfinite(T_ring) and T_ring > rating:
        raise CycloidInputError("torque", args.torque, f"puts {T_ring:.4g} N*m on the ring, beyond "
                                f"the design's static rating {rating:.4g} N*m (Hertz pressure "
                                "4000 MPa on the ring rollers, ISO 76)")
    losses = {k: _json_num(v) for k, v in op.losses.as_dict().items()}
    stalled = not bool(op.locked) and not math.isfinite(float(op.torques[b]))
    # the no-load running torque (the drag at the shafts and the gear's losses at zero load):
    # a driving torque below it cannot keep the drive turning unless the load drives it
    w_a = rpm_to_rad_s(args.speed)
    no_load = float(operating_point(design, a + b, w_a, T_out=0.0).torques[a])
    below_no_load = bool(args.torque * w_a > 0 and abs(args.torque) < abs(no_load))
    stalled = stalled or below_no_load
    p_in = float(op.input_power)
    w_out = float(op.speeds[b])
    t_out = -float(op.torques[b])   # torque the output shaft delivers to the load
    flow = op.mode if bool(op.flow_forward) else b + a
    result = {
        "mode": op.mode, "flow_mode": flow, "held_shaft": h,
        "eta": None if (bool(op.locked) or below_no_load) else _json_num(op.eta),
        "no_load_torque_Nm": _json_num(no_load),
        "eta0": _json_num(op.eta0), "locked": bool(op.locked), "stalled": stalled,
        "losses_W": losses,
        "loss_share": {k: (v / p_in if (v is not None and p_in > 0) else None)
                       for k, v in losses.items()},
        "loss_power_W": _json_num(op.loss_power),
        "input_speed_rpm": args.speed, "input_torque_Nm": _json_num(op.torques[a]),
        "input_power_W": _json_num(op.torques[a] * op.speeds[a]),
        "output_speed_rpm": float(rad_s_to_rpm(w_out)), "output_torque_Nm": _json_num(t_out),
        "output_power_W": _json_num(t_out * w_out),
        "reaction_torque_Nm": _json_num(op.torques[h]),
        "profile": design.profile, "losses": design.losses,
    }
    if not design.calibration.is_default:
        # a calibrated value is reported as calibrated, with what it was fitted to
        result["mesh_loss_W"] = _json_num(op.losses.PL_mesh)
        result["calibration"] = design.calibration.report()
    if design.profile == "physical":
        from model_core.losses import contact_states
        from model_core.drag import IDLE_NAMES
        result["idle_losses_W"] = {k: _json_num(getattr(op.losses, k)) for k in IDLE_NAMES}
        result["grease_temperature_C"] = design.operating_temperature - KELVIN
        result["grease_viscosity_mm2_s"] = thermal.lubricant_viscosity(design) * 1e6
        if math.isfinite(T_ring):
            st = contact_states(design, T_ring, float(op.speeds["2"] - op.speeds["S"]))
            result["rollers"] = {
                k: {"rolling_share": _json_num(st[k + "_rolling"]),
                    "state": ("no plain rollers" if not math.isfinite(st[k + "_rolling"]) else
                              "roll" if st[k + "_rolling"] == 1 else
                              "skid" if st[k + "_rolling"] == 0 else "mixed"),
                    "pin_hersey_min_max": [_json_num(x) for x in st[k + "_hersey"]],
                    "stribeck_clamp_binds": st[k + "_clamped"]} for k in ("ring", "disc")}
    if args.json:
        print(json.dumps(result, indent=2))
        return 0
    if stalled or (bool(op.locked) and not math.isfinite(t_out)):
        why = ("self-locking: the drive cannot be back-driven into S, it holds"
               if op.locked else
               f"the driving torque is below the no-load running torque {no_load:.4g} N*m at "
               "this speed (the drag of the shafts' bearings and seals, the grease, and the "
               "gear's losses at zero load): the drive stalls unless the load drives it"
               if below_no_load else "at this light load the drive's losses (the load-independent "
               "drag, seals and churning included) exceed the power it would transmit: no "
               "steady motion (stall)")
        print(f"cycloid drive, mode {op.mode}: no steady state at {args.speed} r/min, "
              f"{args.torque} N*m: {why}")
        return 0
    print(f"cycloid drive, mode {op.mode} (shaft {a} drives, {b} driven, {h} held), "
          f"power flows {flow[0]} -> {flow[1]}")
    print(f"  input   {args.speed:10.1f} r/min  {args.torque:9.4f} N*m  {result['input_power_W']:9.2f} W")
    print(f"  output  {result['output_speed_rpm']:10.1f} r/min  {t_out:9.4f} N*m  "
          f"{result['output_power_W']:9.2f} W")
    print(f"  reaction torque on held shaft {h}: {result['reaction_torque_Nm']:.4f} N*m")
    if op.locked:
        print(f"  LOCKED: back-driving is self-locking (eta0 = {float(op.eta0):.4f} <= i0 = "
              f"{design.i0:.4f}); the drive holds")
    else:
        print(f"  efficiency eta = {100 * float(op.eta):.2f} %   basic efficiency eta0 = "
              f"{100 * float(op.eta0):.3f} %")
    print("  partial losses:")
    from model_core.drag import IDLE_DESCRIPTIONS
    rows = [(k, losses[k], LOSS_DESCRIPTIONS[k]) for k in LOSS_NAMES]
    rows += [(k, v, IDLE_DESCRIPTIONS[k]) for k, v in result.get("idle_losses_W", {}).items()]
    if "mesh_loss_W" in result:
        from model_core.losses import MESH_LOSS_DESCRIPTION
        rows.append(("PL_mesh", result["mesh_loss_W"], MESH_LOSS_DESCRIPTION))
    for k, v, text in rows:
        share = f"{100 * v / p_in:6.2f} %" if p_in > 0 else "   n/a"
        print(f"    {k:10}  {v:9.3f} W  {share} of input   {text}")
    print(f"    {'sum':10}  {result['loss_power_W']:9.3f} W")
    print(f"  profile {design.profile}, losses {design.losses}")
    if "calibration" in result:
        c = result["calibration"]
        print(f"  CALIBRATED: mesh_loss_k = {c['mesh_loss_k']:.4g}, idle_loss_scale = "
              f"{c['idle_loss_scale']:.4g} (fitted to: {c['source'] or 'not stated'})")
    if "rollers" in result:
        print(f"  grease at {result['grease_temperature_C']:.1f} degC, "
              f"{result['grease_viscosity_mm2_s']:.1f} mm^2/s")
        for k, r in result["rollers"].items():
            if r["rolling_share"] is not None:
                print(f"  {k} rollers: {r['state']} ({100 * r['rolling_share']:.0f} % of the "
                      f"loaded rollers roll), pin Hersey number {r['pin_hersey_min_max'][0]:.3g}"
                      f"-{r['pin_hersey_min_max'][1]:.3g}"
                      f"{', Stribeck clamp binds' if r['stribeck_clamp_binds'] else ''}")
    return 0


def cmd_paper(args) -> int:
    from .paper import run_paper_comparison
    design = _load_design(args.design, args.profile)
    if not args.out:
        return run_paper_comparison(design, args.out, args.json)
    with _staged_dir("out", args.out) as out:
        return run_paper_comparison(design, out, args.json)


def cmd_stiffness(args) -> int:
    from model_core import stiffness as st
    design = _load_design(args.design, args.profile)
    rated = args.rated_torque
    if rated is not None and not (math.isfinite(rated) and rated > 0):
        raise CycloidInputError("rated-torque", rated, "must be a positive number of N*m")
    if args.out:
        _output_dir("out", args.out, create=False)
    values = st.catalogue_values(design, rated)
    if args.out:
        from .plots import plot_stiffness
        with _staged_dir("out", args.out) as out:
            plot_stiffness(design, values["rated_torque_Nm"], out / "stiffness.png")
            (out / "stiffness.json").write_text(json.dumps(values, indent=2))
    if args.json:
        print(json.dumps(values, indent=2))
        return 0
    print(f"Torsional behaviour with the input locked (contact model; rated torque "
          f"{values['rated_torque_Nm']:.3g} N*m)")
    print(f"  torsional rigidity (50-100 % rated)   {values['torsional_rigidity_Nm_per_arcmin']:.4g} N*m/arcmin")
    print(f"  lost motion (+-3 % rated)             {values['lost_motion_arcmin']:.4g} arcmin")
    print(f"  backlash                              {values['backlash_arcmin']:.4g} arcmin")
    print(f"  twist at rated torque                 {values['twist_at_rated_arcmin']:.4g} arcmin")
    print(f"  hysteresis loss (loop width at 0)     {values['hysteresis_loss_arcmin']:.4g} arcmin")
    if args.out:
        print(f"  figure: {Path(args.out) / 'stiffness.png'}")
    return 0


def cmd_build(args) -> int:
    from .fmu_build import ALL_FMUS, build_any
    for name in args.names:
        if name not in ALL_FMUS:
            raise CycloidInputError("FMU name", name, f"must be one of {', '.join(ALL_FMUS)}")
    design = _load_design(args.design, args.profile)
    with _staged_dir("dest", args.dest) as dest:
        for name in args.names or list(ALL_FMUS):
            print(build_any(name, dest, design))
    return 0


def cmd_export_modelica(args) -> int:
    from .modelica_export import export_modelica
    a, b, _ = parse_mode(args.mode)
    design = _load_design(args.design)
    with _staged_dir("out", args.out) as out:
        path = export_modelica(a + b, out, design,
                               design_name=Path(args.design).name if args.design else None)
    print(Path(args.out) / path.name)
    return 0


def _progress_on(args) -> bool:
    """Progress bars (tqdm, stderr) unless --quiet or stderr is not a terminal."""
    return not getattr(args, "quiet", False) and sys.stderr.isatty()


def _bench_step(text) -> float:
    """--step in ms ('steady': bench.STEADY_STEP) -> s; one line naming the field if bad."""
    from .bench import STEADY_STEP
    if str(text).strip().lower() == "steady":
        return STEADY_STEP
    try:
        ms = float(text)
    except ValueError:
        ms = float("nan")
    if not (math.isfinite(ms) and 0.01 <= ms <= 100):
        raise CycloidInputError("step", text, "must be a step in ms from 0.01 to 100, or "
                                "'steady'")
    return ms * 1e-3


def cmd_bench(args) -> int:
    from .bench import Sensors, fmu_names, run_bench, scenario
    from .fmu_cache import fmus_into
    mode = "".join(parse_mode(args.mode)[:2])
    if mode not in ("S1", "S2"):
        raise CycloidInputError("mode", args.mode, "the bench drives the eccentric shaft S: "
                                "S1 or S2")
    _check_seed(args.seed)
    step = _bench_step(args.step)
    try:
        sc = scenario(args.scenario, mode)
    except ValueError as exc:
        raise CycloidInputError("scenario", args.scenario, "must be one of paper, runup, "
                                "loadstep, reversal") from exc
    design = _load_design(args.design, args.profile)
    with _staged_dir("out", args.out) as out:
        # the FMUs built once per version and sources (cyclo_fmu.fmu_cache), copied here
        fmu_dir = fmus_into(out / "fmus", fmu_names(args.fmu_set), design)
        try:
            run = run_bench(sc, fmu_dir, out, Sensors(ideal=args.ideal_sensors, seed=args.seed),
                            step=step, design=design, progress=_progress_on(args),
                            plot=args.plot, fmus=args.fmu_set)
        except CycloidInputError:
            raise
        except ValueError as exc:
            raise CycloidInputError("design", args.design, str(exc))
    print(f"bench: mode {sc.mode}, scenario {sc.name}, {sc.stop_time:.0f} s simulated; "
          f"files in {out}")
    if not design.calibration.is_default:
        c = design.calibration
        print(f"  reducer CALIBRATED: mesh_loss_k = {c.mesh_loss_k:.4g}, idle_loss_scale = "
              f"{c.idle_loss_scale:.4g} (fitted to: {c.source or 'not stated'})")
    if run.windows:
        print(f"  {'n_in r/min':>10} {'T_in N*m':>9} {'eta bench %':>11} {'eta core %':>10}")
        for w in run.windows:
            print(f"  {w['speed_in_rpm']:10.0f} {w['torque_in_Nm']:9.3f} {100 * w['eta']:11.2f} "
                  f"{100 * w.get('eta_core', float('nan')):10.2f}")
    return 0


def cmd_synth(args) -> int:
    from .synth import PLANS, SIZES, synthesize, write_synth  # noqa: F401
    from model_core.effects import EFFECTS
    effects = [e.strip() for e in args.effect.split(",")]
    for e in effects:
        if e not in EFFECTS:
            raise CycloidInputError("effect", e, f"must be one of {', '.join(EFFECTS)} (several "
                                    "separated by commas)")
    if len(set(effects)) != len(effects):
        raise CycloidInputError("effect", args.effect, "names an effect twice")
    rise = args.temperature_rise
    if rise is not None and not (math.isfinite(rise) and -50.0 <= rise <= 150.0):
        raise CycloidInputError("temperature-rise", rise, "must lie between -50 and 150 K")
    if args.size not in SIZES:
        raise CycloidInputError("size", args.size, f"must be one of {', '.join(SIZES)}")
    mode = "".join(parse_mode(args.mode)[:2])
    if mode not in ("S1", "S2"):
        raise CycloidInputError("mode", mode, "the bench drives the eccentric shaft: S1 or S2")
    if args.plan not in PLANS:
        raise CycloidInputError("plan", args.plan, f"must be one of {', '.join(PLANS)}")
    from .synth import ENGINES
    if args.engine not in ENGINES:
        raise CycloidInputError("engine", args.engine, f"must be one of {', '.join(ENGINES)}")
    _check_seed(args.seed)
    truth = args.truth
    _output_file("out", args.out)
    if truth:
        _output_file("truth", truth)
    if args.engine == "bench" and (len(effects) > 1 or rise is not None):
        raise CycloidInputError("engine", args.engine, "hides exactly one effect and writes no "
                                "temperature column; use --engine fast")
    from .synth import BENCH_CANNOT_HIDE
    if args.engine == "bench" and effects[0] in BENCH_CANNOT_HIDE:
        raise CycloidInputError("effect", effects[0], "the bench's FMUs do not carry it (it acts "
                                "through the replay only); use --engine fast")
    design = _load_design(None, args.profile) if args.profile else None
    from tqdm import tqdm
    bar = tqdm(total=2, desc="synth", unit="stage", disable=not _progress_on(args), leave=False)
    rec = synthesize(effects[0] if len(effects) == 1 else effects, args.seed, mode, args.size,
                     design=design, plan=args.plan, engine=args.engine, temperature_rise=rise,
                     progress=_progress_on(args))
    bar.update()
    bar.set_description("synth: writing")
    with _staged_file("out", args.out) as tmp, \
            (_staged_file("truth", truth) if truth else contextlib.nullcontext()) as tmp_truth:
        write_synth(tmp, rec)
        if truth:
            Path(tmp_truth).write_text(json.dumps(rec["truth"], indent=2))
    bar.update()
    bar.close()
    path = Path(args.out)
    print(f"wrote {path}: {len(rec['time_s'])} samples, {rec['time_s'][-1]:.0f} s, mode {mode}")
    return 0


def cmd_diagnose(args) -> int:
    from .diagnosis import DiagnosisError
    from .fmt import friction_level_fields, unit_suffix
    from .io import RecordingError, load_recording
    from .sweep.batch import diagnose_recording
    design = _load_design(args.design, args.profile)
    if args.mode.strip().lower() != "auto":
        parse_mode(args.mode)
    if args.out:
        _output_dir("out", args.out, create=False)
    try:
        rec, mode, checks = load_recording(args.recording, args.mode, design,
                                           columns=args.columns, units=args.units)
        d, result = diagnose_recording(rec, mode, checks, design, progress=True,
                                       calibrate=args.calibrate)
    except (RecordingError, DiagnosisError) as exc:
        raise CycloidInputError("recording", args.recording, str(exc))
    if args.out:
        from .diagnosis import write_diagnosis
        write_diagnosis(args.out, d, design, result, source=str(args.recording))
    if args.json:
        print(json.dumps(result, indent=2))
        return 0
    for e in result["excluded"]:
        print(f"excluded: {e['count']} {e.get('unit', 'samples')} ({e['reason']})")
    if "calibration_fit" in result:
        c = result["calibration_fit"]
        ci = c["ci95"]
        print(f"CALIBRATED to this recording first: mesh_loss_k = {c['mesh_loss_k']:.5g} "
              f"(+- {ci.get('mesh_loss_k', float('nan')):.2g}), idle_loss_scale = "
              f"{c['idle_loss_scale']:.4g} (+- {ci.get('idle_loss_scale', float('nan')):.2g}; "
              f"95 %, noise only); input-torque RMS {1e3 * c['rms_before_Nm']:.2f} -> "
              f"{1e3 * c['rms_after_Nm']:.2f} mN*m; the rest is relative to it")
        for n in c["notes"]:
            print(f"  note: {n}")
    print(f"located: {d.located['statement']}")
    if not d.effects:
        print("effects: none - " + (EFFECTS_NONE_LEFT if d.unexplained["present"]
                                    else EFFECTS_NONE))
    for e in d.effects:
        form = f"; fitted {e['form']}" if e.get("form", "").startswith("per") else ""
        print(f"effect: {e['id']} - {e['description']} (explains {1e3 * e['explained_rms_Nm']:.2f}"
              f" mN*m of the 10 ms means; its torque {1e3 * e['torque_rms_Nm']:.2f} mN*m RMS"
              f"{form})")
        for k, v in e["parameters"].items():
            ci = f" [{v['ci95'][0]:.4g}, {v['ci95'][1]:.4g}]" if v["ci95"] else ""
            print(f"  {k} = {v['value']:.5g}{unit_suffix(v['unit'])}{ci}")
    if d.calibration and d.effect != "friction_miscalibrated":
        v = d.calibration["mu_boundary_rel_error"]
        print(f"friction level ({friction_level_fields(design.profile)}) off by "
              f"{100 * v['value']:+.2f} % "
              f"[{100 * v['ci95'][0]:+.2f}, {100 * v['ci95'][1]:+.2f}]")
    if d.indistinguishable_from:
        print(f"  cannot be told apart from: {', '.join(d.indistinguishable_from)}; "
              f"a run that would: {d.suggested_test}")
    print(f"unexplained: {d.unexplained['statement']}")
    print(f"held-out RMSE of input torque: {1e3 * d.rmse_before_Nm:.2f} -> "
          f"{1e3 * d.rmse_after_Nm:.2f} mN*m; zeta_d (Eq. 31): {100 * d.zeta_d_before:.2f} -> "
          f"{100 * d.zeta_d_after:.2f} %; residual whiteness p: {d.whiteness_before:.2g} -> "
          f"{d.whiteness_after:.2g}")
    return 0


EFFECTS_NONE = "the model explains the data within its noise"
EFFECTS_NONE_LEFT = "no effect of the library explains the mismatch (see unexplained)"




def _workers(args):
    if getattr(args, "workers", None) is not None and not 1 <= args.workers <= 1024:
        raise CycloidInputError("workers", args.workers, "must be from 1 to 1024")
    if args.scheduler and args.serial:
        raise CycloidInputError("serial", "--serial", "contradicts --scheduler (choose one)")
    if args.scheduler:
        from .sweep import require_dask
        require_dask()


def cmd_sweep(args) -> int:
    from .sweep import load_spec, staged_dataset, write_sweep
    spec = load_spec(args.spec)
    if args.profile:
        spec.base.setdefault("model", {})["profile"] = args.profile
        if args.profile == "paper":
            spec.base["model"]["losses"] = "load_dependent"
    if Path(args.out).suffix.lower() != ".parquet":
        raise CycloidInputError("out", args.out, "must end in .parquet")
    _workers(args)
    with staged_dataset("out", args.out) as tmp:
        plan = write_sweep(spec, tmp, scheduler=args.scheduler, workers=args.workers,
                           serial=args.serial, progress=_progress_on(args))
    bad = plan.errors
    where = ("in this process" if plan.backend == "serial" else
             f"{plan.workers} local workers" if plan.backend == "pool" else args.scheduler)
    print(f"sweep: {plan.n} designs x {len(spec.modes)} modes -> {args.out} ({plan.rows} rows"
          f" in {plan.partitions} Parquet partition{'s' if plan.partitions > 1 else ''}"
          f"{f', {bad} with an error (column error)' if bad else ''}; {where}, "
          f"{1e3 * plan.seconds_per_design:.0f} ms/design serially)")
    return 0


def cmd_diagnose_batch(args) -> int:
    from .recordings import RecordingError, parse_column_map
    from .sweep import diagnose_batch, find_recordings
    folder = Path(args.folder)
    if not folder.is_dir():
        raise CycloidInputError("folder", args.folder, "is not a folder")
    paths = find_recordings(folder)
    if not paths:
        raise CycloidInputError("folder", args.folder, "holds no recording (*.csv, *.mf4)")
    design = _load_design(args.design, args.profile)
    mode = "".join(parse_mode(args.mode)[:2])
    try:
        columns = parse_column_map(args.columns) if args.columns else None
    except RecordingError as exc:
        raise CycloidInputError("columns", args.columns, str(exc))
    _workers(args)
    with _staged_dir("out", args.out) as out:
        df = diagnose_batch(folder, out, design, mode, columns=columns,
                            calibrate=args.calibrate,
                            scheduler=args.scheduler, workers=args.workers, serial=args.serial,
                            progress=_progress_on(args))
    bad = int((df["error"] != "").sum())
    print(f"diagnose-batch: {len(df)} recordings -> {args.out}/summary.csv"
          f"{f'; {bad} could not be diagnosed (column error)' if bad else ''}")
    for _, r in df.iterrows():
        print(f"  {r['recording']}: {r['error'] or r['effect']}")
    return 0


def _cluster_options(p):
    p.add_argument("--scheduler", help="address of a running dask.distributed scheduler, "
                   "e.g. tcp://host:8786 (default: this machine: in this process below the "
                   "cut-off, else a local process pool)")
    p.add_argument("--workers", type=int, help="processes of the local pool (default: the "
                   "CPUs this process may use, at most 8)")
    p.add_argument("--serial", action="store_true", help="run in this process, whatever the "
                   "size")


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="cyclo-fmu", description="Cycloid-drive losses, efficiency and FMI tools.")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)
    e = sub.add_parser("efficiency", help="efficiency and partial losses at one operating point")
    e.add_argument("--mode", required=True, help=f"operating mode, one of {', '.join(MODES)}")
    e.add_argument("--speed", required=True, type=_number("speed"),
                   help="signed speed of the driving shaft, r/min")
    e.add_argument("--torque", required=True, type=_number("torque"),
                   help="torque delivered into the driving shaft, N*m")
    e.add_argument("--design", help="design file (TOML) or preset name (mackic-rig); "
                   "default: the paper's test drive")
    e.add_argument("--json", action="store_true", help="print one JSON object")
    e.add_argument("--temperature", type=_number("temperature"),
                   help="grease temperature, degC (fixes it; physical profile)")
    e.add_argument("--ambient", type=_number("ambient"),
                   help="ambient temperature, degC: the grease temperature then follows from "
                   "the housing's steady heat balance (physical profile)")
    _add_profile(e)
    e.set_defaults(func=cmd_efficiency)
    pp = sub.add_parser("paper", help="the paper's Section 5 comparison, theory side")
    pp.add_argument("--out", default="out", help="folder for the figures (default: out)")
    pp.add_argument("--design", help="design file (TOML) or preset name (mackic-rig); "
                   "default: the paper's test drive")
    pp.add_argument("--json", action="store_true", help="print one JSON object")
    _add_profile(pp)
    pp.set_defaults(func=cmd_paper)
    sp = sub.add_parser("stiffness", help="torsional rigidity, lost motion, backlash and the "
                        "hysteresis curve from the contact model, as a catalogue states them")
    sp.add_argument("--design", help="design file (TOML) or preset name (mackic-rig); "
                   "default: the paper's test drive")
    sp.add_argument("--rated-torque", type=_number("rated-torque"), help="rated output torque "
                    "N*m the catalogue values refer to (default: the paper's motor times z1-1)")
    sp.add_argument("--json", action="store_true", help="print one JSON object")
    sp.add_argument("--out", help="folder for stiffness.png and stiffness.json")
    _add_profile(sp)
    sp.set_defaults(func=cmd_stiffness)
    bp = sub.add_parser("build", help="build the FMUs (dist/CycloidDrive.fmu, "
                        "dist/CycloidDriveNative.fmu, ...)")
    bp.add_argument("--dest", default="dist", help="output folder (default: dist)")
    bp.add_argument("--design", help="design file (TOML) or preset name (mackic-rig) built "
                    "into the reducer FMUs (CycloidDrive: its parameters' start values and the "
                    "fields without a parameter; CycloidDriveNative: its loss map); default: "
                    "the paper's test drive")
    bp.add_argument("names", nargs="*", help="FMUs to build (default: all)")
    _add_profile(bp)
    bp.set_defaults(func=cmd_build)
    mx = sub.add_parser("export-modelica", help="a Modelica package: the mode as MSL LossyGear "
                        "with a loss table fitted to the core over the bench envelope")
    mx.add_argument("--mode", required=True, help=f"operating mode, one of {', '.join(MODES)}")
    mx.add_argument("--design", help="design file (TOML) or preset name (mackic-rig); "
                   "default: the paper's test drive")
    mx.add_argument("--out", required=True, help="output folder (writes CycloidDrive_<mode>.mo)")
    mx.set_defaults(func=cmd_export_modelica)
    bench = sub.add_parser("bench", help="simulate the motor - reducer - brake test bench (SSP)")
    bench.add_argument("--mode", default="S1", help="operating mode of the reducer (S1, S2, ...)")
    bench.add_argument("--scenario", default="paper",
                       help="paper (frequency x load series), runup, loadstep, reversal")
    bench.add_argument("--out", default="out/bench", help="output folder (default: out/bench)")
    bench.add_argument("--ideal-sensors", action="store_true", help="switch transducer errors off")
    bench.add_argument("--seed", type=int, default=1, help="noise seed of the transducers")
    bench.add_argument("--step", default="1", help="communication step in ms (default 1, the "
                       "recording's rate); 'steady': the step the convergence check chose for "
                       "steady scenarios (README)")
    bench.add_argument("--quiet", action="store_true", help="no progress bar")
    bench.add_argument("--fmus", dest="fmu_set", default="native", choices=("native", "python"),
                       help="the bench's FMUs: native (C, default: runs in any host, no Python) "
                       "or python (the pythonfmu slaves)")
    bench.add_argument("--plot", action="store_true", help="also draw bench_<mode>_<scenario>.png "
                       "(signals, window efficiencies; matplotlib, about 0.8 s)")
    bench.add_argument("--design", help="design file (TOML) for the reducer, e.g. the "
                       "design_updated.toml a diagnosis wrote, or a preset name (mackic-rig)")
    _add_profile(bench)
    bench.set_defaults(func=cmd_bench, fmus=True)
    sy = sub.add_parser("synth", help="write a bench recording with one hidden effect")
    sy.add_argument("--effect", required=True, help="hidden effect id (see model_core.effects); "
                    "several separated by commas")
    sy.add_argument("--temperature-rise", type=float, help="K: the recording carries a "
                    "temperature column warming by this much (warm-up effects follow it)")
    sy.add_argument("--seed", type=int, default=1)
    sy.add_argument("--mode", default="S1")
    sy.add_argument("--size", default="small", help="tiny (42 s), small (2 min), medium (5), "
                    "large (10)")
    sy.add_argument("--out", required=True, help="recording CSV to write")
    sy.add_argument("--truth", help="also write the hidden truth as JSON here")
    sy.add_argument("--plan", default="full", help="test plan: full (speed, load, direction "
                    "varied) or one_speed (load steps at 2000 r/min only)")
    sy.add_argument("--engine", default="fast", help="fast (the bench's components replayed "
                    "vectorised) or bench (the bench's FMUs co-simulated; slower)")
    sy.add_argument("--quiet", action="store_true", help="no progress bar")
    _add_profile(sy)
    sy.set_defaults(func=cmd_synth, fmus=True)
    dg = sub.add_parser("diagnose", help="locate, explain and model the mismatch of a recording")
    dg.add_argument("recording", help="recording CSV")
    dg.add_argument("--mode", required=True, help=f"operating mode ({', '.join(MODES)}) or "
                    "auto (inferred from the measured speed ratio and its sign)")
    dg.add_argument("--design", help="design file (TOML) or preset name (mackic-rig)")
    dg.add_argument("--out", help="folder for plots, diagnosis.json, design_updated.toml")
    dg.add_argument("--calibrate", action="store_true",
                    help="also fit the calibration effects (mesh_loss: a loss proportional to "
                    "the mesh power, idle_loss_scale: a scale on the load-independent losses) "
                    "and write them to design_updated.toml [calibration]; left out by default "
                    "because free loss scales can stand in for a mismatch outside the library")
    dg.add_argument("--columns", help="column mapping, e.g. 'time_s=t,torque_in_Nm=T22'")
    dg.add_argument("--units", help="units of columns, overriding anything detected, e.g. "
                    "'torque_in_Nm=N*mm,time_s=ms' ('-N*m' also negates the column)")
    dg.add_argument("--json", action="store_true")
    _add_profile(dg)
    dg.set_defaults(func=cmd_diagnose)
    sw = sub.add_parser("sweep", help="design study: many designs over the bench envelope "
                        "(local processes or dask)")
    sw.add_argument("spec", help="sweep spec (TOML; see examples/sweep.toml)")
    sw.add_argument("--out", required=True, help="results (.parquet): a folder of Parquet "
                    "partitions, read as one table by pandas.read_parquet")
    _cluster_options(sw)
    sw.add_argument("--quiet", action="store_true", help="no progress bar")
    _add_profile(sw)
    sw.set_defaults(func=cmd_sweep)
    db = sub.add_parser("diagnose-batch", help="diagnose every recording (*.csv, *.mf4) in a "
                        "folder (dask)")
    db.add_argument("folder", help="folder of recordings")
    db.add_argument("--out", required=True, help="folder for one result folder per recording "
                    "and summary.csv")
    db.add_argument("--mode", required=True)
    db.add_argument("--design", help="design file (TOML) or preset name (mackic-rig)")
    db.add_argument("--calibrate", action="store_true", help="also fit the calibration "
                    "effects (mesh_loss, idle_loss_scale; see diagnose --calibrate)")
    db.add_argument("--columns", help="column mapping, e.g. 'time_s=t,torque_in_Nm=T22'")
    _cluster_options(db)
    db.add_argument("--quiet", action="store_true", help="no progress bar")
    _add_profile(db)
    db.set_defaults(func=cmd_diagnose_batch)
    return p


def _join_signed_numbers(argv):
    """argparse takes '-1e-6' for an option; join it to its flag: --torque=-1e-6."""
    out, i = [], 0
    while i < len(argv):
        a = argv[i]
        if a in ("--speed", "--torque") and i + 1 < len(argv) and argv[i + 1].startswith("-"):
            try:
                float(argv[i + 1])
                out.append(f"{a}={argv[i + 1]}")
                i += 2
                continue
            except ValueError:
                pass
        out.append(a)
        i += 1
    return out


def main(argv=None) -> int:
    argv = _join_signed_numbers(list(sys.argv[1:] if argv is None else argv))
    args = build_parser().parse_args(argv)
    if getattr(args, "fmus", False):
        _collect_fmu_log()
    try:
        return args.func(args)
    except CycloidInputError as exc:
        print(f"cyclo-fmu: error: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:         # the reader of stdout left (`| head`): run() stops quietly
        raise
    except OSError as exc:          # a path the command could not read or write
        where = exc.filename if exc.filename is not None else ""
        print(f"cyclo-fmu: error: {args.command}: {where!r}: {exc.strerror or exc}",
              file=sys.stderr)
        return 2
    except MemoryError:
        print(f"cyclo-fmu: error: {args.command}: out of memory (input too large)",
              file=sys.stderr)
        return 2
    except Exception as exc:        # an FMU's error: surface its message in one line
        if type(exc).__module__.split(".")[0] != "fmpy":
            raise
        logged = "; ".join(f"{i}: {m}" for i, m in _FMU_ERRORS[-2:])
        text = " ".join(f"{exc}{f' ({logged})' if logged else ''}".split())
        print(f"cyclo-fmu: error: {args.command}: FMU failed: {text}", file=sys.stderr)
        return 2


def run() -> None:
    """Console entry point. Commands that load FMUs end the process with os._exit after
    flushing: pythonfmu's native library has been seen, rarely, to abort in its static
    destructors at interpreter exit after many loads and unloads."""
    import os

    from .slaves.heap import keep_temporaries_on_heap
    # our own process: glibc keeps the loss model's large temporaries on its heap (half of a
    # paper-profile map's time was page faults of freshly mapped arrays; cyclo_fmu.slaves.heap)
    keep_temporaries_on_heap()
    try:
        code = main()
        sys.stdout.flush()
    except BrokenPipeError:          # e.g. piped into `head`: stop quietly
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        code = 0
    sys.stderr.flush()
    if len(sys.argv) > 1 and sys.argv[1] in ("bench", "synth", "build"):
        os._exit(code)
    sys.exit(code)


if __name__ == "__main__":
    run()
