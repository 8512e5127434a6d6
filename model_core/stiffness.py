r"""Torsional stiffness, lost motion and hysteresis of the drive, from its contact model.

A catalogue (Nabtesco RV, Sumitomo Fine Cyclo) states the torsional behaviour of a reducer with
its input locked: the output is twisted by a torque and its angle of twist measured. In the
model the twist of the output relative to the ring (input shaft S locked, ring 1 fixed) is the
rotation of the cycloid gear against the ring rollers plus the rotation of the disc against the
gear at the disc rollers, each the rotation ``rot`` that the contact compliance solver of
:mod:`model_core.contact` finds for the gear's torque:

.. math::

    T_c = \sum_i l_i\, Q(l_i\,\mathrm{rot} - \Delta_i), \qquad
    \varphi(T) = \overline{\mathrm{rot}_\mathrm{ring}(s T) + \mathrm{rot}_\mathrm{disc}(s T)}

with s the gear's torque share and the bar the mean over the mesh positions of a cycle. The
clearances Delta (the profile correction delta_z and the pin clearance at the ring rollers, the
hole and pin clearance at the disc rollers, the eccentric bearing's internal clearance) give
the lost motion; the contacts, pins, bearing and shafts in series the stiffness.

**Elements in series** (springs in series add their compliances; Roark's Formulas for
Stress and Strain, 7th ed.): at every roller its Hertz contact (Palmgren's law) and its pin, a
beam simply supported over both gears' rollers (bending and Timoshenko shear) with a normal gap
(profile correction or hole clearance, plus the roller's clearance on its pin); the eccentric
needle bearing (its radial internal clearance, then Palmgren contacts of its most loaded
needle; only the tangential component F_EV = T_c/(e z_c) of its deflection turns the output);
the output shaft and the input shaft (torsion, the latter reflected by 1/z_c^2). Not held: the
gear's web and teeth bending, the ring housing, the support bearings (their deflection does
not twist the output to first order), the transducers and couplings of a bench.

**Assumptions.** The gear with the larger torque share is the one measured. The hysteresis
loop takes the contacts' friction as the mesh's own: twisting in (loading) the applied torque
is :math:`T_{el}/\eta_m`, letting go (unloading) :math:`T_{el}\,\eta_m`, with
:math:`\eta_m` the basic efficiency eta0 of mode 21 (ring fixed, output driven) at a creeping
speed, as the efficiency model computes it.

References
----------
Nabtesco, *Precision reduction gear RV series*, catalogue: torsional rigidity (the slope
between 50 % and 100 % of the rated torque), lost motion (the twist band at +-3 % of the rated
torque), hysteresis curve. Sumitomo Drive Technologies, *Fine Cyclo* catalogue: the same
definitions.
"""
from __future__ import annotations

import functools
import math

import numpy as np

from . import contact, geometry
from .losses import mesh_positions

RAD_TO_ARCMIN = 180.0 * 60.0 / math.pi
#: [1] lost motion is the twist band at +- this share of the rated torque (catalogue definition)
LOST_MOTION_SHARE = 0.03
#: [1] torsional rigidity is the secant between these shares of the rated torque (catalogue)
RIGIDITY_SHARES = (0.5, 1.0)
#: [rad/s] the creeping input speed at which the mesh friction of the hysteresis loop is taken
CREEP_SPEED = 1.0
#: [N*m] the paper's motor: 250 W at 2800 r/min gives 0.853 N*m
PAPER_MOTOR_TORQUE = 250.0 / (2800.0 * math.pi / 30.0)
#: [Pa] Young's modulus of steel (the paper's C45)
STEEL_E = 210e9
#: [Pa] shear modulus of steel, E / (2 (1 + 0.3))
STEEL_G = STEEL_E / 2.6
#: [1] Timoshenko shear coefficient of a round section, 6 (1 + nu) / (7 + 6 nu) at nu = 0.3
#: (Cowper, J. Appl. Mech. 33 (1966) 335)
SHEAR_COEFFICIENT_ROUND = 6 * 1.3 / (7 + 6 * 0.3)
#: [Pa] yield strength of pins and shafts. **Assumption**: 1000 MPa, C45 hardened and tempered
#: to 40 HRC as the paper's gear and shafts (Section 5): 40 HRC is about 1250 MPa tensile
#: strength (ISO 18265 conversion), a yield ratio of 0.8 for quenched and tempered steel.
YIELD_STRENGTH = 1000e6
#: [m] needle diameter D_we of the eccentric bearing. **Assumption**: 2.5 mm, a drawn cup of
#: 25 mm raceway and 32 mm outside diameter (D_p of Table 3) has a 3.5 mm section: 1 mm shell.
NEEDLE_DIAMETER = 2.5e-3
#: [1] needles of the eccentric bearing. **Assumption**: 24, a caged complement at a pitch of
#: about 1.4 D_we on the 27.5 mm pitch circle.
NEEDLE_COUNT = 24
#: [m] effective needle length L_we. **Assumption**: 10 mm in a 12 mm wide cup (the gear's
#: width b1 = 12 mm, HK2512).
NEEDLE_LENGTH = 10e-3


