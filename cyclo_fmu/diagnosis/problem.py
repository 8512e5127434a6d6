"""Stage ``replay``: the recording through the model and the regression problem in block means.

The model is replayed per sample (``replay.replay``: vectorised through the map) and its
output is block-averaged exactly as the measurement is: the residual of a block is the mean,
over the block's samples, of measured minus model input torque, never the model evaluated at
block-mean inputs (the mean of the model is not the model of the means where the model is
discontinuous or bends: speed reversals, the drag's sign, zero crossings, ramp corners).

One artifact remains at sample level: where the model *jumps* between two samples (the
friction and the drag change sign when the speed does; a load step), the samples do not say
where inside the interval the jump happened, and a torque channel settles through it with its
own dynamics. Those samples are not compared (``jump_mask``): the model's value there is not
defined by the samples. The window is a named physical limit (``SETTLE_S``), not a tuned one.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from model_core.effects import EFFECTS

from ..io.checks import STANDSTILL_RPM
from . import residual as R
from .replay import Replay, first_order, replay
from .selection import Term

#: [N*m] below this output torque the recording carries no load (load-dependent terms dropped)
MIN_LOAD = 0.05
#: [s] settling window around an instant where the model jumps (a speed reversal, a step of
#: the model's input torque): 5 ms, five time constants of a 160 Hz first-order torque channel
#: (the slowest transducer class a reducer bench uses; HBM T22: 1 kHz) and one sample of a
#: 200 Hz logger. Inside it the model's value is not defined by the samples; a transient that
#: lasts longer (backlash taken up over tens of ms, a torque channel 20 ms late) stays visible
SETTLE_S = 0.005
#: [1] a change of the model's input torque between two samples larger than this many times
#: the torque channel's sample noise is a jump the samples do not resolve (a load step); a
#: ramp changes the model by less than the noise per sample, and the mean of a straight ramp
#: over a sample interval is its value at the sample (no artifact)
JUMP_NOISE = 3.0
#: [rad/s] at rest the model has no value to compare: a drive standing still under a load (a
#: hoist holding its payload, a brake holding the output) carries a static friction anywhere
#: within its breakaway band, and the replay's kinetic friction takes the sign of the speed
#: reading's noise (measured: +-57 mN*m at 5 N*m on batch 5's hoist with 0.3 r/min of speed
#: noise). The input shaft's standstill bound of the recording checks (``io.checks.
#: STANDSTILL_RPM``, 1 r/min: below any test run, above encoder noise)
REST_SPEED = STANDSTILL_RPM * math.pi / 30

_DRIFT_LOADED = ("friction_miscalibrated", "torque_sensor_gain", "thermal_drift",
                 "viscosity_drift")


@dataclass
class Problem:
    """The regression problem of one recording under one design (block means, SI).

    ``y``: block-mean residual (measured - model input torque, N*m); ``X``: every candidate's
    columns, then the generic basis; ``options``: {effect: [Term]}; ``valid``: the share of
    each block's samples compared (0 where the model jumps through the whole block)."""
    rp: Replay
    sig: dict
    y: np.ndarray
    X: np.ndarray
    options: dict
    generic: Term
    steady: list
    structure: list
    groups: list
    blocks: dict
    m: int
    dt: float
    T_model_f: np.ndarray
    loaded: bool
    mask: np.ndarray = field(repr=False, default=None)
    valid: np.ndarray = field(repr=False, default=None)
    noise_sample: float = 0.0
    bandwidth: float = 0.0
    #: {(effect, shape): (signals its basis read, block-mean column, its filtered samples of
    #: the ``edges`` blocks)} (``_candidates``)
    columns: dict = field(repr=False, default=None)
    #: the blocks whose compared samples may move with the model's steps (``edge_blocks``)
    edges: np.ndarray = field(repr=False, default=None)

    def __getitem__(self, key):          # the dict interface of earlier versions
        return getattr(self, key)


