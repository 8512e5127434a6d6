"""FMI 2.0 co-simulation slave of the cycloid reducer (massless, quasi-static).

Ports, as Modelica flanges (a torque is what the outside applies on the reducer's shaft, so the
power into the reducer at a shaft is tau*w):
  inputs   w_in   speed of the driving shaft (rad/s)
           tau_out torque the load applies on the driven shaft (N*m)
  outputs  w_out  speed of the driven shaft (rad/s)
           tau_in torque the driver applies on the driving shaft (N*m)
           tau_housing torque the support applies on the held shaft (N*m)
           P_loss = tau_in*w_in + tau_out*w_out >= 0 and the partial losses PL1..PL6 (W)
           eta efficiency of the actual power flow, locked (self-locking back-drive holds)
Forward motoring into a brake: tau_in*w_in > 0, tau_out*w_out < 0.

Output-side inertia (``J_out``, default 0): the inertia on the driven shaft (brake drum,
coupling, output transducer) is integrated by the driving side's integrator, not differentiated
here. With the driving shaft's acceleration ``alpha_in`` (from the motor's equation of motion),
the load on the driven shaft is tau_out - J_out r alpha_in (r = w_out/w_in), and all losses and
``tau_in`` are at that total torque. For the integrator the reducer describes its driving
torque as a function of the driving shaft's acceleration a: ``tau_in_static`` (at a = 0) plus
``J_load`` a while the shaft speeds up (a w_in > 0: J_out r^2/eta, the motor drives the load's
inertia) or ``J_load_dec`` a while it slows down (J_out r^2 eta': the inertia back-drives the
reducer), each a secant of the map over alpha_ref. The motor integrates
(J_motor + J_side) dw/dt = T_em - tau_in_static and picks the side at every sub-step.

Parameters: ``mode`` (12, 21, 1S, S1, 2S, S2) and the design values a system engineer varies
(defaults: the paper's test drive). At initialization the full physics core is solved on a grid
(model_core.lossmap.ModeMap); a step interpolates it (``exact = false``) or solves the full core
(``exact = true``, about 2 ms a step).
"""
from __future__ import annotations

import dataclasses
import math
import pickle
import sys
import threading
import weakref
from pathlib import Path

from . import core
from .base import Boolean, Fmi2Status, Integer, Real, String, UnitSlave

