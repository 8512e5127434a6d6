"""Design data of the constrained cycloid drive: geometry, lubricant and friction settings.

All values are SI inside (m, Pa, kg/m^3, m^2/s). Design files (TOML) use mm and mm^2/s, the
units of drawings and data sheets; the conversion happens once, in :func:`design_from_toml`
and :func:`design_to_toml`.

The default is the paper's test drive (Table 3 of Mackic et al.). Values the paper does not
give are marked **assumption** in the field documentation below, with the reason.
"""
from __future__ import annotations

import dataclasses
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from .errors import CycloidInputError
from . import geometry

ROLLER_KINDS = ("plain", "needle")
PROFILE_MODIFICATIONS = ("equidistant", "offset")
DISC_PIN_SLIDING = ("paper", "kinematic")
CONTACT_LAWS = ("hertz", "linear")
#: Shaft seals: radial lip seals on the rotating shafts (model_core.drag PL_seal) or none
SEAL_KINDS = ("lip", "none")
#: Model profiles: "paper" computes what the paper computed (Eq. 24 as printed, Benedict-Kelley
#: at its boundary clamp mu_boundary calibrated to the paper's theory, frictionless contact
#: forces, load-dependent losses only); "physical" the kinematically correct model with roll or
#: skid, a live Stribeck pin law, friction in the force balance and, with losses = "all", the
#: load-independent losses (README, Physics).
PROFILES = ("paper", "physical")
#: Which losses enter: "load_dependent" (the paper's model) or "all" (adds the
#: load-independent drag, seal, support-bearing and churning losses of model_core.drag).
LOSS_SCOPES = ("load_dependent", "all")
#: Fields of DriveDesign that live in the design file's [model] section.
MODEL_FIELDS = ("profile", "losses", "temperature_model", "ambient_temperature",
                "operating_temperature", "housing_heat_capacity", "housing_heat_transfer",
                "housing_area")
#: How the grease temperature is found: from the housing's steady heat balance, or fixed.
TEMPERATURE_MODELS = ("heat_balance", "fixed")
KELVIN = 273.15   # degC at the design-file edge: T[K] = T[degC] + 273.15
#: Combined convection and radiation coefficient of the housing [W/(m^2 K)]. **Assumption**:
#: 15, still air around a small painted housing (ISO/TR 14179-2 gives about 10-20 for natural
#: convection plus radiation).
HOUSING_HEAT_TRANSFER = 15.0
#: Radiating and convecting surface of the housing [m^2]. **Assumption**: a 130 mm x 80 mm
#: cylinder (the paper's drive: ring rollers on a 96 mm pitch circle), 2 pi r^2 + pi d l.
HOUSING_AREA = 2 * math.pi * 0.065 ** 2 + math.pi * 0.13 * 0.08
#: Heat capacity of the housing with everything in it [J/K]. **Assumption**: 2000, about 4 kg
#: of steel and cast iron (c = 460 J/(kg K): 1840 J/K; the 130 mm x 80 mm drive's housing,
#: ring, gears, discs and shafts) and 0.08 kg of grease (c = 2000 J/(kg K): 160 J/K).
HOUSING_HEAT_CAPACITY = 2000.0


def _f(default, unit, doc, toml_unit=None, scale=1.0):
    """A dataclass field carrying its SI unit, its design-file unit and its documentation."""
    return field(default=default, metadata={"unit": unit, "toml_unit": toml_unit or unit,
                                            "scale": scale, "doc": doc})


MM = 1e-3       # design files give lengths in mm
UM = 1e-6       # roughness in micrometres
MM2_S = 1e-6    # kinematic viscosity in mm^2/s


@dataclass(frozen=True)
class Lubricant:
    """The grease. Paper: lithium-complex NLGI 2 grease (KP2PN-20), nu = 200 mm^2/s."""

    kinematic_viscosity: float = _f(200e-6, "m^2/s", "Base-oil kinematic viscosity [paper, Table 3].",
                                    "mm^2/s", MM2_S)
    kinematic_viscosity_100: float = _f(17.5e-6, "m^2/s",
                                        "Base-oil kinematic viscosity at 100 degC (the "
                                        "kinematic_viscosity above is taken at 40 degC) for the "
                                        "Walther/ASTM D341 viscosity-temperature line "
                                        "(model_core.thermal). **Assumption**: 17.5 mm^2/s, a "
                                        "mineral oil of 200 mm^2/s at 40 degC with viscosity "
                                        "index 95 (ASTM D2270 tables); the paper gives none.",
                                        "mm^2/s", MM2_S)
    density: float = _f(900.0, "kg/m^3",
                        "Base-oil density. **Assumption**: 900 kg/m^3, typical mineral base oil "
                        "at 40 C; the paper gives none. Only the product rho*nu (dynamic viscosity) "
                        "enters, in the Benedict-Kelley coefficient.")

    @property
    def dynamic_viscosity(self) -> float:
        """Dynamic viscosity eta = rho * nu in Pa*s."""
        return self.density * self.kinematic_viscosity


@dataclass(frozen=True)
class Friction:
    """Friction settings of the contacts.

    Sliding contacts (roller bore on its pin, when the roller set is "plain") use the
    Benedict-Kelley mixed-lubrication coefficient, bounded between ``mu_full_film`` and
    ``mu_boundary``. Rolling contacts (roller on the cycloid tooth, disc roller in its hole) use a
    rolling-resistance coefficient (rolling-resistance force per normal force). Rolling bearings
    (the eccentric bearing; rollers of kind "needle") use the SKF 2014 frictional-moment model,
    load-dependent terms only, as the paper states.
    """

    mu_boundary: float = _f(0.0906, "1",
                            "Boundary-lubrication friction coefficient of the sliding contacts, the "
                            "upper clamp of the Benedict-Kelley coefficient. **Calibrated**: 0.0906 "
                            "makes the default design's mean S1 efficiency over the bench envelope "
                            "equal the paper's theory mean 65.25 % "
                            "(model_core.paper.calibrate_mu_boundary); it lies at the low end of "
                            "the 0.08-0.15 range of greased steel on steel.")
    mu_full_film: float = _f(0.01, "1",
                             "Lower clamp of the Benedict-Kelley coefficient where its logarithm "
                             "turns negative (full film). **Assumption**: 0.01.")
    pin_roughness: float = _f(1.915e-6, "m",
                              "Composite roughness Ra of pin and roller bore. **Assumption**: the "
                              "paper measured no pins; we combine its Table 3 values by its Eq. (30), "
                              "sqrt(1.263^2 + 1.439^2) = 1.915 um = 75 uin. That lies beyond the "
                              "pole (50 uin) of the Benedict-Kelley roughness factor: surfaces this "
                              "rough run in boundary lubrication, so the sliding coefficient is "
                              "mu_boundary. Smoother pins (below 1.27 um) enter the mixed regime.",
                              "um", UM)
    rolling_ring: float = _f(0.002, "1",
                             "Rolling-resistance coefficient mu_r5 of ring roller on cycloid tooth "
                             "(Eq. 26). **Assumption**: 0.002, lubricated steel line contact "
                             "(0.001-0.003 in handbooks).")
    rolling_disc: float = _f(0.002, "1",
                             "Rolling-resistance coefficient mu_r2 of disc roller in its hole "
                             "(Eq. 23). **Assumption**: 0.002, as mu_r5.")
    skf_R1: float = _f(1.09e-6, "1", "SKF rolling-frictional-moment constant R1 (cylindrical/needle "
                       "roller bearings). **Assumption**: needle bearings are treated as "
                       "cylindrical roller bearings, which the SKF table covers.")
    skf_S1: float = _f(0.16, "1", "SKF sliding-frictional-moment constant S1 (cylindrical roller).")
    skf_S2: float = _f(0.0015, "1", "SKF sliding-frictional-moment constant S2 (cylindrical roller).")
    skf_Krs: float = _f(6e-8, "1", "SKF replenishment/starvation constant K_rs for grease.")
    skf_Kz: float = _f(5.1, "1", "SKF bearing-type constant K_Z (cylindrical roller bearings).")
    skf_mu_bl: float = _f(0.15, "1", "SKF boundary sliding coefficient mu_bl (cylindrical roller).")
    skf_mu_ehl: float = _f(0.02, "1", "SKF full-film sliding coefficient mu_EHL (cylindrical roller).")
    # -- physical profile (model_core.friction.stribeck_pin_mu, roll_or_skid) ------------------
    mu_pin_boundary: float = _f(0.12, "1",
                                "Boundary friction coefficient of a roller bore on its greased steel "
                                "pin (physical profile, the Stribeck law's low-Hersey limit). "
                                "**Assumption**: 0.12, the middle of 0.08-0.15 for boundary-"
                                "lubricated (greased) steel on steel (Bhushan, Introduction to "
                                "Tribology, 2nd ed. 2013, Table 9.1; Stachowiak & Batchelor, "
                                "Engineering Tribology, 4th ed., ch. 8).")
    hersey_transition: float = _f(1.7e-6, "1",
                                  "Hersey number eta*N/p (eta Pa*s, N rev/s, p Pa) at which the pin "
                                  "contact leaves boundary lubrication (Stribeck law). "
                                  "**Assumption**: 1.7e-6, the thick-film limit of McKee's journal "
                                  "tests (Shigley's Mechanical Engineering Design, 10th ed., "
                                  "Sec. 12-3, Fig. 12-4).")
    pin_clearance_ratio: float = _f(2e-3, "1",
                                    "Radial clearance over pin radius c/r of a plain roller on its "
                                    "pin (Petroff term of the Stribeck law). **Assumption**: 0.002, "
                                    "the usual journal clearance ratio 0.001-0.002 (Shigley, "
                                    "Sec. 12-8) at its loose end.")
    mu_tooth: float = _f(0.06, "1",
                         "Traction (sliding) coefficient of a plain roller on the cycloid tooth or "
                         "of a disc roller in its hole, greased steel line contact in mixed/EHL "
                         "lubrication (physical profile: limits the traction that turns the "
                         "roller, and the coefficient of its sliding when it skids). "
                         "**Assumption**: 0.06, inside 0.02-0.10 for lubricated steel rolling-"
                         "sliding line contacts (Johnson, Contact Mechanics, 1985, Sec. 9.3; "
                         "Harris & Kotzalas, Rolling Bearing Analysis, 5th ed., ch. 10).")


