"""Friction laws: Benedict-Kelley mixed lubrication, rolling resistance, SKF bearing moment.

Each function is one physical effect, array-friendly, SI in and out unless its docstring names
the catalogue units it converts to internally.
"""
from __future__ import annotations

import numpy as np

#: Benedict-Kelley constant for W' in N/m, eta in Pa*s and speeds in m/s (29.66 with N/mm).
BK_CONSTANT_SI = 0.02966
UM_TO_MICROINCH = 39.3700787


def benedict_kelley_mu(load_per_width, eta, v_slide, v_sum, roughness, mu_boundary, mu_full_film):
    """Mixed-lubrication friction coefficient of Benedict and Kelley (1961), bounded.

        mu = 0.0127 * C_R * log10(C * W' / (eta * V_s * V_r^2)),  C_R = 50 / (50 - S)

    W' normal load per face width (N/m), eta dynamic viscosity (Pa*s), V_s sliding speed and
    V_r sum (entraining) speed (m/s), C = 0.02966 in these units; S the composite roughness in
    micro-inches as in the original (``roughness`` is given in m and converted here).

    The formula diverges as V_s -> 0 (towards boundary friction), turns negative where its
    argument drops below 1 (full film) and has a pole at S = 50 uin (rough surfaces). It is
    therefore clamped to [mu_full_film, mu_boundary], and a roughness at or above the pole
    gives mu_boundary.
    """
    s_uin = np.asarray(roughness, float) * 1e6 * UM_TO_MICROINCH
    w = np.asarray(load_per_width, float)
    vs = np.abs(np.asarray(v_slide, float))
    vr = np.abs(np.asarray(v_sum, float))
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        arg = BK_CONSTANT_SI * w / (eta * vs * vr * vr)
        c_r = 50.0 / (50.0 - s_uin)
        mu = 0.0127 * c_r * np.log10(arg)
    mu = np.where(np.isnan(mu) | (vs * vr == 0) | (c_r <= 0), mu_boundary, mu)
    return np.clip(mu, mu_full_film, mu_boundary)


def rolling_resistance_loss(coefficient, normal_force, rolling_speed):
    """Power (W) lost to rolling resistance: mu_r * F * v (Eqs. 23, 26)."""
    return coefficient * normal_force * np.abs(rolling_speed)


def sliding_loss(mu, normal_force, sliding_speed):
    """Power (W) lost to sliding friction: mu * F * v_s (Eqs. 25, 27)."""
    return mu * normal_force * np.abs(sliding_speed)


def skf_frictional_moment(radial_load, speed, d, D, nu, friction):
    """Load-dependent frictional moment M_rr + M_sl (N*m) of a cylindrical (needle) roller
    bearing, SKF rolling bearings catalogue (2014) model.

    radial_load F_r in N; speed |n| in rad/s (relative speed of the rings); bore d and outer
    diameter D in m; nu the lubricant's kinematic viscosity in m^2/s. The catalogue's units
    (N*mm, r/min, mm, mm^2/s) are used inside:

        M_rr = phi_ish * phi_rs * G_rr * (nu n)^0.6,   G_rr = R1 d_m^2.41 F_r^0.31
        phi_ish = 1 / (1 + 1.84e-9 (n d_m)^1.28 nu^0.64)            (inlet shear heating)
        phi_rs = exp(-K_rs nu n (d + D) sqrt(K_Z / (2 (D - d))))     (replenishment/starvation)
        M_sl = G_sl mu_sl,  G_sl = S2 d_m F_r  (no axial load),
        mu_sl = phi_bl mu_bl + (1 - phi_bl) mu_EHL,  phi_bl = exp(-2.6e-8 (n nu)^1.4 d_m)

    Seal and drag moments are load-independent and left out, as in the paper.
    """
    fr = friction
    n = np.abs(np.asarray(speed, float)) * 60.0 / (2 * np.pi)
    F = np.maximum(np.asarray(radial_load, float), 0.0)
    d_mm, D_mm, nu_mm = d * 1e3, D * 1e3, nu * 1e6
    dm = 0.5 * (d_mm + D_mm)
    phi_ish = 1.0 / (1.0 + 1.84e-9 * (n * dm) ** 1.28 * nu_mm ** 0.64)
    phi_rs = np.exp(-fr.skf_Krs * nu_mm * n * (d_mm + D_mm) * np.sqrt(fr.skf_Kz / (2 * (D_mm - d_mm))))
    G_rr = fr.skf_R1 * dm ** 2.41 * F ** 0.31
    M_rr = phi_ish * phi_rs * G_rr * (nu_mm * n) ** 0.6
    phi_bl = np.exp(-2.6e-8 * (n * nu_mm) ** 1.4 * dm)
    mu_sl = phi_bl * fr.skf_mu_bl + (1 - phi_bl) * fr.skf_mu_ehl
    M_sl = fr.skf_S2 * dm * F * mu_sl
    return (M_rr + M_sl) * 1e-3