def rated_torque(design) -> float:
    """Rated output torque [N*m]. **Assumption**: the paper's drive is rated by the bench motor
    that drives it (0.853 N*m at the eccentric shaft) times the ratio z1 - 1 (mode S2 driving
    the disc): 11.9 N*m for the paper's drive. Catalogue drives state it; pass yours."""
    return PAPER_MOTOR_TORQUE * (design.z1 - 1)


def _stiff(design, width):
    return (design.linear_stiffness if design.contact_law == "linear"
            else contact.palmgren_stiffness(width))


# -- elements in series with the contacts --------------------------------------------------
def round_section(d):
    """(area A [m^2], second moment I [m^4], section modulus W [m^3]) of a round bar of
    diameter d [m]: pi d^2/4, pi d^4/64, pi d^3/32."""
    return math.pi * d ** 2 / 4, math.pi * d ** 4 / 64, math.pi * d ** 3 / 32


def simply_supported_compliance(a, span, d, E=STEEL_E, G=STEEL_G):
    r"""Deflection per force [m/N] at the load point of a round beam of diameter d [m], simply
    supported over ``span`` [m], loaded by a point force at ``a`` [m] from one support:

    .. math:: c = \frac{a^2 b^2}{3 E I L} + \frac{a b}{\kappa G A L}, \qquad b = L - a

    bending (Roark's Formulas for Stress and Strain, 7th ed., Table 8.1 case 1e, deflection at
    the load) plus the Timoshenko shear deflection (kappa = SHEAR_COEFFICIENT_ROUND)."""
    A, I, _ = round_section(d)
    b = span - a
    return a ** 2 * b ** 2 / (3 * E * I * span) + a * b / (SHEAR_COEFFICIENT_ROUND * G * A * span)


def pin_span(design, width):
    """(load position a, span L) [m] of a pin carrying the rollers of both gears side by side:
    span 2 b + 3 gap, each gear's roller load at its roller's middle, a = gap + b/2 (the two
    gears' loads are symmetric, so both see the same compliance)."""
    g = design.pin_end_gap
    return g + width / 2, 2 * width + 3 * g


def pin_compliance(design, which):
    """Deflection per force [m/N] of a ring ("ring") or disc ("disc") pin at its roller."""
    b, d = (design.b1, design.d_o1) if which == "ring" else (design.b2, design.d_o2)
    a, L = pin_span(design, b)
    return simply_supported_compliance(a, L, d)


def pin_gap(design, which):
    """Normal gap [m] per side between a roller and its pin: a plain roller's journal
    clearance friction.pin_clearance_ratio * d_pin / 2 (the clearance of the Stribeck law, one
    value for both uses), a needle roller's half radial internal clearance
    bearing_clearance / 2."""
    kind, d = ((design.ring_rollers, design.d_o1) if which == "ring"
               else (design.disc_rollers, design.d_o2))
    if kind == "needle":
        return design.bearing_clearance / 2
    return design.friction.pin_clearance_ratio * d / 2


def needle_pitch_diameter(design):
    """Pitch diameter D_pw [m] of the eccentric bearing's needles: d_p + D_we."""
    return design.d_p + NEEDLE_DIAMETER