#: the mesh ripple's shaft orders beyond the driving shaft's 1x and the roller pass
#: (ExtraPhysics.shaft_order_ripple_torque): (field prefix, k_in, k_out), the order of the
#: driving shaft's angle theta k = k_in + k_out r with r = w_out/w_in of the mode: 2x the
#: driving shaft, 1x and 2x the driven shaft. Each field has ``_phase``, ``_load`` and
#: ``_load_phase`` companions
SHAFT_ORDER_RIPPLES = (("ripple_2x", 2.0, 0.0), ("ripple_out_1x", 0.0, 1.0),
                       ("ripple_out_2x", 0.0, 2.0))


@dataclass(frozen=True)
class ExtraPhysics:
    """Physics beyond the paper's load-dependent losses, switched on by a diagnosis
    (model_core.effects). All zero by default: the paper's model. Torques act at the driving
    shaft (the eccentric shaft on the bench), in the sense of its motion."""

    drag_torque: float = _f(0.0, "N*m", "load-independent drag at 300 rad/s of the driving "
                            "shaft, growing as (speed)^(2/3) (churning, seals, bearing drag)")
    drag_exponent: float = _f(2.0 / 3.0, "1", "exponent p of the drag's speed law "
                              "T_drag (|w|/300 rad/s)^p: 2/3 churning, 0 seals, 1 viscous, "
                              "2 windage (0 to 2)")
    stribeck_torque: float = _f(0.0, "N*m", "extra friction at standstill of the driving shaft, "
                                "decaying as exp(-(|w|/w_s)^delta)")
    stribeck_speed: float = _f(40.0, "rad/s", "Stribeck speed w_s")
    input_inertia: float = _f(0.0, "kg*m^2", "unmodelled inertia at the driving shaft "
                              "(dynamic: FMU and bench only)")
    ripple_1x: float = _f(0.0, "N*m", "torque ripple amplitude at 1x the driving speed (dynamic)")
    ripple_1x_phase: float = _f(0.0, "rad", "phase of the 1x ripple (sin(theta + phase))")
    ripple_roller: float = _f(0.0, "N*m", "torque ripple amplitude at the roller-pass order "
                              "(dynamic)")
    ripple_roller_phase: float = _f(0.0, "rad", "phase of the roller-pass ripple")
    thermal_loss_change: float = _f(0.0, "1", "relative change of the losses when warm (dynamic)")
    thermal_tau: float = _f(300.0, "s", "warm-up time constant")
    # -- the warm-up per 10 K (reducer FMUs), the diagnosis's replay only (REPLAY_ONLY) and
    # the bench's transducers --------------------------------------------------------------
    thermal_loss_per_10K: float = _f(0.0, "1", "relative change of the losses per 10 K of the "
                                     "grease temperature from thermal_T_ref, against the "
                                     "model held at one temperature (reducer FMUs: their "
                                     "T_oil, the losses held at T_oil_start, one warm-up; the "
                                     "replay: the recording's temperature column)")
    thermal_T_ref: float = _f(293.15, "K", "temperature the per-10 K loss change is referred "
                              "to: the diagnosis writes the temperature column's first value; "
                              "the default 20 degC (room temperature) is an assumption for a "
                              "design that states none", "degC", None)
    viscosity_ln_change: float = _f(0.0, "1", "change of ln(viscosity) when warm, acting through "
                                    "the model's viscosity sensitivity (replay only)")
    viscosity_tau: float = _f(300.0, "s", "time constant of the viscosity drift (replay only)")
    viscosity_ln_per_10K: float = _f(0.0, "1", "change of ln(viscosity) per 10 K of the "
                                     "recording's temperature column (replay only)")
    torque_in_offset: float = _f(0.0, "N*m", "zero offset of the input torque transducer a "
                                 "diagnosis found (not physics of the drive: the replay "
                                 "corrects the reading, the bench's input torque transducer "
                                 "FMU reads with it)")
    torque_in_gain_error: float = _f(0.0, "1", "gain error of the input torque transducer a "
                                     "diagnosis found (the replay corrects the reading, the "
                                     "bench's transducer FMU reads with it)")
    torque_in_zero_drift: float = _f(0.0, "N*m", "drift of the input torque transducer's zero "
                                     "when warm, first order in time, a diagnosis found (the "
                                     "replay corrects the reading, the bench's transducer FMU "
                                     "reads with it)")
    torque_in_zero_tau: float = _f(300.0, "s", "time constant of the zero's drift")
    torque_in_zero_per_10K: float = _f(0.0, "N*m", "drift of the input torque transducer's zero "
                                       "per 10 K of its temperature from "
                                       "torque_in_zero_T_ref, a diagnosis found (the replay "
                                       "corrects the reading at the recording's temperature "
                                       "column; the bench's transducer FMU reads with it at "
                                       "its temperature input, fed the reducer's T_oil)")
    torque_in_zero_T_ref: float = _f(293.15, "K", "temperature at which the input torque "
                                     "transducer's zero is right, the reference of "
                                     "torque_in_zero_per_10K: the diagnosis writes the "
                                     "temperature column's first value; the default 20 degC "
                                     "(room temperature, where transducers are zeroed) is an "
                                     "assumption for a design that states none", "degC", None)

    discovered: tuple = _f((), "-", "discovered loss terms (model_core.discovered."
                           "DiscoveredTerm): a sparse sum of power laws in driving speed and "
                           "load a diagnosis fitted to a mismatch outside the library; the "
                           "design file's [[extra.discovered]] tables")

    run_in_change: float = _f(0.0, "1", "excess of the load-dependent losses (the gear's "
                              "PL1..PL6, the friction of its sliding and rolling contacts; not "
                              "the idle losses of seals, bearings' drag and churning) of a "
                              "drive that runs in, relative, at the start; it decays with the "
                              "sliding distance, exp(-distance/run_in_distance) (no "
                              "temperature needed; dynamic)")
    run_in_distance: float = _f(1e4, "rad", "distance (angle travelled by the driving shaft) over "
                                "which the run-in excess decays by 1/e")
    ripple_1x_load: float = _f(0.0, "N*m", "part of the 1x ripple's amplitude that grows with "
                               "the load: amplitude at 10 N*m of |tau_out|, in proportion "
                               "(transmission error times mesh stiffness; dynamic)")
    ripple_1x_load_phase: float = _f(0.0, "rad", "phase of the load-scaled 1x ripple")
    ripple_roller_load: float = _f(0.0, "N*m", "part of the roller-pass ripple's amplitude that "
                                   "grows with the load: amplitude at 10 N*m of |tau_out| "
                                   "(dynamic)")
    ripple_roller_load_phase: float = _f(0.0, "rad", "phase of the load-scaled roller-pass "
                                         "ripple")
    stribeck_exponent: float = _f(2.0, "1", "shape exponent delta of the Stribeck decay "
                                  "exp(-(|w|/w_s)^delta): 1 Tustin's exponential, 2 the Gaussian "
                                  "(1 to 2)")
    # -- the mesh ripple at 2x of the driving shaft and at 1x and 2x of the driven shaft
    # (SHAFT_ORDER_RIPPLES): amplitude a + b |tau_out|/10 N*m, each part with its phase ------
    ripple_2x: float = _f(0.0, "N*m", "torque ripple amplitude at 2x the driving speed "
                          "(an oval eccentric bearing race, a cycloid disc's second harmonic "
                          "runout; dynamic): A sin(2 theta + phase); 0 or more")
    ripple_2x_phase: float = _f(0.0, "rad", "phase of the 2x ripple")
    ripple_2x_load: float = _f(0.0, "N*m", "part of the 2x ripple's amplitude that grows with "
                               "the load: amplitude at 10 N*m of |tau_out|, in proportion "
                               "(dynamic); 0 or more")
    ripple_2x_load_phase: float = _f(0.0, "rad", "phase of the load-scaled 2x ripple")
    ripple_out_1x: float = _f(0.0, "N*m", "torque ripple amplitude at 1x the driven shaft's "
                              "speed, referred to the driving shaft (runout of the output "
                              "flange, an eccentric pin circle; dynamic): A sin(theta_out + "
                              "phase), theta_out = theta r the driven shaft's angle, r = "
                              "w_out/w_in of the mode (signed); 0 or more")
    ripple_out_1x_phase: float = _f(0.0, "rad", "phase of the output 1x ripple (against the "
                                    "driven shaft's angle)")
    ripple_out_1x_load: float = _f(0.0, "N*m", "part of the output 1x ripple's amplitude that "
                                   "grows with the load: amplitude at 10 N*m of |tau_out| "
                                   "(dynamic); 0 or more")
    ripple_out_1x_load_phase: float = _f(0.0, "rad", "phase of the load-scaled output 1x "
                                         "ripple")
    ripple_out_2x: float = _f(0.0, "N*m", "torque ripple amplitude at 2x the driven shaft's "
                              "speed (an oval pin circle, a coupling's misalignment; dynamic): "
                              "A sin(2 theta_out + phase); 0 or more")
    ripple_out_2x_phase: float = _f(0.0, "rad", "phase of the output 2x ripple")
    ripple_out_2x_load: float = _f(0.0, "N*m", "part of the output 2x ripple's amplitude that "
                                   "grows with the load: amplitude at 10 N*m of |tau_out| "
                                   "(dynamic); 0 or more")
    ripple_out_2x_load_phase: float = _f(0.0, "rad", "phase of the load-scaled output 2x "
                                         "ripple")
    stribeck_transition: float = _f(0.0, "rad/s", "transition width w_r of the standstill "
                                    "friction's sign through a speed reversal: stribeck_torque "
                                    "tanh(w/w_r) exp(-(|w|/w_s)^delta) (pre-sliding, "
                                    "model_core.friction.reversal_sign; 0: the sharp sign "
                                    "sgn(w); 0 or more)")
    thermal_T_scale: float = _f(0.0, "K", "temperature scale theta of the warm-up's "
                                "temperature law (model_core.thermal.loss_temperature_law): "
                                "the losses change by c (theta/10 K)(1 - exp(-(T - "
                                "thermal_T_ref)/theta)), c = thermal_loss_per_10K, exponential "
                                "as a lubricant's viscosity (a loss following nu^m: theta = "
                                "1/|m d ln nu/dT|); 0: the linear law c (T - thermal_T_ref)/10 K "
                                "(theta -> infinity); else at least 1 K")
    loss_transition: float = _f(0.0, "rad/s", "transition width w_c of the whole loss through "
                                "standstill: the model's loss torque (input torque minus the "
                                "lossless one) times tanh(|w_in|/w_c) (pre-sliding, "
                                "model_core.friction.loss_transition); 0: the losses at their "
                                "full value at any speed (the model); 0 or more")

    #: fields no FMU carries: the diagnosis's replay uses them. Where the same physics has a
    #: form the FMUs carry, the diagnosis writes that too (model_core.effects): a viscosity
    #: drift per 10 K as the lubricant's Walther line (nu_100), in time as the housing's heat
    #: capacity (tau = R C); a warm-up in time is thermal_loss_change/thermal_tau (reducer
    #: FMUs), a loss change per 10 K thermal_loss_per_10K/thermal_T_ref (reducer FMUs, at
    #: their T_oil)
    REPLAY_ONLY = ("viscosity_ln_change", "viscosity_tau", "viscosity_ln_per_10K")
    #: fields the bench's input torque transducer FMU carries (offset, gain_error, zero_drift,
    #: zero_drift_tau, zero_per_10K, zero_T_ref; cyclo_fmu.bench.bench_parameters), not the
    #: reducer FMUs: they are not physics of the drive
    TRANSDUCER = ("torque_in_offset", "torque_in_gain_error", "torque_in_zero_drift",
                  "torque_in_zero_tau", "torque_in_zero_per_10K", "torque_in_zero_T_ref")

    def steady_torque(self, w):
        """Drag and Stribeck torque at driving speed w (rad/s), N*m, signed with the motion:
        the same terms the diagnosis fits (model_core.effects)."""
        import numpy as _np
        w = _np.asarray(w, float)
        if not (self.drag_torque or self.stribeck_torque):
            return _np.zeros(w.shape)
        from .effects import EFFECTS   # (model_core imports it with the package)
        s = {"w_in": _np.atleast_1d(w).ravel()}
        t = self.drag_torque * EFFECTS["load_independent_loss"].basis(
            s, self.drag_exponent)[:, 0]
        if self.stribeck_torque:
            t = t + self.stribeck_torque * EFFECTS["low_speed_friction"].basis(
                s, (self.stribeck_speed, self.stribeck_exponent,
                    self.stribeck_transition))[:, 0]
        return t.reshape(w.shape)


    def loss_transition_share(self, w):
        """Share tanh(|w|/w_c) of the model's loss torque a drive has built up at driving speed
        w [rad/s] (``loss_transition`` w_c; 1 at w_c = 0): model_core.friction.loss_transition,
        the one implementation (the replay, both FMUs and the diagnosis's effect)."""
        from .friction import loss_transition
        return loss_transition(w, self.loss_transition)

    def discovered_torque(self, w, tau_out):
        """Torque (N*m) of the discovered terms at driving speed w (rad/s) and load torque
        tau_out (N*m) (model_core.discovered, the one implementation)."""
        from .discovered import discovered_torque
        return discovered_torque(self.discovered, w, tau_out)

    def load_ripple_torque(self, theta, order, tau_out):
        """Ripple whose amplitude grows with the load (N*m): |tau_out|/T_ref (A1L sin(theta +
        phi1L) + AzL sin(order theta + phizL)), T_ref = 10 N*m (model_core.discovered.T_REF):
        a transmission error times the mesh stiffness gives a torque ripple in proportion to
        the load (model_core.effects 'mesh_ripple', load law 1). Next to ``ripple_1x``/``ripple_roller``
        (the load-independent part) the amplitude is a + b |tau_out|."""
        import numpy as _np
        from .discovered import T_REF
        return (_np.abs(tau_out) / T_REF) * (
            self.ripple_1x_load * _np.sin(theta + self.ripple_1x_load_phase)
            + self.ripple_roller_load * _np.sin(order * theta + self.ripple_roller_load_phase))

    def shaft_order_ripple_torque(self, theta, ratio_out, tau_out):
        """Ripple at 2x the driving shaft and at 1x and 2x the driven shaft (N*m):
        sum over k of (A_k sin(k theta + phi_k) + |tau_out|/T_ref B_k sin(k theta + psi_k)),
        k = 2, r, 2 r with r = w_out/w_in of the mode (signed: k theta is the driven shaft's
        angle; in S2 it turns against the driving shaft) and T_ref = 10 N*m
        (model_core.discovered.T_REF). A transmission error times the mesh stiffness gives
        the load-scaled part B (model_core.effects 'mesh_ripple'); zero mean over a turn of
        the shaft at a held load: the FMUs count it as stored power, not a loss. ``theta``
        [rad] the driving shaft's angle, ``tau_out`` [N*m] the load torque (None where the
        load-scaled parts are zero); scalars or arrays."""
        import numpy as _np
        from .discovered import T_REF
        theta = _np.asarray(theta, float)
        total = _np.zeros(theta.shape)
        load = None
        for prefix, k_in, k_out in SHAFT_ORDER_RIPPLES:
            a, b = getattr(self, prefix), getattr(self, prefix + "_load")
            if not (a or b):
                continue
            angle = (k_in + k_out * ratio_out) * theta
            if a:
                total = total + a * _np.sin(angle + getattr(self, prefix + "_phase"))
            if b:
                if load is None:
                    if tau_out is None:
                        raise ValueError("extra." + prefix + "_load: the load-scaled ripple "
                                         "needs the load torque tau_out")
                    load = _np.abs(tau_out) / T_REF
                total = total + load * b * _np.sin(angle + getattr(self, prefix
                                                                   + "_load_phase"))
        return total if total.ndim else float(total)

    @property
    def has_ripple(self) -> bool:
        """Any ripple term (1x, roller pass, 2x, output 1x/2x; constant or load-scaled)."""
        return bool(self.ripple_1x or self.ripple_roller or self.ripple_1x_load
                    or self.ripple_roller_load or any(
                        getattr(self, p) or getattr(self, p + "_load")
                        for p, _, _ in SHAFT_ORDER_RIPPLES))

    def run_in_torque(self, distance, load_loss_in):
        """Run-in torque at the driving shaft (N*m): c exp(-distance/s0) T_load, with the
        distance the driving shaft has travelled since the start (rad, the integral of |w|) and
        T_load the gear's load-dependent loss torque referred to it (N*m, with the sign of a
        loss: ``lossmap.load_loss_torque``, the partial losses PL1..PL6 over the driving speed,
        the losses ``[calibration] load_loss_scale`` scales): the friction of a new drive's
        sliding and rolling contacts starts c above the model's and settles as its contacts
        run in; the load-independent (idle) losses of seals, bearings' drag and churning do
        not run in (model_core.effects 'run_in'). Zero at zero load."""
        import numpy as _np
        return self.run_in_change * _np.exp(-distance / self.run_in_distance) * load_loss_in

    def thermal_per_10K_torque(self, T, loss_in):
        """Loss change per 10 K at the driving shaft (N*m): c (T - T_ref)/(10 K) loss_in, with
        T the grease temperature (K), T_ref ``thermal_T_ref`` and loss_in the model's loss
        torque referred to the driving shaft (N*m), the model held at one temperature: the
        losses scale by (1 + c (T - T_ref)/10 K); with ``thermal_T_scale`` theta > 0 by
        1 + c g(T - T_ref), g the exponential law (thermal.loss_temperature_law, the one
        implementation) (model_core.effects 'thermal_drift', its
        temperature form, referred to the column's first value; the FMUs hold their losses at
        T_oil_start meanwhile: one warm-up). Scalars or arrays."""
        from .thermal import T_STEP, loss_temperature_law
        if not self.thermal_T_scale:   # the linear law (as before the exponential one)
            return self.thermal_loss_per_10K * (T - self.thermal_T_ref) / T_STEP * loss_in
        return (self.thermal_loss_per_10K
                * loss_temperature_law(T - self.thermal_T_ref, self.thermal_T_scale) * loss_in)

    def dynamic_torque(self, alpha, theta, order, elapsed, loss_in):
        """Inertia, ripple and warm-up torque at the driving shaft (N*m): J*alpha +
        A1 sin(theta + phi1) + Az sin(order*theta + phiz) + c (1 - exp(-elapsed/tau)) loss_in.
        Scalars (the FMU's step) or arrays (a replay); the diagnosis fits the same terms."""
        import numpy as _np
        return (self.input_inertia * alpha
                + self.ripple_1x * _np.sin(theta + self.ripple_1x_phase)
                + self.ripple_roller * _np.sin(order * theta + self.ripple_roller_phase)
                + self.thermal_loss_change * (1.0 - _np.exp(-elapsed / self.thermal_tau)) * loss_in)


