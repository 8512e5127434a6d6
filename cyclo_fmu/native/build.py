"""Build ``CycloidDriveNative.fmu``: the reducer as an FMI 2.0 co-simulation FMU in C.

The physics core solves the design's loss map once, here, for all six modes and both
power-flow directions (the same :class:`model_core.lossmap.ModeMap` the Python FMU
``CycloidDrive.fmu`` builds at its initialization). The map goes into a generated C file
(``cd_map_data.c``, the doubles written as exact hexadecimal literals), which is compiled with
the hand-written wrapper (``fmi2_cycloid.c``) and step arithmetic (``cd_model.c``) into a
shared library with no Python in it. The FMU ships the sources, so a host on another platform
can compile them (FMI 2.0 ``SourceFiles`` and ``sources/buildDescription.xml``).

What is fixed at build time: the design (its geometry, lubricant and friction: the map depends
on them) and the map's range. What stays a run-time parameter: the mode and the extra physics
(design ``[extra]``: drag, Stribeck, inertia, ripple, warm-up); the discovered loss terms
(``[[extra.discovered]]``) are built in, as the map is.
"""
from __future__ import annotations

import hashlib
import math
import os
import shutil
import subprocess
import sys
import tempfile
import uuid
import zipfile
from dataclasses import dataclass
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from model_core import DriveDesign, kinematics
from model_core.errors import CycloidInputError
from model_core.lossmap import ModeMap

from .. import __version__

HERE = Path(__file__).resolve().parent
NAME = "CycloidDriveNative"
#: The C sources written for this project, in this package.
C_SOURCES = ("fmi2_cycloid.c", "cd_model.c")
C_HEADERS = ("cd_model.h", "fmi2_front.h")
#: FMI 2.0 headers (2-clause BSD, Modelica Association), taken from the installed fmpy.
FMI_HEADERS = ("fmi2Functions.h", "fmi2FunctionTypes.h", "fmi2TypesPlatform.h")
GENERATED = "cd_map_data.c"
#: The flags the binary is compiled with. -ffp-contract=off: no fused multiply-add, so that the
#: interpolation rounds as Python's does; -fvisibility=hidden: only the fmi2 functions are
#: exported, so two of these FMUs (two designs) in one process cannot bind to each other's data.
#: Hardening of every native binary we compile (this FMU, the pythonfmu status front, the
#: bench loop; docs/explanation/fmu-safety.md): stack protector on functions with arrays,
#: glibc's checked string/memory functions (_FORTIFY_SOURCE needs -O1 or more), full RELRO
#: (the GOT read-only after loading, every symbol bound at load), position-independent code,
#: format-string warnings as errors, and the command line recorded in the binary's
#: .GCC.command.line section (so that a test, or a user, can read what it was built with).
HARDEN = ("-fstack-protector-strong", "-D_FORTIFY_SOURCE=2", "-fPIC", "-Wformat",
          "-Werror=format-security", "-Wl,-z,relro,-z,now", "-Wl,-z,noexecstack",
          "-frecord-gcc-switches")
CFLAGS = ("-std=c99", "-O2", "-shared", "-fvisibility=hidden", "-ffp-contract=off",
          "-Wall", "-Wl,--no-undefined") + HARDEN

#: Map range, as the Python FMU's defaults (map_torque_max, map_speed_max): the same grid, so
#: that the two FMUs interpolate the same table.
MAP_TORQUE_MAX = 30.0   # N*m
MAP_SPEED_MAX = 350.0   # rad/s

#: The declared ``min`` of a parameter that must be positive: FMI's min is inclusive, so the
#: smallest positive normal double (2.2e-308), which is what the FMU accepts (> 0).
POSITIVE_MIN = sys.float_info.min