def eccentric_bearing_C0(design):
    r"""Basic static radial load rating C0r [N] of the eccentric needle bearing by ISO 76:2006
    (roller bearings): :math:`C_{0r} = 44 (1 - D_{we}/D_{pw})\, Z L_{we} D_{we}` (N, mm),
    with the needle complement NEEDLE_DIAMETER, NEEDLE_COUNT, NEEDLE_LENGTH (assumptions)."""
    Dwe, Dpw = NEEDLE_DIAMETER * 1e3, needle_pitch_diameter(design) * 1e3
    return 44.0 * (1 - Dwe / Dpw) * NEEDLE_COUNT * NEEDLE_LENGTH * 1e3 * Dwe


def eccentric_bearing_deflection(design, force):
    r"""Radial deflection [m] of the eccentric needle bearing under a radial force [N], from
    the clearance closed: the most loaded needle carries :math:`Q = 4.08 F_r / Z` (Stribeck's
    constant for line contact, zero clearance; Harris & Kotzalas, Rolling Bearing Analysis,
    5th ed., Sec. 7.2) and deforms at its two raceways by Palmgren's line-contact law
    (:func:`model_core.contact.palmgren_stiffness` over NEEDLE_LENGTH each)."""
    Q = 4.08 * np.abs(np.asarray(force, float)) / NEEDLE_COUNT
    K = contact.palmgren_stiffness(NEEDLE_LENGTH)
    return 2 * (Q / K) ** 0.9


def _series_force(d, K, law, c, start=None):
    """Force Q >= 0 [N] of a contact of law (K, law) in series with a linear spring of
    compliance c [m/N] under a total approach d [m]: delta_contact(Q) + c Q = d. ``start``:
    forces to start Newton's iteration from (a neighbouring solution), else the root for
    c = 0."""
    d = np.maximum(d, 0.0)
    if law == "linear":
        return d / (1.0 / K + c)
    # Palmgren: g(Q) = (Q/K)^0.9 + c Q - d, increasing and concave: Newton from the right of
    # the root steps left of it once, from the left it climbs to it monotonically (concave:
    # the tangent's zero stays left of the root), so any positive start converges
    Q = K * d ** (10.0 / 9.0)
    if c > 0:
        Q = np.minimum(Q, d / c)
    if start is not None:
        Q = np.where(start > 0, start, Q)
    tiny = 1e-300
    for _ in range(60):
        Qs = np.maximum(Q, tiny)
        x = (Qs / K) ** 0.9
        g = x + c * Qs - d
        dg = 0.9 * x / Qs + c
        Q_new = np.maximum(Qs - g / dg, 0.0)
        if (np.abs(Q_new - Q) <= 1e-13 * np.maximum(Q_new, tiny)).all():
            Q = Q_new
            break
        Q = Q_new
    return np.where(d > 0, Q, 0.0)


def _series_slope(Q, K, law, c):
    """dQ/dd [N/m] of :func:`_series_force` at its solution Q (0 where the contact is open)."""
    if law == "linear":
        return np.full(np.shape(Q), 1.0 / (1.0 / K + c))
    Qs = np.where(Q > 0, Q, 1.0)
    return np.where(Q > 0, 1.0 / (0.9 * (Qs / K) ** 0.9 / Qs + c), 0.0)


def _contact_deformation(Q, K, law):
    return Q / K if law == "linear" else (np.maximum(Q, 0.0) / K) ** 0.9


#: [1] relative tolerance of a roller set's rotation and torque (:func:`solve_series_set`): a
#: few rounding units. The rotation is mostly the clearance taken up, l rot - Delta its small
#: part that loads the contacts, so a tolerance on rot alone (1e-14) left the forces at a
#: vanishing torque (backlash) uncertain by 1e-6 relative
ROTATION_RTOL = 1e-15