#: Bounds of the calibration parameters (see Calibration).
#: k [1]: 0 is the model as derived; a negative k would make the mesh create energy where the
#: model's own losses are small (eta0 (1 - k) > 1): a model that loses too much is corrected
#: through its friction level (diagnosis effect ``friction_miscalibrated``) instead. Above 0.5
#: half the meshing power would vanish in a mechanism the model does not know; no lubricated
#: gear mesh loses that much (review of the paper's drive: the known candidates stack to
#: 0.02-0.03), so such a fit names a different defect.
MESH_LOSS_K_BOUNDS = (0.0, 0.5)
#: idle_loss_scale [1]: 0 removes the load-independent losses; 10 is an order of magnitude
#: above the catalogue estimates of model_core.drag (a cold start with stiff grease and new lip
#: seals reaches about 3-5 times them), beyond which the drag model itself is wrong.
IDLE_LOSS_SCALE_BOUNDS = (0.0, 10.0)
#: load_loss_scale [1]: the same bounds as idle_loss_scale, for the same reason: 0 is a
#: frictionless mechanism; 10 times the modelled sliding and rolling losses is beyond any
#: lubricated contact (boundary friction of steel on steel is about 0.1-0.15, the model's
#: mixed-film coefficients are a few thousandths to a few hundredths), so such a fit names a
#: different defect than a friction level.
LOAD_LOSS_SCALE_BOUNDS = (0.0, 10.0)