# FMU parameter -> (design section or None, design field, unit, description)
DESIGN_PARAMETERS = [
    ("z1", None, "z1", None, "number of ring rollers", Integer),
    ("n_disc_rollers", None, "n_disc_rollers", None, "number of disc rollers k", Integer),
    ("e", None, "e", "m", "eccentricity", Real),
    ("lam", None, "lam", "1", "coefficient of the trochoid lambda = r_p/(e z1)", Real),
    ("d_v1", None, "d_v1", "m", "ring roller diameter", Real),
    ("d_o1", None, "d_o1", "m", "ring pin diameter", Real),
    ("b1", None, "b1", "m", "ring roller width", Real),
    ("d_v2", None, "d_v2", "m", "disc roller diameter", Real),
    ("d_o2", None, "d_o2", "m", "disc pin diameter", Real),
    ("b2", None, "b2", "m", "disc roller width", Real),
    ("d_m2", None, "d_m2", "m", "pitch diameter of the disc rollers", Real),
    ("D_cz", None, "D_cz", "m", "hole diameter in the cycloid gear", Real),
    ("D_p", None, "D_p", "m", "outer diameter of the eccentric bearing", Real),
    ("d_p", None, "d_p", "m", "bore of the eccentric bearing", Real),
    ("delta_z", None, "delta_z", "m", "profile correction", Real),
    ("ring_rollers", None, "ring_rollers", None, "ring rollers: plain or needle", String),
    ("disc_rollers", None, "disc_rollers", None, "disc rollers: plain or needle", String),
    ("nu", "lubricant", "kinematic_viscosity", "m2/s", "lubricant kinematic viscosity", Real),
    ("rho_oil", "lubricant", "density", "kg/m3", "lubricant density", Real),
    ("mu_boundary", "friction", "mu_boundary", "1",
     "boundary friction coefficient of the sliding roller-pin contacts (calibrated)", Real),
    ("mu_pin_boundary", "friction", "mu_pin_boundary", "1",
     "boundary coefficient of the Stribeck pin law (physical profile)", Real),
    ("mu_tooth", "friction", "mu_tooth", "1",
     "traction coefficient at the tooth and in the holes (physical profile)", Real),
    ("pin_roughness", "friction", "pin_roughness", "m", "composite roughness of pin and roller bore", Real),
    ("mu_rolling", "friction", "rolling_ring", "1",
     "rolling-resistance coefficient of the rollers (ring and disc)", Real),
    # physics beyond the paper, switched on by a diagnosis (design [extra])
    ("drag_torque", "extra", "drag_torque", "N.m",
     "load-independent drag at 300 rad/s of the driving shaft, ~ speed^(2/3)", Real),
    ("stribeck_torque", "extra", "stribeck_torque", "N.m", "extra friction at standstill", Real),
    ("stribeck_speed", "extra", "stribeck_speed", "rad/s", "Stribeck speed", Real),
    ("input_inertia", "extra", "input_inertia", "kg.m2", "unmodelled inertia at the driving shaft",
     Real),
    ("ripple_1x", "extra", "ripple_1x", "N.m", "ripple at 1x the driving speed", Real),
    ("ripple_1x_phase", "extra", "ripple_1x_phase", "rad", "phase of the 1x ripple", Real),
    ("ripple_roller", "extra", "ripple_roller", "N.m", "ripple at the roller-pass order", Real),
    ("ripple_roller_phase", "extra", "ripple_roller_phase", "rad", "phase of the roller ripple",
     Real),
    ("thermal_loss_change", "extra", "thermal_loss_change", "1",
     "relative change of the losses when warm", Real),
    ("thermal_tau", "extra", "thermal_tau", "s", "warm-up time constant", Real),
    ("drag_exponent", "extra", "drag_exponent", "1",
     "exponent p of the drag's speed law (|w|/300 rad/s)^p", Real),
    # the model (design [model]); after the others, so that their value references stay
    ("profile", None, "profile", None, "model profile: physical (correct kinematics, roll or "
     "skid, Stribeck pin law, friction in the force balance, load-independent losses) or "
     "paper (what the paper computed)", String),
    ("losses", None, "losses", None, "losses that enter: all or load_dependent (the paper "
     "profile always uses load_dependent)", String),
    ("operating_temperature", None, "operating_temperature", "K",
     "grease temperature (physical profile; sets the viscosity by Walther's law)", Real),
    # what the model learned from a measurement (design [calibration]); last, so that the
    # value references above stay
    ("mesh_loss_k", "calibration", "mesh_loss_k", "1", "calibrated additional mesh loss, a "
     "fraction k of the mesh power: eta0 -> eta0 (1 - k) (0: as derived; 0 to 0.5)", Real),
    ("idle_loss_scale", "calibration", "idle_loss_scale", "1", "calibrated scale on the "
     "load-independent losses (1: as derived; 0 to 10)", Real),
    # extra physics of the library's newer forms; after the others, so that their value
    # references stay
    ("stribeck_exponent", "extra", "stribeck_exponent", "1",
     "shape exponent delta of the Stribeck decay exp(-(|w|/w_s)^delta): 1 Tustin, 2 Gaussian",
     Real),
    ("run_in_change", "extra", "run_in_change", "1", "excess of the load-dependent losses "
     "(PL1..PL6) of a drive that runs in, relative, at the start, decaying as "
     "exp(-distance/run_in_distance)", Real),
    ("run_in_distance", "extra", "run_in_distance", "rad", "distance (angle travelled by the "
     "driving shaft) over which the run-in excess decays by 1/e", Real),
    ("ripple_1x_load", "extra", "ripple_1x_load", "N.m", "load-scaled 1x ripple: amplitude at "
     "10 N.m of |tau_out|, in proportion", Real),
    ("ripple_1x_load_phase", "extra", "ripple_1x_load_phase", "rad",
     "phase of the load-scaled 1x ripple", Real),
    ("ripple_roller_load", "extra", "ripple_roller_load", "N.m", "load-scaled roller-pass "
     "ripple: amplitude at 10 N.m of |tau_out|, in proportion", Real),
    ("ripple_roller_load_phase", "extra", "ripple_roller_load_phase", "rad",
     "phase of the load-scaled roller-pass ripple", Real),
    # the housing's lumped heat balance (model_core.thermal.housing_step); run-time
    # parameters, the loss map does not depend on them
    ("ambient_temperature", None, "ambient_temperature", "K", "ambient temperature of the "
     "housing's heat balance", Real),
    ("housing_heat_capacity", None, "housing_heat_capacity", "J/K", "heat capacity C of the "
     "housing with its contents (lumped heat balance)", Real),
    ("housing_heat_transfer", None, "housing_heat_transfer", "W/(m2.K)", "convection and "
     "radiation coefficient k_h of the housing surface", Real),
    ("housing_area", None, "housing_area", "m2", "housing surface A_h giving heat to the "
     "ambient (R = 1/(k_h A_h))", Real),
]
#: design parameters registered after every other variable (newer: the value references of the
#: older ones stay); entries as DESIGN_PARAMETERS
LATE_DESIGN_PARAMETERS = [
    ("nu_100", "lubricant", "kinematic_viscosity_100", "m2/s", "lubricant kinematic viscosity "
     "at 100 degC: with nu (at 40 degC) the Walther line by which the grease temperature sets "
     "the viscosity (physical profile; a diagnosed viscosity-temperature slope rewrites both)",
     Real),
    ("load_loss_scale", "calibration", "load_loss_scale", "1", "calibrated scale on the "
     "gear's load-dependent friction losses PL1..PL6 (the friction level of the whole gear; "
     "1: as derived; 0 to 10)", Real),
    # the warm-up's per-10 K form (model_core.design.ExtraPhysics.thermal_per_10K_torque)
    ("thermal_loss_per_10K", "extra", "thermal_loss_per_10K", "1", "relative change of the "
     "losses per 10 K of the grease temperature T_oil from thermal_T_ref: the losses, held at "
     "T_oil_start (one warm-up), times (1 + c (T_oil - thermal_T_ref)/10 K)", Real),
    ("thermal_T_ref", "extra", "thermal_T_ref", "K", "temperature the per-10 K loss change is "
     "referred to (a diagnosis: the recording's first temperature)", Real)] + [
    # the mesh ripple at 2x the driving shaft and 1x, 2x the driven shaft
    # (model_core.design.ExtraPhysics.shaft_order_ripple_torque)
    (prefix + sfx, "extra", prefix + sfx, unit, f"{what}: {text}", Real)
    for prefix, what in (("ripple_2x", "ripple at 2x the driving speed"),
                         ("ripple_out_1x", "ripple at 1x the driven shaft's speed (its angle "
                                           "theta w_out/w_in)"),
                         ("ripple_out_2x", "ripple at 2x the driven shaft's speed"))
    for sfx, unit, text in (("", "N.m", "amplitude (>= 0)"), ("_phase", "rad", "phase"),
                            ("_load", "N.m", "load-scaled amplitude at 10 N.m of |tau_out|, "
                             "in proportion (>= 0)"),
                            ("_load_phase", "rad", "phase of the load-scaled part"))] + [
    # the standstill friction's sign through a speed reversal (model_core.friction.
    # reversal_sign)
    ("stribeck_transition", "extra", "stribeck_transition", "rad/s", "transition width w_r of "
     "the standstill friction's sign through a speed reversal, tanh(w/w_r) (pre-sliding; 0: "
     "the sharp sign; >= 0)", Real),
    # the warm-up's exponential temperature law (model_core.thermal.loss_temperature_law)
    ("thermal_T_scale", "extra", "thermal_T_scale", "K", "temperature scale theta of the "
     "warm-up's temperature law: the losses times (1 + c (theta/10 K)(1 - exp(-(T_oil - "
     "thermal_T_ref)/theta))), c = thermal_loss_per_10K; 0: the linear law (1 + c (T_oil - "
     "thermal_T_ref)/10 K); else at least 1 K", Real),
    # the whole loss through standstill (model_core.friction.loss_transition)
    ("loss_transition", "extra", "loss_transition", "rad/s", "transition width w_c of the "
     "whole loss through standstill: the loss torque (input torque minus the lossless one) "
     "and every partial loss times tanh(|w_in|/w_c) (pre-sliding); 0: the losses at full "
     "value at any speed; >= 0", Real)]