def solve_series_set(levers, clearances, torque, K, law, c):
    """Rotation ``rot`` [rad] of a roller set whose every roller is a contact (K, law) in series
    with a linear spring c [m/N] (its pin), with normal gaps ``clearances`` [m]:
    sum_i l_i Q_i(l_i rot - Delta_i) = torque, to ROTATION_RTOL relative (rot or torque).

    The torque is increasing and convex in rot (each Q_i is a convex increasing function of
    its approach, zero while its gap is open), so Newton's iteration from an upper bound
    descends to the root monotonically; it is safeguarded by the bracket (a bisection step
    where a Newton step would leave it). A zero torque gives the rotation a bisection from
    the upper bound ends at (64 halvings). About 6 steps against the 45-50 of a bisection.

    levers, clearances: (m, n) positions x rollers; torque: (k,) [N*m] >= 0. Returns
    (rot (k, m), Q (k, m, n))."""
    l = np.where(levers > 0, levers, 0.0)[None]
    cl = np.broadcast_to(clearances, levers.shape)[None]
    T = np.asarray(torque, float)[:, None]
    # upper bound: the roller with the largest lever carries the torque alone
    m = np.argmax(l[0], axis=-1)
    l_m = l[0][np.arange(l.shape[1]), m][None]
    c_m = cl[0][np.arange(l.shape[1]), m][None]
    Qm = T / l_m
    hi = (c_m + _contact_deformation(Qm, K, law) + c * Qm) / l_m * (1 + 1e-9) + 1e-18
    hi = np.broadcast_to(hi, (T.shape[0], l.shape[1])).copy()
    zero = np.broadcast_to(T <= 0, hi.shape)
    lo = np.zeros_like(hi)
    rot = hi.copy()
    Q = None
    for _ in range(200):
        Q = _series_force(l * rot[..., None] - cl, K, law, c, Q)
        f = np.sum(l * Q, axis=-1) - T
        df = np.sum(l * l * _series_slope(Q, K, law, c), axis=-1)
        lo = np.where(f < 0, rot, lo)
        hi = np.where(f >= 0, rot, hi)
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.where(df > 0, f / df, np.inf)
        new = rot - step
        # converged: the step at the rounding of rot (the root's float, whatever share of
        # rot the clearance takes), or the torque met to the rounding of its sum
        done = ((np.abs(step) <= ROTATION_RTOL * rot) | (np.abs(f) <= ROTATION_RTOL * T)
                | zero)
        outside = ~((new > lo) & (new < hi))
        new = np.where(done, rot, np.where(outside, 0.5 * (lo + hi), new))
        rot = new
        if done.all():
            break
    # a zero torque: where the bisection from the upper bound ended (hi / 2^64, its midpoint)
    rot = np.where(zero, rot * 0.5 ** 65, rot)
    Q = np.where(l > 0, _series_force(l * rot[..., None] - cl, K, law, c), 0.0)
    return rot, Q


@functools.lru_cache(maxsize=16)
def _set_geometry_cached(design, n_positions):
    """:func:`_set_geometry` at the design's mesh positions, once per design (it depends on
    the geometry only; a sweep's design asks for it at every step of its rating and
    stiffness). The arrays are returned read-only."""
    out = _set_geometry(design, mesh_positions(design, n_positions))
    for a in out:
        a.setflags(write=False)
    return out


def _set_geometry(design, psi):
    phi = contact.loaded_half_angles(psi, design.z1)
    l_r = geometry.ring_roller_levers(phi, design.e, design.z1, design.lam)
    c_r = geometry.modification_clearance(phi, design.lam, design.delta_z,
                                          design.profile_modification) + pin_gap(design, "ring")
    theta = contact.loaded_half_angles(psi, design.n_disc_rollers)
    l_d = geometry.disc_roller_levers(theta, design.r_w)
    c_d = np.full_like(l_d, geometry.hole_clearance(design.D_cz, design.d_v2, design.e)
                       + pin_gap(design, "disc"))
    return phi, l_r, c_r, l_d, c_d


