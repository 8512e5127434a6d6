"""Scoring rules shared by the independent batches' runners (run.py, run2.py, run3.py, run4.py).

The diagnosis is a black box here: only the JSON that `cyclo-fmu diagnose FILE --mode auto
--json` prints is read. The rules were fixed from the issue texts (18, 19) and README, not
from the diagnosis code.

- **Proposals** (`unexplained.proposed`, issue 18 item 4): a proposal is right when one of its
  terms carries the expected law (powers of |speed| and |torque| within `POWER_TOL`) and it
  removes at least `PROPOSAL_REMOVES` of the held-out remainder. The powers are read from
  `design_terms` (`speed_exponent`, `load_exponent`) when the JSON gives them, else parsed
  from the term's `feature` text, which writes a factor as `|w_in|^p` or `(|w_in|/300 rad/s)^p`.
  A `refused` proposal (nothing stable across folds) is "refused".
- **Calibration effects** (`mesh_loss`, `idle_loss_scale`, issue 19) may be named in `effects`,
  or, with `--calibrate`, stand under `calibration_fit`. The runners do not pass `--calibrate`
  (the default a user gets), but a fit found there meets an expected group like the
  `calibration` block does (verdict "right (alt)"); it never counts as wrongly named.
- **Substitutes** (ids accepted for an expected id, verdict "right (alt)"): `load_ripple` for
  `mesh_ripple` where the hidden ripple grows with the load (issue 18 asks for `mesh_ripple`
  with the amplitude a + b|T|; the diagnosis names the load-scaled form `load_ripple` today,
  tolerated for now).
- **The loss level of the whole gear** (`load_loss_scale`, issue 18's "loss-scale error",
  added after the batches' expectations were fixed; a scoring tolerance disclosed in README):
  it counts wherever an expected group or the tolerated list accepts `friction_miscalibrated`
  or `mesh_loss` (`with_loss_level`), with the same verdict those would get.
- **A loss proportional to speed x |load|** is, in one mode, a loss proportional to the mesh
  power: `mesh_loss` or `friction_miscalibrated` named (or found as a calibration) with
  nothing unexplained is "right (alt)", as is the unexplained remainder with a proposal.
"""
from __future__ import annotations

import re

import numpy as np

#: [1] share of the held-out remainder a proposed form must remove (issue 18, acceptance)
PROPOSAL_REMOVES = 0.70
#: [1] tolerance on a proposed term's power of speed or torque
POWER_TOL = 0.35
#: [1] smallest |idle_loss_scale - 1| under `calibration_fit` that meets an expected
#: idle-loss group: a fifth of the smallest idle-loss error hidden in the batches (x1.25);
#: below it a fitted scale is the model's own adjustment, not a named effect
CAL_FIT_MIN_IDLE_DEV = 0.05
#: [1] smallest mesh-loss coefficient k under `calibration_fit` that meets an expected
#: load-loss group: a quarter of issue 19's k = 0.002 (a 0.05 % share of the mesh power)
CAL_FIT_MIN_MESH_K = 0.0005
#: [1] smallest |load_loss_scale - 1| under `calibration_fit` that meets an expected
#: load-loss group: half the smallest loss-scale error hidden in the batches (x0.90)
CAL_FIT_MIN_LOAD_DEV = 0.05

#: the `calibration` block is keyed by the design parameter an effect calibrates, not by the
#: effect's id: README (friction level -> mu_boundary) and issue 19 (mesh_loss_k,
#: idle_loss_scale)
CAL_PARAMS = {"friction_miscalibrated": "mu_boundary", "mesh_loss": "mesh_loss",
              "idle_loss_scale": "idle_loss", "load_loss_scale": "load_loss"}
#: a load-dependent loss level, in one mode (friction level or a share of the mesh power)
LOAD_LOSS = ("friction_miscalibrated", "mesh_loss")
#: the scale of all the gear's load-dependent losses: accepted wherever LOAD_LOSS ids are
LOSS_LEVEL = "load_loss_scale"


