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

import numpy as np


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


def _same_path(a, b) -> bool:
    """Whether two paths name one file (resolved; an existing file by its inode)."""
    pa, pb = Path(a), Path(b)
    if pa.exists() and pb.exists():
        return pa.samefile(pb)
    return pa.resolve() == pb.resolve()


def _recording_error(path, exc) -> CycloidInputError:
    """A reader's or the diagnosis's refusal as the CLI's one line, naming the recording once
    (the reader's message often starts with the path itself)."""
    msg = " ".join(str(exc).split())
    for prefix in (f"recording {str(path)!r}", f"recording {path}"):
        if msg.startswith(prefix):
            msg = msg[len(prefix):].lstrip(" ,:")
            break
    return CycloidInputError("recording", str(path), msg)


#: [characters] longest error line printed: real messages stay below ~400; an echo of a
#: pathological input (a 20 MB cell) is cut in the middle
MAX_ERROR_CHARS = 600
#: [1] smallest rated torque `cyclo-fmu stiffness` accepts, as a share of the design's static
#: torque rating (an output torque). A catalogue rates a drive at a sizeable share of what it
#: holds (the paper's drive: 11.9 N*m, 1.3 % of its 898 N*m). Below a thousandth the catalogue
#: values describe the clearances alone: at 0.9 N*m the elastic twist of the paper's drive is
#: 0.07 arcmin against 18.7 arcmin of lost motion (0.4 %), and far below (1e-6 N*m) the secant
#: rigidity is lost in the solver's resolution (it turns negative); 1e-300 N*m printed a lost
#: motion of 1e288 arcmin.
MIN_RATED_TORQUE_SHARE = 1e-3


