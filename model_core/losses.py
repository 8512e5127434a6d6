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

from . import contact, friction, thermal, velocities

LOSS_NAMES = ("PL1", "PL2", "PL3", "PL5", "PL6")
LOSS_DESCRIPTIONS = {
    "PL1": "eccentric (cycloid-gear) bearing",
    "PL2": "disc rollers rolling in the holes",
    "PL3": "disc rollers sliding on their pins",
    "PL5": "ring rollers rolling on the teeth",
    "PL6": "ring rollers sliding on their pins",
}
#: the calibrated additional mesh loss (design [calibration] mesh_loss_k), booked on its own
MESH_LOSS_NAME = "PL_mesh"
MESH_LOSS_DESCRIPTION = ("additional mesh loss, a fraction mesh_loss_k of the mesh power "
                         "(calibrated)")
# physical profile, plain rollers: a skidding roller's sliding at the tooth (hole) is booked on
# PL5 (PL2), where its rolling loss would be; its pin loss PL6 (PL3) is then zero


@dataclass(frozen=True)
class PartialLosses:
    """Partial losses in W (arrays over the operating points; per position: trailing axis)."""

    PL1: np.ndarray
    PL2: np.ndarray
    PL3: np.ndarray
    PL5: np.ndarray
    PL6: np.ndarray
    P_extra: np.ndarray = 0.0   # W, design.extra (drag, Stribeck) at the driving shaft
    PL_support: np.ndarray = 0.0  # W, load-independent (model_core.drag, losses = "all")
    PL_seal: np.ndarray = 0.0
    PL_churn: np.ndarray = 0.0
    #: W, the calibrated additional mesh loss (design.calibration.mesh_loss_k; 0 uncalibrated)
    PL_mesh: np.ndarray = 0.0

    @property
    def idle(self) -> np.ndarray:
        """Load-independent losses (W): support bearings, seals, grease drag."""
        return self.PL_support + self.PL_seal + self.PL_churn

    @property
    def total(self) -> np.ndarray:
        return (self.PL1 + self.PL2 + self.PL3 + self.PL5 + self.PL6 + self.P_extra + self.idle
                + self.PL_mesh)

    def as_dict(self) -> dict:
        return {name: getattr(self, name) for name in LOSS_NAMES}


def joint_cycle_pitches(design) -> int:
    """Ring pitches after which the ring and disc roller patterns both repeat."""
    return design.z_c // math.gcd(design.z_c, design.n_disc_rollers)


def mesh_positions(design, n_positions=None):
    """Ring rotation angles alpha (rad) relative to the carrier sampling one joint mesh cycle."""
    n = int(n_positions or design.n_positions) * joint_cycle_pitches(design)
    return np.arange(n) * (2 * np.pi / design.z1) * joint_cycle_pitches(design) / n


def _pin_stribeck(design, F, spin, width, d_pin, eta, diag, key):
    fr = design.friction
    H = friction.hersey_number(eta, spin, F, width, d_pin)
    mu, clamped = friction.stribeck_pin_mu(H, fr.mu_pin_boundary, fr.hersey_transition,
                                           fr.pin_clearance_ratio)
    if diag is not None:
        loaded = F > 0
        diag.setdefault(key + "_clamped", []).append(np.any(clamped & loaded))
        diag.setdefault(key + "_hersey", []).append(H[loaded] if np.any(loaded) else H.ravel()[:0])
    return mu