#: Run-time parameters, in the order of the C struct CDExtra (cd_model.h):
#: (name, unit, quantity, min, min exclusive, description)
EXTRA = (
    ("drag_torque", "N.m", "Torque", 0.0, False,
     "load-independent drag at 300 rad/s of the driving shaft, ~ speed^(2/3)"),
    ("stribeck_torque", "N.m", "Torque", 0.0, False,
     "extra friction at standstill of the driving shaft, decaying as exp(-(w/w_s)^2)"),
    ("stribeck_speed", "rad/s", "AngularVelocity", POSITIVE_MIN, True,
     "Stribeck speed w_s (> 0)"),
    ("input_inertia", "kg.m2", "MomentOfInertia", 0.0, False,
     "unmodelled inertia at the driving shaft"),
    ("ripple_1x", "N.m", "Torque", None, False, "torque ripple at 1x the driving speed"),
    ("ripple_1x_phase", "rad", "Angle", None, False, "phase of the 1x ripple"),
    ("ripple_roller", "N.m", "Torque", None, False, "torque ripple at the roller-pass order"),
    ("ripple_roller_phase", "rad", "Angle", None, False, "phase of the roller-pass ripple"),
    ("thermal_loss_change", "1", None, -1.0, False,
     "relative change of the losses when warm (>= -1: the losses cannot fall below zero)"),
    ("thermal_tau", "s", "Time", POSITIVE_MIN, True, "warm-up time constant (> 0)"),
    ("drag_exponent", "1", None, 0.0, False, "exponent p of the drag's speed law "
     "(|w|/300 rad/s)^p (0 to 2)"),
    ("stribeck_exponent", "1", None, 1.0, False, "shape exponent delta of the Stribeck decay "
     "exp(-(|w|/w_s)^delta): 1 Tustin, 2 Gaussian (1 to 2)"),
    ("run_in_change", "1", None, -1.0, False, "excess of the load-dependent losses "
     "(PL1..PL6) of a drive that runs in, relative, at the start, decaying as "
     "exp(-distance/run_in_distance)"),
    ("run_in_distance", "rad", "Angle", POSITIVE_MIN, True, "distance (angle travelled by the driving "
     "shaft) over which the run-in excess decays by 1/e (> 0)"),
    ("ripple_1x_load", "N.m", "Torque", None, False, "load-scaled 1x ripple: amplitude at 10 N.m "
     "of |tau_out|, in proportion"),
    ("ripple_1x_load_phase", "rad", "Angle", None, False, "phase of the load-scaled 1x ripple"),
    ("ripple_roller_load", "N.m", "Torque", None, False, "load-scaled roller-pass ripple: "
     "amplitude at 10 N.m of |tau_out|, in proportion"),
    ("ripple_roller_load_phase", "rad", "Angle", None, False,
     "phase of the load-scaled roller-pass ripple"),
    ("thermal_loss_per_10K", "1", None, None, False, "relative change of the losses per 10 K "
     "of the grease temperature T_oil from thermal_T_ref: the losses, held at T_oil_start "
     "(one warm-up), times (1 + c (T_oil - thermal_T_ref)/10 K)"),
    ("thermal_T_ref", "K", "ThermodynamicTemperature", 173.15, True, "temperature the "
     "per-10 K loss change is referred to (a diagnosis: the recording's first temperature; "
     "173.15 to 473.15 K)"),
) + tuple(
    # the mesh ripple at 2x the driving shaft, 1x and 2x the driven shaft
    # (ExtraPhysics.shaft_order_ripple_torque); value references from EXTRA_VR1
    (prefix + sfx, unit, quantity, lo, False, f"{what}: {text}")
    for prefix, what in (("ripple_2x", "ripple at 2x the driving speed"),
                         ("ripple_out_1x", "ripple at 1x the driven shaft's speed (its angle "
                                           "theta w_out/w_in)"),
                         ("ripple_out_2x", "ripple at 2x the driven shaft's speed"))
    for sfx, unit, quantity, lo, text in (
        ("", "N.m", "Torque", 0.0, "amplitude (>= 0)"), ("_phase", "rad", "Angle", None, "phase"),
        ("_load", "N.m", "Torque", 0.0, "load-scaled amplitude at 10 N.m of |tau_out|, in "
         "proportion (>= 0)"),
        ("_load_phase", "rad", "Angle", None, "phase of the load-scaled part"))) + (
    ("stribeck_transition", "rad/s", "AngularVelocity", 0.0, False, "transition width w_r of "
     "the standstill friction's sign through a speed reversal, tanh(w/w_r) (pre-sliding; 0: "
     "the sharp sign; >= 0)"),
    ("thermal_T_scale", "K", "TemperatureDifference", 0.0, False, "temperature scale theta "
     "of the warm-up's temperature law: the losses times (1 + c (theta/10 K)(1 - exp(-(T_oil "
     "- thermal_T_ref)/theta))), c = thermal_loss_per_10K (model_core.thermal."
     "loss_temperature_law); 0: the linear law; else at least 1 K"),
    ("loss_transition", "rad/s", "AngularVelocity", 0.0, False, "transition width w_c of the "
     "whole loss through standstill: the loss torque (input torque minus the lossless one) "
     "and every partial loss times tanh(|w_in|/w_c) (pre-sliding; model_core.friction."
     "loss_transition); 0: the losses at full value at any speed; >= 0"),)
#: value references of EXTRA: its first EXTRA_FIRST at 30.., the others at EXTRA_VR1..
#: (50..59 were taken when they came; fmi2_cycloid.c's extra_index)
EXTRA_FIRST = 20
EXTRA_VR1 = 60


def extra_vr(k: int) -> int:
    """The value reference of EXTRA[k]."""
    return 30 + k if k < EXTRA_FIRST else EXTRA_VR1 + k - EXTRA_FIRST

#: Outputs, in the order of the C state's out[] (value references 10..29), then ``locked``.
OUTPUTS = (
    ("w_out", "rad/s", "AngularVelocity", "speed of the driven shaft"),
    ("tau_in", "N.m", "Torque", "torque the driver applies on the driving shaft"),
    ("tau_housing", "N.m", "Torque", "torque the support applies on the held shaft"),
    ("P_loss", "W", "Power", "total power loss tau_in*w_in + tau_out*w_out - P_stored (>= 0)"),
    ("PL1", "W", "Power", "partial loss PL1: eccentric (cycloid-gear) bearing"),
    ("PL2", "W", "Power", "partial loss PL2: disc rollers rolling in the holes"),
    ("PL3", "W", "Power", "partial loss PL3: disc rollers sliding on their pins"),
    ("PL5", "W", "Power", "partial loss PL5: ring rollers rolling on the cycloid teeth"),
    ("PL6", "W", "Power", "partial loss PL6: ring rollers sliding on their pins"),
    ("eta", "1", None, "efficiency of the actual power flow (0 without power or when locked)"),
    ("eta0", "1", None, "basic efficiency (carrier held)"),
    ("P_extra", "W", "Power", "power of the physics beyond the paper (drag, Stribeck, inertia, "
     "ripple, warm-up) at the driving shaft"),
    ("P_stored", "W", "Power", "power into stored energy at the driving shaft: kinetic energy of "
     "input_inertia and the ripples' zero-mean exchange (part of P_extra, not a loss)"),
    ("PL_support", "W", "Power", "partial loss PL_support: support bearings of the shafts "
     "(load-independent)"),
    ("PL_seal", "W", "Power", "partial loss PL_seal: shaft lip seals"),
    ("PL_churn", "W", "Power", "partial loss PL_churn: grease sheared at the orbiting gears' faces"),
    ("torque_out", "N.m", "Torque", "torque the driven shaft delivers to the load side, J_out's "
     "inertial torque included (what a transducer there reads)"),
    ("tau_in_static", "N.m", "Torque", "tau_in without the torque that accelerates J_out (for "
     "the driving side's integrator)"),
    ("J_load", "kg.m2", "MomentOfInertia", "J_out as the driving shaft feels it through the "
     "reducer while it speeds up (|w_in| rising)"),
    ("J_load_dec", "kg.m2", "MomentOfInertia", "J_out as the driving shaft feels it through the "
     "reducer while it slows down (|w_in| falling)"),
)