def _error_line(text) -> str:
    """One line: whitespace runs (newlines too) collapsed, cut to MAX_ERROR_CHARS."""
    line = " ".join(str(text).split())
    if len(line) > MAX_ERROR_CHARS:
        line = f"{line[:MAX_ERROR_CHARS - 100]} ... {line[-80:]}"
    return line


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
    from .limits import check_speed_rpm
    check_speed_rpm("speed", args.speed)
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
    from model_core.stiffness import ring_torque_rating, static_torque_rating
    w_a = rpm_to_rad_s(args.speed)
    rated = static_torque_rating(design)
    limit_text = (f"the ring's share of the static rating, limited by {rated['limiting']}: "
                  f"{rated['descriptions'][rated['limiting']]}")

    def ring_check(d, op_, field, value, what):
        """Refuse an operating point that overloads the ring (or overflows the model)."""
        rating = ring_torque_rating(d)
        T_ring = abs(float(op_.torques["1"]))
        if not math.isfinite(T_ring) or T_ring > rating:
            load = (f"puts {T_ring:.4g} N*m on the ring" if math.isfinite(T_ring) else
                    "puts more torque on the ring than the model can compute")
            raise CycloidInputError(field, value, f"{what} {load}, beyond the design's static "
                                    f"rating {rating:.4g} N*m ({limit_text})")
        return T_ring

    # the ring's share of a torque at the driving shaft, by the ideal (lossless) torque ratios
    # of Table 1: 1 when the ring drives, |i| when it is driven, |1 - i| when it is held
    from .limits import ring_share as _ring_share
    ring_share = _ring_share(a + b, design.z1)
    rating = ring_torque_rating(design)   # = rated['rating_Nm'] / i0
    # the no-load running torque first: when the drag alone (at this speed, or at this grease
    # temperature) needs a driving torque beyond what the ring can take, the speed or the
    # temperature is at fault, not the torque
    try:
        with np.errstate(all="ignore"):
            T0 = float(operating_point(design, a + b, w_a, T_out=0.0).torques[a])
    except ValueError as exc:
        if isinstance(exc, CycloidInputError):
            raise
        T0 = math.nan
    if not math.isfinite(T0):        # the model cannot evaluate this design at all here
        raise CycloidInputError("design", args.design or "default", f"the model cannot "
                                f"evaluate this design at {args.speed:g} r/min even at no load "
                                "(its no-load running torque is not a finite number)")
    if abs(T0) * ring_share > rating:
        field, value = (("temperature", args.temperature) if args.temperature is not None
                        else ("speed", args.speed))
        raise CycloidInputError(field, value, f"the drive's no-load running torque there "
                                f"({abs(T0):.4g} N*m at {args.speed:g} r/min) alone puts about "
                                f"{abs(T0) * ring_share:.4g} N*m on the ring, beyond the "
                                f"design's static rating {rating:.4g} N*m")
    # a torque whose lossless ring share is beyond twice the rating is refused before the
    # model runs (1e308 N*m would overflow in it); the model's own ring torque is checked after
    T_ring_ideal = abs(args.torque) * ring_share
    if T_ring_ideal > 2 * rating:
        load = f"about {T_ring_ideal:.4g}" if math.isfinite(T_ring_ideal) else "more than 1e308"
        raise CycloidInputError("torque", args.torque, f"puts {load} N*m on the ring (lossless), "
                                f"beyond the design's static rating {rating:.4g} N*m "
                                f"({limit_text})")
    try:
        with np.errstate(all="ignore"):
            if args.ambient is not None:
                op, temperature = thermal.solve_heat_balance(
                    design.replace(ambient_temperature=args.ambient + KELVIN), a + b, w_a,
                    args.torque)
                design = thermal.at_temperature(design, temperature)
            else:
                op = operating_point(design, a + b, w_a, args.torque)
    except ValueError as exc:          # the model's own refusal (e.g. eta0 out of range)
        if isinstance(exc, CycloidInputError) and \
                exc.field.startswith("operating_temperature"):
            raise CycloidInputError("torque", args.torque, f"at {args.speed:g} r/min the "
                                    "housing's steady heat balance puts the grease beyond the "
                                    "model's 200 degC") from None
        if isinstance(exc, CycloidInputError):
            raise
        raise CycloidInputError("torque", args.torque, f"outside what the model can evaluate "
                                f"at {args.speed:g} r/min ({exc})") from None
    T0_share = abs(T0) * ring_share
    T_ring = ring_check(design, op, "torque", args.torque,
                        "it" if T0_share <= 0.5 * rating else
                        f"with the no-load running torque {abs(T0):.4g} N*m (about "
                        f"{T0_share:.4g} N*m of the ring's share) it")
    # the output torque of one gear path: the disc's torque, or the ring's times i0 (the ring
    # rollers' torque about the ring axis is z1/z_c times the gear's)
    T_path = max(abs(float(op.torques["2"])), design.i0 * T_ring)
    if math.isfinite(T_path) and T_path > rated["rating_Nm"]:
        raise CycloidInputError("torque", args.torque, f"puts {T_path:.4g} N*m through the "
                                f"gears, beyond the design's static rating "
                                f"{rated['rating_Nm']:.4g} N*m (limited by {rated['limiting']}: "
                                f"{rated['descriptions'][rated['limiting']]})")
    losses = {k: _json_num(v) for k, v in op.losses.as_dict().items()}
    stalled = not bool(op.locked) and not math.isfinite(float(op.torques[b]))
    # the no-load running torque (the drag at the shafts and the gear's losses at zero load):
    # a driving torque below it cannot keep the drive turning unless the load drives it
    with np.errstate(all="ignore"):
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
    if not (stalled or bool(op.locked)):   # a running drive: every number must be finite
        from .limits import check_finite_result
        check_finite_result("torque" if abs(args.torque) > abs(no_load) else "speed",
                            args.torque if abs(args.torque) > abs(no_load) else args.speed,
                            {"eta": float(op.eta), "eta0": float(op.eta0),
                             "loss_power": float(op.loss_power),
                             **{k: float(v) for k, v in op.losses.as_dict().items()},
                             "output_torque": t_out, "output_speed": w_out})
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
    if args.band:
        from model_core.design import CONSERVATIVE_DESCRIPTION, conservative_variant
        op_c = operating_point(conservative_variant(design), a + b, rpm_to_rad_s(args.speed),
                               args.torque)
        result["band"] = {"variant": CONSERVATIVE_DESCRIPTION,
                          "eta_nominal": _json_num(op.eta),
                          "eta_conservative": _json_num(op_c.eta),
                          "loss_power_conservative_W": _json_num(op_c.loss_power)}
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
    if "band" in result:
        bd = result["band"]
        cons = ("no steady state" if bd["eta_conservative"] is None
                else f"{100 * bd['eta_conservative']:.2f} %")
        print(f"  band: nominal {100 * float(op.eta):.2f} %, conservative {cons} "
              f"({bd['variant']})")
    if "calibration" in result:
        c = result["calibration"]
        print(f"  CALIBRATED: mesh_loss_k = {c['mesh_loss_k']:.4g}, idle_loss_scale = "
              f"{c['idle_loss_scale']:.4g}, load_loss_scale = {c['load_loss_scale']:.4g} "
              f"(fitted to: {c['source'] or 'not stated'})")
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
        return run_paper_comparison(design, args.out, args.json, args.band)
    with _staged_dir("out", args.out) as out:
        return run_paper_comparison(design, out, args.json, args.band)