@dataclass(frozen=True)
class Calibration:
    """What the model learned from a measurement: three loss parameters and where they came from.

    Defaults (k = 0, scales = 1) are the model as derived, with bit-identical results. A value
    other than the default is always reported as **calibrated**, with ``source``, what it was
    fitted to (model_core.calibration, the diagnosis effects ``mesh_loss``, ``idle_loss_scale``
    and ``load_loss_scale``).
    """

    mesh_loss_k: float = _f(0.0, "1",
                            "Additional loss in the meshing, as a fraction k of the mesh power: "
                            "the basic efficiency becomes eta0 (1 - k) in both relative flow "
                            "directions (a loss element of efficiency 1 - k in series with the "
                            "mechanism on its disc side), applied in the fixed point of "
                            "model_core.efficiency.operating_point, so the force balance, "
                            "self-locking and back-driving see it; booked as the partial loss "
                            "PL_mesh. Bounds 0 to 0.5 (MESH_LOSS_K_BOUNDS). **Calibrated** "
                            "where not 0.")
    idle_loss_scale: float = _f(1.0, "1",
                                "Scale on the load-independent losses of model_core.drag "
                                "(support bearings, seals, grease drag; physical profile with "
                                "losses = 'all'; no effect otherwise). Bounds 0 to 10 "
                                "(IDLE_LOSS_SCALE_BOUNDS). **Calibrated** where not 1.")
    load_loss_scale: float = _f(1.0, "1",
                                "Multiplies the gear's load-dependent friction losses PL1..PL6 "
                                "(all sliding and rolling contacts of the mechanism): the "
                                "friction level of the whole gear, the most common real mismatch "
                                "(issue 18). Applied in the fixed point of "
                                "model_core.efficiency.operating_point, so the force balance, "
                                "self-locking and back-driving see it. It does not scale the "
                                "mesh_loss_k extra (k stays an additive loss of mesh power) nor "
                                "the load-independent losses (idle_loss_scale). Bounds 0 to 10 "
                                "(LOAD_LOSS_SCALE_BOUNDS). **Calibrated** where not 1.")
    source: str = _f("", "-", "What the values were fitted to, and how (free text, echoed by "
                     "every output). Empty for the uncalibrated defaults.")

    @property
    def is_default(self) -> bool:
        """Whether the model is as derived (k = 0, scales = 1)."""
        return (self.mesh_loss_k == 0.0 and self.idle_loss_scale == 1.0
                and self.load_loss_scale == 1.0)

    def report(self) -> dict:
        """The calibration as outputs echo it: the values, ``calibrated`` (bool) and ``source``."""
        return {"mesh_loss_k": self.mesh_loss_k, "idle_loss_scale": self.idle_loss_scale,
                "load_loss_scale": self.load_loss_scale,
                "calibrated": not self.is_default, "source": self.source}