#: SI base-unit exponents and display units (name, factor: display = factor * SI value)
UNITS = {
    "rad/s": (dict(rad=1, s=-1), (("r/min", 30.0 / math.pi),)),
    "rad/s2": (dict(rad=1, s=-2), ()),
    "N.m": (dict(kg=1, m=2, s=-2), ()),
    "W": (dict(kg=1, m=2, s=-3), ()),
    "1": ({}, (("%", 100.0),)),
    "m": (dict(m=1), (("mm", 1e3), ("um", 1e6))),
    "m2/s": (dict(m=2, s=-1), (("mm2/s", 1e6),)),
    "kg/m3": (dict(kg=1, m=-3), ()),
    "kg.m2": (dict(kg=1, m=2), ()),
    "rad": (dict(rad=1), (("deg", 180.0 / math.pi),)),
    "s": (dict(s=1), ()),
    "N/m": (dict(kg=1, s=-2), (("N/mm", 1e-3),)),
    "K": (dict(K=1), ()),
    "J/K": (dict(kg=1, m=2, s=-2, K=-1), ()),
    "W/(m2.K)": (dict(kg=1, s=-3, K=-1), ()),
    "m2": (dict(m=2), ()),
}
DISPLAY = {"rad/s": "r/min", "m": "mm", "m2/s": "mm2/s", "rad": "deg", "N/m": "N/mm"}

_SHAFT = {"1": 0, "2": 1, "S": 2}

#: [K] the grease temperatures the FMU accepts (as the Python FMU's T_OIL_RANGE)
T_OIL_RANGE = (173.15, 473.15)


def THERMAL_PARAMS(design):
    """The heat balance's Real parameters, in the order of the C state's thermal block (value
    references 55..59): (name, vr, unit, quantity, start, min, max, description)."""
    return (
        ("T_oil_start", 55, "K", "ThermodynamicTemperature", design.operating_temperature,
         T_OIL_RANGE[0], T_OIL_RANGE[1], "grease/housing temperature at the start of the "
         "internal heat balance"),
        ("ambient_temperature", 56, "K", "ThermodynamicTemperature", design.ambient_temperature,
         T_OIL_RANGE[0], T_OIL_RANGE[1], "ambient temperature of the housing's heat balance"),
        ("housing_heat_capacity", 57, "J/K", "HeatCapacity", design.housing_heat_capacity,
         POSITIVE_MIN, None, "heat capacity C of the housing with its contents (lumped heat "
         "balance)"),
        ("housing_heat_transfer", 58, "W/(m2.K)", "CoefficientOfHeatTransfer",
         design.housing_heat_transfer, POSITIVE_MIN, None, "convection and radiation "
         "coefficient k_h of the housing surface"),
        ("housing_area", 59, "m2", "Area", design.housing_area, POSITIVE_MIN, None,
         "housing surface A_h giving heat to the ambient (R = 1/(k_h A_h))"))


def design_constants(design: DriveDesign):
    """The design values the map was built from, as (name, type, value, unit, description):
    the Python FMU's design parameter names (constants here), then the design fields it does
    not expose."""
    from ..slaves.cycloid_drive import DESIGN_PARAMETERS, THERMAL_PARAMETERS
    out = []
    for entry in DESIGN_PARAMETERS:
        name, section, field, unit, desc, kind = entry[:6]
        if section == "extra" or name in THERMAL_PARAMETERS:
            continue
        owner = design if section is None else getattr(design, section)
        out.append((name, kind.__name__, getattr(owner, field), unit, desc))
    more = (("torque_share", "Real", design.torque_share, "1",
             "share of the torque carried by the first cycloid gear"),
            ("profile_modification", "String", design.profile_modification, None,
             "kind of the profile correction: equidistant or offset"),
            ("disc_pin_sliding", "String", design.disc_pin_sliding, None,
             "sliding speed of a plain disc roller on its pin: paper or kinematic"),
            ("contact_law", "String", design.contact_law, None, "contact force law: hertz or "
             "linear"),
            ("linear_stiffness", "Real", design.linear_stiffness, "N/m",
             "contact stiffness for contact_law linear"),
            ("n_positions", "Integer", design.n_positions, None,
             "mesh positions per pitch the losses are averaged over"),
            ("mu_full_film", "Real", design.friction.mu_full_film, "1",
             "lower clamp of the Benedict-Kelley coefficient"),
            ("mu_rolling_disc", "Real", design.friction.rolling_disc, "1",
             "rolling-resistance coefficient of the disc rollers (mu_rolling: the ring rollers)"),
            ("seals", "String", design.seals, None, "shaft seals: lip or none"),
            ("calibration_source", "String", design.calibration.source, None,
             "what the calibration (mesh_loss_k, idle_loss_scale, load_loss_scale) was fitted "
             "to; empty: not calibrated"))
    names = {o[0] for o in out}
    out += [m for m in more if m[0] not in names]
    # the discovered loss terms (design [[extra.discovered]]): built in, shown as constants
    from ..slaves.cycloid_drive import DISCOVERED_PARAMETERS, discovered_values
    values = discovered_values(design)
    out += [(name, "Real", values[name], unit, desc) for name, _k, _f, unit, desc, *_ in
            DISCOVERED_PARAMETERS]
    # the Python FMU's newer design parameters, last (the older constants' value references
    # stay)
    from ..slaves.cycloid_drive import LATE_DESIGN_PARAMETERS
    for name, section, field, unit, desc, kind in LATE_DESIGN_PARAMETERS:
        if section == "extra":    # run-time parameters of the native FMU (EXTRA)
            continue
        out.append((name, kind.__name__, getattr(getattr(design, section), field), unit, desc))
    return out