def cmd_stiffness(args) -> int:
    from model_core import stiffness as st
    design = _load_design(args.design, args.profile)
    rated = args.rated_torque
    if rated is not None and not (math.isfinite(rated) and rated > 0):
        raise CycloidInputError("rated-torque", rated, "must be a positive number of N*m")
    if rated is not None:
        r = st.static_torque_rating(design)     # an output torque, as --rated-torque
        if rated > r["rating_Nm"]:
            raise CycloidInputError("rated-torque", rated, f"beyond the design's static rating "
                                    f"{r['rating_Nm']:.4g} N*m (limited by {r['limiting']}: "
                                    f"{r['descriptions'][r['limiting']]})")
        floor = MIN_RATED_TORQUE_SHARE * r["rating_Nm"]
        if rated < floor:
            raise CycloidInputError("rated-torque", rated, f"below {floor:.4g} N*m, "
                                    f"{MIN_RATED_TORQUE_SHARE:g} of the design's static rating "
                                    f"{r['rating_Nm']:.4g} N*m: the catalogue values there would "
                                    "describe the clearances alone, not the drive's stiffness")
    if args.out:
        _output_dir("out", args.out, create=False)
    try:
        with np.errstate(all="ignore"):
            values = st.catalogue_values(design, rated)
    except ValueError as exc:
        if isinstance(exc, CycloidInputError):
            raise
        raise CycloidInputError("design", args.design or "default", "the contact model cannot "
                                f"evaluate this design ({' '.join(str(exc).split())[:200]})"
                                ) from None
    from .limits import check_finite_result
    check_finite_result("rated-torque", rated, values)
    if args.out:
        from .plots import plot_stiffness
        with _staged_dir("out", args.out) as out:
            plot_stiffness(design, values["rated_torque_Nm"], out / "stiffness.png")
            (out / "stiffness.json").write_text(json.dumps(values, indent=2))
    if args.json:
        print(json.dumps(values, indent=2))
        return 0
    print(f"Torsional behaviour with the input locked (series model; rated torque "
          f"{values['rated_torque_Nm']:.3g} N*m)")
    print(f"  torsional rigidity (50-100 % rated)   {values['torsional_rigidity_Nm_per_arcmin']:.4g} N*m/arcmin")
    print(f"  lost motion (+-3 % rated)             {values['lost_motion_arcmin']:.4g} arcmin")
    print(f"  backlash                              {values['backlash_arcmin']:.4g} arcmin")
    print(f"  twist at rated torque                 {values['twist_at_rated_arcmin']:.4g} arcmin")
    print(f"  hysteresis loss (loop width at 0)     {values['hysteresis_loss_arcmin']:.4g} arcmin")
    print("  elements in series (share of the rigidity's compliance; lost motion; twist at rated):")
    for name, v in values["elements"].items():
        print(f"    {name:28s} {100 * v['rigidity_compliance_share']:5.1f} %  "
              f"{v['lost_motion_arcmin']:7.3f} arcmin  {v['twist_at_rated_arcmin']:7.3f} arcmin")
    r = values["static_rating"]
    print(f"  static torque rating (output)         {r['rating_Nm']:.4g} N*m, limited by "
          f"{r['limiting']} ({r['descriptions'][r['limiting']]})")
    for name, T in r["elements"].items():
        print(f"    {name:28s} {T:10.4g} N*m")
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


#: the named scenarios of ``bench --scenario``; anything else names a recording to replay
NAMED_SCENARIOS = ("paper", "runup", "loadstep", "reversal")


def _replay_input(args, design):
    """The recording of ``bench --scenario FILE`` or ``verify FILE`` read, checked and its mode
    resolved as ``diagnose`` does: (rec, mode); one line naming the field if bad."""
    from .io import RecordingError, load_recording
    path = args.recording if hasattr(args, "recording") else args.scenario
    field = "recording" if hasattr(args, "recording") else "scenario"
    if args.mode.strip().lower() != "auto":
        parse_mode(args.mode)
    try:
        rec, mode, _ = load_recording(path, args.mode, design, columns=args.columns,
                                      units=args.units)
    except RecordingError as exc:
        raise CycloidInputError(field, path, str(exc))
    mode = "".join(parse_mode(mode)[:2])
    if mode not in ("S1", "S2"):
        raise CycloidInputError("mode", mode, "the bench drives the eccentric shaft S: S1 or S2")
    return rec, mode


def cmd_bench(args) -> int:
    from .bench import Sensors, fmu_names, run_bench, scenario
    from .fmu_cache import fmus_into
    if args.scenario not in NAMED_SCENARIOS:
        return _bench_replay(args)
    if args.columns or args.units:
        raise CycloidInputError("columns" if args.columns else "units",
                                args.columns or args.units, "apply to a recording given as "
                                "--scenario, not to a named scenario")
    mode = "".join(parse_mode(args.mode)[:2])
    if mode not in ("S1", "S2"):
        raise CycloidInputError("mode", args.mode, "the bench drives the eccentric shaft S: "
                                "S1 or S2")
    _check_seed(args.seed)
    step = _bench_step(args.step)
    sc = scenario(args.scenario, mode)
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
              f"{c.idle_loss_scale:.4g}, load_loss_scale = {c.load_loss_scale:.4g} "
              f"(fitted to: {c.source or 'not stated'})")
    if run.windows:
        print(f"  {'n_in r/min':>10} {'T_in N*m':>9} {'eta bench %':>11} {'eta core %':>10}")
        for w in run.windows:
            print(f"  {w['speed_in_rpm']:10.0f} {w['torque_in_Nm']:9.3f} {100 * w['eta']:11.2f} "
                  f"{100 * w.get('eta_core', float('nan')):10.2f}")
    return 0