def _gear_losses(design, gear_torque, w2_rel, psi_ring, psi_disc, state=None, gear=0,
                 ring_index=None, disc_index=None, dedup=True, diag=None, disc_torque=None,
                 ring_flow=None):
    """Losses of one gear with its roller patterns at psi_ring, psi_disc (rad from its line of
    centres); gear_torque and w2_rel shaped (...), positions trailing.

    ring_index, disc_index: when given, psi_ring and psi_disc are distinct classes and the
    returned losses are gathered to the positions ``ring_index`` / ``disc_index`` (same length).
    disc_torque: the gear's torque on the disc side where friction makes it differ from the
    ring side (physical profile); None: the same (the paper's frictionless balance).
    ring_flow: +1 where the ring drives in the relative motion, -1 where it is driven; with it
    the ring rollers' normal forces carry the friction's moment
    (friction.ring_friction_arm_ratio). diag: a dict collecting roller states (contact_states).
    """
    fr = design.friction
    nu = thermal.lubricant_viscosity(design)
    eta = design.lubricant.density * nu
    T = np.asarray(gear_torque, float)
    W = np.asarray(w2_rel, float)[..., None, None]
    # the ring and the disc side each only when its inputs changed since the last call with
    # this state (in the fixed point in eta0 one side often keeps its torque: the known one)
    memo = state if (dedup and diag is None) else None
    phi, F, PL5, PL6 = _memoised(
        memo, ("memo ring", gear), (T, W, ring_flow),
        lambda: _ring_side(design, T, W, psi_ring, state, gear, dedup, diag, ring_flow, eta))
    T_d = T if disc_torque is None else np.asarray(disc_torque, float)
    dcls, Q, PL2, PL3 = _memoised(
        memo, ("memo disc", gear), (T_d, W),
        lambda: _disc_side(design, T_d, W, psi_disc, state, gear, dedup, diag, eta))
    W2 = W[..., 0]
    # eccentric bearing: relative speed of its rings is |w_p - w_S| = |w2 - wS| (Eq. 21)
    if ring_index is None:
        F_EV, F_EH = contact.eccentric_bearing_force(design, phi, F, Q)
    else:
        d_index, r_i, d_i, pair_index = _bearing_pairs(ring_index, disc_index, dcls,
                                                       Q.shape[-2])
        F_EV, F_EH = contact.eccentric_bearing_force(design, phi, F, Q, r_i, d_i)
        PL5, PL6 = PL5[..., ring_index], PL6[..., ring_index]
        PL2, PL3 = PL2[..., d_index], PL3[..., d_index]
    F_E = np.hypot(F_EV, F_EH)
    Om = np.abs(W2)
    PL1 = friction.skf_frictional_moment(F_E, Om, design.d_p, design.D_p, nu, fr) * Om
    if ring_index is not None:
        PL1 = PL1[..., pair_index]
    return PL1, PL2, PL3, PL5, PL6


def _ring_side(design, T, W, psi_ring, state, gear, dedup, diag, ring_flow, eta):
    """Ring rollers of one gear (see _gear_losses): (phi, F, PL5, PL6), the losses per
    position (class)."""
    fr = design.friction
    physical = design.profile == "physical"
    nu = thermal.lubricant_viscosity(design)
    # ring rollers (z1 per position)
    # dedup: only the rollers that carry load somewhere in the batch (the others add zeros)
    phi, F = contact.ring_roller_forces(design, T, psi_ring, state, ("ring", gear),
                                        dedup=dedup, layout="compact" if dedup else "positions")
    omega_r = velocities.relative_ring_speed(W, design.z1)
    r_c = design.d_v1 / 2
    v_rt = velocities.profile_velocity(phi, design.e, design.z1, design.lam, r_c, omega_r)
    PL5 = friction.rolling_resistance_loss(fr.rolling_ring, F, v_rt)
    if design.ring_rollers == "plain" and physical:
        v_s = velocities.ring_contact_sliding(phi, design.e, design.z1, design.lam, r_c, omega_r)
        spin = v_s / r_c
        mu6 = _pin_stribeck(design, F, spin, design.b1, design.d_o1, eta, diag, "ring")
        with np.errstate(divide="ignore", invalid="ignore"):
            rr = np.where(v_s > 0, fr.rolling_ring * r_c * np.abs(v_rt) / np.where(v_s > 0, v_s, 1.0),
                          0.0)
        rolls = friction.roll_or_skid(fr.mu_tooth, mu6, design.d_o1 / 2, r_c, rr)
        mu_eff = np.where(rolls, mu6 * design.d_o1 / design.d_v1, fr.mu_tooth)
        PL6 = np.where(rolls, friction.sliding_loss(mu6, F, design.d_o1 / design.d_v1 * v_s), 0.0)
        PL5 = np.where(rolls, PL5, friction.sliding_loss(fr.mu_tooth, F, v_s))
        if diag is not None:
            loaded = np.broadcast_to(F > 0, rolls.shape)
            diag.setdefault("ring_rolling", []).append(
                (np.sum(rolls & loaded), np.sum(loaded)))
        PL6 = PL6.sum(-1)
    elif design.ring_rollers == "plain":
        v6 = velocities.ring_pin_sliding(phi, design.e, design.z1, design.lam, design.d_v1,
                                         design.d_o1, omega_r)
        mu6 = friction.benedict_kelley_mu(F / design.b1, eta, v6, v6, fr.pin_roughness,
                                          fr.mu_boundary, fr.mu_full_film)
        PL6 = friction.sliding_loss(mu6, F, v6).sum(-1)
    else:
        spin = velocities.ring_roller_spin(phi, design.e, design.z1, design.lam, r_c, omega_r)
        M = friction.skf_frictional_moment(F, spin, design.d_o1, design.d_v1, nu, fr)
        with np.errstate(divide="ignore", invalid="ignore"):
            mu_eff = np.where(F > 0, M / np.where(F > 0, F, 1.0) / r_c, 0.0)
        PL6 = (M * spin).sum(-1)
    PL5 = PL5.sum(-1)
    if physical and ring_flow is not None:
        # friction in the force balance: the normal forces that carry T1 with the friction's
        # moment, N0/(1 - rho_1) (ring drives) or N0/(1 + rho_1) (ring driven)
        rho1 = friction.ring_friction_arm_ratio(phi, F, mu_eff, design.e, design.z1, design.lam,
                                                r_c)
        k = 1.0 / (1.0 - np.asarray(ring_flow, float)[..., None] * rho1)
        PL5, PL6, F = PL5 * k, PL6 * k, F * k[..., None]
    return phi, F, PL5, PL6