@dataclass
class ModeData:
    name: str
    ratio: tuple
    a: int
    b: int
    h: int
    wdir: dict
    tables: dict          # forward -> ndarray (n_speed, n_torque, 6)
    idle: np.ndarray      # (n_speed, 6): the drag at the shafts
    w_low: float          # rad/s, the grid's lowest speed
    ratio_out: float
    order: float


def export_map(design: DriveDesign, torque_max=MAP_TORQUE_MAX, speed_max=MAP_SPEED_MAX):
    """Solve the loss map of every mode (ModeMap, as the Python FMU does at initialization).
    Returns (lt, lw, modes): the ln-torque and ln-speed grids and a ModeData per mode."""
    lt = lw = None
    modes = []
    for mode in kinematics.MODES:
        mm = ModeMap(design, mode, torque_max, speed_max)
        if lt is None:
            lt, lw = list(mm._lt), list(mm._lw)
        elif lt != mm._lt or lw != mm._lw:
            raise AssertionError("the maps of the six modes must share one grid")
        a, b, h = kinematics.parse_mode(mode)
        unit = kinematics.shaft_speeds(mode, 1.0, design.z1)
        # as CycloidDrive.exit_initialization_mode computes them
        ratio_out = float(unit[b])
        order = design.z1 * abs(float(unit["1"] - unit["S"])) / abs(float(unit[a]))
        modes.append(ModeData(mode, mm.ratio, _SHAFT[a], _SHAFT[b], _SHAFT[h], dict(mm._wdir),
                              {fwd: mm._arrays[fwd] for fwd in (True, False)},
                              np.asarray(mm._idle_array), mm._w_low, ratio_out, order))
    return lt, lw, modes


def _hex(x: float) -> str:
    x = float(x)
    if not math.isfinite(x):
        raise ValueError(f"non-finite value {x} in the exported map")
    return x.hex()


def _c_string(s: str) -> str:
    return ('"' + str(s).replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n")
            .replace("\t", "\\t").replace("\r", "\\r") + '"')


def _vr_tables(constants):
    """Value references of the constants, per type (100, 101, ...)."""
    counters = {"Real": 100, "Integer": 100, "String": 100}
    vrs = []
    for c in constants:
        vrs.append(counters[c[1]])
        counters[c[1]] += 1
    return vrs


def generate_data_c(design, lt, lw, nodes, constants, guid, torque_max, speed_max) -> str:
    """The C file that carries the design: the maps at the grease temperature's nodes
    (``nodes``: [(T, modes)], model_core.thermal.map_temperatures), extra defaults, constants,
    GUID."""
    lines = [f"/* Generated by cyclo-fmu {__version__} (cyclo_fmu/native/build.py): the loss "
             "map of one design.", " * Do not edit: rebuild with `cyclo-fmu build --design "
             "FILE`. Doubles as exact hexadecimal literals. */",
             '#include "cd_model.h"', ""]

    def arr(name, values):
        body = ",\n".join("    " + ", ".join(_hex(v) for v in values[i:i + 4])
                          for i in range(0, len(values), 4))
        lines.append(f"static const double {name}[{len(values)}] = {{\n{body}\n}};")

    arr("LT", lt)
    arr("LW", lw)
    for k, (_, modes) in enumerate(nodes):
        for m in modes:
            for fwd in (False, True):
                arr(f"TAB{k}_{m.name}_{int(fwd)}", m.tables[fwd].ravel().tolist())
            arr(f"IDLE{k}_{m.name}", m.idle.ravel().tolist())
    lines.append("")

    def cdmap(k, modes):
        out = [f"    {len(lt)}, {len(lw)}, LT, LW, {_hex(design.i0)}, {_hex(modes[0].w_low)},",
               "    {"]
        for m in modes:
            out.append(f"        {{{_c_string(m.name)}, "
                       f"{{{', '.join(_hex(r) for r in m.ratio)}}}, "
                       f"{m.a}, {m.b}, {m.h}, {{{m.wdir[False]}, {m.wdir[True]}}}, "
                       f"{{TAB{k}_{m.name}_0, TAB{k}_{m.name}_1}}, IDLE{k}_{m.name}, "
                       f"{_hex(m.ratio_out)}, {_hex(m.order)}}},")
        out.append("    }")
        return out
    lines.append(f"static const CDMap MAPS[{len(nodes)}] = {{")
    for k, (_, modes) in enumerate(nodes):
        lines += ["  {"] + cdmap(k, modes) + ["  },"]
    lines.append("};")
    arr("MAP_T", [T for T, _ in nodes])
    lines.append(f"const CDThermalMap CD_THERMAL = {{{len(nodes)}, MAP_T, MAPS}};")
    ref = [T for T, _ in nodes].index(float(design.operating_temperature))
    lines.append("const CDMap CD_MAP = {")
    lines += cdmap(ref, nodes[ref][1])
    lines.append("};")
    ex = design.extra
    lines.append("const CDExtra CD_DEFAULT_EXTRA = {"
                 + ", ".join(_hex(getattr(ex, e[0])) for e in EXTRA) + "};")
    # design [[extra.discovered]] (model_core.discovered), padded to CD_MAX_DISCOVERED
    from model_core.discovered import MAX_TERMS
    terms = [(t.coefficient, t.speed_exponent, t.load_exponent) for t in ex.discovered]
    rows = terms + [(0.0, 0.0, 0.0)] * (MAX_TERMS - len(terms))
    lines.append(f"const CDTerm CD_DISCOVERED[CD_MAX_DISCOVERED] = {{"
                 + ", ".join("{" + ", ".join(_hex(v) for v in r) + "}" for r in rows) + "};")
    lines.append(f"const int CD_N_DISCOVERED = {len(terms)};")
    lines.append("const double CD_DEFAULT_THERMAL[CD_N_THERMAL] = {"
                 + ", ".join(_hex(p[4]) for p in THERMAL_PARAMS(design)) + "};")
    lines.append(f"const char CD_GUID[] = {_c_string(guid)};")
    lines.append(f"const double CD_MAP_TORQUE_MAX = {_hex(torque_max)};")
    lines.append(f"const double CD_MAP_SPEED_MAX = {_hex(speed_max)};")
    vrs = _vr_tables(constants)
    for kind, ctype, fmt in (("Real", "CDConstReal", _hex), ("Integer", "CDConstInteger", str),
                             ("String", "CDConstString", _c_string)):
        rows = [f"    {{{vr}u, {fmt(c[2])}}}" for c, vr in zip(constants, vrs) if c[1] == kind]
        if kind == "Real":   # map_torque_max, map_speed_max (value references 200, 201)
            rows += [f"    {{200u, {_hex(torque_max)}}}", f"    {{201u, {_hex(speed_max)}}}"]
        n = len(rows)
        if not rows:   # C forbids empty initialisers
            rows = ["    {0u, 0}"]
        lines.append(f"const {ctype} CD_CONST_{kind.upper()}[] = {{\n" + ",\n".join(rows)
                     + "\n};")
        lines.append(f"const int CD_N_CONST_{kind.upper()} = {n};")
    return "\n".join(lines) + "\n"