def _bench_replay(args) -> int:
    """``bench --scenario RECORDING``: the bench driven by the recording's measured input speed
    and output torque (cyclo_fmu.bench_replay)."""
    from .bench import Sensors, fmu_names
    from .bench_replay import plot_replay, replay_recording, write_replay
    from .recordings import RecordingError
    from .fmu_cache import fmus_into
    if not Path(args.scenario).is_file():
        raise CycloidInputError("scenario", args.scenario, "must be one of "
                                f"{', '.join(NAMED_SCENARIOS)} or a recording file to replay")
    _check_seed(args.seed)
    if str(args.step).strip() != "1":
        raise CycloidInputError("step", args.step, "a replay runs at the recording's own step")
    design = _load_design(args.design, args.profile)
    rec, mode = _replay_input(args, design)
    with _staged_dir("out", args.out) as out:
        fmu_dir = fmus_into(out / "fmus", fmu_names(args.fmu_set), design)
        try:
            rp = replay_recording(rec, mode, fmu_dir, design,
                                  Sensors(ideal=args.ideal_sensors, seed=args.seed),
                                  args.fmu_set, progress=_progress_on(args))
        except RecordingError as exc:
            raise CycloidInputError("scenario", args.scenario, str(exc))
        except ValueError as exc:
            raise CycloidInputError("design", args.design, str(exc))
        name = f"recording_{mode}_replay.csv"
        write_replay(out / name, rp)
        if args.plot:
            plot_replay(rp, out / f"bench_{mode}_replay.png")
    t = rp.simulated["time_s"]
    print(f"bench: mode {mode}, scenario replay of {args.scenario} ({len(t)} samples, "
          f"{t[-1] - t[0]:.1f} s, step {1e3 * rp.step:.4g} ms); files in {out}")
    for n in rp.notes:
        print(f"  {n}")
    print(f"  simulated recording: {out / name} (the recording's time base)")
    return 0