ALL_DESIGN_PARAMETERS = DESIGN_PARAMETERS + LATE_DESIGN_PARAMETERS
#: design parameters of the heat balance only (run-time in both FMUs; not in the loss map)
THERMAL_PARAMETERS = ("ambient_temperature", "housing_heat_capacity", "housing_heat_transfer",
                      "housing_area")

#: the design's discovered loss terms ([[extra.discovered]], model_core.discovered) as
#: numbered slots (FMU parameter -> DiscoveredTerm field, unit, description, min, max); a slot
#: whose torque is 0 is empty. Registered after every other variable: the value references of
#: the older ones stay
DISCOVERED_SLOTS = core.discovered.MAX_TERMS
DISCOVERED_PARAMETERS = [
    (f"discovered{k}_{name}", k - 1, field, unit, desc.format(k=k), lo, hi)
    for k in range(1, DISCOVERED_SLOTS + 1)
    for name, field, unit, desc, lo, hi in (
        ("torque", "coefficient", "N.m", "discovered loss term {k}: torque at 300 rad/s and "
         "10 N.m load, sgn(w_in) (|w_in|/300 rad/s)^p (|tau_out|/10 N.m)^q (0: unused)",
         None, None),
        ("speed_exponent", "speed_exponent", "1", "discovered loss term {k}: exponent p of the "
         "driving speed", 0.0, core.discovered.MAX_EXPONENT),
        ("load_exponent", "load_exponent", "1", "discovered loss term {k}: exponent q of the "
         "load torque", 0.0, core.discovered.MAX_EXPONENT))]


def discovered_values(design) -> dict:
    """The discovered slots' parameter values for a design (empty slots 0)."""
    terms = design.extra.discovered
    return {name: float(getattr(terms[k], field)) if k < len(terms) else 0.0
            for name, k, field, *_ in DISCOVERED_PARAMETERS}


#: min/max of the parameters (the modelDescription's; checked at initialization). Lengths,
#: viscosity, density positive; friction coefficients in [0, 1]: above 1 no lubricated steel
#: contact (dry steel on steel is about 0.6-0.8); thermal_loss_change >= -1: the losses cannot
#: fall below zero when warm (that also keeps P_loss >= 0).
PARAMETER_LIMITS = dict(
    z1=(3, None), n_disc_rollers=(3, None), lam=(1.0, None),
    nu_100=(0.0, None),
    **{n: (0.0, None) for n in ("e", "d_v1", "d_o1", "b1", "d_v2", "d_o2", "b2", "d_m2", "D_cz",
                                "D_p", "d_p", "delta_z", "nu", "rho_oil", "pin_roughness",
                                "drag_torque", "stribeck_torque", "input_inertia",
                                "ripple_2x", "ripple_2x_load", "ripple_out_1x",
                                "ripple_out_1x_load", "ripple_out_2x", "ripple_out_2x_load",
                                "stribeck_transition", "thermal_T_scale", "loss_transition")},
    # must be positive: FMI's min is inclusive, so the smallest positive normal double
    **{n: (sys.float_info.min, None) for n in ("stribeck_speed", "thermal_tau")},
    mu_boundary=(0.0, 1.0), mu_rolling=(0.0, 1.0), thermal_loss_change=(-1.0, None),
    mode_number=(0, 6), map_torque_max=(sys.float_info.min, None),
    map_speed_max=(sys.float_info.min, None),
    stribeck_exponent=(1.0, 2.0), run_in_change=(-1.0, None),
    run_in_distance=(sys.float_info.min, None),
    operating_temperature=(0.0, None), mesh_loss_k=(0.0, 0.5), idle_loss_scale=(0.0, 10.0),
    load_loss_scale=(0.0, 10.0),
    # temperatures: the design's valid range, -100 to 200 degC
    ambient_temperature=(173.15, 473.15), T_oil_start=(173.15, 473.15),
    thermal_T_ref=(173.15, 473.15),
    **{n: (sys.float_info.min, None) for n in ("housing_heat_capacity",
                                               "housing_heat_transfer", "housing_area")})
#: [K] the grease temperatures the FMUs accept (input T_oil_in, the heat balance's result):
#: the design's valid range, -100 to 200 degC
T_OIL_RANGE = (173.15, 473.15)

#: partial losses with an output each: the paper's load-dependent ones, then the physical
#: profile's load-independent ones (zero with losses = "load_dependent"); they sum to P_loss
#: less P_extra
OUTPUT_LOSSES = ("PL1", "PL2", "PL3", "PL5", "PL6", "PL_support", "PL_seal", "PL_churn",
                 "PL_mesh")
_LOSS_TEXT = {**core.losses.LOSS_DESCRIPTIONS, **core.drag.IDLE_DESCRIPTIONS,
              core.losses.MESH_LOSS_NAME: core.losses.MESH_LOSS_DESCRIPTION}
#: the design an FMU was built with (``cyclo-fmu build --design``), in its resources next to
#: this package's modules; without it the paper's test drive
DESIGN_FILE = "design.toml"
#: rad/s^2, default of ``alpha_ref``: the bench's regulator ramps the stator frequency at
#: 25 Hz/s, which on the two-pole motor is 2 pi 25 = 157 rad/s^2 of the synchronous speed
ALPHA_REF = 2 * math.pi * 25.0
#: relative change of w_in and tau_out within which a steady step reuses the last J_load
_SLOPE_REUSE = 1e-3


#: default ranges of the loss map (parameters map_torque_max, map_speed_max)
MAP_TORQUE_MAX, MAP_SPEED_MAX = 30.0, 350.0
#: modes whose map for the default design is solved when the FMU is built and shipped in it
#: (the paper's two measured modes, the bench's); any other design, mode or range solves its
#: own at initialization (40-50 ms in a new process, benchmarks/bench_core.py)
SHIPPED_MAP_MODES = ("S1", "S2")
_MAP_DIR = Path(__file__).resolve().parent / "_maps"


def _map_key(design, mode, torque_max, speed_max):
    """What a loss map depends on: the whole design (profile included) but the heat balance's
    parameters, mode and ranges, and the map's layout (a map pickled by another version of the
    core is not used)."""
    plain = core.DriveDesign()
    design = dataclasses.replace(design, **{n: getattr(plain, n) for n in THERMAL_PARAMETERS})
    return (repr(design), mode, float(torque_max), float(speed_max), core.lossmap.MAP_LAYOUT)


def _map_file(mode, temperature):
    """File name of a shipped map: mode and the node's grease temperature [K]."""
    return f"{mode}_{temperature:.2f}K.pkl"