def gear_path(design, gear_torque, n_positions=None):
    """The load path of one gear at gear torques T_c [N*m] (k,): roller forces and the twist
    of the output split by element.

    Returns a dict with ``parts`` {element: twist [rad] (k,)} (means over the mesh positions;
    they add up to the gear's twist), ``F_ring`` (k, m, n1), ``F_disc`` (k, m, n2), ``F_E``
    (k, m) the eccentric-bearing force magnitude [N] and the angles ``phi``."""
    T = np.atleast_1d(np.abs(np.asarray(gear_torque, float)))
    phi, l_r, c_r, l_d, c_d = _set_geometry_cached(design, n_positions)
    law = design.contact_law
    parts = {}
    forces = {}
    for name, l, cl, width, c_pin in (("ring", l_r, c_r, design.b1, pin_compliance(design, "ring")),
                                      ("disc", l_d, c_d, design.b2, pin_compliance(design, "disc"))):
        K = _stiff(design, width)
        rot, Q = solve_series_set(l, cl, T, K, law, c_pin)
        lpos = np.where(l > 0, l, 0.0)[None]
        # torque weights v_i = l_i Q_i / T_c, summing to 1 (all 0 at zero torque)
        T_safe = np.where(T > 0, T, 1.0)[:, None, None]
        v = np.where((lpos > 0) & (T[:, None, None] > 0), lpos * Q / T_safe, 0.0)
        inv_l = np.where(lpos > 0, 1.0 / np.where(lpos > 0, lpos, 1.0), 0.0)
        gap = np.sum(v * np.broadcast_to(cl, Q.shape) * inv_l, -1)
        hertz = np.sum(v * _contact_deformation(Q, K, law) * inv_l, -1)
        pin = np.sum(v * c_pin * Q * inv_l, -1)
        # (rot = gap + hertz + pin at every position, to the bisection's tolerance)
        parts[f"{name}_clearance"] = gap.mean(-1)
        parts[f"{name}_contact"] = hertz.mean(-1)
        parts[f"{name}_pins"] = pin.mean(-1)
        forces[name] = Q
    parts["ring_clearance"] = parts["ring_clearance"] + free_rotation(design)
    F_EV, F_EH = contact.eccentric_bearing_force(design, phi, forces["ring"], forces["disc"])
    F_E = np.hypot(F_EV, F_EH)
    # the tangential component F_EV = T_c / (e z_c) (Eq. 19) carries the input torque: its
    # share of the bearing's deflection turns the gear as the eccentric would
    with np.errstate(invalid="ignore", divide="ignore"):
        u_t = np.where(F_E > 0, eccentric_bearing_deflection(design, F_E) * np.abs(F_EV) / F_E, 0.0)
    ez = design.e * (design.z1 - 1)
    parts["eccentric_bearing_clearance"] = np.full(T.shape, design.bearing_clearance / 2 / ez)
    parts["eccentric_bearing"] = u_t.mean(-1) / ez
    return {"parts": parts, "F_ring": forces["ring"], "F_disc": forces["disc"], "F_E": F_E,
            "phi": phi}


def shaft_twists(design, output_torque):
    r"""Torsion [rad] of the output shaft and of the input shaft (reflected to the output) at
    output torques T [N*m]: :math:`T L / (G J)` and :math:`T L_S / (G J_S z_c^2)`, J = pi d^4/32
    (the input shaft carries T / z_c and its twist appears z_c times smaller at the output)."""
    T = np.abs(np.asarray(output_torque, float))
    J_out = math.pi * design.output_shaft_diameter ** 4 / 32
    J_in = math.pi * design.input_shaft_diameter ** 4 / 32
    zc = design.z1 - 1
    return {"output_shaft": T * design.output_shaft_length / (STEEL_G * J_out),
            "input_shaft": T * design.input_shaft_length / (STEEL_G * J_in * zc ** 2)}


def _share(design):
    return max(design.torque_share, 1.0 - design.torque_share)


def free_rotation(design) -> float:
    r"""Rigid rotation [rad] of the gear against the ring rollers that closes the first contact
    of the corrected profile: :math:`\delta_z / (e (z_1 - 1))`, the gap the profile correction
    leaves at the roller with the largest lever arm (the pitch radius of the gear; exact for
    the equidistant correction, whose normal gap is delta_z at every roller; for the offset
    correction an approximation)."""
    return design.delta_z / (design.e * (design.z1 - 1))