def cmd_verify(args) -> int:
    """``verify RECORDING --design D``: the co-simulation with the design on the recording's
    inputs, the input torque's residual against the recording's noise floor."""
    from .bench import fmu_names
    from .bench_replay import verify_recording, write_replay
    from .fmu_cache import fmus_into
    from .recordings import RecordingError
    import tempfile
    design = _load_design(args.design, args.profile)
    if args.mode.strip().lower() != "auto":
        parse_mode(args.mode)
    if args.out:
        _output_dir("out", args.out, create=False)
    rec, mode = _replay_input(args, design)
    with tempfile.TemporaryDirectory(prefix="cyclofmu_verify_") as tmp:
        fmu_dir = fmus_into(Path(tmp) / "fmus", fmu_names(args.fmu_set), design)
        try:
            result, rp = verify_recording(rec, mode, fmu_dir, design, args.fmu_set,
                                          progress=_progress_on(args))
        except RecordingError as exc:
            raise CycloidInputError("recording", args.recording, str(exc))
        except ValueError as exc:
            raise CycloidInputError("design", args.design, str(exc))
    result = {"recording": str(args.recording), "design": args.design or "(default)",
              "fmus": args.fmu_set, **result}
    if args.out:
        with _staged_dir("out", args.out) as out:
            write_replay(out / f"recording_{mode}_verify.csv", rp)
            (out / "verify.json").write_text(json.dumps(result, indent=2))
    code = 0 if result["reproduces_to_noise_floor"] else 1
    if args.json:
        print(json.dumps(result, indent=2))
        return code
    r = result
    print(f"verify: {args.recording}, mode {mode}, design {r['design']} ({args.fmu_set} FMUs)")
    print(f"  the bench co-simulated on the recording's measured input speed and output "
          f"torque; {r['blocks']} blocks of {1e3 * r['block_s']:.3g} ms")
    print(f"  input torque residual RMS {1e3 * r['torque_in_residual_rms_Nm']:.3f} mN*m "
          f"(mean {1e3 * r['torque_in_residual_mean_Nm']:+.3f}); noise floor "
          f"{1e3 * r['noise_floor_Nm']:.3f} mN*m; ratio {r['ratio_to_noise_floor']:.3f} "
          f"(tolerance {r['tolerance']:g})")
    print(f"  speeds: input {r['speed_in_residual_rms_rpm']:.3g} r/min, output "
          f"{r['speed_out_residual_rms_rpm']:.3g} r/min RMS; output torque "
          f"{1e3 * r['torque_out_residual_rms_Nm']:.3g} mN*m RMS")
    print("  " + ("reproduces the recording to its noise floor" if code == 0 else
                  "does NOT reproduce the recording to its noise floor: a mismatch remains "
                  "(diagnose the recording against this design)"))
    return code


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
        if _same_path(truth, args.out):
            raise CycloidInputError("truth", truth, "is the recording's own file (--out): the "
                                    "truth would overwrite the recording; give another name")
    if args.engine == "bench" and len(effects) > 1:
        raise CycloidInputError("engine", args.engine, "hides exactly one effect; use --engine "
                                "fast")
    from .synth import BENCH_CANNOT_HIDE, BENCH_TEMPERATURE_EFFECTS
    if args.engine == "bench" and rise is not None and effects[0] not in BENCH_TEMPERATURE_EFFECTS:
        raise CycloidInputError("effect", effects[0], "with --temperature-rise the bench hides "
                                f"only {', '.join(sorted(BENCH_TEMPERATURE_EFFECTS))} (the "
                                "reducer's grease on the temperature, the input torque "
                                "transducer on the grease's); use --engine fast")
    if args.engine == "bench" and rise is None and effects[0] in BENCH_CANNOT_HIDE:
        raise CycloidInputError("effect", effects[0], "the bench's FMUs carry it only through "
                                "a temperature (give --temperature-rise), not in time; or use "
                                "--engine fast")
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
    bandwidth = _bandwidth(args.bandwidth)
    if args.out:
        _output_dir("out", args.out, create=False)
    try:
        rec, mode, checks = load_recording(args.recording, args.mode, design,
                                           columns=args.columns, units=args.units)
        d, result = diagnose_recording(rec, mode, checks, design, progress=True,
                                       calibrate=args.calibrate, bandwidth=bandwidth,
                                       with_effects=tuple(args.with_effect or ()))
    except (RecordingError, DiagnosisError) as exc:
        raise _recording_error(args.recording, exc) from None
    if args.verify:
        result["verify"] = _verify_updated(rec, mode, design, d)
    # the stages' results (the problem's matrix and sample-level signals, the selection's
    # scaled columns: ~200 MB at 600 000 samples) are read by nothing the command writes or
    # prints: released before the figure is drawn
    d.stages = {}
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
        def _val(name, fmt):
            v = format(c[name], fmt)
            return (f"{v} (+- {ci[name]:.2g})" if name in ci
                    else f"{v} (as the design: not named)")
        print(f"CALIBRATED to this recording (diagnosed): mesh_loss_k = "
              f"{_val('mesh_loss_k', '.5g')}, idle_loss_scale = "
              f"{_val('idle_loss_scale', '.4g')}, load_loss_scale = "
              f"{_val('load_loss_scale', '.4g')} (95 %, noise only); written to "
              "design_updated.toml [calibration]")
        for n in c["notes"]:
            print(f"  note: {n}")
    print(f"located: {d.located['statement']}")
    if not d.effects:
        print("effects: none - " + (EFFECTS_NONE_LEFT if d.unexplained["present"]
                                    else EFFECTS_NONE))
    for e in d.effects:
        # the forms beyond a plain time constant: per 10 K of the column (linear or the
        # exponential law), and the heat balance driven by the loss power
        form = (f"; fitted {e['form']}" if e.get("form", "").startswith(("per", "time, "))
                else "")
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
    proposed = d.unexplained.get("proposed")
    if proposed:
        print(_proposed_line(proposed))
    print(f"held-out RMSE of input torque: {1e3 * d.rmse_before_Nm:.2f} -> "
          f"{1e3 * d.rmse_after_Nm:.2f} mN*m; zeta_d (Eq. 31): {100 * d.zeta_d_before:.2f} -> "
          f"{100 * d.zeta_d_after:.2f} %; residual whiteness p: {d.whiteness_before:.2g} -> "
          f"{d.whiteness_after:.2g}")
    if args.verify:
        v = result["verify"]
        if "skipped" in v:
            print(f"verify: skipped ({v['skipped']})")
        else:
            print(f"verify through the bench (native FMUs, the updated design): input torque "
                  f"residual RMS {1e3 * v['torque_in_residual_rms_Nm']:.3f} mN*m against the "
                  f"noise floor {1e3 * v['noise_floor_Nm']:.3f} mN*m: ratio "
                  f"{v['ratio_to_noise_floor']:.3f} (tolerance {v['tolerance']:g}): "
                  + ("reproduces the recording to its noise floor"
                     if v["reproduces_to_noise_floor"] else "does NOT reproduce the recording"))
    return 0


def _proposed_line(p) -> str:
    """One line for ``unexplained.proposed`` (diagnosis.discover)."""
    if not p.get("formula"):
        return f"  proposed form: none ({p.get('refused')})"
    return (f"  proposed form: {p['formula']}; held-out RMS {1e3 * p['heldout_rms_before_Nm']:.2f}"
            f" -> {1e3 * p['heldout_rms_after_Nm']:.2f} mN*m (noise "
            f"{1e3 * p['noise_Nm']:.2f}); reading: {p['reading']}")