def jump_mask(t, w_in, T_model, noise, dt) -> np.ndarray:
    """Samples compared (True) and not (False: within ``SETTLE_S`` of a sample interval where
    the speed changes sign or the model's input torque changes by more than ``JUMP_NOISE``
    times the torque channel's sample noise ``noise`` N*m)."""
    n = len(t)
    s = np.signbit(w_in)
    jump = np.zeros(n, bool)
    jump[:-1] = (s[1:] != s[:-1]) | (np.abs(np.diff(T_model)) > JUMP_NOISE * max(noise, 1e-12))
    k = int(np.ceil(SETTLE_S / dt))
    if not jump.any():
        return np.ones(n, bool)
    # dilate by k samples on each side (the jump's interval is [i, i+1])
    c = np.concatenate([[0], np.cumsum(jump)])
    lo = np.clip(np.arange(n) - k - 1, 0, n)
    hi = np.clip(np.arange(n) + k + 1, 0, n)
    return (c[hi] - c[lo]) == 0


#: [1] a step of the model's input torque between two samples within this factor of the jump
#: threshold (``JUMP_NOISE`` times the sample noise) may cross it in the re-linearised replay
#: (the friction level corrected by a few per cent moves the model's steps by less): the blocks
#: within the settling window of such a step keep their filtered samples of every column
#: (``edge_blocks``), so that a problem replayed at another level recomputes only the blocks
#: whose compared samples changed. Speed only, never a result: where a block outside them
#: changes, every column is computed again (the same numbers either way)
STEP_MARGIN = 2.0
#: [1] the edge blocks' filtered samples are kept only while the edge blocks are at most this
#: share of the blocks (their samples then cost at most this share of the matrix's memory;
#: measured: 0.15 % of a 10-minute four-quadrant recording's blocks, 2.3 % of a 42-s one):
#: where the model steps near the threshold all along (an hour read as 10 ms block means, one
#: sample a block: half its blocks, 190 MB), a change of the mask is as likely outside them,
#: and every column is computed again anyway. Speed and memory only, never a result
EDGE_SHARE = 0.1


def edge_blocks(w_in, T_model, noise, dt, m, n_blocks) -> np.ndarray:
    """Indices of the blocks (of ``m`` samples, the first ``n_blocks``) whose compared samples
    (``jump_mask``) may change when the model's steps change by less than ``STEP_MARGIN``:
    those within the settling window of a sample interval whose step lies within that factor
    of the jump threshold (a reversal of the speed is a jump at any level); none where they
    are more than ``EDGE_SHARE`` of the blocks."""
    d = np.abs(np.diff(T_model))
    thr = JUMP_NOISE * max(noise, 1e-12)
    s = np.signbit(w_in)
    near = np.flatnonzero((d > thr / STEP_MARGIN) & (d <= thr * STEP_MARGIN)
                          & (s[1:] == s[:-1]))
    if not len(near):
        return np.zeros(0, np.intp)
    k = int(np.ceil(SETTLE_S / dt)) + 1
    first = np.maximum(near - k, 0) // m
    last = np.minimum(near + k + 1, n_blocks * m - 1) // m
    hit = np.zeros(n_blocks + 1, np.intp)
    np.add.at(hit, first[first < n_blocks], 1)
    np.add.at(hit, np.minimum(last[first < n_blocks], n_blocks - 1) + 1, -1)
    edges = np.flatnonzero(np.cumsum(hit[:-1]) > 0)
    return edges if len(edges) <= EDGE_SHARE * n_blocks else np.zeros(0, np.intp)