def skf_ball_frictional_moment(radial_load, speed, d, D, nu, R1, S1, K_z, K_rs, mu_bl,
                               mu_ehl):
    """Frictional moment M_rr + M_sl (N*m) of a deep-groove ball bearing under a radial load
    alone, SKF rolling bearings catalogue (2014) model, the same model as
    :func:`skf_frictional_moment` with the ball bearing's load terms:

        M_rr = phi_ish * phi_rs * G_rr * (nu n)^0.6,   G_rr = R1 d_m^1.96 F_r^0.54
        M_sl = G_sl mu_sl,   G_sl = S1 d_m^-0.26 F_r^(5/3)          (F_a = 0)

    with phi_ish, phi_rs and mu_sl as there (K_z the bearing type's constant). Units as
    there: F_r in N, speed in rad/s, d and D in m, nu in m^2/s; the catalogue's N*mm, r/min,
    mm and mm^2/s inside. Seal and drag moments are left out (grease: SKF neglects M_drag)."""
    n = np.abs(np.asarray(speed, float)) * 60.0 / (2 * np.pi)
    F = np.maximum(np.asarray(radial_load, float), 0.0)
    d_mm, D_mm, nu_mm = d * 1e3, D * 1e3, nu * 1e6
    dm = 0.5 * (d_mm + D_mm)
    phi_ish = 1.0 / (1.0 + 1.84e-9 * (n * dm) ** 1.28 * nu_mm ** 0.64)
    phi_rs = np.exp(-K_rs * nu_mm * n * (d_mm + D_mm) * np.sqrt(K_z / (2 * (D_mm - d_mm))))
    M_rr = phi_ish * phi_rs * R1 * dm ** 1.96 * F ** 0.54 * (nu_mm * n) ** 0.6
    phi_bl = np.exp(-2.6e-8 * (n * nu_mm) ** 1.4 * dm)
    mu_sl = phi_bl * mu_bl + (1 - phi_bl) * mu_ehl
    M_sl = S1 * dm ** -0.26 * F ** (5.0 / 3.0) * mu_sl
    return (M_rr + M_sl) * 1e-3


#: Upper bound of any sliding coefficient the Stribeck law may return [1]: dry clean steel on
#: steel (about 0.6, Bhushan 2013, Table 9.1); reaching it means the film model has broken down,
#: and every such point is reported (StribeckMu.clamped).
MU_DRY_STEEL = 0.6


def hersey_number(eta, omega_rel, normal_force, width, diameter):
    """Hersey number H = eta N / p of a journal contact (dimensionless in SI).

    eta dynamic viscosity [Pa*s], omega_rel relative angular speed of roller and pin [rad/s]
    (N = |omega_rel|/(2 pi) in rev/s), p = F/(b d) the projected pressure [Pa] of the normal
    force F [N] on the pin of width b [m] and diameter d [m] (Shigley, Sec. 12-3).
    """
    F = np.maximum(np.asarray(normal_force, float), 1e-12)
    p = F / (width * diameter)
    return eta * np.abs(np.asarray(omega_rel, float)) / (2 * np.pi) / p