def twist_parts(design, output_torque, n_positions=None) -> dict:
    """The output's twist [rad] at output torques T [N*m] (>= 0) split by element, each (k,):
    ring_clearance, ring_contact, ring_pins, disc_clearance, disc_contact, disc_pins,
    eccentric_bearing_clearance, eccentric_bearing (the gear with the larger torque share),
    output_shaft, input_shaft (the whole torque). Their sum is :func:`twist`."""
    T = np.atleast_1d(np.abs(np.asarray(output_torque, float)))
    parts = gear_path(design, _share(design) * T, n_positions)["parts"]
    parts.update(shaft_twists(design, T))
    return parts


def twist(design, output_torque, n_positions=None) -> np.ndarray:
    """Angle of twist [rad] of the output against the locked input for output torques [N*m].

    Odd in the torque; at zero torque the middle of the dead band (0). Elements in series
    (springs in series: their compliances add): the gear with the larger torque share (its
    clearances, Hertz contacts and pins per roller, its eccentric bearing), then the shafts."""
    T = np.atleast_1d(np.asarray(output_torque, float))
    out = np.zeros_like(T)
    nz = T != 0
    if nz.any():
        parts = twist_parts(design, T[nz], n_positions)
        out[nz] = np.sign(T[nz]) * sum(parts.values())
    return out.reshape(np.shape(output_torque))


def backlash(design, n_positions=None) -> float:
    """Backlash [rad]: the twist band at vanishing torque (both contact sets' clearances taken
    up, the mean over mesh positions), 2 x twist(0+)."""
    tiny = 1e-9 * rated_torque(design)
    return float(2 * twist(design, tiny, n_positions))


def torsional_stiffness(design, torque=None) -> float:
    """Tangent torsional stiffness dT/dphi [N*m/rad] at an output torque (default the rated
    torque), by a central difference of :func:`twist` (0.01 % of the torque)."""
    T = rated_torque(design) if torque is None else float(torque)
    h = 1e-4 * T
    return float(2 * h / (twist(design, T + h) - twist(design, T - h)))


def mesh_efficiency(design, torque) -> float:
    """eta0 of mode 21 (ring fixed, output driven, input locked) at a creeping speed and the
    given output torque: the friction share of the hysteresis loop."""
    from .efficiency import operating_point
    op = operating_point(design, "21", CREEP_SPEED, T_in=abs(float(torque)))
    eta0 = float(np.asarray(op.eta0))
    return eta0 if math.isfinite(eta0) and 0 < eta0 <= 1 else 1.0


def hysteresis_loop(design, torque_max=None, n=81) -> dict:
    """The hysteresis curve of a +-``torque_max`` cycle (default the rated torque): twist [rad]
    on the loading and the unloading branch over the applied torque [N*m].

    Loading (twisting further), the applied torque overcomes the elastic torque and the mesh
    friction: T = T_el / eta_m; unloading, the friction holds part of it: T = T_el eta_m."""
    Tm = rated_torque(design) if torque_max is None else float(torque_max)
    eta = mesh_efficiency(design, Tm)
    T_el = np.linspace(-Tm, Tm, n)
    phi = twist(design, T_el)
    load = np.where(T_el >= 0, T_el / eta, T_el * eta)      # torque rising through the loop
    unload = np.where(T_el >= 0, T_el * eta, T_el / eta)    # torque falling
    return {"twist_rad": phi, "torque_loading_Nm": load, "torque_unloading_Nm": unload,
            "eta_mesh": eta}


ELEMENT_DESCRIPTIONS = {
    "ring_clearance": "profile correction and ring rollers' clearance on their pins",
    "ring_contact": "Hertz contacts tooth - ring roller",
    "ring_pins": "ring pins (bending and shear)",
    "disc_clearance": "hole clearance and disc rollers' clearance on their pins",
    "disc_contact": "Hertz contacts hole - disc roller",
    "disc_pins": "disc (output) pins (bending and shear)",
    "eccentric_bearing_clearance": "eccentric needle bearing's internal clearance",
    "eccentric_bearing": "eccentric needle bearing (needle contacts)",
    "output_shaft": "output shaft torsion",
    "input_shaft": "input (eccentric) shaft torsion, reflected",
}


