"""Physical effects the paper's load-dependent model leaves out, as parametric torque terms.

Each effect adds a torque at the reducer's input shaft (N*m, in the sense of the input torque:
positive = the driver must deliver more). All but ``thermal_drift`` and ``low_speed_friction``
are linear in their parameters; those two have one shape parameter (a time constant, a
Stribeck speed) scanned on a grid. The same terms serve the synthetic recordings (a hidden
effect), the diagnosis (candidate library) and, once fitted, the updated model.

Signals (numpy arrays over samples, SI): t (s), w_in (rad/s), alpha_in (rad/s^2), theta_in
(rad, integral of w_in), loss_in (the model's loss torque referred to the input, N*m:
T_in_model - T_in_lossless), order_roller (roller-pass order of the input speed),
temperature (degC or None).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

W_REF = 300.0   # rad/s, reference input speed of the drag law (about 2860 r/min)


@dataclass(frozen=True)
class Parameter:
    name: str
    unit: str
    lower: float
    upper: float
    description: str


@dataclass(frozen=True)
class Effect:
    id: str
    description: str
    parameters: tuple          # linear parameters (Parameter), in basis-column order
    shape: tuple = ()          # grid of the nonlinear shape parameter, () if none
    shape_name: str = ""
    shape_unit: str = ""

    def basis(self, s: dict, shape=None) -> np.ndarray:
        """Columns (n_samples, n_params) whose combination with the parameters is the torque."""
        return _BASIS[self.id](s, shape)

    def torque(self, s: dict, values, shape=None) -> np.ndarray:
        """The effect's torque at the input shaft for parameter values (N*m)."""
        B = self.basis(s, shape)
        return B @ np.asarray(values, float) if B.shape[1] else np.zeros(len(s["t"]))


def _drag(s, shape):
    w = s["w_in"]
    return (np.sign(w) * (np.abs(w) / W_REF) ** (2.0 / 3.0))[:, None]


def _thermal(s, shape):
    if s.get("temperature") is not None:
        T = s["temperature"]
        return (s["loss_in"] * (T - T[0]) / 10.0)[:, None]
    return (s["loss_in"] * (1.0 - np.exp(-(s["t"] - s["t"][0]) / shape)))[:, None]


def _inertia(s, shape):
    return s["alpha_in"][:, None]


def _ripple(s, shape):
    th = s["theta_in"]
    k = s["order_roller"]
    return np.stack([np.sin(th), np.cos(th), np.sin(k * th), np.cos(k * th)], -1)


def _stribeck(s, shape):
    w = s["w_in"]
    return (np.sign(w) * np.exp(-(w / shape) ** 2))[:, None]


def _offset(s, shape):
    return np.ones((len(s["t"]), 1))


def _friction(s, shape):
    return s["loss_in"][:, None]


def _none(s, shape):
    return np.zeros((len(s["t"]), 0))


_BASIS = {"load_independent_loss": _drag, "thermal_drift": _thermal, "inertia": _inertia,
          "mesh_ripple": _ripple, "low_speed_friction": _stribeck,
          "torque_sensor_offset": _offset, "friction_miscalibrated": _friction, "none": _none}