@dataclass(frozen=True)
class DriveDesign:
    """A constrained (1-DOF) cycloid drive: central ring 1 with z1 rollers, cycloid gear(s) with
    z1-1 teeth, disc 2 with k rollers in holes of the gear, eccentric shaft S.

    Defaults: the paper's test drive (Table 3). Lengths in m.
    """

    z1: int = _f(15, "1", "Number of rollers on the central ring [paper, Table 3].")
    n_disc_rollers: int = _f(7, "1", "Number k of rollers on the disc [paper, Table 3].")
    e: float = _f(2e-3, "m", "Eccentricity [paper, Table 3].", "mm", MM)
    lam: float = _f(1.6, "1", "Coefficient of the trochoid lambda = r_p/(e*z1) [paper, Table 3]; "
                    "the short-width coefficient is K1 = 1/lambda.")
    d_v1: float = _f(12e-3, "m", "Outer diameter of the ring rollers [paper, Table 3].", "mm", MM)
    d_o1: float = _f(8e-3, "m", "Ring pin diameter (bore of the ring roller). **Assumption**: 8 mm, "
                     "the bore of a standard drawn-cup needle bearing with D = 12 mm (HK0808 "
                     "series), so the plain and needle variants fit the same pin.", "mm", MM)
    b1: float = _f(12e-3, "m", "Width of the ring rollers [paper, Table 3].", "mm", MM)
    d_v2: float = _f(14e-3, "m", "Outer diameter of the disc rollers [paper, Table 3].", "mm", MM)
    d_o2: float = _f(10e-3, "m", "Disc pin diameter. **Assumption**: 10 mm, the bore of a "
                     "drawn-cup needle bearing with D = 14 mm (HK1010 series).", "mm", MM)
    b2: float = _f(12e-3, "m", "Width of the disc rollers [paper, Table 3].", "mm", MM)
    d_m2: float = _f(56e-3, "m", "Pitch diameter of the disc rollers [paper, Table 3].", "mm", MM)
    D_cz: float = _f(18e-3, "m", "Diameter of the holes in the cycloid gear. **Assumption**: "
                     "the standard design D_CZ = d_v2 + 2e = 18 mm (no hole clearance).", "mm", MM)
    D_p: float = _f(32e-3, "m", "Outer diameter of the eccentric (cycloid-gear) bearing "
                    "[paper, Table 3].", "mm", MM)
    d_p: float = _f(25e-3, "m", "Bore (raceway) diameter of the eccentric bearing. **Assumption**: "
                    "25 mm, a drawn-cup needle bearing with D = 32 mm (HK2516 series).", "mm", MM)
    bearing_clearance: float = _f(0.015e-3, "m",
                                  "Radial internal clearance of the eccentric needle bearing "
                                  "(and of the rollers' needle bearings with roller kind "
                                  "'needle'): the total radial play of one ring against the other "
                                  "(ISO 5753-1 definition); enters the lost motion "
                                  "(model_core.stiffness). **Assumption**: 15 um, the middle of "
                                  "the Normal group of ISO 5753-1 for radial bearings of 24-30 mm "
                                  "bore (5-20 um for deep-groove ball bearings, about 10-25 um "
                                  "for a drawn cup on an h6 shaft after mounting).", "mm", MM)
    pin_end_gap: float = _f(1e-3, "m",
                            "Axial gap at each side of a roller on its pin (between the rollers of "
                            "the two gears and at the pin's supports): the pins are beams simply "
                            "supported at both ends over 2 b + 3 gap, each gear's roller load at "
                            "its roller's middle (model_core.stiffness). **Assumption**: 1 mm, "
                            "the axial play of small reducers.", "mm", MM)
    output_shaft_diameter: float = _f(30e-3, "m",
                                      "Diameter of the output shafts (ring 1 and disc 2) between "
                                      "the mechanism and the coupling, for their torsion "
                                      "(model_core.stiffness) and their torsional yield. "
                                      "**Assumption**: 30 mm, the bore of the 6006 support "
                                      "bearings of model_core.drag.", "mm", MM)
    output_shaft_length: float = _f(60e-3, "m",
                                    "Twisted length of an output shaft, mechanism to coupling. "
                                    "**Assumption**: 60 mm (two 13 mm bearings, a seal, a "
                                    "housing wall and a coupling seat).", "mm", MM)
    input_shaft_diameter: float = _f(20e-3, "m",
                                     "Diameter of the eccentric (input) shaft S, for its torsion. "
                                     "**Assumption**: 20 mm, the bore of the 6004 support "
                                     "bearings of model_core.drag.", "mm", MM)
    input_shaft_length: float = _f(60e-3, "m",
                                   "Twisted length of the input shaft, coupling to eccentric. "
                                   "**Assumption**: 60 mm, as the output shafts.", "mm", MM)
    delta_z: float = _f(0.05e-3, "m", "Size of the profile correction [paper, Table 3].", "mm", MM)
    profile_modification: str = _f("equidistant", "-",
                                   "Kind of the profile correction delta_z: 'equidistant' (the "
                                   "profile is generated with the roller radius enlarged by "
                                   "delta_z) or 'offset' (pin-circle radius reduced by delta_z). "
                                   "**Assumption**: equidistant, the usual single correction and "
                                   "the one whose first contact lies at cos(phi) = K1.")
    torque_share: float = _f(0.5, "1", "Share of the torque carried by the first of the two "
                             "cycloid gears. **Assumption**: 0.5, the paper's equal split; designers "
                             "often use 0.55 for manufacturing errors.")
    ring_rollers: str = _f("plain", "-", "Ring rollers: 'plain' (roller slides on its pin) or "
                           "'needle' (needle bearing). **Assumption**: plain, the design whose "
                           "largest losses are the roller-pin sliding losses (paper, Fig. 7).")
    disc_rollers: str = _f("plain", "-", "Disc rollers: 'plain' or 'needle', as ring_rollers.")
    disc_pin_sliding: str = _f("paper", "-",
                               "Sliding speed of a plain disc roller on its pin: 'paper' uses Eq. (24) "
                               "as printed, (D_CZ/2)(d_o2/d_v2)|w_p - w_s|; 'kinematic' the derived "
                               "e (d_o2/d_v2)|w_p - w_s| (a hole translating on a circle of radius e "
                               "drives the roller surface at e*Omega). **Choice**: 'paper', because the "
                               "paper's published efficiencies rest on Eq. (24); 'kinematic' gives "
                               "D_CZ/(2e) = 4.5 times less disc-pin sliding (README, Known "
                               "deviations).")
    contact_law: str = _f("hertz", "-", "Contact force law: 'hertz' (Palmgren line contact, "
                          "delta = 3.84e-5 Q^0.9 / l^0.8, mm and N; Harris, Rolling Bearing "
                          "Analysis) or 'linear' (Q = linear_stiffness * delta).")
    linear_stiffness: float = _f(2e8, "N/m", "Contact stiffness per contact for contact_law "
                                 "'linear'. A very large value gives the rigid limit.", "N/mm", 1e3)
    n_positions: int = _f(8, "1", "Mesh positions per ring-roller pitch over which losses are "
                          "averaged (the efficiency changes by < 5e-5 from 8 to 64).")
    profile: str = _f("physical", "-", "Model profile: 'physical' (default: correct kinematics "
                      "for both roller kinds, roll or skid, Stribeck pin law, friction in the "
                      "force balance, load-independent losses with losses = 'all') or 'paper' "
                      "(what the paper computed: Eq. 24 as printed, mu_boundary calibrated to "
                      "its theory, load-dependent losses only). The physical profile does not "
                      "yet predict the paper's experiment (README, Two profiles).")
    seals: str = _f("lip", "-", "Shaft seals: 'lip' (a radial lip seal on the input and on the "
                    "output shaft, model_core.drag PL_seal) or 'none'. **Choice**: 'lip', what a "
                    "production reducer has to keep its grease in (and the behaviour before the "
                    "field existed). The paper's laboratory prototype is shown without seal "
                    "data; its calibration (preset mackic-rig) keeps only about 2 % of the "
                    "catalogue idle losses, which is consistent with 'none'.")
    losses: str = _f("all", "-", "Losses that enter: 'load_dependent' (the paper's model) or "
                     "'all' (adds the load-independent losses of model_core.drag). The paper "
                     "profile always uses 'load_dependent'.")
    ambient_temperature: float = _f(293.15, "K", "Ambient temperature of the housing's heat "
                                    "balance (model_core.thermal). **Assumption**: 20 degC, a "
                                    "laboratory.", "degC", None)
    temperature_model: str = _f("fixed", "-", "Grease temperature (physical profile): "
                                "'heat_balance' solves the housing's steady heat balance "
                                "(model_core.thermal.solve_heat_balance, single operating points); "
                                "'fixed' (default) uses operating_temperature. **Choice**: fixed "
                                "at 40 degC for maps, as the paper's short bench runs. The paper "
                                "profile uses the catalogue viscosity as given.")
    operating_temperature: float = _f(313.15, "K", "Grease temperature with temperature_model = "
                                      "'fixed' (default 40 degC, the catalogue temperature of the "
                                      "base-oil viscosity).", "degC", None)
    housing_heat_capacity: float = _f(HOUSING_HEAT_CAPACITY, "J/K", "Heat capacity of the "
                                      "housing with its contents, the lumped thermal mass of the "
                                      "FMUs' heat balance (model_core.thermal.housing_step). "
                                      "**Assumption**: 2000 J/K, about 4 kg of steel and 0.08 kg "
                                      "of grease.")
    housing_heat_transfer: float = _f(HOUSING_HEAT_TRANSFER, "W/(m^2 K)", "Convection and "
                                      "radiation coefficient of the housing surface. "
                                      "**Assumption**: 15, still air (ISO/TR 14179-2: 10-20).")
    housing_area: float = _f(HOUSING_AREA, "m^2", "Surface of the housing that gives heat to "
                             "the ambient. **Assumption**: a 130 mm x 80 mm cylinder, "
                             "0.0592 m^2.")
    lubricant: Lubricant = field(default_factory=Lubricant)
    friction: Friction = field(default_factory=Friction)
    extra: ExtraPhysics = field(default_factory=ExtraPhysics)
    calibration: Calibration = field(default_factory=Calibration)

    def __post_init__(self):
        validate_design(self)

    # -- derived geometry (the paper's notation) --------------------------------------------
    @property
    def i0(self) -> float:
        """Basic speed ratio i0 = (n1/n2) at nS = 0 = (z1-1)/z1 (Eq. 1, Table 1)."""
        return (self.z1 - 1) / self.z1

    @property
    def z_c(self) -> int:
        """Number of teeth of the cycloid gear, z1 - 1."""
        return self.z1 - 1

    @property
    def r_p(self) -> float:
        """Pitch radius of the ring rollers, r_p = lambda*e*z1 (from Eq. 3)."""
        return self.lam * self.e * self.z1

    @property
    def K1(self) -> float:
        """Short-width coefficient K1 = e*z1/r_p = 1/lambda."""
        return 1.0 / self.lam

    @property
    def r_w(self) -> float:
        """Pitch radius of the disc rollers, d_m2/2."""
        return self.d_m2 / 2

    def replace(self, **changes) -> "DriveDesign":
        """A copy with fields changed (validated). Nested: lubricant=..., friction=..."""
        return dataclasses.replace(self, **changes)


