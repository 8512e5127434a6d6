"""Partial power losses PL1, PL2, PL3, PL5, PL6 (Eqs. 20-27), per mesh position and averaged.

The losses follow from the relative motion (carrier held) and the contact forces. The forces
come from the frictionless balance of each gear at the ring torque T1 (as in the paper): a gear
carrying the share s of the drive feels T_c = s*|T1|*(z1-1)/z1 from the ring rollers and the same
torque from the disc rollers (Section 3).

Mesh positions. Turning the ring by alpha relative to the carrier moves the ring rollers by alpha
and the disc rollers by alpha/i0 relative to the line of centres. Both patterns repeat after
n_cycle = (z1-1)/gcd(z1-1, k) ring pitches (two for the paper's 15 and 7), so losses are
averaged over that joint cycle, ``design.n_positions`` positions per ring pitch. The second gear
sits half a turn away: its rollers are seen at angles shifted by pi.

Distinct positions. A gear at a mesh position is fully described by the angles of its rollers
relative to its line of centres; positions (of either gear, when both carry the same torque)
whose roller angles coincide as sets give the same losses. Each such class is evaluated once,
ring and disc rollers separately (for the paper's drive 8 ring and 16 disc classes of the 32
gear positions of a cycle), and the contact solver further solves each distinct set of lever
arms and clearances once (8 and 9). ``dedup=False`` is the straightforward per-position path.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import contact, friction, velocities

LOSS_NAMES = ("PL1", "PL2", "PL3", "PL5", "PL6")
LOSS_DESCRIPTIONS = {
    "PL1": "eccentric (cycloid-gear) bearing",
    "PL2": "disc rollers rolling in the holes",
    "PL3": "disc rollers sliding on their pins",
    "PL5": "ring rollers rolling on the teeth",
    "PL6": "ring rollers sliding on their pins",
}


@dataclass(frozen=True)
class PartialLosses:
    """Partial losses in W (arrays over the operating points; per position: trailing axis)."""

    PL1: np.ndarray
    PL2: np.ndarray
    PL3: np.ndarray
    PL5: np.ndarray
    PL6: np.ndarray
    P_extra: np.ndarray = 0.0   # W, design.extra (drag, Stribeck) at the driving shaft

    @property
    def total(self) -> np.ndarray:
        return self.PL1 + self.PL2 + self.PL3 + self.PL5 + self.PL6 + self.P_extra

    def as_dict(self) -> dict:
        return {name: getattr(self, name) for name in LOSS_NAMES}


def joint_cycle_pitches(design) -> int:
    """Ring pitches after which the ring and disc roller patterns both repeat."""
    return design.z_c // math.gcd(design.z_c, design.n_disc_rollers)


def mesh_positions(design, n_positions=None):
    """Ring rotation angles alpha (rad) relative to the carrier sampling one joint mesh cycle."""
    n = int(n_positions or design.n_positions) * joint_cycle_pitches(design)
    return np.arange(n) * (2 * np.pi / design.z1) * joint_cycle_pitches(design) / n


def _gear_losses(design, gear_torque, w2_rel, psi_ring, psi_disc, state=None, gear=0,
                 ring_index=None, disc_index=None, dedup=True):
    """Losses of one gear with its roller patterns at psi_ring, psi_disc (rad from its line of
    centres); gear_torque and w2_rel shaped (...), positions trailing.

    ring_index, disc_index: when given, psi_ring and psi_disc are distinct classes and the
    returned losses are gathered to the positions ``ring_index`` / ``disc_index`` (same length).
    """
    fr, lub = design.friction, design.lubricant
    T = np.asarray(gear_torque, float)
    W = np.asarray(w2_rel, float)[..., None, None]
    eta = lub.dynamic_viscosity
    # ring rollers (z1 per position)
    phi, F = contact.ring_roller_forces(design, T, psi_ring, state, ("ring", gear),
                                           dedup=dedup)
    omega_r = velocities.relative_ring_speed(W, design.z1)
    r_c = design.d_v1 / 2
    v_rt = velocities.profile_velocity(phi, design.e, design.z1, design.lam, r_c, omega_r)
    PL5 = friction.rolling_resistance_loss(fr.rolling_ring, F, v_rt).sum(-1)
    if design.ring_rollers == "plain":
        v6 = velocities.ring_pin_sliding(phi, design.e, design.z1, design.lam, design.d_v1,
                                         design.d_o1, omega_r)
        mu6 = friction.benedict_kelley_mu(F / design.b1, eta, v6, v6, fr.pin_roughness,
                                          fr.mu_boundary, fr.mu_full_film)
        PL6 = friction.sliding_loss(mu6, F, v6).sum(-1)
    else:
        spin = velocities.ring_roller_spin(phi, design.e, design.z1, design.lam, r_c, omega_r)
        M = friction.skf_frictional_moment(F, spin, design.d_o1, design.d_v1,
                                           lub.kinematic_viscosity, fr)
        PL6 = (M * spin).sum(-1)
    # disc rollers (k per position)
    theta, Q = contact.disc_roller_forces(design, T, psi_disc, state, ("disc", gear),
                                             dedup=dedup)
    W2 = W[..., 0]
    PL2 = friction.rolling_resistance_loss(fr.rolling_disc, Q,
                                           velocities.disc_rolling_speed(design.D_cz, W2)[..., None]).sum(-1)
    if design.disc_rollers == "plain":
        v3 = velocities.disc_pin_sliding(design.e, design.d_v2, design.d_o2, W2,
                                         design.D_cz if design.disc_pin_sliding == "paper" else None)[..., None]
        mu3 = friction.benedict_kelley_mu(Q / design.b2, eta, v3, v3, fr.pin_roughness,
                                          fr.mu_boundary, fr.mu_full_film)
        PL3 = friction.sliding_loss(mu3, Q, v3).sum(-1)
    else:
        spin2 = velocities.disc_roller_spin(design.e, design.d_v2, W2)[..., None]
        M = friction.skf_frictional_moment(Q, spin2, design.d_o2, design.d_v2,
                                           lub.kinematic_viscosity, fr)
        PL3 = (M * spin2).sum(-1)
    # eccentric bearing: relative speed of its rings is |w_p - w_S| = |w2 - wS| (Eq. 21)
    F_EV, F_EH = contact.eccentric_bearing_force(design, phi, F, Q, ring_index, disc_index)
    if ring_index is not None:
        PL5, PL6 = PL5[..., ring_index], PL6[..., ring_index]
        PL2, PL3 = PL2[..., disc_index], PL3[..., disc_index]
    F_E = np.hypot(F_EV, F_EH)
    Om = np.abs(W2)
    PL1 = friction.skf_frictional_moment(F_E, Om, design.d_p, design.D_p,
                                         lub.kinematic_viscosity, fr) * Om
    return PL1, PL2, PL3, PL5, PL6


def _angle_classes(psi, n):
    """Classes of positions psi whose n equally spaced rollers sit at the same angles (as a set,
    mod 2 pi, to 1e-9 of a turn). Returns (representative positions, class of each position)."""
    turn = 10 ** 9
    u = np.round(np.mod(psi[:, None] / (2 * np.pi) + np.arange(n) / n, 1.0) * turn) % turn
    _, rep, cls = np.unique(np.sort(u, -1), axis=0, return_index=True, return_inverse=True)
    return psi[rep], cls.reshape(-1)


_CLASS_CACHE: dict = {}


def _mesh_entries(design, n_positions, gears, dedup):
    """Ring and disc positions of the given gears over one mesh cycle (gear-major), reduced to
    distinct classes when ``dedup``: (psi_ring, ring_index, psi_disc, disc_index)."""
    key = (design.z1, design.n_disc_rollers, int(n_positions or design.n_positions), gears, dedup)
    hit = _CLASS_CACHE.get(key)
    if hit is not None:
        return hit
    alpha = mesh_positions(design, n_positions)
    psi_ring = np.concatenate([alpha + np.pi * g for g in gears])
    psi_disc = np.concatenate([alpha / design.i0 + np.pi * g for g in gears])
    if dedup:
        psi_ring, ring_index = _angle_classes(psi_ring, design.z1)
        psi_disc, disc_index = _angle_classes(psi_disc, design.n_disc_rollers)
        hit = (psi_ring, ring_index, psi_disc, disc_index)
    else:
        hit = (psi_ring, None, psi_disc, None)
    if len(_CLASS_CACHE) > 64:
        _CLASS_CACHE.clear()
    _CLASS_CACHE[key] = hit
    return hit


def partial_losses_by_position(design, ring_torque, w2_rel, n_positions=None, state=None,
                               dedup=True):
    """Partial losses of the whole drive (both gears) at each mesh position, W.

    ring_torque: |T1|, the torque on the ring shaft (N*m), shape (...); w2_rel = w2 - wS (rad/s).
    state: optional dict for warm-starting the contact solutions of repeated calls.
    dedup: evaluate each distinct gear position and contact problem once (default); False is
    the straightforward per-position path (same results to ~1e-13, slower).
    Returns (alpha, PartialLosses with arrays shaped (..., n_alpha)).
    """
    alpha = mesh_positions(design, n_positions)
    m = alpha.size
    T1 = np.abs(np.asarray(ring_torque, float))
    Tc = T1 * design.z_c / design.z1
    # gears carrying the same torque are evaluated together (one set of classes)
    shares = (design.torque_share, 1.0 - design.torque_share)
    groups = {}
    for gear, share in enumerate(shares):
        if share != 0:
            groups.setdefault(share if dedup else gear, []).append(gear)
    total = None
    for gears in groups.values():
        gears = tuple(gears)
        psi_ring, ring_index, psi_disc, disc_index = _mesh_entries(design, n_positions, gears,
                                                                   dedup)
        parts = _gear_losses(design, shares[gears[0]] * Tc, w2_rel, psi_ring, psi_disc, state,
                             gears, ring_index, disc_index, dedup)
        for g in range(len(gears)):
            sl = tuple(p[..., g * m:(g + 1) * m] for p in parts)
            total = sl if total is None else tuple(a + b for a, b in zip(total, sl))
    return alpha, PartialLosses(*total)


def partial_losses(design, ring_torque, w2_rel, n_positions=None, state=None,
                   dedup=True) -> PartialLosses:
    """Partial losses (W) averaged over a full mesh cycle; arrays shaped like the inputs."""
    _, by_pos = partial_losses_by_position(design, ring_torque, w2_rel, n_positions, state,
                                           dedup)
    return PartialLosses(*(getattr(by_pos, n).mean(-1) for n in LOSS_NAMES))