def _verify_updated(rec, mode, design, d) -> dict:
    """``diagnose --verify``: the bench (native FMUs, the reducer built for the updated design)
    co-simulated on the recording's inputs with the design the diagnosis writes
    (cyclo_fmu.bench_replay.verify_recording)."""
    import tempfile
    from .bench import fmu_names
    from .bench_replay import verify_recording
    from .diagnosis import updated_design
    from .fmu_cache import fmus_into
    mode = "".join(parse_mode(mode)[:2])
    if mode not in ("S1", "S2"):
        return {"skipped": f"mode {mode}: the bench drives the eccentric shaft (S1, S2)"}
    fixed, _ = d.updated or updated_design(design, d)
    with tempfile.TemporaryDirectory(prefix="cyclofmu_verify_") as tmp:
        fmu_dir = fmus_into(Path(tmp) / "fmus", fmu_names("native"), fixed)
        out, _ = verify_recording(rec, mode, fmu_dir, fixed, "native")
    return out


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
    mode = ("auto" if args.mode.strip().lower() == "auto" else
            "".join(parse_mode(args.mode)[:2]))
    from .io.units import parse_units
    try:
        columns = parse_column_map(args.columns) if args.columns else None
    except RecordingError as exc:
        raise CycloidInputError("columns", args.columns, str(exc))
    try:
        units = parse_units(args.units) if args.units else None
    except RecordingError as exc:
        raise CycloidInputError("units", args.units, str(exc))
    _workers(args)
    with _staged_dir("out", args.out) as out:
        df = diagnose_batch(folder, out, design, mode, columns=columns, units=units,
                            calibrate=args.calibrate,
                            scheduler=args.scheduler, workers=args.workers, serial=args.serial,
                            progress=_progress_on(args))
    bad = int((df["error"] != "").sum())
    print(f"diagnose-batch: {len(df)} recordings -> {Path(args.out) / 'summary.csv'}: "
          f"{len(df) - bad} diagnosed, {bad} failed")
    for _, r in df.iterrows():
        found = f" (mode {r['mode']})" if mode == "auto" else ""
        what = f"failed: {r['error']}" if r["error"] else f"{r['effect']}{found}"
        print(f"  {r['recording']}: {what}")
    if bad:        # partial results are written; the exit status says not all went well
        print(f"cyclo-fmu: error: diagnose-batch: {bad} of {len(df)} recordings could not be "
              "diagnosed (their reasons above and in summary.csv, column error)",
              file=sys.stderr)
        return 1
    return 0


#: [Hz] the largest transducer bandwidth ``diagnose --bandwidth`` takes: 1 MHz, far above any
#: torque transducer (strain-gauge shafts reach a few kHz); a larger value is a unit mistake
MAX_BANDWIDTH_HZ = 1e6


def _bandwidth(value):
    """``--bandwidth`` checked [Hz]: None (the Diagnoser's default) or a positive finite
    frequency up to MAX_BANDWIDTH_HZ."""
    if value is None:
        return None
    if not math.isfinite(value) or value <= 0 or value > MAX_BANDWIDTH_HZ:
        raise CycloidInputError("bandwidth", value, "the transducer bandwidth must be a "
                                f"frequency in Hz above 0 and at most {MAX_BANDWIDTH_HZ:g}")
    return float(value)