def _disc_side(design, T_d, W, psi_disc, state, gear, dedup, diag, eta):
    """Disc rollers of one gear (see _gear_losses): (dcls, Q, PL2, PL3), at the distinct
    contact problems (dcls: the problem of each position class; None without dedup)."""
    fr = design.friction
    physical = design.profile == "physical"
    nu = thermal.lubricant_viscosity(design)
    # disc rollers (k per position)
    # dedup: the disc rollers' losses depend on their forces alone, so they are evaluated at
    # the distinct contact problems (dcls: the problem of each position class)
    dcls, Q = contact.disc_roller_forces(design, T_d, psi_disc, state, ("disc", gear),
                                         dedup=dedup, layout="distinct" if dedup else "positions")
    if not dedup:
        dcls = None
    W2 = W[..., 0]
    v_r2 = velocities.disc_rolling_speed(design.D_cz, W2)[..., None]
    PL2 = friction.rolling_resistance_loss(fr.rolling_disc, Q, v_r2)
    if design.disc_rollers == "plain" and physical:
        spin2 = velocities.disc_roller_spin(design.e, design.d_v2, W2)[..., None]
        v3 = velocities.disc_pin_sliding(design.e, design.d_v2, design.d_o2, W2)[..., None]
        v_skid = velocities.disc_hole_sliding(design.e, W2)[..., None]
        mu3 = _pin_stribeck(design, Q, spin2, design.b2, design.d_o2, eta, diag, "disc")
        rr2 = fr.rolling_disc * (design.d_v2 / 2) * v_r2 / np.maximum(v_skid, 1e-300)
        rolls = friction.roll_or_skid(fr.mu_tooth, mu3, design.d_o2 / 2, design.d_v2 / 2, rr2)
        PL3 = np.where(rolls, friction.sliding_loss(mu3, Q, v3), 0.0).sum(-1)
        PL2 = np.where(rolls, PL2, friction.sliding_loss(fr.mu_tooth, Q, v_skid))
        if diag is not None:
            loaded = np.broadcast_to(Q > 0, rolls.shape)
            diag.setdefault("disc_rolling", []).append((np.sum(rolls & loaded), np.sum(loaded)))
    elif design.disc_rollers == "plain":
        v3 = velocities.disc_pin_sliding(design.e, design.d_v2, design.d_o2, W2,
                                         design.D_cz if design.disc_pin_sliding == "paper" else None)[..., None]
        mu3 = friction.benedict_kelley_mu(Q / design.b2, eta, v3, v3, fr.pin_roughness,
                                          fr.mu_boundary, fr.mu_full_film)
        PL3 = friction.sliding_loss(mu3, Q, v3).sum(-1)
    else:
        spin2 = velocities.disc_roller_spin(design.e, design.d_v2, W2)[..., None]
        M = friction.skf_frictional_moment(Q, spin2, design.d_o2, design.d_v2, nu, fr)
        PL3 = (M * spin2).sum(-1)
    PL2 = PL2.sum(-1)
    return dcls, Q, PL2, PL3


def _same(a, b):
    if a is None or b is None:
        return a is b
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and np.array_equal(a, b)


def _memoised(memo, key, inputs, compute):
    """compute(), or its result of the last call under ``key`` in ``memo`` (the operating
    point's state dict) when the inputs are the same (compared exactly; stored as copies)."""
    if memo is None:
        return compute()
    hit = memo.get(key)
    if hit is not None and all(_same(a, b) for a, b in zip(hit[0], inputs)):
        return hit[1]
    out = compute()
    memo[key] = (tuple(None if a is None else np.array(a, copy=True) for a in inputs), out)
    return out


_PAIR_CACHE: dict = {}


def _bearing_pairs(ring_index, disc_index, dcls, n_disc):
    """Distinct (ring class, disc problem) pairs of the gear positions, for the eccentric
    bearing: (disc index of each position, ring and disc index of each pair, pair of each
    position). Cached on the (cached) index arrays themselves."""
    key = (id(ring_index), id(disc_index), id(dcls), n_disc)
    hit = _PAIR_CACHE.get(key)
    if hit is not None and hit[0] is ring_index and hit[1] is disc_index and hit[2] is dcls:
        return hit[3]
    d_index = disc_index if dcls is None else dcls[disc_index]
    pairs, pair_index = np.unique(ring_index * (n_disc + 1) + d_index, return_inverse=True)
    r_i, d_i = np.divmod(pairs, n_disc + 1)
    out = (d_index, r_i, d_i, pair_index.reshape(-1))
    if len(_PAIR_CACHE) > 64:
        _PAIR_CACHE.clear()
    _PAIR_CACHE[key] = (ring_index, disc_index, dcls, out)
    return out


