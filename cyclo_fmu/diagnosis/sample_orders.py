"""Stage ``orders``: the library's mesh ripple judged where it is resolvable, at sample level.

The selection compares model and measurement on block means (``problem``: 10 ms). A shaft
order whose frequency is several times the block rate averages out of a block mean, of the
residual and of the ripple's columns alike: a roller-pass ripple at 300-500 Hz leaves only
its leakage in 10 ms blocks (about 1/(2 pi f T_block) of its amplitude, a few per cent), and a
recording that never runs slowly (a fast plan, a load that switches every few blocks) gives the
selection nothing to choose it on. The remainder stage sees it at sample level
(``remainder._lines``: the roller pass against its off-order twins) and reported it as "library
orders left".

Here the ripple is fitted on what the block means do not hold: the sample-level residual minus
its block means (over the compared samples), against the ripple's columns (through the
transducer's low pass) minus theirs. Within-block deviations are orthogonal to block means
over the same samples, so this fit takes nothing from the block-level selection's
information and the selection's fits stand as they are. The amplitude law (0: a; 1:
a + b |tau_out|/T_REF, ``model_core.effects.RIPPLE_LOAD_LAWS``) is chosen like the selection
chooses a shape: on BIC and on the held-out error of time-ordered folds. The claim itself stood
already against the orders' twins (the remainder's order claims at the false-alarm rate); the
named effect carries that check.
"""
from __future__ import annotations

import math

import numpy as np

from model_core.effects import EFFECTS, RIPPLE_LOAD_LAWS, ripple_orders

from . import residual as R
from .problem import masked_means
from .remainder import orders_part
from .replay import first_order
from .select_effects import MIN_EXPLAINED_NM
from .selection import DELTA_BIC


def _within(x, mask, m, counts):
    """``x`` (n, k) minus its block means over the compared samples (in place)."""
    mb = masked_means(x, mask, m, counts)
    x -= np.repeat(mb, m, axis=0)
    return x


def _resolvable(P, n):
    """Samples where every ripple order is resolved: compared (``P.mask``), moving (above
    ``residual.MOVING_SHARE`` of the peak speed) and the highest order below
    ``residual.ORDER_NYQUIST_SHARE`` of the sampling rate (the remainder's order analysis)."""
    w = np.abs(P.sig["w_in"][:n])
    k_max = max(abs(k) for k in ripple_orders(P.sig))
    f_max = k_max * w / (2 * math.pi)
    return (P.mask[:n] & (w > R.MOVING_SHARE * max(float(np.max(w)), 1e-12))
            & (f_max < R.ORDER_NYQUIST_SHARE / P.dt))