def _calibrate_options(p):
    """``--no-calibrate`` (and ``--calibrate``, the default, kept for scripts of earlier
    versions)."""
    g = p.add_mutually_exclusive_group()
    g.add_argument("--no-calibrate", dest="calibrate", action="store_false",
                   help="leave the calibration effects (mesh_loss: a loss proportional to the "
                   "mesh power, idle_loss_scale: a scale on the load-independent losses, "
                   "load_loss_scale: a scale on the gear's load-dependent losses) out "
                   "of the candidates; by default they are fitted with the other effects, "
                   "checked against the closed forms of the discovery (a free loss scale "
                   "must not stand in for a loss of another law) and written to "
                   "design_updated.toml [calibration]")
    g.add_argument("--calibrate", dest="calibrate", action="store_true",
                   help="the default (kept for earlier scripts): the calibration effects are "
                   "candidates")
    p.set_defaults(calibrate=True)


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
    e.add_argument("--band", action="store_true", help="also the conservative variant's "
                   "efficiency (boundary pin friction, catalogue idle losses with lip seals), "
                   "JSON key band")
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
    pp.add_argument("--band", action="store_true", help="also the physical profile's "
                    "conservative variant (boundary pin friction, catalogue idle losses with lip "
                    "seals), JSON key band")
    _add_profile(pp)
    pp.set_defaults(func=cmd_paper)
    sp = sub.add_parser("stiffness", help="torsional rigidity, lost motion, backlash and the "
                        "hysteresis curve from the contact model, as a catalogue states them")
    sp.add_argument("--design", help="design file (TOML) or preset name (mackic-rig); "
                   "default: the paper's test drive")
    sp.add_argument("--rated-torque", type=_number("rated-torque"), help="rated output torque "
                    "N*m the catalogue values refer to (default: the paper's motor times z1-1); "
                    "from 1e-3 of the design's static rating up to that rating")
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
    bench.add_argument("--mode", default="S1", help="operating mode of the reducer: S1 or S2 "
                       "(the bench's motor drives the eccentric shaft S; default S1); with a "
                       "recording also auto (inferred from its speed ratio)")
    bench.add_argument("--scenario", default="paper",
                       help="paper (frequency x load series), runup, loadstep, reversal, or a "
                       "recording (CSV of any dialect, MDF4) to replay: the motor follows its "
                       "measured input speed, a load machine applies its measured output torque")
    bench.add_argument("--columns", help="with a recording: column mapping, e.g. "
                       "'time_s=t,torque_in_Nm=T22' (as diagnose)")
    bench.add_argument("--units", help="with a recording: units of columns, e.g. "
                       "'torque_in_Nm=N*mm' (as diagnose)")
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
    vf = sub.add_parser("verify", help="co-simulate the bench with a design (e.g. a diagnosis's "
                        "design_updated.toml) on a recording's own inputs: does it reproduce "
                        "the recording to its noise floor? (exit 1 if not)")
    vf.add_argument("recording", help="recording (CSV of any dialect, MDF4)")
    vf.add_argument("--design", help="design file (TOML), e.g. design_updated.toml, or a preset "
                    "name (mackic-rig); default: the paper's test drive")
    vf.add_argument("--mode", default="auto", help="operating mode (S1, S2) or auto (default: "
                    "inferred from the measured speed ratio)")
    vf.add_argument("--columns", help="column mapping, e.g. 'time_s=t,torque_in_Nm=T22'")
    vf.add_argument("--units", help="units of columns, e.g. 'torque_in_Nm=N*mm'")
    vf.add_argument("--fmus", dest="fmu_set", default="native", choices=("native", "python"),
                    help="the bench's FMUs (default native; the reducer is built for the design)")
    vf.add_argument("--out", help="folder for the simulated recording and verify.json")
    vf.add_argument("--json", action="store_true", help="print one JSON object")
    vf.add_argument("--quiet", action="store_true", help="no progress bar")
    _add_profile(vf)
    vf.set_defaults(func=cmd_verify, fmus=True)
    sy = sub.add_parser("synth", help="write a bench recording with one hidden effect")
    sy.add_argument("--effect", required=True, help="hidden effect id (see model_core.effects); "
                    "several separated by commas")
    sy.add_argument("--temperature-rise", type=float, help="K: the recording carries a "
                    "temperature column warming by this much (warm-up effects follow it)")
    sy.add_argument("--seed", type=int, default=1, help="seed of the transducer noise and "
                    "the hidden effect's draw, 0 to 2^63-1 (default 1): the same seed writes "
                    "the same recording")
    sy.add_argument("--mode", default="S1", help="operating mode of the recorded reducer: S1 "
                    "or S2 (the bench drives the eccentric shaft S; default S1)")
    sy.add_argument("--size", default="small", help="tiny (42 s), small (2 min), medium (5), "
                    "large (10)")
    sy.add_argument("--out", required=True, help="recording CSV to write")
    sy.add_argument("--truth", help="also write the hidden truth as JSON here")
    sy.add_argument("--plan", default="full", help="test plan: full (speed, load, direction "
                    "varied), one_speed (load steps at 2000 r/min only), four_quadrant (with "
                    "back-driven holds) or hoist (payloads lifted and lowered at 1.5-30 r/min "
                    "and 300-1200 r/min; engine fast)")
    sy.add_argument("--engine", default="fast", help="fast (the bench's components replayed "
                    "vectorised) or bench (the bench's FMUs co-simulated; slower)")
    sy.add_argument("--quiet", action="store_true", help="no progress bar")
    _add_profile(sy)
    sy.set_defaults(func=cmd_synth, fmus=True)
    dg = sub.add_parser("diagnose", help="locate, explain and model the mismatch of a recording "
                        "(CSV/ASCII or MDF4)")
    dg.add_argument("recording", help="recording: CSV/ASCII (any common dialect) or MDF4 "
                    "(.mf4, needs the mdf extra)")
    dg.add_argument("--mode", required=True, help=f"operating mode ({', '.join(MODES)}) or "
                    "auto (inferred from the measured speed ratio and its sign)")
    dg.add_argument("--design", help="design file (TOML) or preset name (mackic-rig)")
    dg.add_argument("--out", help="folder for plots, diagnosis.json, design_updated.toml")
    _calibrate_options(dg)
    from model_core.effects import OPT_IN
    dg.add_argument("--with-effect", action="append", choices=OPT_IN, metavar="EFFECT",
                    help="add an effect a diagnosis considers only when asked (repeatable; "
                    f"{', '.join(OPT_IN)}: the losses' build-up through standstill over a "
                    "width of speed w_c, for recordings that creep at a few r/min: hoists, "
                    "positioning)")
    dg.add_argument("--bandwidth", type=float, default=None, metavar="HZ",
                    help="the input torque transducer's bandwidth [Hz] (its data sheet's -3 dB "
                    "frequency with the amplifier's filter): the model's torque is filtered by "
                    "a first-order low-pass of this corner before it is compared; default 1000 "
                    "(an assumption: a strain-gauge shaft transducer with a 1 kHz amplifier "
                    "filter)")
    dg.add_argument("--columns", help="column mapping, e.g. 'time_s=t,torque_in_Nm=T22'")
    dg.add_argument("--units", help="units of columns, overriding anything detected, e.g. "
                    "'torque_in_Nm=N*mm,time_s=ms' ('-N*m' also negates the column)")
    dg.add_argument("--verify", action="store_true", help="also co-simulate the bench (native "
                    "FMUs) with the updated design on the recording's inputs and report the "
                    "input torque residual against the recording's noise floor (as verify)")
    dg.add_argument("--json", action="store_true", help="print the diagnosis as one JSON "
                    "object (the keys of diagnosis.json; strict JSON, null for undefined)")
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
    db.add_argument("--mode", required=True, help=f"operating mode of every recording "
                    f"({', '.join(MODES)}) or auto (each recording's mode inferred from its "
                    "measured speed ratio and its sign)")
    db.add_argument("--design", help="design file (TOML) or preset name (mackic-rig)")
    _calibrate_options(db)
    db.add_argument("--columns", help="column mapping, e.g. 'time_s=t,torque_in_Nm=T22'")
    db.add_argument("--units", help="units of columns, overriding anything detected, e.g. "
                    "'torque_in_Nm=N*mm,time_s=ms' ('-N*m' also negates the column)")
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