# ---------------------------------------------------------------------------------------------
def _check_finite(obj, prefix=""):
    for f in dataclasses.fields(obj):
        v = getattr(obj, f.name)
        if isinstance(f.default, str):
            if not isinstance(v, str):
                raise CycloidInputError(prefix + f.name, v, "must be a string")
            continue
        if not isinstance(f.default, (int, float)) or isinstance(f.default, bool):
            continue
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise CycloidInputError(prefix + f.name, v, "must be a number")
        if isinstance(v, (int, float)) and not math.isfinite(v):
            raise CycloidInputError(prefix + f.name, v, "must be a finite number")


#: Upper bound on the number of ring rollers [1]: reducers have about 10-120; the contact
#: solver's arrays grow with z1^2 (z1 = 100000 would ask for about 600 GiB).
MAX_Z1 = 1000
#: Upper bound on the mesh positions per pitch [1]: the mean converges by 8-64 positions.
MAX_N_POSITIONS = 4096
#: Upper bound on one contact array, z1^2 x n_positions float64 values [B]: 512 MiB, a quarter
#: of a small machine's memory, so that a design can never exhaust it.
MAX_CONTACT_ARRAY_BYTES = 512 * 2 ** 20
#: Lower bound on the catalogue viscosities [m^2/s]: 1 mm^2/s, water's; no lubricating oil is
#: thinner (the thinnest ISO VG 2 oils have about 2 mm^2/s at 40 degC), and the Walther line
#: of ASTM D341 (log log (nu + 0.7), model_core.thermal) is undefined from 0.3 mm^2/s down,
#: where the model would return NaN.
MIN_VISCOSITY = 1e-6
#: Upper bound on a friction coefficient [1]: dry clean steel on steel reaches about 0.6-0.8;
#: above 1 the sliding contacts would self-lock the drive in every mode.
MAX_FRICTION_COEFFICIENT = 1.0


def validate_design(d: DriveDesign) -> None:
    """Reject impossible designs with a :class:`CycloidInputError` naming the field."""
    _check_finite(d)
    _check_finite(d.lubricant, "lubricant.")
    _check_finite(d.friction, "friction.")
    _check_finite(d.extra, "extra.")
    _check_finite(d.calibration, "calibration.")
    if any((ord(c) < 0x20 and c not in "\n\t") or ord(c) == 0x7f for c in d.calibration.source):
        raise CycloidInputError("calibration.source", d.calibration.source[:40],
                                "must be text without control characters (line breaks and tabs "
                                "are allowed)")
    for name, (lo, hi) in (("mesh_loss_k", MESH_LOSS_K_BOUNDS),
                           ("idle_loss_scale", IDLE_LOSS_SCALE_BOUNDS),
                           ("load_loss_scale", LOAD_LOSS_SCALE_BOUNDS)):
        v = getattr(d.calibration, name)
        if not lo <= v <= hi:
            raise CycloidInputError("calibration." + name, v, f"must lie between {lo:g} and "
                                    f"{hi:g} (model_core.design.{name.upper()}_BOUNDS)")
    for name in ("thermal_T_ref", "torque_in_zero_T_ref"):
        v = getattr(d.extra, name)
        if not 173.15 < v < 473.15:   # echoed in degC, as the file gives it
            raise CycloidInputError(f"[extra].{name}_degC", float(f"{v - KELVIN:.10g}"),
                                    "must lie between -100 and 200 degC")
    from .thermal import T_SCALE_MIN
    if not (d.extra.thermal_T_scale == 0.0 or T_SCALE_MIN <= d.extra.thermal_T_scale < math.inf):
        raise CycloidInputError("extra.thermal_T_scale", d.extra.thermal_T_scale,
                                f"must be 0 (the linear law) or at least {T_SCALE_MIN:g} K "
                                "(model_core.thermal.T_SCALE_MIN)")
    if not d.extra.run_in_change >= -1.0:
        raise CycloidInputError("extra.run_in_change", d.extra.run_in_change,
                                "must be at least -1 (the losses cannot fall below zero)")
    for name in ("stribeck_speed", "thermal_tau", "viscosity_tau", "torque_in_zero_tau",
                 "run_in_distance"):
        if not getattr(d.extra, name) > 0:
            raise CycloidInputError("extra." + name, getattr(d.extra, name), "must be positive")
    if not 1.0 <= d.extra.stribeck_exponent <= 2.0:
        raise CycloidInputError("extra.stribeck_exponent", d.extra.stribeck_exponent,
                                "must lie between 1 (Tustin) and 2 (Gaussian)")
    if not 0.0 <= d.extra.stribeck_transition < float("inf"):
        raise CycloidInputError("extra.stribeck_transition", d.extra.stribeck_transition,
                                "must be 0 (a sharp sign) or a positive width in rad/s")
    if not 0.0 <= d.extra.loss_transition < float("inf"):
        raise CycloidInputError("extra.loss_transition", d.extra.loss_transition,
                                "must be 0 (the losses at full value) or a positive width in "
                                "rad/s")
    if not 0.0 <= d.extra.drag_exponent <= 2.0:
        raise CycloidInputError("extra.drag_exponent", d.extra.drag_exponent,
                                "must lie between 0 and 2")
    for name in ("drag_torque", "stribeck_torque", "input_inertia") + tuple(
            p + sfx for p, _, _ in SHAFT_ORDER_RIPPLES for sfx in ("", "_load")):
        if getattr(d.extra, name) < 0:
            raise CycloidInputError("extra." + name, getattr(d.extra, name),
                                    "must not be negative")
    for name in ("z1", "n_disc_rollers", "n_positions"):
        v = getattr(d, name)
        if int(v) != v:
            raise CycloidInputError(name, v, "must be a whole number")
        object.__setattr__(d, name, int(v))   # 15.0 -> 15: counts are used as integers
    from .discovered import DiscoveredTerm, MAX_TERMS
    disc = d.extra.discovered
    if not isinstance(disc, tuple) or not all(isinstance(k, DiscoveredTerm) for k in disc):
        raise CycloidInputError("extra.discovered", disc, "must be a tuple of DiscoveredTerm")
    if len(disc) > MAX_TERMS:
        raise CycloidInputError("extra.discovered", len(disc), f"at most {MAX_TERMS} terms")
    for i, k in enumerate(disc):
        k.validate(f"extra.discovered[{i}]")
    if not -0.5 < d.extra.torque_in_gain_error < 0.5:
        raise CycloidInputError("extra.torque_in_gain_error", d.extra.torque_in_gain_error,
                                "must lie between -0.5 and 0.5")
    if d.z1 < 3:
        raise CycloidInputError("z1", d.z1, "a cycloid drive needs at least 3 ring rollers")
    if d.n_disc_rollers < 3:
        raise CycloidInputError("n_disc_rollers", d.n_disc_rollers, "needs at least 3 disc rollers "
                                "(with 2, both can lie on the line of centres and carry nothing)")
    if d.n_positions < 2:
        raise CycloidInputError("n_positions", d.n_positions, "needs at least 2 mesh positions")
    # bounds on what would exhaust memory: the contact solver holds arrays of
    # z1 (rollers) x z1 (load-sharing candidates) x n_positions float64 values
    if d.z1 > MAX_Z1:
        raise CycloidInputError("z1", d.z1, f"at most {MAX_Z1} ring rollers (cycloid reducers "
                                "have about 10-120; the contact arrays grow with z1^2)")
    if d.n_positions > MAX_N_POSITIONS:
        raise CycloidInputError("n_positions", d.n_positions, f"at most {MAX_N_POSITIONS} mesh "
                                "positions (the efficiency changes by < 5e-5 from 8 to 64; the "
                                "contact arrays grow with n_positions)")
    if d.z1 ** 2 * d.n_positions * 8 > MAX_CONTACT_ARRAY_BYTES:
        raise CycloidInputError("n_positions", d.n_positions, f"with z1 = {d.z1} the contact "
                                f"arrays (z1^2 x n_positions x 8 B) would exceed "
                                f"{MAX_CONTACT_ARRAY_BYTES / 2**20:.0f} MiB; use fewer positions")
    for name in ("e", "lam", "d_v1", "d_o1", "b1", "d_v2", "d_o2", "b2", "d_m2", "D_cz", "D_p",
                 "d_p", "linear_stiffness", "torque_share", "output_shaft_diameter",
                 "output_shaft_length", "input_shaft_diameter", "input_shaft_length"):
        v = getattr(d, name)
        if not v > 0:
            raise CycloidInputError(name, v, "must be positive")
    for name in ("bearing_clearance", "pin_end_gap"):
        if getattr(d, name) < 0:
            raise CycloidInputError(name, getattr(d, name), "must not be negative")
    if d.delta_z < 0:
        raise CycloidInputError("delta_z", d.delta_z, "profile correction must not be negative")
    if d.torque_share > 1:
        raise CycloidInputError("torque_share", d.torque_share, "a share must not exceed 1")
    if d.lam <= 1:
        raise CycloidInputError("lam", d.lam, f"K1 = 1/lambda = {1 / d.lam:.4g} must be < 1 "
                                "(a prolate epicycloid); K1 >= 1 gives no valid cycloid tooth")
    if d.d_o1 >= d.d_v1:
        raise CycloidInputError("d_o1", d.d_o1, f"ring pin must be smaller than its roller "
                                f"(d_v1 = {d.d_v1})")
    if d.d_o2 >= d.d_v2:
        raise CycloidInputError("d_o2", d.d_o2, f"disc pin must be smaller than its roller "
                                f"(d_v2 = {d.d_v2})")
    if d.D_cz < d.d_v2 + 2 * d.e - 1e-12:
        raise CycloidInputError("D_cz", d.D_cz, f"holes must clear the disc rollers: "
                                f"D_cz >= d_v2 + 2e = {d.d_v2 + 2 * d.e:.6g} m")
    if d.d_p >= d.D_p:
        raise CycloidInputError("d_p", d.d_p, f"bearing bore must be smaller than D_p = {d.D_p}")
    rho_min = geometry.min_radius_of_curvature(d.z1, d.e, d.lam)
    if d.d_v1 / 2 + d.delta_z >= rho_min:
        raise CycloidInputError("d_v1", d.d_v1, f"roller radius (+ correction) exceeds the smallest "
                                f"radius of curvature of the cycloid, {rho_min:.6g} m: the profile "
                                "is undercut (looped)")
    if d.r_w - d.D_cz / 2 <= d.D_p / 2:
        raise CycloidInputError("d_m2", d.d_m2, "the holes cut into the eccentric bearing seat "
                                f"(d_m2/2 - D_cz/2 must exceed D_p/2 = {d.D_p / 2})")
    if 2 * d.r_w * math.sin(math.pi / d.n_disc_rollers) <= d.D_cz:
        raise CycloidInputError("D_cz", d.D_cz, "neighbouring holes overlap")
    if d.r_w + d.D_cz / 2 >= d.r_p - d.e - d.d_v1 / 2:
        raise CycloidInputError("d_m2", d.d_m2, "the holes reach beyond the root of the teeth")
    for name, allowed in (("ring_rollers", ROLLER_KINDS), ("disc_rollers", ROLLER_KINDS),
                          ("profile_modification", PROFILE_MODIFICATIONS),
                          ("contact_law", CONTACT_LAWS), ("seals", SEAL_KINDS),
                          ("disc_pin_sliding", DISC_PIN_SLIDING)):
        if getattr(d, name) not in allowed:
            raise CycloidInputError(name, getattr(d, name), f"must be one of {', '.join(allowed)}")
    for name, allowed in (("profile", PROFILES), ("losses", LOSS_SCOPES)):
        if getattr(d, name) not in allowed:
            raise CycloidInputError(name, getattr(d, name), f"must be one of {', '.join(allowed)}")
    for name in ("ambient_temperature", "operating_temperature"):
        v = getattr(d, name)
        if not 173.15 < v < 473.15:     # echoed in degC, the unit the user gave it in
            raise CycloidInputError(name + "_degC", float(f"{v - KELVIN:.10g}"),
                                    "must lie between -100 and 200 degC")
    for name in ("housing_heat_capacity", "housing_heat_transfer", "housing_area"):
        v = getattr(d, name)
        if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
            raise CycloidInputError(name, v, "must be a positive number")
    if d.temperature_model not in TEMPERATURE_MODELS:
        raise CycloidInputError("temperature_model", d.temperature_model,
                                f"must be one of {', '.join(TEMPERATURE_MODELS)}")
    lub, fr = d.lubricant, d.friction
    for name in ("kinematic_viscosity", "kinematic_viscosity_100", "density"):
        if not getattr(lub, name) > 0:
            raise CycloidInputError("lubricant." + name, getattr(lub, name), "must be positive")
    if not lub.kinematic_viscosity_100 < lub.kinematic_viscosity:
        raise CycloidInputError("lubricant.kinematic_viscosity_100", lub.kinematic_viscosity_100,
                                "must be below the 40 degC viscosity (oils thin when hot)")
    for name in ("kinematic_viscosity_100", "kinematic_viscosity"):
        if getattr(lub, name) < MIN_VISCOSITY:
            raise CycloidInputError("lubricant." + name, getattr(lub, name),
                                    f"below {MIN_VISCOSITY * 1e6:g} mm^2/s (water's): no "
                                    "lubricating oil is that thin, and the Walther viscosity-"
                                    "temperature line (ASTM D341) fails below 0.3 mm^2/s")
    for f in dataclasses.fields(fr):
        if getattr(fr, f.name) < 0:
            raise CycloidInputError("friction." + f.name, getattr(fr, f.name), "must not be negative")
    for name in ("hersey_transition", "pin_clearance_ratio"):
        if not getattr(fr, name) > 0:
            raise CycloidInputError("friction." + name, getattr(fr, name), "must be positive")
    for name in ("mu_boundary", "mu_full_film", "mu_pin_boundary", "mu_tooth"):
        if getattr(fr, name) > MAX_FRICTION_COEFFICIENT:
            raise CycloidInputError("friction." + name, getattr(fr, name),
                                    f"a friction coefficient above {MAX_FRICTION_COEFFICIENT} is "
                                    "beyond even dry clean steel on steel (about 0.6-0.8); the "
                                    "drive could not run")
    if fr.mu_full_film > fr.mu_boundary:
        raise CycloidInputError("friction.mu_full_film", fr.mu_full_film,
                                f"must not exceed mu_boundary = {fr.mu_boundary}")
    _check_extra_torques(d)