EFFECTS = {
    "load_independent_loss": Effect(
        "load_independent_loss",
        "no-load drag (grease churning, seals, bearing drag): a torque that grows with speed as "
        "(nu n)^(2/3) and does not depend on load",
        (Parameter("T_drag", "N*m", 0.0, 0.5, f"drag torque at the input at {W_REF:.0f} rad/s"),)),
    "thermal_drift": Effect(
        "thermal_drift",
        "the lubricant's viscosity changes as the drive warms, so the losses drift with time "
        "(first order) or with temperature",
        (Parameter("loss_change", "1", -0.5, 0.5, "relative change of the losses when warm "
                   "(or per 10 K with a temperature column)"),),
        shape=(60.0, 150.0, 300.0, 600.0, 1200.0), shape_name="tau", shape_unit="s"),
    "inertia": Effect(
        "inertia", "unmodelled rotating inertia on the input side: torque J dw/dt",
        (Parameter("J", "kg*m^2", -1e-2, 1e-2, "inertia referred to the input shaft"),)),
    "mesh_ripple": Effect(
        "mesh_ripple", "torque ripple at orders of the shaft speed: eccentric (1x) and "
        "roller pass",
        (Parameter("A1_sin", "N*m", -0.5, 0.5, "1x ripple, sine"),
         Parameter("A1_cos", "N*m", -0.5, 0.5, "1x ripple, cosine"),
         Parameter("Az_sin", "N*m", -0.5, 0.5, "roller-pass ripple, sine"),
         Parameter("Az_cos", "N*m", -0.5, 0.5, "roller-pass ripple, cosine"))),
    "low_speed_friction": Effect(
        "low_speed_friction", "boundary / Stribeck friction rising at low sliding speed: "
        "T_s exp(-(w/w_s)^2)",
        (Parameter("T_stribeck", "N*m", 0.0, 0.5, "extra friction torque at standstill"),),
        shape=(20.0, 40.0, 80.0, 150.0), shape_name="w_s", shape_unit="rad/s"),
    "torque_sensor_offset": Effect(
        "torque_sensor_offset", "a zero offset of the input torque transducer",
        (Parameter("offset", "N*m", -0.5, 0.5, "zero offset of the input torque reading"),)),
    "friction_miscalibrated": Effect(
        "friction_miscalibrated", "nothing is missing: the model's friction coefficient is off "
        "(losses scaled)",
        (Parameter("loss_scale_error", "1", -0.5, 0.5, "relative error of the model's losses"),)),
    "none": Effect("none", "the model explains the data within its noise", ()),
}


def extra_torque(extra, s: dict) -> np.ndarray:
    """Torque (N*m) at the driving shaft of a design's ``extra`` physics (design.ExtraPhysics),
    from the same terms the diagnosis fits; steady (drag, Stribeck) and dynamic (inertia,
    ripple, warm-up) parts."""
    n = len(s["t"])
    total = np.zeros(n)
    if extra.drag_torque:
        total += EFFECTS["load_independent_loss"].torque(s, [extra.drag_torque])
    if extra.stribeck_torque:
        total += EFFECTS["low_speed_friction"].torque(s, [extra.stribeck_torque],
                                                     extra.stribeck_speed)
    if (extra.input_inertia or extra.ripple_1x or extra.ripple_roller
            or extra.thermal_loss_change):
        total += extra.dynamic_torque(s["alpha_in"], s["theta_in"], s["order_roller"],
                                      s["t"] - s["t"][0], s["loss_in"])
    return total


def switch_on(extra, effect: str, values: dict, shape=None):
    """``extra`` (design.ExtraPhysics) with an effect's fitted or hidden parameter values
    switched on; effects that are not physics of the drive (a transducer offset, a friction
    level, none) leave it unchanged."""
    from dataclasses import replace
    v = values
    if effect == "load_independent_loss":
        return replace(extra, drag_torque=max(v["T_drag"], 0.0))
    if effect == "low_speed_friction":
        return replace(extra, stribeck_torque=max(v["T_stribeck"], 0.0), stribeck_speed=shape)
    if effect == "inertia":
        return replace(extra, input_inertia=max(v["J"], 0.0))
    if effect == "mesh_ripple":
        # A sin(th + phi) = A cos(phi) sin(th) + A sin(phi) cos(th)
        return replace(extra, ripple_1x=float(np.hypot(v["A1_sin"], v["A1_cos"])),
                       ripple_1x_phase=float(np.arctan2(v["A1_cos"], v["A1_sin"])),
                       ripple_roller=float(np.hypot(v["Az_sin"], v["Az_cos"])),
                       ripple_roller_phase=float(np.arctan2(v["Az_cos"], v["Az_sin"])))
    if effect == "thermal_drift":
        return replace(extra, thermal_loss_change=v["loss_change"], thermal_tau=shape)
    return extra