def with_loss_level(ids):
    """``ids`` (an expected group or a tolerated list) with ``load_loss_scale`` added where it
    accepts one of LOAD_LOSS (the scoring tolerance above)."""
    ids = list(ids)
    if any(i in LOAD_LOSS for i in ids) and LOSS_LEVEL not in ids:
        ids.append(LOSS_LEVEL)
    return ids


#: hidden kinds whose expected id may be named by a substitute: {kind: {expected: [subst]}}
SUBSTITUTES = {"ripple_load": {"mesh_ripple": ["load_ripple"]},
               "ripple_roller_load": {"mesh_ripple": ["load_ripple"]}}
#: hidden kinds that are a loss proportional to speed x |load| (rule above)
SPEED_LOAD_KINDS = ("speed_load",)


def match(entry, cid):
    """An expectation entry (an id, or "re:<regex>") against a named id."""
    return bool(re.search(entry[3:], cid)) if entry.startswith("re:") else entry == cid


def in_calibration(cid, cal):
    """Whether the `calibration` block holds the effect cid at a value whose 95 % interval
    excludes the parameter's neutral value (1 for a scale, else 0)."""
    key = CAL_PARAMS.get(cid)
    for name, v in (cal or {}).items():
        if key and key in name and isinstance(v, dict) and v.get("ci95"):
            lo, hi = v["ci95"]
            neutral = 1.0 if "scale" in name else 0.0
            if lo > neutral or hi < neutral:
                return True
    return False


def in_calibration_fit(cid, fit):
    """Whether `calibration_fit` (written by --calibrate: mesh_loss_k, idle_loss_scale and
    their 95 % half-widths under ci95) holds the effect cid beyond its interval and beyond
    the named minimum size (a NaN interval, seen when the other parameter sits on its bound,
    is judged by the size alone)."""
    if not isinstance(fit, dict):
        return False
    ci = fit.get("ci95") or {}

    def num(x):
        return float(x) if isinstance(x, (int, float)) and np.isfinite(x) else None

    def half(key):   # a missing or non-finite half-width: judged by the size alone
        h = num(ci.get(key))
        return 0.0 if h is None else h

    if cid == "mesh_loss":
        k = num(fit.get("mesh_loss_k"))
        return k is not None and k - half("mesh_loss_k") > 0 and k >= CAL_FIT_MIN_MESH_K
    if cid == "load_loss_scale":
        s = num(fit.get("load_loss_scale"))
        return s is not None and abs(s - 1) > half("load_loss_scale") and \
            abs(s - 1) >= CAL_FIT_MIN_LOAD_DEV
    if cid == "idle_loss_scale":
        s = num(fit.get("idle_loss_scale"))
        return s is not None and abs(s - 1) > half("idle_loss_scale") and \
            abs(s - 1) >= CAL_FIT_MIN_IDLE_DEV
    return False


def found_as_calibration(cid, d):
    return in_calibration(cid, d.get("calibration")) or \
        in_calibration_fit(cid, d.get("calibration_fit"))


def substitutes(truth_kinds):
    """{expected id: [ids accepted for it]} for the hidden kinds of a case."""
    out = {}
    for k in truth_kinds:
        for exp, subs in SUBSTITUTES.get(k, {}).items():
            out.setdefault(exp, []).extend(subs)
    return out


# ----------------------------------------------------------------------------- proposals
_SPEED = r"(?:w_in|w_out|n_in|omega_in|omega|ω|speed|w|n)"
_TORQUE = r"(?:tau_out|tau_in|torque_out|torque_in|t_out|t_in|tau|τ|torque|load|t)"
_FACTOR = (r"\|\s*(?P<v>{var})\s*\|"             # |var|
           r"(?:\s*/[^)^|]*\))?"                  # optional "/300 rad/s)" closing a "(...)"
           r"(?:\s*(?:\^|\*\*)\s*\(?\s*(?P<p>[0-9]*\.?[0-9]+)|(?P<sq>²))?")