def base_design(folder=None):
    """The design this FMU was built with: ``folder``/DESIGN_FILE if there is one (written by
    ``cyclo-fmu build --design``), else the paper's test drive. Its values are the design
    parameters' start values, and the fields the FMU does not expose as parameters come
    from it."""
    if folder is not None:
        path = Path(folder) / DESIGN_FILE
        if path.is_file():
            return core.design.design_from_toml(path.read_text(encoding="utf-8"))
    return core.DriveDesign()


def write_shipped_maps(folder, modes=SHIPPED_MAP_MODES, design=None):
    """Solve ``design``'s maps (default: the paper's test drive) for ``modes`` and store them
    in ``folder`` (at build)."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    import warnings

    import numpy as np
    design = design or core.DriveDesign()
    for mode in modes:
        # every node over the grease temperature (model_core.thermal.map_temperatures)
        for T in core.thermal.map_temperatures(design):
            node = core.thermal.at_temperature(design, T)
            # quiet as at an FMU's initialization: the map handles the points that do not run
            with warnings.catch_warnings(), np.errstate(all="ignore"):
                warnings.simplefilter("ignore", RuntimeWarning)
                m = core.lossmap.ModeMap(node, mode, MAP_TORQUE_MAX, MAP_SPEED_MAX)
            key = _map_key(node, mode, MAP_TORQUE_MAX, MAP_SPEED_MAX)
            with open(folder / _map_file(mode, T), "wb") as f:
                # the key first, on its own: a design it does not fit reads no table (1 ms)
                pickle.dump(key, f, protocol=pickle.HIGHEST_PROTOCOL)
                pickle.dump(m.__dict__, f, protocol=pickle.HIGHEST_PROTOCOL)


def _shipped_map(key, temperature, folder=_MAP_DIR):
    """The map shipped in ``folder`` for exactly this key (grease at ``temperature`` K), or
    None."""
    path = Path(folder) / _map_file(key[1], temperature)
    if not path.is_file():
        return None
    with open(path, "rb") as f:
        if pickle.load(f) != key:
            return None
        state = pickle.load(f)
    m = core.lossmap.ModeMap.__new__(core.lossmap.ModeMap)
    m.__dict__.update(state)
    return m


class _MapTables:
    """The solved tables of one loss map (a ``ModeMap``'s attributes but its ``out_of_range``
    counter): read-only once solved, so every instance in this process that needs the map of
    the same key (``_map_key``: design, mode, ranges) shares one copy. Each instance's
    ``ModeMap`` holds a reference; when the last one is freed (fmi2FreeInstance) the tables go
    with it (``_TABLES`` holds them weakly)."""
    __slots__ = ("state", "__weakref__")

    def __init__(self, state):
        self.state = state


_TABLES = weakref.WeakValueDictionary()      # map key -> _MapTables, while an instance uses it
_TABLES_LOCK = threading.Lock()              # instances may initialise on different threads


def _shared_map(key, build):
    """A ``ModeMap`` with the tables of ``key``: the ones another live instance holds, else
    ``build()``'s (a shipped map or a solve, outside the lock), shared from then on. Its own
    ``out_of_range`` counter starts at 0."""
    with _TABLES_LOCK:
        tables = _TABLES.get(key)
    if tables is None:
        state = dict(build().__dict__)
        state.pop("out_of_range", None)
        with _TABLES_LOCK:      # another thread may have solved it meanwhile: take the first
            tables = _TABLES.setdefault(key, _MapTables(state))
    m = core.lossmap.ModeMap.__new__(core.lossmap.ModeMap)
    m.__dict__.update(tables.state)
    m.out_of_range = 0
    m._tables_ref = tables            # keeps the shared tables alive while this map lives
    return m


class CycloidDrive(UnitSlave):
    author = "cyclo-fmu"
    description = ("Constrained cycloid drive: load-dependent losses and efficiency "
                   "(Mackic et al.), quasi-static, all six modes and four quadrants")

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        # the design built in (build --design), read from this FMU's own resources (the FMUs
        # of a bench share the first-loaded copy of this package)
        self._base_error = None
        try:
            self._base = default = base_design(self._package_folder())
        except (core.CycloidInputError, OSError) as exc:
            # reported at initialization as fmi2Error (an FMU must not crash its host)
            self._base_error = str(exc)
            self._base = default = core.DriveDesign()
        self.parameter("mode", "S1", None, "operating mode: driving shaft, driven shaft "
                       "(12, 21, 1S, S1, 2S, S2; 1 ring, 2 disc, S eccentric)", String)
        self.parameter("mode_number", 0, None, "the mode as a number for importers that cannot "
                       "set String parameters (fmpy's SSP master): 0 = use mode, 1..6 = 12, 21, "
                       "1S, S1, 2S, S2", Integer, min=0, max=6)
        for name, section, field, unit, desc, kind in DESIGN_PARAMETERS:
            owner = default if section is None else getattr(default, section)
            lo, hi = PARAMETER_LIMITS.get(name, (None, None))
            self.parameter(name, getattr(owner, field), unit, desc, kind, min=lo, max=hi,
                           display="um" if name == "pin_roughness" else None)
        self.parameter("exact", False, None, "solve the full model every step instead of "
                       "interpolating the map built at initialization", Boolean)
        self.parameter("J_out", 0.0, "kg.m2", "inertia on the driven shaft, reflected to the "
                       "driving side's integrator (see J_load)", min=0.0)
        self.parameter("alpha_ref", ALPHA_REF, "rad/s2", "acceleration of the driving shaft "
                       "over which J_load and J_load_dec are secants (the order of the "
                       "accelerations the train sees). Assumption", min=sys.float_info.min)
        self.parameter("map_torque_max", MAP_TORQUE_MAX, "N.m", "largest |tau_out| in the loss map",
                       min=sys.float_info.min)
        self.parameter("map_speed_max", MAP_SPEED_MAX, "rad/s", "largest |w_in| in the loss map",
                       min=sys.float_info.min)
        self.parameter("use_T_oil_input", False, None, "take the grease/housing temperature "
                       "from the input T_oil_in (true) or from the internal lumped heat balance "
                       "(false: C dT/dt = P_loss - (T - ambient_temperature)/R, started at "
                       "T_oil_start)", Boolean)
        self.parameter("T_oil_start", default.operating_temperature, "K", "grease/housing "
                       "temperature at the start of the internal heat balance",
                       min=PARAMETER_LIMITS["T_oil_start"][0],
                       max=PARAMETER_LIMITS["T_oil_start"][1])
        self.input("w_in", 0.0, "rad/s", "speed of the driving shaft")
        self.input("tau_out", 0.0, "N.m", "torque the load applies on the driven shaft")
        self.input("alpha_in", 0.0, "rad/s2", "acceleration of the driving shaft (from its "
                   "integrator's equation of motion); used with J_out")
        self.input("T_oil_in", default.operating_temperature, "K", "grease/housing temperature "
                   "from outside (a measurement, a thermal model); used with use_T_oil_input")
        self.output("w_out", 0.0, "rad/s", "speed of the driven shaft", depends=("w_in",))
        # alpha_in acts through J_out (0 by default); declared, so that the dependencies hold
        # for every parameter value
        both = ("w_in", "tau_out", "alpha_in", "T_oil_in")
        self.output("tau_in", 0.0, "N.m", "torque the driver applies on the driving shaft",
                    depends=both)
        self.output("tau_housing", 0.0, "N.m", "torque the support applies on the held shaft",
                    depends=both)
        self.output("P_loss", 0.0, "W", "total power loss tau_in*w_in + tau_out*w_out - P_stored "
                    "(>= 0)", depends=both)
        for n in OUTPUT_LOSSES[:5]:
            self.output(n, 0.0, "W", f"partial loss {n}: {_LOSS_TEXT[n]}", depends=both)
        self.output("eta", 0.0, "1", "efficiency of the actual power flow (0 without power or "
                    "when locked)", depends=both, quantity="Efficiency", display="%")
        self.output("eta0", 1.0, "1", "basic efficiency (carrier held)", depends=both,
                    quantity="Efficiency", display="%")
        self.output("locked", False, None, "self-locking back-drive holds: the driving shaft "
                    "must push although the load drives", depends=both, kind=Boolean)
        self.output("tau_in_static", 0.0, "N.m", "tau_in without the torque that accelerates "
                    "J_out (for the driving side's integrator)", depends=both)
        self.output("J_load", 0.0, "kg.m2", "J_out as the driving shaft feels it through the "
                    "reducer while it speeds up (|w_in| rising)", depends=both)
        self.output("torque_out", 0.0, "N.m", "torque the driven shaft delivers to the load side, "
                    "J_out's inertial torque included (what a transducer there reads)",
                    depends=both)
        self.output("P_extra", 0.0, "W", "power of the physics beyond the paper (drag, Stribeck, "
                    "inertia, ripple, warm-up) at the driving shaft", depends=both)
        self.output("P_stored", 0.0, "W", "power into stored energy at the driving shaft: "
                    "kinetic energy of input_inertia and the ripples' zero-mean exchange (part "
                    "of P_extra, not a loss)", depends=both)
        for n in OUTPUT_LOSSES[5:8]:     # after the older outputs: their value references stay
            self.output(n, 0.0, "W", f"partial loss {n}: {_LOSS_TEXT[n]}", depends=both)
        self.output("J_load_dec", 0.0, "kg.m2", "J_out as the driving shaft feels it through the "
                    "reducer while it slows down (|w_in| falling)", depends=both)
        self.output("PL_mesh", 0.0, "W", f"partial loss PL_mesh: {_LOSS_TEXT['PL_mesh']}",
                    depends=both)
        for name, _k, _field, unit, desc, lo, hi in DISCOVERED_PARAMETERS:
            self.parameter(name, 0.0, unit, desc, Real, min=lo, max=hi)
        self.output("T_oil", default.operating_temperature, "K", "grease/housing temperature "
                    "(T_oil_in, or the heat balance's); the losses are evaluated at it, or at "
                    "T_oil_start while thermal_loss_change or thermal_loss_per_10K is not 0 (one "
                    "warm-up)",
                    depends=("T_oil_in",))
        self.output("Q_ambient", 0.0, "W", "heat flow from the housing to the ambient "
                    "(T_oil - ambient_temperature)/R", depends=("T_oil_in",))
        for name, section, field, unit, desc, kind in LATE_DESIGN_PARAMETERS:
            lo, hi = PARAMETER_LIMITS.get(name, (None, None))
            self.parameter(name, getattr(getattr(default, section), field), unit, desc, kind,
                           min=lo, max=hi)
        self._T = default.operating_temperature
        self._theta = 0.0
        self._distance = 0.0
        self._slope_key = None
        self._w_last = None
        self._map = None
        self._map_key = None
        self._last_inputs = None
        self._design = None
        self._warm_in_time = False
        self._warned_range = False

    # -- life cycle ---------------------------------------------------------------------------
    def _build_design(self):
        changes, lub, fr, ex, cal = {}, {}, {}, {}, {}
        for name, section, field, unit, desc, kind in ALL_DESIGN_PARAMETERS:
            v = getattr(self, name)
            {None: changes, "lubricant": lub, "friction": fr, "extra": ex,
             "calibration": cal}[section][field] = v
        base = self._base
        if fr["rolling_ring"] != base.friction.rolling_ring:   # one parameter sets both
            fr["rolling_disc"] = fr["rolling_ring"]
        slots = [{} for _ in range(DISCOVERED_SLOTS)]
        for name, k, field, *_ in DISCOVERED_PARAMETERS:
            slots[k][field] = float(getattr(self, name))
        ex["discovered"] = tuple(core.discovered.DiscoveredTerm(**x) for x in slots
                                 if x["coefficient"] != 0.0)
        return dataclasses.replace(base, lubricant=dataclasses.replace(base.lubricant, **lub),
                                   friction=dataclasses.replace(base.friction, **fr),
                                   extra=dataclasses.replace(base.extra, **ex),
                                   calibration=dataclasses.replace(base.calibration, **cal),
                                   **changes)

    def _package_folder(self):
        """This FMU's copy of the slaves' package under its resources, or None."""
        if self.resources:
            folder = Path(self.resources) / __package__
            if folder.is_dir():
                return folder
        return None

    def _map_folder(self):
        """This FMU's shipped maps: under its own resources (the FMUs of a bench share the
        first-loaded copy of this package, whose folder may belong to another FMU)."""
        pkg = self._package_folder()
        if pkg is not None and (pkg / "_maps").is_dir():
            return pkg / "_maps"
        return _MAP_DIR

    #: the dynamic state besides the variables (fmi2GetFMUstate)
    state_attributes = ("_theta", "_distance", "_w_last", "_slope_key", "_last_inputs",
                        "_warned_range", "_T")

    #: no step yet in Initialization Mode: no acceleration, no warm-up
    init_independent = ("input_inertia", "thermal_loss_change", "thermal_tau")

    def _setup(self):
        try:
            if self._base_error:
                raise core.CycloidInputError(DESIGN_FILE, "(built in)", self._base_error)
            self.check_limits()
            mode = self.mode
            if self.mode_number:
                if not 1 <= self.mode_number <= 6:
                    raise core.CycloidInputError("mode_number", self.mode_number,
                                                 "must be 0 (use mode) or 1..6")
                mode = core.MODES[self.mode_number - 1]
            a, b, h = core.kinematics.parse_mode(mode)
            self._mode = a + b
            idx = {"1": 0, "2": 1, "S": 2}
            self._shaft_index = (idx[a], idx[b], idx[h])
            self._design = self._build_design()
            theta = self._design.extra.thermal_T_scale
            if not (theta == 0.0 or core.thermal.T_SCALE_MIN <= theta < math.inf):
                raise core.CycloidInputError("thermal_T_scale", theta, "must be 0 (the linear "
                                             "law) or at least "
                                             f"{core.thermal.T_SCALE_MIN:g} K")
            for name in ("map_torque_max", "map_speed_max"):
                v = getattr(self, name)
                if not (math.isfinite(v) and v > 0):
                    raise core.CycloidInputError(name, v, "must be a positive number")
            if not (math.isfinite(self.J_out) and self.J_out >= 0):
                raise core.CycloidInputError("J_out", self.J_out, "must not be negative")
            if not (math.isfinite(self.alpha_ref) and self.alpha_ref > 0):
                raise core.CycloidInputError("alpha_ref", self.alpha_ref, "must be positive")
            # the map depends on design, mode and ranges only: solved once for them (Initialization
            # Mode's reads and the exit validate the same parameters again)
            map_key = _map_key(self._design, self._mode, self.map_torque_max,
                               self.map_speed_max)
            if self.exact:
                self._map = None
            elif self._map is None or self._map_key != map_key:
                folder = self._map_folder()
                tmax, smax, mode = self.map_torque_max, self.map_speed_max, self._mode

                def node(design_T):
                    # a node over the grease temperature: shipped, or solved now (the one at
                    # the operating temperature here, the others at the first step that
                    # needs them). No mallopt here: an FMU must not change the host's
                    # allocator (the map solves 10-20 % slower with glibc's default
                    # thresholds early in a process; docs/explanation/fmu-safety.md)
                    # The tables are shared with the other instances of this process that
                    # use the same map (_shared_map).
                    key = _map_key(design_T, mode, tmax, smax)

                    def build():
                        m = _shipped_map(key, design_T.operating_temperature, folder)
                        return m if m is not None else core.lossmap.ModeMap(design_T, mode,
                                                                            tmax, smax)
                    return _shared_map(key, build)
                self._map = core.lossmap.ThermalMap(self._design, mode, tmax, smax, node)
                self._map_key = map_key
            self._dependent = core.thermal.temperature_dependent(self._design)
            # one warm-up: a warm-up in time holds the losses at the start's temperature
            self._warm_in_time = bool(self._design.extra.thermal_loss_change
                                      or self._design.extra.thermal_loss_per_10K)
            self._R = core.thermal.housing_resistance(self._design)
            ex = self._design.extra
            self._steady_extra = bool(ex.drag_torque or ex.stribeck_torque)
            self._discovered = bool(ex.discovered)
            self._transition = bool(ex.loss_transition)
            self._dynamic_extra = bool(ex.input_inertia or ex.has_ripple
                                       or ex.run_in_change
                                       or ex.thermal_loss_change
                                       or ex.thermal_loss_per_10K)
            unit = core.shaft_speeds(self._mode, 1.0, self._design.z1)
            self._ratio_out = float(unit[b])
            self._shaft_ripple = any(getattr(ex, f) or getattr(ex, f + "_load")
                                     for f, _, _ in core.design.SHAFT_ORDER_RIPPLES)
            # roller pass: z1 per turn of the ring relative to the carrier, per driving turn
            self._order = self._design.z1 * abs(float(unit["1"] - unit["S"])) / abs(float(unit[a]))
        except (core.CycloidInputError, TypeError, ValueError) as exc:
            self.fail(f"invalid parameter: {exc}")
        self._theta, self._w_last, self._slope_key = 0.0, None, None
        self._distance = 0.0
        self._last_inputs = None
        self._T = self.T_oil_start

    def _evaluate_init(self):
        if self._in_init:   # a read in Initialization Mode: commit no dynamic state
            saved = self._theta, self._w_last, self._distance, self._T
            try:
                self._update()
            finally:
                self._theta, self._w_last, self._distance, self._T = saved
        else:               # fmi2ExitInitializationMode: the state starts here
            self._update()

    def do_step(self, current_time, step_size):
        self._update(current_time + step_size, step_size)
        return True

    # -- physics ------------------------------------------------------------------------------
    def _temperature(self, t, dt, w_in, tau_ext, alpha):
        """The grease temperature at the end of the step [K]: the input, or the heat balance
        stepped from the last one with the loss at the step's start held over the step
        (thermal.housing_step): the loss of the step's inputs (held by the master over the step)
        at the temperature of the step's start."""
        if self.use_T_oil_input:
            T = self.T_oil_in
            if not (isinstance(T, (int, float)) and T_OIL_RANGE[0] < T < T_OIL_RANGE[1]):
                self.fail(f"T_oil_in = {T!r} K: must be a temperature between "
                          f"{T_OIL_RANGE[0]} and {T_OIL_RANGE[1]} K (-100 to 200 degC)")
        elif dt > 0:
            d = self._design
            P0 = self._loss_at_start(t - dt, w_in, tau_ext, alpha)
            T = core.thermal.housing_step(self._T, P0, dt, d.ambient_temperature,
                                          d.housing_heat_capacity, self._R)
            if not T_OIL_RANGE[0] < T < T_OIL_RANGE[1]:
                self.fail(f"the heat balance's grease temperature {T!r} K left -100 to 200 "
                          f"degC (loss {P0!r} W, R = {self._R:.4g} K/W): refused")
        else:
            T = self._T
        self._T = T
        self.T_oil = T
        self.Q_ambient = core.thermal.heat_to_ambient(T, self._design.ambient_temperature,
                                                      self._R)
        return T

    def _loss_at_start(self, t0, w_in, tau_ext, alpha):
        """P_loss [W] at the step's start t0: the step's inputs at the present temperature,
        without a step of the dynamic terms (no acceleration from a step, no angle advanced);
        the outputs are computed again for the step's end."""
        if (not self._dependent and not self._dynamic_extra
                and self._last_inputs == (w_in, tau_ext, alpha, None)):
            return self.P_loss      # the same inputs, and the losses do not depend on T
        saved = self._theta, self._w_last, self._distance
        try:
            self._update_at(t0, 0.0, w_in, tau_ext - self.J_out * self._ratio_out * alpha)
            return self.P_loss
        finally:
            self._theta, self._w_last, self._distance = saved

    def _update(self, t=0.0, dt=0.0):
        w_in, tau_ext, alpha = self.w_in, self.tau_out, self.alpha_in
        if not (math.isfinite(w_in) and math.isfinite(tau_ext) and math.isfinite(alpha)):
            self.require_finite(w_in=w_in, tau_out=tau_ext, alpha_in=alpha)
        T = self._temperature(t, dt, w_in, tau_ext, alpha)
        # the temperature counts where the losses depend on it (physical profile)
        inputs = (w_in, tau_ext, alpha, self._loss_T() if self._dependent else None)
        if inputs == self._last_inputs:
            # the same inputs as the last step, bit for bit (a steady state: 88 % of the
            # paper scenario's steps), and no time-dependent physics: the outputs stand
            return
        self._last_inputs = None
        self._solve(t, dt, w_in, tau_ext, alpha)
        if not self._dynamic_extra:
            self._last_inputs = inputs

    def _solve(self, t, dt, w_in, tau_ext, alpha):
        J_r = self.J_out * self._ratio_out
        tau_out = tau_ext - J_r * alpha          # the load including the output inertia
        self._update_at(t, dt, w_in, tau_out)
        self.torque_out = -tau_out
        if J_r == 0.0:
            self.tau_in_static, self.J_load, self.J_load_dec = self.tau_in, 0.0, 0.0
            return
        gear = self._tau_in_gear
        # exact, not gear less a slope times alpha: the map's curvature would then feed the
        # acceleration back into the integrator's torque (an oscillation at the step rate)
        static = self._gear_torque(w_in, tau_ext)
        # the driving torque as a function of the driving shaft's acceleration a, for the
        # integrator: tau_in_static + J_load a while the shaft speeds up (a w > 0), + J_load_dec
        # a while it slows down (a w < 0: the load's inertia back-drives); the slopes are
        # secants over +-alpha_ref, the order of the accelerations the train sees, so that
        # they depend on the operating point only: the efficiency's kink (forward against
        # back-driven) lies between the two sides, and the integrator picks the side at each
        # of its sub-steps. A secant over the present acceleration would feed the acceleration
        # back into the slope one step late (a two-step oscillation after every kink)
        key = self._slope_key
        if (key is not None and abs(w_in - key[0]) <= _SLOPE_REUSE * abs(key[0])
                and abs(tau_ext - key[1]) <= _SLOPE_REUSE * abs(key[1])):
            J_acc, J_dec = key[2], key[3]   # steady: the slopes of the last step still hold
        else:
            A = self.alpha_ref if w_in >= 0 else -self.alpha_ref    # speeding up
            J_acc = (self._gear_torque(w_in, tau_ext - J_r * A) - static) / A
            J_dec = (static - self._gear_torque(w_in, tau_ext + J_r * A)) / A
            lossless = J_r * self._ratio_out
            # standstill in the exact core, or locked: the lossless reflection
            J_acc = J_acc if (math.isfinite(J_acc) and J_acc > 0) else lossless
            J_dec = J_dec if (math.isfinite(J_dec) and J_dec > 0) else lossless
            self._slope_key = (w_in, tau_ext, J_acc, J_dec)
        self.J_load, self.J_load_dec = J_acc, J_dec
        self.tau_in_static = self.tau_in - (gear - static)

    def _gear_torque(self, w_in, tau_out):
        """Driving-shaft torque of the gear alone (map or exact core) at a load torque, its
        losses through standstill scaled as ``_update_at`` scales them."""
        gear = self._gear_torque_full(w_in, tau_out)
        if not self._transition:
            return gear
        lossless = -tau_out * self._ratio_out
        return lossless + float(self._design.extra.loss_transition_share(w_in)) * (gear - lossless)

    def _gear_torque_full(self, w_in, tau_out):
        if self._map is not None:
            return self._map.solve(w_in, tau_out, self._loss_T())[1][self._shaft_index[0]]
        if w_in == 0:
            return 0.0
        op = core.operating_point(self._design_at_T(), self._mode, w_in, T_out=tau_out)
        return float(op.torques[self._mode[0]]) - float(self._design.extra.steady_torque(w_in))

    def _update_at(self, t, dt, w_in, tau_out):
        if self._map is not None:
            speeds, torques, losses, eta, eta0, locked, forward = self._map.solve(
                w_in, tau_out, self._loss_T())
            # below the grid (|w_in| < map_speed_max/1000: start-up, standstill) the edge values
            # are the physics' own limit, not a lack of range: warn only beyond the maxima
            if (not self._warned_range and (abs(tau_out) > self.map_torque_max
                                            or abs(w_in) > self.map_speed_max)):
                self._warned_range = True
                self.log(f"operating point outside the loss map (|tau_out| <= "
                         f"{self.map_torque_max} N.m, |w_in| <= {self.map_speed_max} rad/s): "
                         "clamped to its edge; raise map_torque_max/map_speed_max",
                         Fmi2Status.warning, "logStatusWarning")
            ia, ib, ih = self._shaft_index
            self.w_out = speeds[ib]
            self.tau_in = self._tau_in_gear = torques[ia]
            self.tau_housing = torques[ih]
            for n, v in zip(OUTPUT_LOSSES, losses):
                setattr(self, n, v)
            if self._steady_extra:
                self.tau_in += float(self._design.extra.steady_torque(w_in))
        else:
            speeds, torques, losses, eta, eta0, locked = self._exact(w_in, tau_out)
        if self._transition:
            # the losses through standstill (ExtraPhysics.loss_transition_share, the one
            # formula): the gear's loss torque beyond the lossless one and every partial loss
            # times tanh(|w_in|/w_c), as the native FMU and the replay scale them
            share = float(self._design.extra.loss_transition_share(w_in))
            change = (share - 1.0) * (self._tau_in_gear + tau_out * self._ratio_out)
            self._tau_in_gear += change
            self.tau_in += change
            for n in OUTPUT_LOSSES:
                setattr(self, n, share * getattr(self, n))
        if self._discovered:     # design [[extra.discovered]] (model_core.discovered)
            self.tau_in += float(self._design.extra.discovered_torque(w_in, tau_out))
        self.P_stored = 0.0
        self._inertia_torque = 0.0
        if self._dynamic_extra:
            self.tau_in += self._dynamic_torque(t, dt, w_in, tau_out)
            if self._design.extra.run_in_change:     # after it, as the native FMU adds it
                self.tau_in += self._run_in
            if self._design.extra.thermal_loss_per_10K:   # after it, as the native FMU
                self.tau_in += self._per_10K
        self.P_extra = (self.tau_in - self._tau_in_gear) * w_in
        self.P_loss = self.tau_in * w_in + tau_out * self.w_out - self.P_stored
        # the support takes what the shafts do not: the gear's reaction and the drag of
        # bearings, seals and grease (they act between shafts and housing), so that
        # tau_in + tau_out + tau_housing = input_inertia * alpha (0 without it)
        self.tau_housing = -(self.tau_in - self._inertia_torque + tau_out)
        if not (math.isfinite(self.P_loss) and math.isfinite(self.tau_housing)):
            self.fail(f"w_in = {w_in!r} rad/s, tau_out = {tau_out!r} N.m give outputs that "
                      "are not finite numbers (inputs far beyond any drive): refused")
        if self._steady_extra or self._dynamic_extra or self._discovered or self._transition:
            p_in = max(self.tau_in * w_in, tau_out * self.w_out)
            p_out = -min(self.tau_in * w_in, tau_out * self.w_out)
            eta = p_out / p_in if (p_in > 0 and p_out > 0 and not locked) else 0.0
        self.eta, self.eta0, self.locked = eta, eta0, locked

    def _dynamic_torque(self, t, dt, w_in, tau_out):
        """Inertia, ripple and warm-up terms at the driving shaft (design.extra)."""
        alpha = 0.0 if (self._w_last is None or dt <= 0) else (w_in - self._w_last) / dt
        if dt > 0:
            self._theta += w_in * dt
            self._distance += abs(w_in) * dt
            self._w_last = w_in
        elif self._w_last is None:
            self._w_last = w_in
        loss_in = self._tau_in_gear + tau_out * self._ratio_out   # minus the lossless torque
        ex = self._design.extra
        torque = float(ex.dynamic_torque(alpha, self._theta, self._order, t, loss_in))
        # the run-in scales the gear's load-dependent losses PL1..PL6 alone (its outputs, set
        # by _update_at before this call), not the idle ones
        self._run_in = float(ex.run_in_torque(self._distance, core.lossmap.load_loss_torque(
            self.PL1 + self.PL2 + self.PL3 + self.PL5 + self.PL6, w_in))) \
            if ex.run_in_change else 0.0
        # the per-10 K loss change at the grease temperature T_oil (the losses themselves held
        # at T_oil_start: one warm-up)
        self._per_10K = float(ex.thermal_per_10K_torque(self._T, loss_in))
        # the conservative part: d/dt of J w^2/2 and of the ripples' potentials
        # -A cos(theta + phi) - A_z/z cos(z theta + phi_z), each times w = dtheta/dt
        stored = float(ex.dynamic_torque(alpha, self._theta, self._order, 0.0, 0.0))
        self._inertia_torque = ex.input_inertia * alpha
        if ex.ripple_1x_load or ex.ripple_roller_load:   # zero-mean at a held load: stored
            ripple = float(ex.load_ripple_torque(self._theta, self._order, tau_out))
            torque = torque + ripple
            stored = stored + ripple
        if self._shaft_ripple:      # 2x, output 1x and 2x: zero-mean at a held load: stored
            ripple = float(ex.shaft_order_ripple_torque(self._theta, self._ratio_out, tau_out))
            torque = torque + ripple
            stored = stored + ripple
        self.P_stored = stored * w_in
        return torque

    def _design_at_T(self):
        """The design with its grease at the present temperature (physical profile)."""
        T = self._loss_T()
        if not self._dependent or T == self._design.operating_temperature:
            return self._design
        return core.thermal.at_temperature(self._design, T)

    def _loss_T(self):
        """The grease temperature the losses are evaluated at [K]: the present one, or, with a
        warm-up in the design (``thermal_loss_change`` in time, ``thermal_loss_per_10K`` per
        10 K of T_oil), the start's ``T_oil_start``. A warm-up was fitted against the model
        held at one temperature, so it holds the model's own temperature physics already: the
        losses following the heat balance (or the input) as well would count that warm-up
        twice. T_oil and Q_ambient still follow the heat balance or the input (docs/explanation/thermal.md, "One warm-up")."""
        return self.T_oil_start if self._warm_in_time else self._T

    def _exact(self, w_in, tau_out):
        a, b = self._mode[0], self._mode[1]
        h = _held(self._mode)
        w = core.shaft_speeds(self._mode, w_in, self._design.z1)
        self.w_out = float(w[b])
        if w_in == 0:   # standstill: no direction of motion, no drag, no loss
            self.tau_in = self.tau_housing = self._tau_in_gear = 0.0
            for n in OUTPUT_LOSSES:
                setattr(self, n, 0.0)
            return None, None, None, 0.0, 1.0, False
        op = core.operating_point(self._design_at_T(), self._mode, w_in, T_out=tau_out)
        self.tau_in = float(op.torques[a])
        self._tau_in_gear = self.tau_in - float(self._design.extra.steady_torque(w_in))
        self.tau_housing = float(op.torques[h])
        for n in OUTPUT_LOSSES:
            setattr(self, n, float(getattr(op.losses, n)))
        eta = 0.0 if (op.locked or not math.isfinite(float(op.eta))) else float(op.eta)
        # same reporting as the map: ``eta`` 0 when locked or without power
        return None, None, None, eta, float(op.eta0), bool(op.locked)


def _held(mode):
    return next(s for s in "12S" if s not in mode)