# -- modelDescription.xml ----------------------------------------------------------------------
def _num(x) -> str:
    return repr(float(x)) if isinstance(x, float) else str(x)


def _real_attrs(unit, quantity=None, start=None, display=None, min_=None, max_=None):
    at = []
    if quantity:
        at.append(f'quantity="{quantity}"')
    if unit:
        at.append(f'unit="{unit}"')
    disp = display if display is not None else DISPLAY.get(unit)
    if disp:
        at.append(f'displayUnit="{disp}"')
    if min_ is not None:
        at.append(f'min="{_num(float(min_))}"')
    if max_ is not None:
        at.append(f'max="{_num(float(max_))}"')
    if start is not None:
        at.append(f'start="{_num(float(start))}"')
    return " ".join(at)


def model_description(design, constants, guid, torque_max, speed_max, description) -> str:
    v = []          # (xml, name)

    def sv(name, vr, causality, variability, desc, element, initial=None):
        init = f' initial="{initial}"' if initial else ""
        v.append((f'    <ScalarVariable name="{name}" valueReference="{vr}" '
                  f'causality="{causality}" variability="{variability}"{init} '
                  f'description={quoteattr(desc)}>\n      {element}\n    </ScalarVariable>',
                  name))

    sv("w_in", 0, "input", "continuous", "speed of the driving shaft",
       f'<Real {_real_attrs("rad/s", "AngularVelocity", 0.0)}/>')
    sv("tau_out", 1, "input", "continuous", "torque the load applies on the driven shaft",
       f'<Real {_real_attrs("N.m", "Torque", 0.0)}/>')
    sv("alpha_in", 2, "input", "continuous", "acceleration of the driving shaft (from its "
       "integrator's equation of motion); used with J_out",
       f'<Real {_real_attrs("rad/s2", "AngularAcceleration", 0.0)}/>')
    sv("T_oil_in", 3, "input", "continuous", "grease/housing temperature from outside (a "
       "measurement, a thermal model); used with use_T_oil_input",
       f'<Real {_real_attrs("K", "ThermodynamicTemperature", design.operating_temperature)}/>')
    for k, (name, unit, quantity, desc) in enumerate(OUTPUTS):
        sv(name, 10 + k, "output", "continuous", desc,
           f'<Real {_real_attrs(unit, quantity, display="%" if unit == "1" else None)}/>',
           "calculated")
        if name == "J_load_dec":   # after the outputs at 10..29
            sv("PL_mesh", 52, "output", "continuous", "partial loss PL_mesh: additional mesh "
               "loss, a fraction mesh_loss_k of the mesh power (calibrated; 0 uncalibrated)",
               f'<Real {_real_attrs("W", "Power")}/>', "calculated")
            sv("T_oil", 53, "output", "continuous", "grease/housing temperature (T_oil_in, or "
               "the heat balance's); the losses are evaluated at it, or at T_oil_start while "
               "thermal_loss_change or thermal_loss_per_10K is not 0 (one warm-up)",
               f'<Real {_real_attrs("K", "ThermodynamicTemperature")}/>', "calculated")
            sv("Q_ambient", 54, "output", "continuous", "heat flow from the housing to the "
               "ambient (T_oil - ambient_temperature)/R", f'<Real {_real_attrs("W", "Power")}/>',
               "calculated")
        if name == "eta0":
            sv("locked", 10, "output", "discrete", "self-locking back-drive holds: the driving "
               "shaft must push although the load drives", "<Boolean/>", "calculated")
    sv("mode", 0, "parameter", "fixed", "operating mode: driving shaft, driven shaft (12, 21, "
       "1S, S1, 2S, S2; 1 ring, 2 disc, S eccentric)", '<String start="S1"/>', "exact")
    sv("mode_number", 0, "parameter", "fixed", "the mode as a number for importers that cannot "
       "set String parameters: 0 = use mode, 1..6 = 12, 21, 1S, S1, 2S, S2",
       '<Integer min="0" max="6" start="0"/>', "exact")
    for k, (name, unit, quantity, lo, _excl, desc) in enumerate(EXTRA):
        sv(name, extra_vr(k), "parameter", "fixed", desc + " (design [extra])",
           f'<Real {_real_attrs(unit, quantity, getattr(design.extra, name), min_=lo)}/>',
           "exact")
    from ..slaves.cycloid_drive import ALPHA_REF
    sv("J_out", 50, "parameter", "fixed", "inertia on the driven shaft, reflected to the driving "
       "side's integrator (see J_load)",
       f'<Real {_real_attrs("kg.m2", "MomentOfInertia", 0.0, min_=0.0)}/>', "exact")
    sv("alpha_ref", 51, "parameter", "fixed", "acceleration of the driving shaft over which "
       "J_load and J_load_dec are secants (the order of the accelerations the train sees). "
       "Assumption", f'<Real {_real_attrs("rad/s2", "AngularAcceleration", ALPHA_REF, min_=POSITIVE_MIN)}/>',
       "exact")
    sv("use_T_oil_input", 11, "parameter", "fixed", "take the grease/housing temperature from "
       "the input T_oil_in (true) or from the internal lumped heat balance (false: C dT/dt = "
       "P_loss - (T - ambient_temperature)/R, started at T_oil_start)",
       '<Boolean start="false"/>', "exact")
    for name, vr, unit, quantity, value, lo, hi, desc in THERMAL_PARAMS(design):
        sv(name, vr, "parameter", "fixed", desc,
           f'<Real {_real_attrs(unit, quantity, value, min_=lo, max_=hi)}/>', "exact")
    for c, vr in zip(constants, _vr_tables(constants)):
        name, kind, value, unit, desc = c
        desc = desc + " (constant: fixed by the design this FMU was built for)"
        if kind == "Real":
            q = {"m": "Length", "m2/s": "KinematicViscosity", "kg/m3": "Density",
                 "N/m": "TranslationalSpringConstant"}.get(unit)
            disp = "um" if name == "pin_roughness" else None
            el = f'<Real {_real_attrs(unit if unit else None, q, value, display=disp)}/>'
        elif kind == "Integer":
            el = f'<Integer start="{int(value)}"/>'
        else:
            el = f'<String start={quoteattr(str(value))}/>'
        sv(name, vr, "local", "constant", desc, el, "exact")
    for name, value, unit, quantity, desc in (
            ("map_torque_max", torque_max, "N.m", "Torque", "largest |tau_out| in the loss map"),
            ("map_speed_max", speed_max, "rad/s", "AngularVelocity",
             "largest |w_in| in the loss map")):
        sv(name, 200 + (name == "map_speed_max"), "local", "constant",
           desc + " (constant: fixed at build time)",
           f'<Real {_real_attrs(unit, quantity, value)}/>', "exact")
    index = {name: i + 1 for i, (_, name) in enumerate(v)}

    # Outputs: dependencies on the inputs in Step Mode. InitialUnknowns: on inputs and
    # parameters in Initialization Mode (t = start, no step yet: no inertia or warm-up term).
    mode_p = ["mode", "mode_number"]
    steady = ["drag_torque", "stribeck_torque", "stribeck_speed", "stribeck_exponent",
              "drag_exponent", "run_in_change", "run_in_distance", "ripple_1x_load",
              "ripple_1x_load_phase", "ripple_roller_load", "ripple_roller_load_phase",
              "ripple_1x", "ripple_1x_phase", "ripple_roller", "ripple_roller_phase"] + [
                  e[0] for e in EXTRA[EXTRA_FIRST:]]
    # alpha_in acts through J_out (0 by default); declared, so that the dependencies hold for
    # every parameter value
    both = ["w_in", "tau_out", "alpha_in", "T_oil_in"]
    inertia = ["J_out", "use_T_oil_input", "T_oil_start"]
    deps = {"w_out": (["w_in"], ["w_in"] + mode_p)}
    # tau_housing closes the torque balance: it carries the extra physics' reaction too
    for name in ("tau_in", "P_loss", "eta", "P_extra", "P_stored", "tau_in_static",
                 "tau_housing"):
        deps[name] = (both, both + mode_p + steady + inertia
                      + (["alpha_ref"] if name == "tau_in_static" else []))
    for name in ("PL1", "PL2", "PL3", "PL5", "PL6", "PL_support", "PL_seal",
                 "PL_churn", "PL_mesh", "eta0", "locked", "torque_out"):
        deps[name] = (both, both + mode_p + inertia)
    for name in ("J_load", "J_load_dec"):
        deps[name] = (both, both + mode_p + inertia + ["alpha_ref"])
    for name in ("T_oil", "Q_ambient"):
        deps[name] = (["T_oil_in"], ["T_oil_in", "use_T_oil_input", "T_oil_start"]
                      + ([] if name == "T_oil" else ["ambient_temperature",
                                                     "housing_heat_transfer", "housing_area"]))

    def unknown(name, which):
        d = sorted(index[x] for x in deps[name][which])
        kinds = " ".join(["dependent"] * len(d))
        return (f'      <Unknown index="{index[name]}" dependencies="{" ".join(map(str, d))}" '
                f'dependenciesKind="{kinds}"/>')

    outs = sorted((n for n in deps), key=index.get)
    units = []
    for u, (base, disp) in UNITS.items():
        b = " ".join(f'{k}="{e}"' for k, e in base.items())
        body = [f"      <BaseUnit {b}/>"] + [
            f'      <DisplayUnit name="{n}" factor="{_num(f)}"/>' for n, f in disp]
        units.append(f'    <Unit name="{u}">\n' + "\n".join(body) + "\n    </Unit>")
    sources = "".join(f'\n        <File name="{f}"/>' for f in C_SOURCES + (GENERATED,))
    return f'''<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription
  fmiVersion="2.0"
  modelName="{NAME}"
  guid="{guid}"
  description={quoteattr(description)}
  author="cyclo-fmu"
  version="{__version__}"
  copyright="Copyright (c) the cyclo-fmu authors"
  license="MIT"
  generationTool="cyclo-fmu {__version__} (cyclo_fmu.native)"
  variableNamingConvention="structured"
  numberOfEventIndicators="0">
  <CoSimulation
    modelIdentifier="{NAME}"
    canHandleVariableCommunicationStepSize="true"
    canGetAndSetFMUstate="true"
    canSerializeFMUstate="true"
    providesDirectionalDerivative="false">
    <SourceFiles>{sources}
    </SourceFiles>
  </CoSimulation>
  <UnitDefinitions>
{chr(10).join(units)}
  </UnitDefinitions>
  <LogCategories>
    <Category name="logStatusError" description="errors: bad input or parameter, calls out of order"/>
    <Category name="logStatusWarning" description="warnings: operating point beyond the loss map"/>
    <Category name="logAll" description="everything"/>
  </LogCategories>
  <DefaultExperiment startTime="0.0" stopTime="10.0" stepSize="0.001"/>
  <ModelVariables>
{chr(10).join(x for x, _ in v)}
  </ModelVariables>
  <ModelStructure>
    <Outputs>
{chr(10).join(unknown(n, 0) for n in outs)}
    </Outputs>
    <InitialUnknowns>
{chr(10).join(unknown(n, 1) for n in outs)}
    </InitialUnknowns>
  </ModelStructure>
</fmiModelDescription>
'''