#: [N*m] extra torques at the driving shaft up to this are accepted without computing the
#: drive's static rating (0.5 ms): the paper's drive is driven with at most 0.85 N*m
EXTRA_TORQUE_CHEAP = 1.0


def _check_extra_torques(d: DriveDesign) -> None:
    """A drag (or standstill friction) at the driving shaft S that alone needs more torque than
    the ring can take statically (its Hertz rating, ``stiffness.ring_torque_rating``, over the
    ratio z1 - 1) stalls any such drive: refused, naming the field."""
    ex = d.extra
    for name in ("drag_torque", "stribeck_torque"):
        v = getattr(ex, name)
        if v <= EXTRA_TORQUE_CHEAP:
            continue
        from .stiffness import ring_torque_rating
        cap = ring_torque_rating(d) / (d.z1 - 1)
        if v > cap:
            raise CycloidInputError("extra." + name, v, f"needs more than the {cap:.4g} N*m the "
                                    "drive can take at its driving shaft (the ring's static "
                                    "rating over z1 - 1): it could not turn")


# -- design files -----------------------------------------------------------------------------
_SECTIONS = (("geometry", None), ("lubricant", "lubricant"), ("friction", "friction"))
#: the nested sections of DriveDesign
_NESTED = ("lubricant", "friction", "extra", "calibration", "discovered")
#: the sections of a design file
SECTIONS = ("model", "geometry", "lubricant", "friction", "extra", "calibration")


def _to_si(v: float, scale) -> float:
    if scale is None:   # degC -> K
        return v + KELVIN
    # divide by an exact integer (1000, 1e6) so that 18 mm -> 0.018 round-trips exactly
    return v / round(1 / scale) if scale < 1 else v * scale


def _from_si(v: float, scale) -> float:
    if scale is None:   # K -> degC
        return v - KELVIN
    return v * round(1 / scale) if scale < 1 else v / scale


def _toml_key(f) -> str:
    u = f.metadata.get("toml_unit", "1")
    suffix = {"mm": "_mm", "um": "_um", "mm^2/s": "_mm2_s", "GPa": "_GPa", "N/mm": "_N_mm",
              "degC": "_degC"}.get(u, "")
    return f.name + suffix


def _section_to_dict(obj, only=None, skip=()) -> dict:
    out = {}
    for f in dataclasses.fields(obj):
        if f.name in _NESTED or f.name in skip:
            continue
        if only is not None and f.name not in only:
            continue
        v = getattr(obj, f.name)
        if isinstance(v, float):
            scale = f.metadata.get('scale', 1.0)
            x = _from_si(v, scale)
            short = float(f"{x:.12g}")      # 12 digits hide the unit conversion's noise,
            v = short if _to_si(short, scale) == v else x   # unless they lose the value
        out[_toml_key(f)] = v
    return out


def _section_from_dict(cls, data: dict, section: str, only=None, skip=()) -> dict:
    keys = {_toml_key(f): f for f in dataclasses.fields(cls)
            if f.name not in _NESTED and f.name not in skip
            and (only is None or f.name in only)}
    kwargs = {}
    for key, value in data.items():
        if key not in keys:
            raise CycloidInputError(f"[{section}].{key}", value, "unknown key in design file "
                                    f"(known: {', '.join(sorted(keys))})")
        f = keys[key]
        if isinstance(f.default, str):
            if not isinstance(value, str):
                raise CycloidInputError(f"[{section}].{key}", value, "must be a string")
            kwargs[f.name] = value
        elif isinstance(f.default, int) and not isinstance(f.default, bool):
            if isinstance(value, bool) or not isinstance(value, (int, float)) or int(value) != value:
                raise CycloidInputError(f"[{section}].{key}", value, "must be a whole number")
            kwargs[f.name] = int(value)
        else:
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise CycloidInputError(f"[{section}].{key}", value, "must be a number")
            kwargs[f.name] = _to_si(float(value), f.metadata.get("scale", 1.0))
    return kwargs