def _edge_samples(y, edges, m):
    """The filtered samples ``y`` (n x columns) of the blocks ``edges``: (len(edges) * m,
    columns), a copy."""
    return y[:len(y) // m * m].reshape(-1, m, *y.shape[1:])[edges].reshape(-1, *y.shape[1:])


def masked_means(x, mask, m, counts=None):
    """Block means over the compared samples only (the plain mean where none is).
    ``counts``: the compared samples per block (``mask`` summed over each block), where many
    series share one mask (counting them costs as much as the sum of a series)."""
    from .replay import block_means, _block_sum
    if mask.all():
        return block_means(x, m)
    n = (len(x) // m) * m
    x = x[:n].reshape(-1, m, *x.shape[1:])
    mk = mask[:n].reshape(-1, m)
    cnt = mk.sum(1) if counts is None else counts
    if x[0, 0].size == 1:    # one column: numpy sums each block's contiguous samples
        s = np.where(mk, x.reshape(mk.shape), 0.0).sum(1).reshape(cnt.shape + x.shape[2:])
    else:   # columns: summed block position by block position (see replay._block_sum)
        mk3 = mk.reshape(mk.shape + (1,) * (x.ndim - 2))
        s = _block_sum(x, lambda i: np.where(mk3[:, i], x[:, i], 0.0))
    c = cnt.reshape(cnt.shape + (1,) * (x.ndim - 2))
    out = s / np.maximum(c, 1)
    empty = cnt == 0               # blocks with no compared sample: their plain mean
    if empty.any():
        out[empty] = x[empty].mean(1)
    return out


class _Reads(dict):
    """The signals dict, noting which signals a basis reads (``_candidates``' reuse)."""

    def __init__(self, sig):
        super().__init__(sig)
        self.read = set()

    def __getitem__(self, key):
        self.read.add(key)
        return super().__getitem__(key)

    def get(self, key, default=None):
        self.read.add(key)
        return super().get(key, default)

    def __contains__(self, key):
        self.read.add(key)
        return super().__contains__(key)

    # any other look at the whole dict counts as reading every signal (never reused wrongly)
    def _every(self):
        self.read.update(super().keys())

    def keys(self):
        self._every()
        return super().keys()

    def items(self):
        self._every()
        return super().items()

    def values(self):
        self._every()
        return super().values()

    def __iter__(self):
        self._every()
        return super().__iter__()

    def copy(self):
        self._every()
        return dict(self)


def _same_signal(a, b) -> bool:
    if a is b:
        return True
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return (isinstance(a, np.ndarray) and isinstance(b, np.ndarray)
                and a.shape == b.shape and np.array_equal(a, b))
    return type(a) is type(b) and a == b


#: {effect: index of the transition width w_r [rad/s] in its shape}: effects whose basis
#: reads the driving speed alone and carries the sign of a reversal as
#: ``friction.reversal_sign(w, w_r)`` (tanh(w / w_r), the sharp sign at w_r = 0)
_REVERSAL_WIDTH = {"low_speed_friction": 2}
#: [1] beyond |w| = TANH_SATURATION w_r, tanh(w / w_r) is +-1 in double precision
#: (1 - tanh(x) ~ 2 exp(-2 x) = 8e-18 at x = 20, below half the spacing 1.1e-16 of doubles
#: under 1; checked where it is used): the basis at w_r equals the sharp one to the bit there
TANH_SATURATION = 20.0
#: [samples] the filtered difference of a widened column is followed this far past a run of
#: changed samples before it is looked for again (the filter's tail: it ends where the filtered
#: column meets the sharp one to the bit; longer where it has not)
_TAIL = 64


def _tanh_saturates() -> bool:
    x = TANH_SATURATION * np.array([1.0, 1.5, 3.0, 1e3, 1e300])
    return bool(np.all(np.tanh(x) == 1.0) and np.all(np.tanh(-x) == -1.0))


class _Widened:
    """The block-mean columns of a reversal-width effect (``_REVERSAL_WIDTH``) at widths
    w_r > 0 from its sharp column (w_r = 0) of the same other shape parameters: the basis
    differs from the sharp one only at the samples where |w| < ``TANH_SATURATION`` w_r (near a
    reversal); there it is evaluated (the same formula, ``Effect.basis``), the low pass is run
    from the sample before each run of changed samples (its state: the sharp column's output
    there) until its output meets the sharp column's to the bit (from there on input and state
    are the same: so is every later sample), and only the blocks it touched are averaged
    again. The same numbers as the whole column computed, bit for bit (tests/
    test_reversal_friction.py), at the cost of the samples near reversals (a 600 000-sample
    four-quadrant recording: the refinement's 39 new columns in 0.15 s instead of 0.26 s of
    CPU; the widest width, 4 rad/s, changes the 35 % of its samples below 80 rad/s). One sharp
    column is held at a time (the grid lists a sharp shape's widths together)."""

    def __init__(self, sig, dt, bandwidth, mask, m, counts, edges):
        self.sig, self.dt, self.bandwidth = sig, dt, bandwidth
        self.mask, self.m, self.counts, self.edges = mask, m, counts, edges
        self.key = self.absw = None
        # the samples of the edge blocks (``edge_blocks``), in order
        self.at = (edges[:, None] * m + np.arange(m)).reshape(-1)

    def column(self, eff, shape, k, known):
        """(signals read, block-mean column, filtered samples of the edge blocks) of ``shape``
        (width ``shape[k]`` > 0); ``known``: {shape: (keys, column, edge samples)} of the
        effect's columns so far (the sharp one's, if there)."""
        sharp = shape[:k] + (0.0,) + shape[k + 1:]
        if self.key != (eff.id, sharp):
            self.sig.read = set()
            x0 = eff.basis(self.sig, sharp)
            keys = frozenset(self.sig.read)
            if keys != {"w_in"}:
                raise ValueError(f"{eff.id}: a reversal-width basis reads {sorted(keys)}")
            y0 = first_order(x0, self.dt, self.bandwidth)
            got = known.get(sharp)
            B0 = (np.asarray(got[1]) if got is not None and got[0] == keys else
                  masked_means(y0, self.mask, self.m, self.counts))
            self.key, self.keys, self.x0, self.y0, self.B0 = (eff.id, sharp), keys, x0, y0, B0
            self.Y0 = _edge_samples(y0, self.edges, self.m)
        w = self.sig["w_in"]
        if self.absw is None:
            self.absw = np.abs(w)
        x0, y0, m, n = self.x0, self.y0, self.m, len(w)
        near = np.flatnonzero(self.absw < TANH_SATURATION * shape[k])
        xs = eff.basis({"w_in": w[near]}, shape)
        changed = xs[:, 0] != x0[near, 0]
        idx, vals = near[changed], xs[changed]
        B, Y = self.B0.copy(), self.Y0.copy()
        if not len(idx):
            return self.keys, B, Y
        # runs of changed samples: a new one where the gap to the last exceeds the tail
        cut = np.flatnonzero(np.diff(idx) > _TAIL) + 1
        starts, ends = idx[np.r_[0, cut]], idx[np.r_[cut - 1, len(idx) - 1]] + 1
        windows = []                  # (first sample, filtered output up to the meeting)
        i = 0
        while i < len(starts):
            a, e = int(starts[i]), int(ends[i])
            tail = _TAIL
            while True:
                stop = min(e + tail, n)
                while i + 1 < len(starts) and starts[i + 1] < stop:   # runs overlapping
                    i += 1
                    e = int(ends[i])
                    stop = min(e + tail, n)
                xw = x0[a:stop].copy()
                j0, j1 = np.searchsorted(idx, [a, stop])
                xw[idx[j0:j1] - a] = vals[j0:j1]
                yw = first_order(xw, self.dt, self.bandwidth, None if a == 0 else y0[a - 1:a])
                met = np.flatnonzero(yw[e - a:, 0] == y0[e:stop, 0])
                if len(met) or stop == n:
                    end = e + int(met[0]) if len(met) else n
                    windows.append((a, yw[:end - a]))
                    break
                tail *= 4
            i += 1
        touched = np.zeros(len(B), bool)
        for a, yw in windows:
            touched[a // m:(a + len(yw) - 1) // m + 1] = True
            j0, j1 = np.searchsorted(self.at, [a, a + len(yw)])
            Y[j0:j1] = yw[self.at[j0:j1] - a]
        rows = np.flatnonzero(touched)
        yb = y0.reshape(-1, m, *y0.shape[1:])[rows]          # (a copy: the touched blocks)
        flat = yb.reshape(-1, *y0.shape[1:])
        for a, yw in windows:        # a window's blocks are consecutive rows of ``yb``
            at = int(np.searchsorted(rows, a // m)) * m + a % m
            flat[at:at + len(yw)] = yw
        mb = self.mask.reshape(-1, m)[rows].reshape(-1)
        B[rows] = masked_means(flat, mb, m, None if self.counts is None else self.counts[rows])
        return self.keys, B, Y


class _Patched:
    """A reused block-mean column (a view of the earlier problem's matrix) whose blocks
    ``rows`` are averaged again (``values``): written into the new matrix by ``_assemble``
    (in place, where the earlier matrix is reused) without a copy of the whole column."""

    def __init__(self, base, rows, values):
        self.base, self.rows, self.values = base, rows, values
        self.shape = base.shape

    def __array__(self, dtype=None, copy=None):
        out = np.array(self.base, dtype=dtype, copy=True)
        out[self.rows] = self.values
        return out

    def write(self, view):
        if not (view.__array_interface__ == self.base.__array_interface__):
            view[...] = self.base
        view[self.rows] = self.values


def _beyond_alone(k, extra) -> bool:
    """Are the ``extra`` columns after ``k`` lead columns filtered and averaged alone
    (``_fresh``)? Where both parts have at least two columns (averaged as a basis of several
    columns is, ``masked_means``: the same numbers as the whole basis's)."""
    return k >= 2 and extra >= 2


def _fresh(x, k, B0, Y0, dt, bandwidth, mask, m, counts, edges, beyond=False):
    """(block means, filtered samples of the edge blocks) of the basis ``x`` (n x columns)
    through the low pass; its first ``k`` columns' are ``B0`` and ``Y0`` (another shape's,
    whose basis they are: ``Effect.leads``). The low pass and the block means act column by
    column, so only the other columns are filtered and averaged: the same numbers, where
    both parts have at least two columns and are averaged as a basis of several columns is
    (``masked_means``, ``_beyond_alone``); else all are. ``beyond``: ``x`` holds only the
    columns after the ``k`` lead columns (``_beyond_alone`` true)."""
    if beyond:
        y = first_order(x, dt, bandwidth)
        return (np.hstack([B0, masked_means(y, mask, m, counts)]),
                np.hstack([Y0, _edge_samples(y, edges, m)]))
    if k and not _beyond_alone(k, x.shape[1] - k):
        k = 0
    y = first_order(x[:, k:] if k else x, dt, bandwidth)
    B, Y = masked_means(y, mask, m, counts), _edge_samples(y, edges, m)
    return (np.hstack([B0, B]), np.hstack([Y0, Y])) if k else (B, Y)


def _candidates(P_sig, candidates, loaded, dt, bandwidth, mask, m, reuse=None, counts=None,
                refined=None, edges=None):
    """Every candidate's block-mean columns (each shape's basis at sample level, through the
    transducer's low pass, block-averaged over the compared samples) and its Terms. ``reuse``:
    (signals, columns[, changed]) of an earlier problem with the same samples and block
    length (the re-linearised replay): a column whose basis read only signals equal to that
    problem's (the recording's own speed, angle, time, load) is that problem's column, the
    same numbers; the ones that read the model (its loss, sensitivities, torque) are computed
    again. ``changed``: the blocks whose compared samples differ from that problem's (the
    mask moved with the model's steps), all among its edge blocks: there a reused column is
    averaged again from its filtered samples kept there (``edge_blocks``).
    ``counts``: ``mask``'s compared samples per block (``masked_means``). ``refined``:
    {effect: shapes} scanned instead of ``Effect.shapes`` (a refinement of a selected
    effect's shape, ``Effect.refine``). ``edges``: the edge blocks (sorted) whose filtered
    samples each column keeps. Returns (cols, options, columns) with columns
    {(effect, shape): (signals read, column, filtered samples of the edge blocks)}."""
    cols, options, columns = [], {}, {}
    sig = _Reads(P_sig)
    edges = np.zeros(0, np.intp) if edges is None else edges
    old_sig, old_cols, changed = (tuple(reuse) + (None,))[:3] if reuse is not None else (
        {}, {}, None)
    same = {}
    widened = _Widened(sig, dt, bandwidth, mask, m, counts, edges)
    saturates = _tanh_saturates()
    if changed is not None:
        at = np.searchsorted(edges, changed)       # the changed blocks among the edge blocks
        mask_c = mask.reshape(-1, m)[changed].reshape(-1)
        counts_c = None if counts is None else counts[changed]

    def unchanged(keys):
        for k in keys:
            if k not in same:
                same[k] = k in old_sig and _same_signal(P_sig.get(k), old_sig[k])
            if not same[k]:
                return False
        return True

    def patched(B, Y):
        if changed is None or not len(changed):
            return B, Y
        return _Patched(B, changed, masked_means(
            Y.reshape(len(edges), m, -1)[at].reshape(-1, Y.shape[1]), mask_c, m,
            counts_c)), Y
    for eid in candidates:
        eff = EFFECTS[eid]
        if any(P_sig.get(r) is None for r in eff.requires):
            continue
        if not loaded and eid in _DRIFT_LOADED:
            continue
        terms = []
        prev = None        # (shape, basis, block means, edge samples, signals read) of the
        #                    last shape computed (an Effect.nested effect's)
        for shape in (refined or {}).get(eid) or eff.shapes(P_sig):
            if shape is None and eff.shape and not (eff.temperature_form
                                                    and P_sig.get("temperature") is not None):
                # Effect.shapes' fallback when its filter keeps no shape of the grid (a run-in
                # on an hour-long recording: every distance settles within the first fold) is
                # no shape: the effect cannot be resolved in this recording (its basis would
                # divide by None)
                continue
            old = old_cols.get((eid, shape))
            k = _REVERSAL_WIDTH.get(eid)
            if old is not None and unchanged(old[0]):
                keys = old[0]
                B, Y = patched(*old[1:])
            elif k is not None and isinstance(shape, tuple) and shape[k] > 0 and saturates:
                keys, B, Y = widened.column(eff, shape, k, {s: c for (e, s), c in
                                                            columns.items() if e == eid})
            else:
                lead = prev if prev is not None and eff.leads(shape, prev[0]) else None
                prev = None
                sig.read = set()
                k_lead, B0, Y0 = (0, None, None) if lead is None else (
                    lead[1].shape[1], lead[2], lead[3])
                beyond = lead is not None and not eff.leads(True, shape)
                # a basis that begins with the lead's and leads no other shape: only its
                # columns after the lead's are filtered and averaged (``_fresh``), so only
                # they are formed (``Effect.basis_beyond``, the same numbers)
                x = (eff.basis(sig, shape) if lead is None else
                     eff.basis_beyond(sig, shape, lead[:2]) if beyond else
                     eff.basis(sig, shape, lead[:2]))
                keys = frozenset(sig.read) | (lead[4] if lead is not None else frozenset())
                if beyond and not _beyond_alone(k_lead, x.shape[1]):
                    x = eff.basis(sig, shape, lead[:2])
                    beyond = False
                lead = None                   # (released before this basis is filtered)
                B, Y = _fresh(x, k_lead, B0, Y0, dt, bandwidth, mask, m, counts, edges,
                              beyond)
                # kept for the effect's next shape, whose basis may begin with this one
                # (Effect.leads: the mesh ripple's load law a + b |T| begins with a's)
                prev = (shape, x, B, Y, keys) if eff.nested and not beyond else None
                del x
            columns[(eid, shape)] = (keys, B, Y)
            k0 = sum(c.shape[1] for c in cols)
            cols.append(B)
            par = eff.parameters_for(shape)
            terms.append(Term(eid, shape, tuple(range(k0, k0 + B.shape[1])),
                              tuple(p.name for p in par), tuple(p.unit for p in par),
                              tuple(p.lower for p in par), tuple(p.upper for p in par),
                              eff.shape_count(shape)))
        options[eid] = terms
    return cols, options, columns


def _structure(Gb, groups, k0):
    """The generic basis as Terms: whole, each group alone and the steady (operating point)
    part. A group that holds nothing (e.g. time polynomials) extrapolates badly into a
    held-out time-ordered fold and would hide, in the whole basis's held-out error, what
    another group explains; so each is tried alone too."""
    def part(keep):
        idx = [i for i, g in enumerate(groups) if keep(g)]
        return Term("generic", None, tuple(k0 + i for i in idx), tuple(groups[i] for i in idx),
                    ("N*m",) * len(idx), (-np.inf,) * len(idx), (np.inf,) * len(idx))
    generic = part(lambda g: True)
    names = list(dict.fromkeys(groups))
    steady = [part(lambda g: g.startswith("operating point"))] + [
        part(lambda g, n=n: g == n) for n in names if n.startswith("operating point")]
    structure = [generic] + [part(lambda g, n=n: g == n) for n in names] + steady[:1]
    return generic, steady, structure


def build_problem(rec, design, mode, candidates, bandwidth, block,
                  sensitivities=None, reuse=None, refined=None) -> Problem:
    """Stage ``replay``: replay ``rec`` through ``design`` per sample, mask the jumps, and form
    the block-mean regression problem. ``reuse``: an earlier Problem of the same recording
    (another design): candidate columns that do not depend on the design are taken from it
    (``_candidates``). ``refined``: {effect: shapes} scanned instead of the effect's grid
    (``Effect.refine``: once selected)."""
    t = rec.time
    dt = float(np.median(np.diff(t)))
    # the calibration's sensitivities only where a candidate reads them (four replays)
    calibration = any(r in ("sens_k", "sens_idle", "sens_load") for c in candidates
                      for r in EFFECTS[c].requires)
    rp = replay(design, mode, rec, bandwidth, sensitivities, calibration)
    sig = rp.signals
    T_model_f = first_order(rp.T_model, dt, bandwidth)
    m = max(1, int(round(block / dt)))
    noise = R.robust_sigma(np.diff(rec.torque_in)) / np.sqrt(2)
    mask = jump_mask(t, rec.speed_in, rp.T_model, noise, dt)
    mask &= np.abs(rec.speed_in) >= REST_SPEED
    n = (len(t) // m) * m
    mask_b = mask[:n]
    counts = mask_b.reshape(-1, m).sum(1)
    valid = counts / m           # (numpy's mean of the block's booleans, the same numbers)

    def mean(x):
        return masked_means(x[:n], mask_b, m, counts)
    y = mean(rec.torque_in - T_model_f)
    temp = getattr(rec, "temperature", None)
    blocks = {"t": mean(t), "w_in": mean(rec.speed_in), "T_out": mean(rec.torque_out),
              "T_in": mean(rec.torque_in), "alpha": mean(sig["alpha_in"]),
              "temperature": mean(temp) if temp is not None else None}
    loaded = float(np.max(np.abs(rec.torque_out))) >= MIN_LOAD
    sig_n = {k: (v[:n] if isinstance(v, np.ndarray) and v.shape[:1] == t.shape else v)
             for k, v in sig.items()}
    prior, edges, into = None, None, None
    if (reuse is not None and reuse.columns is not None and reuse.m == m and reuse.dt == dt
            and reuse.bandwidth == bandwidth and reuse.mask.shape == mask.shape):
        # the blocks whose compared samples moved with the model's steps: reused columns are
        # averaged again there from their kept samples (all of them edge blocks), or, where
        # another block changed, computed afresh
        changed = np.flatnonzero((reuse.mask[:n] != mask_b).reshape(-1, m).any(1))
        if not len(changed) or (reuse.edges is not None
                                and np.isin(changed, reuse.edges).all()):
            prior = ({k: (v[:n] if isinstance(v, np.ndarray) and v.shape[:1] == t.shape
                          else v) for k, v in reuse.sig.items()}, reuse.columns, changed)
            edges = reuse.edges        # (the kept samples do not depend on the mask)
    if reuse is not None and reuse.columns is not None:
        # the earlier matrix, released by its owner, is written over (its columns are read,
        # where reused, before the new matrix is written)
        into = _released_matrix(reuse)
        into = None if into is None else (reuse.options, into)
    if edges is None:
        edges = edge_blocks(rec.speed_in[:n], rp.T_model[:n], noise, dt, m, n // m)
    parts = _assemble(sig_n, candidates, loaded, dt, bandwidth, mask_b, m, prior, counts,
                      refined, blocks, edges, into)
    if reuse is not None:
        reuse.columns = None       # (views of the earlier problem's X: released with it)
    # the replay's temporaries are freed: their heap pages go back before the next stage's peak
    from ..slaves.heap import release_free_heap
    release_free_heap()
    return Problem(rp=rp, sig=sig, y=y, blocks=blocks, m=m, dt=dt, T_model_f=T_model_f,
                   loaded=loaded, mask=mask, valid=valid, noise_sample=noise,
                   bandwidth=bandwidth, edges=edges, **parts)


def _assemble(sig_n, candidates, loaded, dt, bandwidth, mask_b, m, prior, counts, refined,
              blocks, edges, into=None) -> dict:
    """The candidates' columns and the generic basis as one matrix ``X`` with their Terms
    (the Problem's fields X, options, generic, steady, structure, groups, columns).
    ``into``: (Terms, matrix) of an earlier problem whose matrix its owner released (the
    re-linearised replay's): where the Terms lie in the same columns, the new matrix is
    written over it (the reused columns are already in place) instead of allocated."""
    cols, options, columns = _candidates(sig_n, candidates, loaded, dt, bandwidth, mask_b, m,
                                         prior, counts, refined, edges)
    Gb, groups = R.generic_basis(blocks)
    k0 = sum(c.shape[1] for c in cols)
    generic, steady, structure = _structure(Gb, groups, k0)
    cols.clear()
    if not columns:
        return dict(X=Gb, options=options, generic=generic, steady=steady,
                    structure=structure, groups=groups, columns=columns)
    shape = (len(Gb), k0 + Gb.shape[1])
    if into is not None and into[1].shape == shape and _layout(into[0]) == _layout(options):
        X = into[1]
    else:
        X = np.empty(shape)
    # (np.hstack's numbers, each column written into place and released as it goes: the
    # columns and the matrix are not both held at once, 66 MB at 600 000 samples)
    for eid, terms in options.items():   # kept for a re-linearised problem: views of X
        for term in terms:
            keys, B, Y = columns[(eid, term.shape)]
            view = (X[:, list(term.cols)] if not term.cols else
                    X[:, term.cols[0]:term.cols[-1] + 1])
            if isinstance(B, _Patched):
                B.write(view)
            elif term.cols and view.__array_interface__ != B.__array_interface__:
                view[...] = B
            columns[(eid, term.shape)] = (keys, view, Y)
            del B
    X[:, k0:] = Gb
    return dict(X=X, options=options, generic=generic, steady=steady, structure=structure,
                groups=groups, columns=columns)


def _layout(options) -> list:
    return [(eid, t.shape, t.cols) for eid, terms in options.items() for t in terms]


def _released_matrix(P):
    """The matrix of problem ``P`` when its owner released it (``P.X`` None) and only its
    columns' views hold it; else None."""
    if P.X is not None or not P.columns:
        return None
    base = next(iter(P.columns.values()))[1].base
    ok = (isinstance(base, np.ndarray) and base.ndim == 2 and base.base is None
          and base.flags.c_contiguous and base.flags.writeable
          and all(c[1].base is base for c in P.columns.values()))
    return base if ok else None


def refine_problem(P: Problem, candidates, refined: dict) -> Problem:
    """``P`` with the shapes ``refined`` ({effect: shapes}, e.g. an effect's finer grid
    ``Effect.refine``) scanned instead of their grids: the same replay, mask and blocks; the
    columns ``P`` has are reused, only the new shapes' are computed (no second replay)."""
    from dataclasses import replace as _replace
    n = len(P.y) * P.m
    full = P.mask.shape
    sig_n = {k: (v[:n] if isinstance(v, np.ndarray) and v.shape[:1] == full else v)
             for k, v in P.sig.items()}
    mask_b = P.mask[:n]
    counts = mask_b.reshape(-1, P.m).sum(1)
    parts = _assemble(sig_n, candidates, P.loaded, P.dt, P.bandwidth, mask_b, P.m,
                      (sig_n, P.columns), counts, refined, P.blocks, P.edges)
    P.columns = None               # (views of the earlier X: released with it)
    return _replace(P, **parts)