def fit_ripple(P, r_raw, n_folds=5):
    """The mesh ripple fitted on the within-block residual at sample level: None where too few
    samples resolve it, else a dict with the law, its coefficients and standard errors, the
    held-out RMS it removes and its sample-level torque's RMS."""
    m = P.m
    n = len(P.y) * m
    use = _resolvable(P, n)
    if np.count_nonzero(use) < 100 * 4 * len(RIPPLE_LOAD_LAWS):
        return None
    mask = P.mask[:n]
    counts = mask.reshape(-1, m).sum(1)
    eff = EFFECTS["mesh_ripple"]
    law_max = max(RIPPLE_LOAD_LAWS)
    sig = {k: (v[:n] if isinstance(v, np.ndarray) and v.shape[:1] == P.mask.shape else v)
           for k, v in P.sig.items()}
    # the columns through the transducer's low pass one at a time, in place (the basis is the
    # stage's largest array: no filtered copy of it beside it)
    B = eff.basis(sig, law_max)
    for j in range(B.shape[1]):
        B[:, j] = first_order(B[:, j], P.dt, P.bandwidth)
    B = _within(B, mask, m, counts)
    r = _within(np.array(r_raw[:n], float)[:, None], mask, m, counts)[:, 0]
    # the samples that do not resolve the orders weigh nothing (zeroed in place, no copy)
    B[~use] = 0.0
    r[~use] = 0.0
    nu = int(np.count_nonzero(use))
    # time-ordered folds with equal shares of the resolvable samples; per-fold Gram matrices
    cum = np.cumsum(use)
    bounds = np.searchsorted(cum, (np.arange(n_folds + 1) * nu) // n_folds, side="left")
    bounds[0], bounds[-1] = 0, n
    Gf = [B[a:b].T @ B[a:b] for a, b in zip(bounds[:-1], bounds[1:])]
    bf = [B[a:b].T @ r[a:b] for a, b in zip(bounds[:-1], bounds[1:])]
    rf = [float(r[a:b] @ r[a:b]) for a, b in zip(bounds[:-1], bounds[1:])]
    G, bb, rr = sum(Gf), sum(bf), sum(rf)

    def solve(Gm, bm, k):
        return np.linalg.lstsq(Gm[:k, :k], bm[:k], rcond=1e-12)[0]

    laws = {}
    for law in RIPPLE_LOAD_LAWS:
        k = len(eff.parameters_for(law))
        c = solve(G, bb, k)
        rss = max(rr - 2 * c @ bb[:k] + c @ G[:k, :k] @ c, 1e-300)
        held, jack = 0.0, []
        for f in range(n_folds):
            cf = solve(G - Gf[f], bb - bf[f], k)
            jack.append(cf)
            held += rf[f] - 2 * cf @ bf[f][:k] + cf @ Gf[f][:k, :k] @ cf
        laws[law] = dict(k=k, coef=c, rss=rss, held=max(held, 0.0), jack=np.array(jack),
                         bic=nu * math.log(rss / nu) + k * math.log(nu))
    best = min(RIPPLE_LOAD_LAWS)
    for law in sorted(RIPPLE_LOAD_LAWS)[1:]:
        # a richer law only where it is better both on BIC (by DELTA_BIC) and held out
        if (laws[law]["bic"] < laws[best]["bic"] - DELTA_BIC
                and laws[law]["held"] < laws[best]["held"]):
            best = law
    L = laws[best]
    k = L["k"]
    s2 = L["rss"] / max(nu - k, 1)
    se = np.sqrt(np.maximum(np.diag(np.linalg.pinv(G[:k, :k])) * s2, 0.0))
    # the standard error of white sample noise, or the leave-one-fold-out jackknife's where
    # larger (coloured noise, a noisy load signal in the load part: the folds' spread says)
    J = L["jack"]
    se_jack = np.sqrt((n_folds - 1) / n_folds * np.sum((J - J.mean(0)) ** 2, axis=0))
    se = np.maximum(se, se_jack)
    del B, r
    # (the low pass is linear and starts in steady state: the filtered sum is the sum filtered)
    torque = first_order(eff.basis(sig, best) @ L["coef"], P.dt, P.bandwidth)
    return dict(law=best, coef=L["coef"], se=se,
                explained=math.sqrt(max(rr - L["held"], 0.0) / nu),
                torque_rms=float(np.sqrt(np.mean(torque ** 2))), n=nu,
                share=max(rr - L["rss"], 0.0) / max(rr, 1e-300))


def name_ripple(d, P, rem, n_folds=5):
    """Where the remainder found the library's orders left (standing against their twins at
    sample level, ``remainder._lines``) and no mesh ripple is named, fit it at sample level
    (``fit_ripple``) and name it in ``d`` (a ``Diagnosis``): the effect with its parameters,
    the orders taken out of what is unexplained. ``d`` is changed in place and returned."""
    un = d.unexplained
    inside = dict(un.get("library_orders_left") or {})
    if not inside or any(e["id"] == "mesh_ripple" for e in d.effects):
        return d
    fit = fit_ripple(P, rem.residual_raw, n_folds)
    if fit is None or fit["explained"] < MIN_EXPLAINED_NM:
        return d
    eff = EFFECTS["mesh_ripple"]
    names = [p for p in eff.parameters_for(fit["law"])]
    params = {p.name: {"value": float(v), "unit": p.unit,
                       "ci95": [float(v - 1.96 * s), float(v + 1.96 * s)]}
              for p, v, s in zip(names, fit["coef"], fit["se"])}
    for name, (val, unit) in eff.shape_parameters(fit["law"]).items():
        params[name] = {"value": val, "unit": unit, "ci95": None}
    checks = un.get("claims", {}).get("orders", {})
    check = max((checks[n] for n in inside if n in checks),
                key=lambda c: c.get("statistic", 0.0), default=None)
    entry = {"id": "mesh_ripple", "description": eff.description, "parameters": params,
             "explained_rms_Nm": fit["explained"], "torque_rms_Nm": fit["torque_rms"],
             "share_of_residual": fit["share"], "stability": 1.0,
             "separating_run": eff.separating_run, "form": "time",
             "judged": "at sample level: the residual and the ripple's columns minus their "
                       "block means", "indistinguishable_from": []}
    if check is not None:
        entry["twins"] = check
    from .result import headline
    effects = [e for e in d.effects if e["id"] != "friction_miscalibrated"
               or not d.calibration] + [entry]
    effects.sort(key=lambda e: -e["explained_rms_Nm"])
    d.effects = effects
    close = d.indistinguishable_from if d.effect == effects[0]["id"] else []
    d.effect, d.effect_description, d.parameters, d.indistinguishable_from, \
        d.suggested_test = headline(effects, d.calibration, close)
    # the orders taken out of what is unexplained
    # the listed orders outside the library (the order scan's orders have a part of their own)
    scanned = un.get("claims", {}).get("order_scan", {})
    outside = {n: a for n, a in (un.get("orders") or {}).items() if n not in scanned}
    old = orders_part({**inside, **outside})
    left = math.sqrt(max(un.get("rms_Nm", 0.0) ** 2
                         - sum(a * a / 2 for a in inside.values()), 0.0))
    un["library_orders_left"] = {}
    b = un.get("bursts", {})
    still = (rem.smooth or bool(un.get("orders")) or bool(un.get("peaks_Hz_Nm"))
             or any("reversal" in e or e == "load or speed steps" for e in b.get("tied", [])))
    if still:
        st = un["statement"]
        if outside:
            st = st.replace(old, orders_part(outside))
        else:
            for a in ("; " + old, old + "; ", old):
                if a in st:
                    st = st.replace(a, "", 1)
                    break
        un["statement"] = st
        un["rms_Nm"] = left
    else:
        un.update(present=False, rms_Nm=0.0, statement="nothing the model and the selected "
                  "effects leave is structured beyond the noise.")
    d.notes.append(
        f"mesh_ripple named at sample level (load law {fit['law']:g}): its orders lie above "
        f"what the {1e3 * P.m * P.dt:g} ms block means resolve, so it was fitted on the "
        f"within-block residual of {fit['n']} moving samples; it stood against its off-order "
        "twins in the remainder's order analysis")
    return d