BUILD_DESCRIPTION = '''<?xml version="1.0" encoding="UTF-8"?>
<fmiBuildDescription fmiVersion="3.0">
  <BuildConfiguration modelIdentifier="{name}">
    <SourceFileSet language="C99" compilerOptions="-ffp-contract=off">
{files}
    </SourceFileSet>
    <Library name="m"/>
  </BuildConfiguration>
</fmiBuildDescription>
'''


def fmi_header_dir() -> Path:
    """fmpy's copy of the FMI headers (2-clause BSD)."""
    import fmpy
    d = Path(fmpy.__file__).resolve().parent / "c-code"
    missing = [h for h in FMI_HEADERS if not (d / h).is_file()]
    if missing:
        raise FileNotFoundError(f"FMI 2.0 headers {', '.join(missing)} not found in {d}")
    return d


def find_compiler() -> str:
    cc = os.environ.get("CC") or shutil.which("gcc") or shutil.which("cc")
    if not cc:
        raise CycloidInputError("C compiler", "gcc", "not found: CycloidDriveNative.fmu is "
                                "compiled at build time; install gcc or set CC, or build only "
                                "the Python FMUs (cyclo-fmu build CycloidDrive ...)")
    return cc


def compile_binary(sources: Path, out: Path, cc: str | None = None) -> None:
    cc = cc or find_compiler()
    out.parent.mkdir(parents=True, exist_ok=True)
    cmd = [cc, *CFLAGS, f"-I{sources}", "-o", str(out),
           *[str(sources / f) for f in C_SOURCES + (GENERATED,)], "-lm"]
    try:
        r = subprocess.run(cmd, capture_output=True, text=True)
    except OSError as exc:
        raise CycloidInputError("C compiler", cc, f"cannot be run ({exc.strerror})") from exc
    if r.returncode != 0:
        first = next((ln for ln in r.stderr.splitlines() if "error" in ln), r.stderr.strip())
        raise CycloidInputError("C compiler", cc, f"failed on the native FMU: {first[:300]}")