_INTERRUPTED = []      # signal numbers received (run() routes SIGINT and SIGTERM here)


def _on_signal(signum, frame):
    """SIGINT/SIGTERM: note it and unwind as Ctrl-C does, so that every staged output is
    removed on the way out (a slave's Python code may turn the KeyboardInterrupt into an FMU
    error; the note tells main() what it was)."""
    _INTERRUPTED.append(signum)
    raise KeyboardInterrupt


def _interrupted(args) -> int:
    import signal
    signum = _INTERRUPTED[0] if _INTERRUPTED else signal.SIGINT
    name = signal.Signals(signum).name
    print(f"cyclo-fmu: {args.command}: interrupted ({name}); partial outputs removed",
          file=sys.stderr)
    return 128 + int(signum)


def _user_path(filename) -> str:
    """The user's file name for a staged temporary (``.out.csv.partial-123.csv`` ->
    ``out.csv``): internal names stay out of error messages."""
    import re
    p = Path(str(filename))
    m = re.fullmatch(r"\.(.+?)\.partial-\d+(\.[^.]*)?", p.name)
    return str(p.with_name(m.group(1))) if m else str(filename)


def main(argv=None) -> int:
    argv = _join_signed_numbers(list(sys.argv[1:] if argv is None else argv))
    args = build_parser().parse_args(argv)
    if getattr(args, "fmus", False):
        _collect_fmu_log()
    try:
        return args.func(args)
    except KeyboardInterrupt:       # Ctrl-C, or SIGTERM through run()'s handler
        return _interrupted(args)
    except CycloidInputError as exc:
        print(_error_line(f"cyclo-fmu: error: {exc}"), file=sys.stderr)
        return 2
    except BrokenPipeError:         # the reader of stdout left (`| head`): run() stops quietly
        raise
    except OSError as exc:          # a path the command could not read or write
        if _INTERRUPTED:
            return _interrupted(args)
        where = _user_path(exc.filename) if exc.filename is not None else ""
        print(_error_line(f"cyclo-fmu: error: {args.command}: {where!r}: "
                          f"{exc.strerror or exc}"), file=sys.stderr)
        return 2
    except MemoryError:
        print(f"cyclo-fmu: error: {args.command}: out of memory (input too large)",
              file=sys.stderr)
        return 2
    except Exception as exc:        # an FMU's error: surface its message in one line
        if _INTERRUPTED:            # the signal reached a slave's Python code: its FMU
            return _interrupted(args)   # call failed because of it
        if type(exc).__module__.split(".")[0] != "fmpy":
            raise
        logged = "; ".join(f"{i}: {m}" for i, m in _FMU_ERRORS[-2:])
        text = " ".join(f"{exc}{f' ({logged})' if logged else ''}".split())
        print(_error_line(f"cyclo-fmu: error: {args.command}: FMU failed: {text}"),
              file=sys.stderr)
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
    import signal
    # this process is the host (no FMU's): SIGTERM unwinds like Ctrl-C, removing staged outputs
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, _on_signal)
    try:
        code = main()
        sys.stdout.flush()
    except BrokenPipeError:          # e.g. piped into `head`: stop quietly
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        code = 0
    sys.stderr.flush()
    if len(sys.argv) > 1 and sys.argv[1] in ("bench", "synth", "build", "verify"):
        os._exit(code)
    sys.exit(code)


if __name__ == "__main__":
    run()
