"""Load-independent losses (physical profile, losses = "all"): the support bearings of the
shafts, the shaft seals and the grease drag of the eccentric bearings.

The paper keeps only load-dependent losses and blames part of its 1.76-1.92 % gap between
theory and experiment on these (Section 5). Each is a named partial loss in W:

- ``PL_support``: two deep-groove ball bearings on each rotating shaft, by the SKF 2014
  frictional-moment model (the model of the eccentric bearing, ``friction.skf_frictional_moment``)
  with the deep-groove ball bearing's terms (``friction.skf_ball_frictional_moment``) at a
  constant radial load SUPPORT_RADIAL_LOAD (SKF, Rolling bearings, PUB BU/P1 10000/2 EN (2014),
  "Friction"). Until 2026-11 Palmgren's M0 with f0 = 0.75 was used, 2.4-6 times more.
- ``PL_churn``: the grease sheared between the orbiting cycloid gears' faces and their
  neighbours (disc, housing, the other gear): Couette flow P = eta v^2 A / h per face, with v =
  e |w2 - wS| the gear's translation speed relative to the disc (Petroff's film argument; the
  eccentric bearings' own viscous rolling loss is already in PL1 through SKF's M_rr, and SKF
  neglects M_drag for grease lubrication).
- ``PL_seal``: radial lip seals on the input and output shafts (design ``seals = "lip"``, the
  default; zero with ``"none"``), frictional power
  P = SEAL_POWER_COEFF d^2 n [W; d mm, n r/min] (the rule of thumb of the seal makers'
  catalogues, e.g. Freudenberg Simrit, Technical Manual, radial shaft seals, frictional power
  chart, for a greased seal on a ground steel shaft).

Every dimension here is an **assumption** (the paper shows the bench in a photograph only),
named as a module constant with its reason.
"""
from __future__ import annotations

import numpy as np

from .kinematics import rad_s_to_rpm

#: Names of the load-independent partial losses.
IDLE_NAMES = ("PL_support", "PL_seal", "PL_churn")
IDLE_DESCRIPTIONS = {
    "PL_support": "support bearings of the shafts (load-independent)",
    "PL_seal": "shaft lip seals",
    "PL_churn": "grease sheared at the orbiting gears' faces",
}

#: Support bearings per rotating shaft: (bore, outside diameter) [m], two each.
#: **Assumption**: input shaft S on two 6004 (20 x 42 mm), output shafts 1 and 2 on two 6006
#: (30 x 55 mm): light series for a 250 W drive.
SUPPORT_BEARINGS = {"S": (0.020, 0.042), "1": (0.030, 0.055), "2": (0.030, 0.055)}
#: [N] radial load on each support bearing. **Assumption**: 50 N, the couple of the two
#: gears' eccentric-bearing forces (about 250 N each at the middle of the bench's torque band,
#: 13 mm apart) reacted by two bearings about 60 mm apart; taken constant, so the support
#: losses stay load-independent (their growth with load, F^0.54, is not modelled).
SUPPORT_RADIAL_LOAD = 50.0
#: SKF geometry constants of deep-groove ball bearings of series 60 (6004, 6006) [1]:
#: R1 = 4.1e-7, S1 = 3.73e-3 (SKF 2014, table of geometry constants for rolling and sliding
#: frictional moments; **not verified against the printed catalogue in this project**: a
#: reviewer should check them), K_Z = 3.1 (deep-groove ball bearings), mu_EHL = 0.05 (mineral
#: base oil); K_rs (grease) and mu_bl as for the eccentric bearing (Friction.skf_Krs,
#: Friction.skf_mu_bl).
SKF_BALL_R1 = 4.1e-7
SKF_BALL_S1 = 3.73e-3
SKF_BALL_KZ = 3.1
SKF_BALL_MU_EHL = 0.05
#: Gap between a gear face and its neighbour [m]. **Assumption**: 0.5 mm, an axial play
#: typical of small reducers.
FACE_GAP = 0.5e-3
#: Gear faces running in grease [1]. **Assumption**: 4, both faces of both gears.
N_FACES = 4
#: Shaft diameters at the lip seals [m]. **Assumption**: one seal on S at 20 mm, one on each
#: output shaft at 30 mm (the held shaft's seal does not move).
SEAL_DIAMETERS = {"S": 0.020, "1": 0.030, "2": 0.030}
#: Seal frictional power coefficient [W/(mm^2 r/min)]. **Assumption**: 7.7e-6 (about 8.6 W at
#: 20 mm and 2800 r/min, 0.03 N*m), the middle of the seal makers' charts for NBR lip seals.
SEAL_POWER_COEFF = 7.7e-6