def catalogue_values(design, rated=None) -> dict:
    """What a catalogue states, from the series model.

    Returns ``rated_torque_Nm``, ``torsional_rigidity_Nm_per_arcmin`` (secant between 50 % and
    100 % of the rated torque), ``lost_motion_arcmin`` (twist band at +-3 % of the rated
    torque), ``backlash_arcmin``, ``twist_at_rated_arcmin``, ``hysteresis_loss_arcmin`` (width
    of the loop at zero torque), ``stiffness_Nm_per_rad`` (tangent at the rated torque),
    ``elements`` (per element: its twist at the rated torque, its share of the rigidity's
    compliance and of the lost motion) and ``static_rating`` (:func:`static_torque_rating`)."""
    TR = rated_torque(design) if rated is None else float(rated)
    a, b = RIGIDITY_SHARES
    T3 = LOST_MOTION_SHARE * TR
    parts = twist_parts(design, [a * TR, b * TR, T3])
    phi_a, phi_b, phi_3 = (sum(parts.values())[i] for i in range(3))
    lm = 2 * float(phi_3)
    loop = hysteresis_loop(design, TR)
    bl = backlash(design)
    d_phi = phi_b - phi_a
    elements = {name: {"description": ELEMENT_DESCRIPTIONS[name],
                       "twist_at_rated_arcmin": float(v[1]) * RAD_TO_ARCMIN,
                       "rigidity_compliance_share": float((v[1] - v[0]) / d_phi),
                       "lost_motion_arcmin": 2 * float(v[2]) * RAD_TO_ARCMIN}
                for name, v in parts.items()}
    return {"rated_torque_Nm": TR,
            "torsional_rigidity_Nm_per_arcmin": (b - a) * TR / (d_phi * RAD_TO_ARCMIN),
            "lost_motion_arcmin": lm * RAD_TO_ARCMIN,
            "backlash_arcmin": bl * RAD_TO_ARCMIN,
            "twist_at_rated_arcmin": float(phi_b) * RAD_TO_ARCMIN,
            "hysteresis_loss_arcmin": bl * RAD_TO_ARCMIN,
            "stiffness_Nm_per_rad": torsional_stiffness(design, TR),
            "eta_mesh": loop["eta_mesh"],
            "elements": elements,
            "static_rating": static_torque_rating(design)}


#: [Pa] static limit of the Hertz pressure of the roller contacts (ISO 76, see
#: model_core.contact.STATIC_CONTACT_PRESSURE_LIMIT)
STATIC_CONTACT_PRESSURE_LIMIT = contact.STATIC_CONTACT_PRESSURE_LIMIT
#: [1] static safety factor s0 of the eccentric bearing at its rating: 1, the load equal to C0
#: (ISO 76 defines C0 as the load of a permanent deformation of 1e-4 D_we, the same criterion
#: as the 4000 MPa of the roller contacts)
STATIC_SAFETY_BEARING = 1.0

RATING_DESCRIPTIONS = {
    "ring_contact": "Hertz pressure tooth - ring roller reaches 4000 MPa (ISO 76)",
    "disc_contact": "Hertz pressure hole - disc roller reaches 4000 MPa (ISO 76)",
    "ring_pins": "bending stress of the most loaded ring pin reaches the yield strength",
    "disc_pins": "bending stress of the most loaded disc pin reaches the yield strength",
    "eccentric_bearing": "eccentric bearing load reaches its static rating C0 (ISO 76)",
    "output_shaft": "torsional shear of the output shaft reaches yield / sqrt(3) (von Mises)",
}


