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
clearances Delta (the profile correction delta_z at the ring rollers, the hole clearance at the
disc rollers) give the lost motion; the Palmgren (or linear) contact law the stiffness.

**Assumptions.** The shafts, the eccentric bearing and the housing are rigid (the roller
contacts are the compliance the model holds); the gear with the larger torque share is the
one measured. The hysteresis loop takes the contacts' friction as the mesh's own: twisting in
(loading) the applied torque is :math:`T_{el}/\eta_m`, letting go (unloading)
:math:`T_{el}\,\eta_m`, with :math:`\eta_m` the basic efficiency eta0 of mode 21 (ring fixed,
output driven) at a creeping speed, as the efficiency model computes it.

References
----------
Nabtesco, *Precision reduction gear RV series*, catalogue: torsional rigidity (the slope
between 50 % and 100 % of the rated torque), lost motion (the twist band at +-3 % of the rated
torque), hysteresis curve. Sumitomo Drive Technologies, *Fine Cyclo* catalogue: the same
definitions.
"""
from __future__ import annotations

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


def rated_torque(design) -> float:
    """Rated output torque [N*m]. **Assumption**: the paper's drive is rated by the bench motor
    that drives it (0.853 N*m at the eccentric shaft) times the ratio z1 - 1 (mode S2 driving
    the disc): 11.9 N*m for the paper's drive. Catalogue drives state it; pass yours."""
    return PAPER_MOTOR_TORQUE * (design.z1 - 1)


def _stiff(design, width):
    return (design.linear_stiffness if design.contact_law == "linear"
            else contact.palmgren_stiffness(width))


def _rotations(design, gear_torque, n_positions=None):
    """(rot_ring, rot_disc) [rad] for gear torques (n,), each (n, m) over mesh positions m."""
    T = np.abs(np.asarray(gear_torque, float))
    psi = mesh_positions(design, n_positions)
    phi = contact.loaded_half_angles(psi, design.z1)
    l_r = geometry.ring_roller_levers(phi, design.e, design.z1, design.lam)
    c_r = geometry.modification_clearance(phi, design.lam, design.delta_z,
                                          design.profile_modification)
    theta = contact.loaded_half_angles(psi, design.n_disc_rollers)
    l_d = geometry.disc_roller_levers(theta, design.r_w)
    c_d = np.full_like(l_d, geometry.hole_clearance(design.D_cz, design.d_v2, design.e))
    Tm = np.broadcast_to(T[:, None], T.shape + psi.shape)
    rot_r = contact.solve_rotation(np.broadcast_to(l_r, Tm.shape + l_r.shape[-1:]),
                                   np.broadcast_to(c_r, Tm.shape + c_r.shape[-1:]), Tm,
                                   design.contact_law, _stiff(design, design.b1))
    rot_d = contact.solve_rotation(np.broadcast_to(l_d, Tm.shape + l_d.shape[-1:]),
                                   np.broadcast_to(c_d, Tm.shape + c_d.shape[-1:]), Tm,
                                   design.contact_law, _stiff(design, design.b2))
    return rot_r, rot_d


def free_rotation(design) -> float:
    r"""Rigid rotation [rad] of the gear against the ring rollers that closes the first contact
    of the corrected profile: :math:`\delta_z / (e (z_1 - 1))`, the gap the profile correction
    leaves at the roller with the largest lever arm (the pitch radius of the gear; exact for
    the equidistant correction, whose normal gap is delta_z at every roller; for the offset
    correction an approximation)."""
    return design.delta_z / (design.e * (design.z1 - 1))


def twist(design, output_torque, n_positions=None) -> np.ndarray:
    """Angle of twist [rad] of the output against the locked input for output torques [N*m].

    Odd in the torque; at zero torque the middle of the dead band (0): any torque first turns
    the gear through the profile correction's free rotation, then deforms the contacts. The
    torque on one gear is its share of the output torque; the mean over the mesh positions of
    a cycle."""
    T = np.atleast_1d(np.asarray(output_torque, float))
    share = max(design.torque_share, 1.0 - design.torque_share)
    out = np.zeros_like(T)
    nz = T != 0
    if nz.any():
        rot_r, rot_d = _rotations(design, share * np.abs(T[nz]), n_positions)
        out[nz] = np.sign(T[nz]) * (free_rotation(design) + (rot_r + rot_d).mean(-1))
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


def catalogue_values(design, rated=None) -> dict:
    """What a catalogue states, from the contact model.

    Returns ``rated_torque_Nm``, ``torsional_rigidity_Nm_per_arcmin`` (secant between 50 % and
    100 % of the rated torque), ``lost_motion_arcmin`` (twist band at +-3 % of the rated
    torque), ``backlash_arcmin``, ``twist_at_rated_arcmin``, ``hysteresis_loss_arcmin`` (width
    of the loop at zero torque) and ``stiffness_Nm_per_rad`` (tangent at the rated torque)."""
    TR = rated_torque(design) if rated is None else float(rated)
    a, b = RIGIDITY_SHARES
    phi_a, phi_b = twist(design, [a * TR, b * TR])
    lm = 2 * float(twist(design, LOST_MOTION_SHARE * TR))
    loop = hysteresis_loop(design, TR)
    # width at zero applied torque: the unloading branch from +T reaches 0 at T_el = 0+, the
    # loading branch from -T at T_el = 0-: the dead band
    bl = backlash(design)
    return {"rated_torque_Nm": TR,
            "torsional_rigidity_Nm_per_arcmin": (b - a) * TR / ((phi_b - phi_a) * RAD_TO_ARCMIN),
            "lost_motion_arcmin": lm * RAD_TO_ARCMIN,
            "backlash_arcmin": bl * RAD_TO_ARCMIN,
            "twist_at_rated_arcmin": float(phi_b) * RAD_TO_ARCMIN,
            "hysteresis_loss_arcmin": bl * RAD_TO_ARCMIN,
            "stiffness_Nm_per_rad": torsional_stiffness(design, TR),
            "eta_mesh": loop["eta_mesh"]}