def stribeck_pin_mu(hersey, mu_boundary, hersey_transition, clearance_ratio):
    """Friction coefficient of a plain roller on its greased pin over the Stribeck curve.

    .. math::

        \\mu = \\mu_{bl} \\exp(-H / H_t) + 2 \\pi^2 H (r/c)

    The boundary term fades as the Hersey number H = eta N/p passes the thick-film limit H_t
    (McKee's journal tests, Shigley Fig. 12-4); the second is Petroff's law of a concentric
    journal (Shigley Eq. 12-6), the viscous shear of the full film with radial clearance c over
    radius r. The sum has the Stribeck curve's shape: boundary value at standstill or high load,
    a minimum near H_t, rising with H in the full film. Bounded above by MU_DRY_STEEL.

    Returns (mu, clamped) where clamped marks the points where the upper bound binds.

    References: R. Stribeck, Z. VDI 46 (1902); M. D. Hersey, J. Wash. Acad. Sci. 4 (1914);
    R. G. Budynas, J. K. Nisbett, Shigley's Mechanical Engineering Design, 10th ed., Sec. 12-3
    to 12-8.
    """
    H = np.asarray(hersey, float)
    mu = mu_boundary * np.exp(-H / hersey_transition) + 2 * np.pi ** 2 * H / clearance_ratio
    clamped = mu > MU_DRY_STEEL
    return np.minimum(mu, MU_DRY_STEEL), clamped


def roll_or_skid(mu_tooth, mu_pin, r_pin, r_roller, rolling_term=0.0):
    r"""Whether a plain roller rolls on the tooth (True) or skids (False).

    A roller turning on its pin needs the friction moment mu_pin F r_pin (plus its rolling
    resistance, ``rolling_term`` = mu_r r_roller v_roll/v_s in units of F) from the tooth's
    traction, at most mu_tooth F r_roller. It rolls (and its bore slides on the pin) where

    .. math:: \mu_{tooth} r_{roller} > \mu_{pin} r_{pin} + \mu_r r_{roller} v_{roll}/v_s

    and otherwise stays still on its pin and skids on the tooth. Multiplied by v_s/r_roller
    this is: the traction's power exceeds the rolling roller's dissipation, so the roller takes
    the regime of lower dissipation and the loss is continuous at the switch (derived;
    Sensinger 2013, J. Mech. Des. 135:071006, for fixed versus rolling pins).
    """
    return np.asarray(mu_tooth) * r_roller > np.asarray(mu_pin) * r_pin + rolling_term * 1.0