#: Shaft speed [rad/s] below which the drag's torque is taken proportional to the speed,
#: T = M w / DRAG_SIGN_SPEED, instead of M sign(w). **Assumption**, a regularisation of the
#: sign of a Coulomb-like moment (seals, Palmgren's M0 at nu n < 2000) for time-stepping
#: hosts, which cannot resolve the stiction at a standstill: 1 rad/s (about 10 r/min), below
#: 2 % of the bench's lowest test speed (500 r/min at the input, 33 r/min at the output), so
#: steady operating points do not see it.
DRAG_SIGN_SPEED = 1.0


def drag_sign(w):
    """sign(w), linear within +-DRAG_SIGN_SPEED [rad/s] (see there): continuous through a
    standstill."""
    return np.clip(np.asarray(w, float) / DRAG_SIGN_SPEED, -1.0, 1.0)


def support_bearing_moment(design, speed, d, D, nu):
    """Frictional moment [N*m] of one support bearing (bore d, outside D [m]) turning at
    ``speed`` [rad/s] in grease of kinematic viscosity nu [m^2/s]: the SKF model at
    SUPPORT_RADIAL_LOAD (see module note)."""
    from .friction import skf_ball_frictional_moment
    fr = design.friction
    return skf_ball_frictional_moment(SUPPORT_RADIAL_LOAD, speed, d, D, nu, SKF_BALL_R1,
                                      SKF_BALL_S1, SKF_BALL_KZ, fr.skf_Krs, fr.skf_mu_bl,
                                      SKF_BALL_MU_EHL)


def idle_torques(design, speeds, nu):
    """Torques [N*m] the outside must apply on each shaft to keep it turning against the
    load-independent drag, per partial loss.

    Parameters
    ----------
    design : DriveDesign
    speeds : dict
        Shaft speeds {"1", "2", "S": rad/s} (scalars or arrays, signed).
    nu : float
        Kinematic viscosity of the grease [m^2/s].

    Returns
    -------
    dict
        ``{name: {"1": T1, "2": T2, "S": TS}}`` for name in IDLE_NAMES. A shaft's support
        bearings and seal act on it alone, T = sign(w) M (M twice support_bearing_moment for
        the two bearings; the
        seal's M = P/|w| = SEAL_POWER_COEFF d^2 * 60/(2 pi), constant; sign(w) is
        ``drag_sign``, linear within DRAG_SIGN_SPEED of a standstill); the grease drag acts
        between the eccentric S and the disc 2 (the orbiting gear's faces against the disc and
        housing, sheared at e |wS - w2|) as a pair, +M on S and -M on 2 with M = P/|wS - w2|.
        The held shaft's entry is the housing's reaction (its own speed is zero). The power
        sum_x T_x w_x of each entry is that loss (``idle_losses``).
    """
    zero = 0.0 * sum(np.asarray(speeds[x], float) for x in "12S")
    sup, seal = {}, {}
    for shaft, (d, D) in SUPPORT_BEARINGS.items():
        w = np.asarray(speeds[shaft], float)
        M = support_bearing_moment(design, w, d, D, nu)
        sign = drag_sign(w)
        sup[shaft] = zero + 2 * M * sign
        seal[shaft] = zero + (SEAL_POWER_COEFF * (SEAL_DIAMETERS[shaft] * 1e3) ** 2
                              * rad_s_to_rpm(1.0) * sign) * (design.seals == "lip")
    w_rel = np.asarray(speeds["S"], float) - np.asarray(speeds["2"], float)
    # face area of a gear: an annulus from the eccentric bearing's seat to the tooth root
    r_out = design.r_p - design.e - design.d_v1 / 2
    r_in = design.D_p / 2
    area = np.pi * (r_out ** 2 - r_in ** 2)
    eta = design.lubricant.density * nu
    # Couette drag P = N eta (e w_rel)^2 A / h, as a torque pair M = P / |w_rel|
    M_churn = zero + N_FACES * eta * design.e ** 2 * w_rel * area / FACE_GAP
    churn = {"1": zero, "2": -M_churn, "S": M_churn}
    return {"PL_support": sup, "PL_seal": seal, "PL_churn": churn}


def idle_losses(design, speeds, nu):
    """Load-independent losses [W] at the shaft speeds ``speeds`` {"1","2","S": rad/s} with
    the grease's kinematic viscosity nu [m^2/s]; a dict keyed IDLE_NAMES: the power
    sum_x T_x w_x of each entry of ``idle_torques``."""
    torques = idle_torques(design, speeds, nu)
    return {name: sum(t[x] * np.asarray(speeds[x], float) for x in "12S")
            for name, t in torques.items()}