def design_to_dict(design: DriveDesign) -> dict:
    """The design as nested dict in design-file units (mm, mm^2/s, um)."""
    return {"model": _section_to_dict(design, only=MODEL_FIELDS),
            "geometry": _section_to_dict(design, skip=MODEL_FIELDS),
            "lubricant": _section_to_dict(design.lubricant),
            "friction": _section_to_dict(design.friction),
            "extra": _extra_to_dict(design.extra),
            "calibration": _section_to_dict(design.calibration)}


def _extra_to_dict(extra) -> dict:
    out = _section_to_dict(extra)
    if extra.discovered:
        out["discovered"] = [{"coefficient_Nm": k.coefficient, "speed_exponent":
                              k.speed_exponent, "load_exponent": k.load_exponent}
                             for k in extra.discovered]
    return out


def design_from_dict(data: dict) -> DriveDesign:
    """Build a validated design from a dict in design-file units; missing keys keep defaults."""
    if not isinstance(data, dict):
        raise CycloidInputError("design", data, "must be a table")
    for section in data:
        if section not in SECTIONS:
            raise CycloidInputError(f"[{section}]", "...", "unknown section in design file "
                                    f"(known: {', '.join(SECTIONS)})")
    for section in SECTIONS:
        if not isinstance(data.get(section, {}), dict):
            raise CycloidInputError(f"[{section}]", data[section], "must be a table")
    lub = Lubricant(**_section_from_dict(Lubricant, data.get("lubricant", {}), "lubricant"))
    fr = Friction(**_section_from_dict(Friction, data.get("friction", {}), "friction"))
    geo = _section_from_dict(DriveDesign, data.get("geometry", {}), "geometry", skip=MODEL_FIELDS)
    geo.update(_section_from_dict(DriveDesign, data.get("model", {}), "model", only=MODEL_FIELDS))
    try:
        extra = dict(data.get("extra", {}))
        from .discovered import terms_from_toml
        discovered = terms_from_toml(extra.pop("discovered", []))
        ex = ExtraPhysics(**_section_from_dict(ExtraPhysics, extra, "extra"),
                          discovered=discovered)
        cal = Calibration(**_section_from_dict(Calibration, data.get("calibration", {}),
                                               "calibration"))
        return DriveDesign(lubricant=lub, friction=fr, extra=ex, calibration=cal, **geo)
    except CycloidInputError as exc:
        raise _in_file_terms(exc) from None


def _in_file_terms(exc: CycloidInputError) -> CycloidInputError:
    """The error of a design built from a file, restated with the file's key and unit
    (``lubricant.kinematic_viscosity = -5e-06`` -> ``[lubricant].kinematic_viscosity_mm2_s =
    -5.0``), so that it names what the user wrote."""
    section, _, name = exc.field.rpartition(".")
    if not section and name.endswith("_degC") and name[:-5] in MODEL_FIELDS:
        return CycloidInputError(f"[model].{name}", exc.value, exc.reason)
    cls = {"": DriveDesign, "lubricant": Lubricant, "friction": Friction,
           "extra": ExtraPhysics, "calibration": Calibration}.get(section)
    f = {x.name: x for x in dataclasses.fields(cls)}.get(name) if cls else None
    if f is None or not isinstance(exc.value, (int, float)) or isinstance(exc.value, bool):
        return exc
    value = exc.value
    if isinstance(f.default, float):
        scale = f.metadata.get("scale", 1.0)
        if scale is not None:
            value = float(f"{_from_si(float(value), scale):.12g}")
    if not section:
        section = "model" if name in MODEL_FIELDS else "geometry"
    return CycloidInputError(f"[{section}].{_toml_key(f)}", value, exc.reason)


def _toml_value(v) -> str:
    if isinstance(v, str):
        # a TOML basic string: backslash, quote and control characters escaped (a calibration
        # source may span lines)
        out = []
        for ch in v:
            if ch == "\\":
                out.append("\\\\")
            elif ch == '"':
                out.append('\\"')
            elif ch == "\n":
                out.append("\\n")
            elif ch == "\t":
                out.append("\\t")
            elif ord(ch) < 0x20 or ord(ch) == 0x7f:
                out.append(f"\\u{ord(ch):04x}")
            else:
                out.append(ch)
        return '"' + "".join(out) + '"'
    if isinstance(v, bool):
        return "true" if v else "false"
    return repr(v)


def design_to_toml(design: DriveDesign) -> str:
    """The design as TOML text (lengths in mm, viscosity in mm^2/s, roughness in um)."""
    lines = ["# cyclo-fmu design file: lengths in mm, viscosity in mm^2/s, roughness in um"]
    for section, values in design_to_dict(design).items():
        values.pop("discovered", None)     # [[extra.discovered]] tables, at the end
        lines.append(f"\n[{section}]")
        lines += [f"{k} = {_toml_value(v)}" for k, v in values.items()]
    from .discovered import terms_to_toml
    return "\n".join(lines) + "\n" + terms_to_toml(design.extra.discovered)


def design_from_toml(source) -> DriveDesign:
    """Read a design from a TOML file path or TOML text."""
    if isinstance(source, Path) or (isinstance(source, str) and "\n" not in source
                                    and source.endswith(".toml")):
        path = Path(source)
        try:
            text = path.read_text(encoding="utf-8")
        except OSError as exc:
            raise CycloidInputError("design file", str(path), f"cannot be read ({exc.strerror})")
        except UnicodeDecodeError as exc:
            raise CycloidInputError("design file", str(path), f"is not UTF-8 TOML text (byte "
                                    f"{exc.start}: {exc.reason}); a binary file?")
    else:
        text = source
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise CycloidInputError("design file", str(source)[:60], f"is not valid TOML ({exc})")
    return design_from_dict(data)


def scale_friction_level(design: DriveDesign, factor: float) -> DriveDesign:
    """The design with its sliding-friction level scaled by ``factor`` (a diagnosis' friction
    level): mu_boundary in the paper profile; in the physical profile also the pin's boundary
    coefficient and the tooth traction (mu_pin_boundary, mu_tooth), which set its sliding
    losses."""
    fr = design.friction
    changes = {"mu_boundary": fr.mu_boundary * factor}
    if design.profile == "physical":
        changes.update(mu_pin_boundary=fr.mu_pin_boundary * factor, mu_tooth=fr.mu_tooth * factor)
    return dataclasses.replace(design, friction=dataclasses.replace(fr, **changes))


def scale_viscosity(design: DriveDesign, factor: float) -> DriveDesign:
    """The design with its grease's viscosity scaled by ``factor`` at every temperature (both
    catalogue viscosities, so the Walther line keeps its slope approximately)."""
    lub = design.lubricant
    return dataclasses.replace(design, lubricant=dataclasses.replace(
        lub, kinematic_viscosity=lub.kinematic_viscosity * factor,
        kinematic_viscosity_100=lub.kinematic_viscosity_100 * factor))


#: The conservative variant's Hersey transition [1]: 1, six orders of magnitude above any
#: Hersey number of a greased pin in the drive (about 1e-9 to 1e-6), so the Stribeck law's
#: boundary term exp(-H/H_t) stays 1 within 1e-6: the pins at boundary friction everywhere.
CONSERVATIVE_HERSEY_TRANSITION = 1.0
#: What the conservative variant changes (printed by ``--band``)
CONSERVATIVE_DESCRIPTION = (
    "conservative variant (model_core.design.conservative_variant): (1) the pins at boundary "
    "friction everywhere (friction.hersey_transition = 1: mu_pin = mu_pin_boundary plus "
    "Petroff at every Hersey number, no mixed-film relief); (2) laboratory idle losses: the "
    "catalogue load-independent losses in full (calibration.idle_loss_scale at least 1, lip "
    "seals); nothing else changes (geometry, k, tooth traction, temperature). The physical "
    "profile with losses = 'all' only: the paper profile's pins are already at their boundary "
    "clamp and it has no idle losses.")


def conservative_variant(design: DriveDesign) -> DriveDesign:
    """The design's conservative variant (``--band``): exactly the two changes of
    CONSERVATIVE_DESCRIPTION (boundary pin friction, full catalogue idle losses with lip
    seals). The paper's absolute efficiency level is uncertain by several points (its input
    transducer's zero may drift 0.1 N*m per 10 K against inputs of 0.3-0.85 N*m), so a
    prediction is given as nominal next to this variant."""
    fr = dataclasses.replace(design.friction, hersey_transition=max(
        design.friction.hersey_transition, CONSERVATIVE_HERSEY_TRANSITION))
    cal = dataclasses.replace(design.calibration,
                              idle_loss_scale=max(design.calibration.idle_loss_scale, 1.0))
    return dataclasses.replace(design, friction=fr, calibration=cal, seals="lip")