def ring_friction_arm_ratio(phi, force, mu_eff, e, z1, lam, r_c):
    """rho_1: the moment of the tooth-contact friction forces about the ring centre over that of
    the normal forces, for ring rollers at phi (rad from the line of centres, pitch-point side)
    carrying normal forces ``force`` [N] with effective tangential coefficients ``mu_eff``
    (mu_tooth when a roller skids, mu_pin r_pin/r_roller when it rolls); rollers on the last
    axis.

    Friction in the force balance (derived). With the ring centre O1 at the origin, the gear
    centre O2 = (e, 0), the pitch point P = (e z1, 0) and a roller centre D = r_p (cos phi,
    sin phi), the normal n = (P - D)/|DP| passes through P and the tooth contact C = D + r_c n.
    The friction force mu N t (t perpendicular to n) opposes the gear's motion relative to the
    ring at C, a rotation about P. Its moment about O1 is mu N (C - O1).n, that of the normal
    force N e z1 |n_y| = N r_p sin(phi)/S_l, so

    .. math::

        \\rho_1 = \\frac{\\sum \\mu_i N_i (e z_1 S_l - r_c - e z_1 (1 - \\lambda \\cos\\phi)/S_l)}
                       {\\sum N_i r_p \\sin\\phi / S_l}

    A known ring torque T1 then needs the normal forces N_0/(1 - rho_1) when the ring drives
    in the relative motion and N_0/(1 + rho_1) when it is driven (N_0 frictionless); the same
    torque balance on the gear gives the mesh efficiency (1 - rho_2)/(1 - rho_1) driving and
    (1 + rho_1)/(1 + rho_2) driven, and their losses equal sum mu N v_s (checked in the tests).
    """
    S = np.sqrt(1 + lam * lam - 2 * lam * np.cos(phi))
    r_p = lam * e * z1
    F = np.maximum(np.asarray(force, float), 0.0)
    arm_f = e * z1 * S - r_c - e * z1 * (1 - lam * np.cos(phi)) / S
    arm_n = r_p * np.sin(phi) / S
    num = (mu_eff * F * arm_f).sum(-1)
    den = (F * arm_n).sum(-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(den > 0, num / np.where(den > 0, den, 1.0), 0.0)


def reversal_sign(w, w_r):
    """Sign of a friction torque through a reversal of the sliding speed, regularised over a
    transition width: the velocity-regularised Coulomb law.

        s(w) = tanh(w / w_r)   for w_r > 0,      s(w) = sign(w)   for w_r = 0

    Real friction does not jump when the speed changes sign: the contact first deforms
    elastically (pre-sliding, a micro-displacement of micrometres), and the friction torque
    follows the displacement (Dahl 1968) before gross sliding sets in (Armstrong-Helouvry,
    Dupont and Canudas de Wit 1994). Seen against the speed, the torque passes through zero
    over a band of speeds whose width depends on the contact's stiffness and on how fast the
    reversal is run; tanh(w/w_r) is the standard velocity-regularised stand-in for it
    (Andersson, Soderberg and Bjorklund 2007). ``w_r -> 0`` is the sharp Coulomb sign; s is
    odd in w, |s| <= 1, and s w >= 0, so a torque T_0 s(w) with T_0 >= 0 always dissipates.

    Parameters
    ----------
    w : array_like
        Sliding (here: driving shaft) speed [rad/s], signed.
    w_r : float
        Transition width [rad/s], 0 or more: at |w| = w_r the sign has reached
        tanh(1) = 76 %, at 3 w_r 99.5 %.

    Returns
    -------
    numpy.ndarray
        s(w) [1], in [-1, 1], the shape of w.

    References
    ----------
    P. R. Dahl, "A solid friction model", Aerospace Corp. TOR-0158(3107-18)-1, 1968.
    B. Armstrong-Helouvry, P. Dupont, C. Canudas de Wit, "A survey of models, analysis tools
    and compensation methods for the control of machines with friction", Automatica 30 (1994)
    1083-1138.
    S. Andersson, A. Soderberg, S. Bjorklund, "Friction models for sliding dry, boundary and
    mixed lubricated contacts", Tribology International 40 (2007) 580-587.
    """
    w = np.asarray(w, float)
    if not w_r > 0:
        if w_r != 0:
            raise ValueError(f"reversal_sign: the transition width w_r must be 0 or more, "
                             f"got {w_r!r} rad/s")
        return np.sign(w)
    return np.tanh(w / w_r)


def loss_transition(w, w_c):
    """Share of the kinetic losses a drive has built up at driving speed w: the transition of
    the whole friction through standstill.

        s(w) = tanh(|w| / w_c)   for w_c > 0,      s(w) = 1   for w_c = 0

    The model's losses take their full value at any speed above zero; a real drive's friction
    builds up over a band of speeds above standstill (pre-sliding of every contact: pins,
    rollers, bearings and seals alike; Dahl 1968, Armstrong-Helouvry et al. 1994): the loss
    torque passes through zero with the speed. ``s`` is :func:`reversal_sign` of |w| (the
    same regularised sign, applied to the whole loss rather than the Stribeck term alone);
    ``w_c -> 0`` is the model (s = 1 wherever w != 0, and at w = 0 too, where the model's
    own loss stands). 0 <= s <= 1 and s is even in w: the loss torque s L keeps the sign of
    L, so a dissipative loss stays dissipative.

    Parameters
    ----------
    w : array_like
        Driving shaft speed [rad/s], signed.
    w_c : float
        Transition width [rad/s], 0 or more: at |w| = w_c the loss has reached tanh(1) = 76 %
        of its value, at 3 w_c 99.5 %.

    Returns
    -------
    numpy.ndarray
        s(w) [1], in [0, 1], the shape of w.

    References
    ----------
    P. R. Dahl, "A solid friction model", Aerospace Corp. TOR-0158(3107-18)-1, 1968.
    B. Armstrong-Helouvry, P. Dupont, C. Canudas de Wit, Automatica 30 (1994) 1083-1138.
    """
    w = np.asarray(w, float)
    if w_c == 0:
        return np.ones(w.shape)
    return reversal_sign(np.abs(w), w_c)