def term_powers(text):
    """(power of |speed|, power of |torque|) a proposed term's feature text holds (0 where
    absent); sign(...) factors are no power. Reads `|w_in|^2`, `(|w_in|/300 rad/s)^1`,
    `(|tau_out|/10 N*m)^2`, `|T|²`."""
    s = re.sub(r"(?:sign|sgn)\s*\([^)]*\)", " ", str(text).lower())
    out = []
    for var in (_SPEED, _TORQUE):
        p = 0.0
        for m in re.finditer(r"(?<![a-z_])" + _FACTOR.format(var=var), s):
            p += 2.0 if m.group("sq") else float(m.group("p")) if m.group("p") else 1.0
        out.append(p)
    return tuple(out)


def proposal_powers(p):
    """[(speed power, torque power)] of a proposal's terms: `design_terms` when present (the
    structured form), else parsed from the terms' feature text."""
    dt = p.get("design_terms") or []
    if dt and all("speed_exponent" in t or "load_exponent" in t for t in dt):
        return [(float(t.get("speed_exponent") or 0.0), float(t.get("load_exponent") or 0.0))
                for t in dt]
    return [term_powers(tm.get("feature", "")) for tm in (p.get("terms") or [])]


def judge_proposal(want, unexplained):
    """("right" | "other form" | "weak" | "refused" | "absent", info) for a proposal against
    want = {"speed": p, "torque": q} (missing keys are 0), or {"temperature": True} (a term in
    the temperature)."""
    p = (unexplained or {}).get("proposed")
    if not p:
        return "absent", None
    before, after = p.get("heldout_rms_before_Nm"), p.get("heldout_rms_after_Nm")
    removed = (1 - after / before) if before and after is not None else float("nan")
    terms = p.get("terms") or []
    powers = proposal_powers(p)
    ws, wt = want.get("speed", 0), want.get("torque", 0)
    if want.get("temperature"):      # a term in the temperature (its family or its text)
        hit = any(re.search(r"temp|theta|θ", f"{tm.get('family', '')} {tm.get('feature', '')}",
                            re.I) for tm in terms)
    else:
        hit = any(abs(a - ws) <= POWER_TOL and abs(b - wt) <= POWER_TOL for a, b in powers)
    info = dict(formula=p.get("formula"), reading=p.get("reading"), refused=p.get("refused"),
                features=[tm.get("feature") for tm in terms], powers=powers,
                coefficients=[tm.get("coefficient") for tm in terms],
                removed=None if removed != removed else round(removed, 3))
    if p.get("refused") or not terms:
        return "refused", info
    if not removed >= PROPOSAL_REMOVES:
        return "weak", info
    return ("right" if hit else "other form"), info


# ----------------------------------------------------------------------------- claims
def unexplained_claims(d):
    """A short text of the unexplained part: its size, what it follows, the bursts and orders
    that stood against their twins, with p-values."""
    u = d.get("unexplained") or {}
    if not u.get("present"):
        return "-"
    parts = [f"{1e3 * (u.get('rms_Nm') or 0):.2f} mN*m"]
    cl = u.get("claims") or {}
    st = cl.get("structure") or {}
    if st:
        parts.append(f"structure p={st.get('p_value', float('nan')):.2g}")
    fo = u.get("follows") or {}
    if fo:
        parts.append("follows " + ", ".join(f"{k} {1e3 * v:.2f}" for k, v in fo.items()))
    for k, v in (u.get("orders") or {}).items():
        parts.append(f"order {k} {1e3 * v:.2f}" if isinstance(v, (int, float)) else
                     f"order {k}")
    b = u.get("bursts") or {}
    for k, c in (b.get("checks") or {}).items():
        if k in (b.get("tied") or []):
            parts.append(f"bursts at {k} {1e3 * (c.get('rms_Nm') or 0):.2f} "
                         f"p={c.get('p_value', float('nan')):.2g}")
    if u.get("peaks_Hz_Nm"):
        parts.append(f"peaks {u['peaks_Hz_Nm']}")
    return "; ".join(parts)