def contact_states(design, ring_torque, w2_rel, n_positions=None):
    """What the plain rollers do and where the pin law sits, at |T1| = ring_torque [N*m] and
    w2 - wS = w2_rel [rad/s] (scalars or arrays; physical profile).

    Returns a dict: ``ring_rolling``/``disc_rolling`` the share of loaded rollers that roll on
    the tooth (hole) rather than skid (NaN without plain rollers of that set);
    ``ring_hersey``/``disc_hersey`` (min, max) of the pins' Hersey numbers over the loaded
    rollers; ``ring_clamped``/``disc_clamped`` whether the Stribeck law's upper bound binds
    anywhere (MU_DRY_STEEL)."""
    diag = {}
    alpha = mesh_positions(design, n_positions)
    Tc = np.abs(np.asarray(ring_torque, float)) * design.z_c / design.z1
    for gear, (share, shift) in enumerate(((design.torque_share, 0.0),
                                           (1.0 - design.torque_share, np.pi))):
        if share:
            _gear_losses(design, share * Tc, w2_rel, alpha + shift, alpha / design.i0 + shift,
                         None, ("states", gear), dedup=False, diag=diag)
    out = {}
    for key in ("ring", "disc"):
        r = diag.get(key + "_rolling")
        out[key + "_rolling"] = (sum(a for a, _ in r) / max(sum(b for _, b in r), 1)
                                 if r else float("nan"))
        h = [x for x in diag.get(key + "_hersey", []) if x.size]
        out[key + "_hersey"] = ((float(min(x.min() for x in h)), float(max(x.max() for x in h)))
                                if h else (float("nan"), float("nan")))
        out[key + "_clamped"] = bool(any(diag.get(key + "_clamped", [])))
    return out


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


_ALPHA_CACHE: dict = {}   # (z1, k, n_positions) -> mesh positions (read-only)


def partial_losses_by_position(design, ring_torque, w2_rel, n_positions=None, state=None,
                               dedup=True, disc_torque=None, ring_flow=None):
    """Partial losses of the whole drive (both gears) at each mesh position, W.

    ring_torque: |T1|, the torque on the ring shaft (N*m), shape (...); w2_rel = w2 - wS (rad/s).
    state: optional dict for warm-starting the contact solutions of repeated calls.
    dedup: evaluate each distinct gear position and contact problem once (default); False is
    the straightforward per-position path (same results to ~1e-13, slower).
    disc_torque: |T2| (N*m) where friction in the force balance makes the disc side's torque
    differ from the frictionless i0*|T1| (physical profile); None: i0*|T1| (the paper).
    ring_flow: +1/-1 where the ring drives/is driven in the relative motion (physical profile:
    friction in the ring rollers' force balance); None: frictionless forces (the paper).
    Returns (alpha, PartialLosses with arrays shaped (..., n_alpha)).
    """
    key = (design.z1, design.n_disc_rollers, int(n_positions or design.n_positions))
    alpha = _ALPHA_CACHE.get(key)
    if alpha is None:
        alpha = mesh_positions(design, n_positions)
        alpha.flags.writeable = False
        _ALPHA_CACHE[key] = alpha
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
        share = shares[gears[0]]
        Td = None if disc_torque is None else share * np.abs(np.asarray(disc_torque, float))
        parts = _gear_losses(design, share * Tc, w2_rel, psi_ring, psi_disc, state,
                             gears, ring_index, disc_index, dedup, disc_torque=Td,
                             ring_flow=ring_flow)
        for g in range(len(gears)):
            sl = tuple(p[..., g * m:(g + 1) * m] for p in parts)
            total = sl if total is None else tuple(a + b for a, b in zip(total, sl))
    return alpha, PartialLosses(*total)


def partial_losses(design, ring_torque, w2_rel, n_positions=None, state=None,
                   dedup=True, disc_torque=None, ring_flow=None) -> PartialLosses:
    """Partial losses (W) averaged over a full mesh cycle; arrays shaped like the inputs."""
    _, by_pos = partial_losses_by_position(design, ring_torque, w2_rel, n_positions, state,
                                           dedup, disc_torque, ring_flow)
    # the mean over the positions (np.add.reduce / m is what ndarray.mean computes)
    return PartialLosses(*(np.add.reduce(getattr(by_pos, n), -1) / by_pos.PL1.shape[-1]
                           for n in LOSS_NAMES))