def build_native_fmu(design: DriveDesign | None = None, dest="dist", *,
                     torque_max: float = MAP_TORQUE_MAX, speed_max: float = MAP_SPEED_MAX,
                     name: str = NAME, cc: str | None = None) -> Path:
    """Build ``dest/CycloidDriveNative.fmu`` for ``design`` (default: the paper's test drive)
    and return its path. ``name`` only changes the file name (the model identifier, and so the
    binary's name, stays ``CycloidDriveNative``)."""
    design = design or DriveDesign()
    for field, v in (("map_torque_max", torque_max), ("map_speed_max", speed_max)):
        if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
            raise CycloidInputError(field, v, "must be a positive number")
    cc = cc or find_compiler()
    headers = fmi_header_dir()
    from model_core import thermal
    nodes = []
    for T in thermal.map_temperatures(design):
        lt, lw, modes = export_map(thermal.at_temperature(design, T), float(torque_max),
                                   float(speed_max))
        nodes.append((T, modes))
    constants = design_constants(design)
    # GUID: a digest of everything the binary carries, so another design gives another GUID
    placeholder = "{00000000-0000-0000-0000-000000000000}"
    body = generate_data_c(design, lt, lw, nodes, constants, placeholder, torque_max, speed_max)
    digest = hashlib.sha256(body.encode())
    for f in C_SOURCES + C_HEADERS:
        digest.update((HERE / f).read_bytes())
    guid = "{" + str(uuid.UUID(bytes=digest.digest()[:16], version=4)) + "}"
    data_c = body.replace(placeholder, guid)
    cal = design.calibration
    calibrated = ("" if cal.is_default else f", CALIBRATED mesh_loss_k = {cal.mesh_loss_k:.4g}, "
                  f"idle_loss_scale = {cal.idle_loss_scale:.4g}, "
                  f"load_loss_scale = {cal.load_loss_scale:.4g}")
    desc = (f"Constrained cycloid drive (z1 = {design.z1}, mu_boundary = "
            f"{design.friction.mu_boundary:g}{calibrated}): load-dependent losses and efficiency "
            "(Mackic et al.), quasi-static, all six modes and four quadrants; native C, the "
            "design's loss map built in")
    md = model_description(design, constants, guid, torque_max, speed_max, desc)
    dest = Path(dest)
    dest.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="cyclofmu_native_") as tmp:
        stage = Path(tmp) / "fmu"
        src = stage / "sources"
        src.mkdir(parents=True)
        for f in C_SOURCES + C_HEADERS:
            shutil.copyfile(HERE / f, src / f)
        for f in FMI_HEADERS:
            shutil.copyfile(headers / f, src / f)
        (src / GENERATED).write_text(data_c)
        files = "\n".join(f'      <SourceFile name="{f}"/>' for f in C_SOURCES + (GENERATED,))
        (src / "buildDescription.xml").write_text(BUILD_DESCRIPTION.format(name=NAME,
                                                                           files=files))
        (stage / "modelDescription.xml").write_text(md)
        doc = stage / "documentation"
        doc.mkdir()
        (doc / "index.html").write_text(_documentation(design, torque_max, speed_max))
        lic = doc / "licenses"
        lic.mkdir()
        (lic / "LICENSE.txt").write_text(MIT_LICENSE)
        (lic / "fmi-headers-BSD-2-Clause.txt").write_text(_fmi_license(headers))
        compile_binary(src, stage / "binaries" / "linux64" / f"{NAME}.so", cc)
        from .cross import compile_win64     # binaries/win64 with mingw-w64 or Zig
        compile_win64(src, C_SOURCES + (GENERATED,), stage / "binaries" / "win64" / f"{NAME}.dll")
        out = dest / f"{name}.fmu"
        partial = dest / f".{name}.fmu.partial-{os.getpid()}"
        with zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as zf:
            for p in sorted(stage.rglob("*")):
                if p.is_file():
                    zf.write(p, p.relative_to(stage).as_posix())
        os.replace(partial, out)
    return out