def _element_loads(design, T_out):
    """The quantity each element's rating limits at output torques T_out [N*m] (k,), over a
    mesh cycle, the gear with the larger share: {element: (values (k,), limit, exponent)},
    the values growing about as T^exponent."""
    T_out = np.atleast_1d(np.asarray(T_out, float))
    g = gear_path(design, _share(design) * T_out)
    F_r, F_d, F_E = (np.max(g[k].reshape(T_out.size, -1), -1) for k in ("F_ring", "F_disc", "F_E"))
    a1, L1 = pin_span(design, design.b1)
    a2, L2 = pin_span(design, design.b2)
    R_hole = 1.0 / (2.0 / design.d_v2 - 2.0 / design.D_cz)    # roller in a concave hole
    return {
        "ring_contact": (contact.line_contact_pressure(F_r, design.b1, design.d_v1 / 2),
                         STATIC_CONTACT_PRESSURE_LIMIT, 0.5),
        "disc_contact": (contact.line_contact_pressure(F_d, design.b2, R_hole),
                         STATIC_CONTACT_PRESSURE_LIMIT, 0.5),
        "ring_pins": (F_r * a1 * (L1 - a1) / L1 / round_section(design.d_o1)[2],
                      YIELD_STRENGTH, 1.0),
        "disc_pins": (F_d * a2 * (L2 - a2) / L2 / round_section(design.d_o2)[2],
                      YIELD_STRENGTH, 1.0),
        "eccentric_bearing": (F_E * STATIC_SAFETY_BEARING, eccentric_bearing_C0(design), 1.0),
        "output_shaft": (16 * T_out / (math.pi * design.output_shaft_diameter ** 3),
                         YIELD_STRENGTH / math.sqrt(3), 1.0),
    }


#: [1] relative tolerance of the static rating's torques (:func:`static_torque_rating`)
RATING_RTOL = 1e-12


@functools.lru_cache(maxsize=32)
def ring_torque_rating(design) -> float:
    """The torque on the ring [N*m] at which the drive reaches its static rating
    (:func:`static_torque_rating`, an output torque): the rating over i0, since the ring path's
    output torque is i0 times the ring's. The limit the command line and the design checks
    compare a ring torque with."""
    return static_torque_rating(design)["rating_Nm"] / design.i0


def static_torque_rating(design) -> dict:
    """Static torque rating of the drive [N*m, output torque]: the minimum over its elements of
    the torque at which each reaches its static limit (RATING_DESCRIPTIONS), the limiting one
    named.

    Returns ``{"rating_Nm", "limiting", "elements": {element: N*m}, "descriptions"}``. A limit
    of yield or permanent deformation (ISO 76's C0 criterion), not a catalogue's rated or
    peak torque (those add fatigue life and safety factors): the torque a drive must never
    see, not one it should run at. Each element's torque by fixed-point steps
    T <- T (limit / value)^(1/p), p the element's nominal exponent at the first step (exact
    for a load proportional to T^p; the clearances make it nearly so), then the local
    exponent from the last two steps (a secant in logarithms), all elements at once, to
    RATING_RTOL."""
    names = list(RATING_DESCRIPTIONS)
    T = np.full(len(names), 100.0)
    limit = exponent = None
    T_prev = v_prev = None
    for _ in range(40):
        loads = _element_loads(design, T)
        if limit is None:
            limit = np.array([loads[n][1] for n in names])
            exponent = np.array([loads[n][2] for n in names])
        v = np.array([loads[n][0][i] for i, n in enumerate(names)])
        # each element's load against the torque as a local power law v ~ T^p: p the nominal
        # exponent at the first step, then the secant's of the last two steps in logarithms
        # (superlinear: about 5 steps to 1e-12 where the fixed point with the nominal exponent
        # took 12 to 1e-9)
        p = exponent
        if T_prev is not None:
            with np.errstate(divide="ignore", invalid="ignore"):
                sec = np.log(v / v_prev) / np.log(T / T_prev)
            p = np.where(np.isfinite(sec) & (sec > 0.1 * exponent) & (sec < 10 * exponent),
                         sec, exponent)
        T_new = T * (limit / v) ** (1.0 / p)
        done = np.all(np.abs(T_new - T) <= RATING_RTOL * T)
        T_prev, v_prev, T = T, v, T_new
        if done:
            break
    out = {n: float(T[i]) for i, n in enumerate(names)}
    limiting = min(out, key=out.get)
    return {"rating_Nm": out[limiting], "limiting": limiting, "elements": out,
            "descriptions": {k: RATING_DESCRIPTIONS[k] for k in out}}