MIT_LICENSE = """CycloidDriveNative.fmu (cyclo-fmu): the C sources written for cyclo-fmu, the
generated map and the binary.

MIT License

Copyright (c) the cyclo-fmu authors

Permission is hereby granted, free of charge, to any person obtaining a copy of this software
and associated documentation files (the "Software"), to deal in the Software without
restriction, including without limitation the rights to use, copy, modify, merge, publish,
distribute, sublicense, and/or sell copies of the Software, and to permit persons to whom the
Software is furnished to do so, subject to the following conditions:

The above copyright notice and this permission notice shall be included in all copies or
substantial portions of the Software.

THE SOFTWARE IS PROVIDED "AS IS", WITHOUT WARRANTY OF ANY KIND, EXPRESS OR IMPLIED, INCLUDING
BUT NOT LIMITED TO THE WARRANTIES OF MERCHANTABILITY, FITNESS FOR A PARTICULAR PURPOSE AND
NONINFRINGEMENT. IN NO EVENT SHALL THE AUTHORS OR COPYRIGHT HOLDERS BE LIABLE FOR ANY CLAIM,
DAMAGES OR OTHER LIABILITY, WHETHER IN AN ACTION OF CONTRACT, TORT OR OTHERWISE, ARISING FROM,
OUT OF OR IN CONNECTION WITH THE SOFTWARE OR THE USE OR OTHER DEALINGS IN THE SOFTWARE.
"""


def _fmi_license(headers: Path) -> str:
    """The FMI headers' own license notice, as their header comment states it."""
    text = (headers / "fmi2FunctionTypes.h").read_text()
    start = text.index("Copyright (C)")
    end = text.index("*/", start)
    body = "\n".join(line.strip() for line in text[start:end].splitlines()).strip()
    return ("The FMI 2.0 headers in sources/ (fmi2Functions.h, fmi2FunctionTypes.h, "
            "fmi2TypesPlatform.h), as shipped by fmpy:\n\n" + body + "\n")


def _documentation(design, torque_max, speed_max) -> str:
    from model_core.design import design_to_toml
    from html import escape
    return f"""<!DOCTYPE html>
<html><head><meta charset="utf-8"><title>{NAME}</title></head><body>
<h1>{NAME} (cyclo-fmu {__version__})</h1>
<p>Constrained cycloid drive after Mackic et al.: load-dependent losses and efficiency,
quasi-static, all six modes, both power-flow directions, self-locking. FMI 2.0 co-simulation,
native C (no Python). The loss map of the design below is built in: |tau_out| from
{torque_max * 1e-3:g} to {torque_max:g} N.m, |w_in| from {speed_max * 1e-3:g} to {speed_max:g}
rad/s, log-spaced; outside, eta0 is held at the edge (the losses keep scaling with the power).</p>
<p>Ports as Modelica flanges: a torque is what the outside applies on the reducer's shaft, so
the power into the reducer at a shaft is tau*w. Inputs w_in, tau_out; outputs w_out, tau_in,
tau_housing, P_loss, PL1..PL6, PL_support, PL_seal, PL_churn, PL_mesh, eta, eta0, locked,
P_extra.</p>
<h2>Design (fixed at build time)</h2><pre>{escape(design_to_toml(design))}</pre>
<p>License: MIT (cyclo-fmu). The FMI headers in sources/ are the Modelica Association's,
2-clause BSD.</p>
</body></html>
"""
