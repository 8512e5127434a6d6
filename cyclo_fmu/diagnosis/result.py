"""Stage ``report``: the Diagnosis (the JSON contract) from the stages' results."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from model_core.effects import (EFFECTS, LOOKALIKE_GROUPS, SENSOR_EFFECTS, HeatBalanceTau,
                                TemperatureScale)

from . import residual as R
from .replay import block_means, first_order
from .problem import MIN_LOAD
from .select_effects import backdriven, fit_rms
from .selection import DELTA_BIC


class DiagnosisError(ValueError):
    """A recording with nothing to diagnose; the message says why, in one line."""


@dataclass
class Diagnosis:
    """What a diagnosis found (see ``to_json`` for the file contract)."""
    effects: list                 # dicts, largest explained RMS first
    calibration: dict             # the friction level: {name: {value, unit, ci95}} or {}
    unexplained: dict
    effect: str
    effect_description: str
    parameters: dict
    evidence: list
    located: dict
    rmse_before_Nm: float
    rmse_after_Nm: float
    zeta_d_before: float
    zeta_d_after: float
    indistinguishable_from: list = field(default_factory=list)
    suggested_test: str = ""
    whiteness_before: float = float("nan")
    whiteness_after: float = float("nan")
    excluded_blocks: int = 0
    withdrawn: list = field(default_factory=list)
    unstable: list = field(default_factory=list)
    notes: list = field(default_factory=list)
    temperature_form: bool = False
    design_check: dict = field(default_factory=dict)
    updated: tuple = field(default=None, repr=False)   # (design, notes) checked by the Diagnoser
    series: dict = field(default_factory=dict, repr=False)
    stages: dict = field(default_factory=dict, repr=False)   # the stages' typed results
    #: the recording tells a transducer gain from its look-alike losses where the claims were
    #: made (select_effects.flow_told_apart; the JSON's calibration_fit.back_driven)
    back_driven: bool = None

    def to_json(self) -> dict:
        return {"effects": self.effects, "effect": self.effect,
                "effect_description": self.effect_description,
                "parameters": self.parameters, "calibration": self.calibration,
                "unexplained": self.unexplained, "evidence": self.evidence,
                "located": self.located, "rmse_before_Nm": self.rmse_before_Nm,
                "rmse_after_Nm": self.rmse_after_Nm, "zeta_d_before": self.zeta_d_before,
                "zeta_d_after": self.zeta_d_after,
                "indistinguishable_from": self.indistinguishable_from,
                "suggested_test": self.suggested_test,
                "whiteness_p_before": self.whiteness_before,
                "whiteness_p_after": self.whiteness_after,
                "withdrawn": self.withdrawn, "unstable": self.unstable,
                "notes": self.notes, "design_check": self.design_check}


def zeta_d(w_in, T_in, w_out, T_out, T_in_model, m):
    """Eq. (31) over driven blocks (``model_core.paper.additional_loss_factor``)."""
    from model_core.paper import additional_loss_factor
    return additional_loss_factor(w_in, T_in, w_out, T_out, T_in_model, m)


def lookalikes(prob, S, opts) -> dict:
    """{selected effect: [look-alikes]}: an effect whose replacement by another candidate
    (at its best shape) fits within ``DELTA_BIC`` of the selection; and, by physics
    (``model_core.effects.LOOKALIKE_GROUPS``), a group of selected effects whose replacement
    by the other side of its group does (a transducer gain against the mesh loss with the
    idle-loss scale: alike where power flows one way only)."""
    out = {}
    for a, b in LOOKALIKE_GROUPS:
        for mine, other in ((a, b), (b, a)):
            if any(e not in opts and e not in S.ids for e in other + mine):
                continue
            for t in [x for x in S.terms if x.effect in mine]:
                # t replaced by the other side, the rest of its own side free beside it
                add = tuple(min(opts[e], key=lambda o: prob.fit((o,), cv=False).rss)
                            for e in other + mine if e != t.effect and e not in S.ids)
                f = prob.fit(tuple(x for x in S.terms if x != t) + add, cv=False)
                if f.admissible and f.bic - S.bic < DELTA_BIC:
                    out.setdefault(t.effect, []).extend(
                        e for e in other if e not in out.get(t.effect, []))
    for t in S.terms:
        rest = tuple(x for x in S.terms if x != t)
        for eid, terms in opts.items():
            if eid in S.ids or (t.effect == "friction_miscalibrated"
                                and eid not in SENSOR_EFFECTS):
                continue
            for alt in terms:
                f = prob.fit(rest + (alt,), cv=False)
                if f.admissible and f.bic - S.bic < DELTA_BIC:
                    out.setdefault(t.effect, []).append(eid)
                    break
    return out


def evidence(prob, S, opts) -> list:
    rows = []
    for eid, terms in opts.items():
        if eid in S.ids:
            t = next(x for x in S.terms if x.effect == eid)
            f = S
        else:
            fits = [prob.fit(S.terms + (alt,), cv=False) for alt in terms]
            f, t = min(zip(fits, terms), key=lambda p: p[0].bic)
            f = prob.fit(f.terms)
        v, _ = f.of(t)
        rows.append({"id": eid, "bic": f.bic, "cv_rmse_Nm": f.cv_rmse, "rss": f.rss,
                     "n_parameters": len(v), "selected": eid in S.ids,
                     "admissible": f.admissible,
                     "parameters": {n: float(x) for n, x in zip(t.names, v)},
                     "shape": t.shape})
    base = prob.fit(())
    rows.append({"id": "none", "bic": base.bic, "cv_rmse_Nm": base.cv_rmse, "rss": base.rss,
                 "n_parameters": 0, "selected": not S.terms, "admissible": True,
                 "parameters": {}, "shape": None})
    return sorted(rows, key=lambda r: r["bic"])


def _in_first_analysis(first, eid, base_rss):
    """What effect ``eid`` explains in the first analysis ``first`` = (S1, prob1, P1), at the
    design's own level (a re-linearised effect is reported there): (RMS explained in the fit,
    share of the base RSS), or None where the first analysis did not select it."""
    S1, prob1, _ = first
    own = [x for x in S1.terms if x.effect == eid]
    if not own:
        return None
    rest1 = prob1.fit(tuple(x for x in S1.terms if x not in own), cv=False)
    return fit_rms(prob1, rest1, S1), (rest1.rss - S1.rss) / max(base_rss, 1e-300)


def _entry(t, S, prob, P, first, rel1, base_rss, stability, check, offset=0.0):
    """One selected effect's dict (drop-one explained RMS, its torque at sample level, its
    parameters with 95 % intervals, its twin check). ``offset``: the change of a calibration
    effect already applied to the design by the re-linearisation (estimator), added to the
    value; what it explains and its torque are then the first analysis's."""
    v, s = S.of(t)
    eff = EFFECTS[t.effect]
    sig, dt, bw = P.sig, P.dt, P.bandwidth
    rest = prob.fit(tuple(x for x in S.terms if x != t), cv=False)
    expl = fit_rms(prob, rest, S)
    share = (rest.rss - S.rss) / max(base_rss, 1e-300)
    torque = first_order(eff.basis(sig, t.shape), dt, bw) @ v
    if t.effect == "friction_miscalibrated" and rel1 and first is not None:
        # relinearised: what the level explains, and its torque, are the first analysis's
        # (at the design's own level), at the whole relative error
        P1 = first[2]
        expl, share = _in_first_analysis(first, t.effect, base_rss) or (expl, share)
        whole = (1 + rel1) * (1 + float(v[0])) - 1
        torque = whole * first_order(eff.basis(P1.sig, None), dt, bw)[:, 0]
    if offset and first is not None:
        P1 = first[2]
        expl, share = _in_first_analysis(first, t.effect, base_rss) or (expl, share)
        whole = offset + float(v[0])
        torque = whole * first_order(eff.basis(P1.sig, None), dt, bw)[:, 0]
    params = {}
    for name, unit, val, se in zip(t.names, t.units, v, s):
        val = val + offset
        if t.effect == "friction_miscalibrated" and rel1:
            val, se = (1 + rel1) * (1 + val) - 1, (1 + rel1) * se
        params[name] = {"value": float(val), "unit": unit,
                        "ci95": [float(val - 1.96 * se), float(val + 1.96 * se)]}
    # the temperature form: the linear law (shape None) or the exponential one at a
    # temperature scale theta (a TemperatureScale), per 10 K at the column's first value
    form = (eff.temperature_form and (t.shape is None or isinstance(t.shape, TemperatureScale))
            and sig.get("temperature") is not None)
    if form:
        for x in params.values():
            x["unit"] = f"{x['unit']} per 10 K"
    if eff.shape and t.shape is not None:
        for name, (val, unit) in eff.shape_parameters(t.shape).items():
            params[name] = {"value": val, "unit": unit, "ci95": None}
    entry = {"id": t.effect, "description": eff.description, "parameters": params,
             "explained_rms_Nm": expl, "torque_rms_Nm": float(np.sqrt(np.mean(torque ** 2))),
             "share_of_residual": share, "stability": stability.get(t.effect, 1.0),
             "separating_run": eff.separating_run,
             "form": ("per 10 K of the temperature column" + (
                          f", exponential law (theta {float(t.shape):g} K)"
                          if isinstance(t.shape, TemperatureScale) else "")) if form else
                     ("time, the housing's heat balance driven by the model's loss power"
                      if isinstance(t.shape, HeatBalanceTau) else
                      ("time" if eff.shape else ""))}
    if form:
        # the per-10 K form is referred to the column's first value (model_core.effects._warm):
        # the updated design carries it as extra.thermal_T_ref
        entry["reference_temperature_C"] = float(np.asarray(sig["temperature"], float)[0])
    if check is not None:
        entry["twins"] = check.to_json()
    return entry, form


def _one_direction(w_in) -> bool:
    """The driving shaft never turns the other way: every block moving faster than the drag's
    sign regularisation (``model_core.drag.DRAG_SIGN_SPEED``, 1 rad/s: below it the speed is
    a standstill's noise) has the same sign."""
    from model_core.drag import DRAG_SIGN_SPEED
    w = np.asarray(w_in, float)
    w = w[np.isfinite(w) & (np.abs(w) > DRAG_SIGN_SPEED)]
    return bool(w.size) and bool(np.all(w > 0) or np.all(w < 0))


def _notes(sel, rem, P, effects, close_first):
    notes = []
    b = rem.unexplained["bursts"]
    if b.get("at", {}).get("load or speed steps") and not rem.step_transient:
        notes.append(f"{b['at']['load or speed steps']} of the {b['count']} excluded spike "
                     "blocks sit at load or speed steps; their residual does not stand out "
                     "against the twins (time-shifted residual)")
    if not P.loaded:
        notes.append(f"no load (|torque_out| below {MIN_LOAD:g} N*m): the friction level "
                     "and the load-dependent effects cannot be judged")
    for eid_, t_rms, g_rms in rem.dominant:
        notes.append(f"{eid_} named though a smooth function of the operating point could "
                     f"stand in for it: it explains {1e3 * t_rms:.2f} mN*m, more than the "
                     f"{1e3 * g_rms:.2f} mN*m the generic basis adds beside it (a shape the "
                     "library's term does not quite have, or a small unknown; "
                     + ("reported as unexplained)" if rem.smooth else
                        "not beyond its twins)"))
    if getattr(sel, "reshaped", None):
        notes.append(f"{' and '.join(sel.reshaped)} not named: the recording wanted these "
                     "free scales of the gear's load-dependent losses together, which reshapes "
                     "the model's loss law instead of setting its level (the loss follows a "
                     "law other than the model's; either scale alone would stand in for it)")
    for c in dict.fromkeys(sel.confounded):
        notes.append(f"{c} not named: a steady function of the operating point explains the "
                     "same change over time (the recording does not return to its operating "
                     f"points late enough to tell a drift apart); to separate: "
                     f"{EFFECTS[c].separating_run}")
    one_way = _one_direction(P.blocks["w_in"])
    for e in effects:
        if one_way and e["id"] in ("torque_sensor_offset", "torque_sensor_drift"):
            notes.append(f"{e['id']}: the driving shaft turns one way only in this recording, "
                         "so a loss of the same course (a drag that is constant, or follows "
                         "time or temperature, and opposes the motion) reads the same; a "
                         "transducer's zero keeps its sign when the motion reverses, a loss "
                         "does not: runs in both directions separate them")
    for c in rem.unexplained.get("_rejected", []):
        notes.append(f"{c} proposed by the selection but not named: its statistic lies within "
                     "what twins of the recording show at the false-alarm rate")
    if rem.gain_alone is not None:
        g, e, left = rem.gain_alone
        notes.append(f"a transducer gain error of {100 * g:+.2g} % would explain "
                     f"{1e3 * e:.2f} mN*m of what is left"
                     + ("" if left else " and leave nothing structured")
                     + "; not named: " + ("its back-driven segments, held out, do not "
                                          "prefer it to the losses it looks like, so"
                                          if backdriven(P.blocks) else
                                          "without back-driven segments")
                     + " a gain error cannot be told from a friction law other than the "
                     "model's (back-driven segments separate them: the losses change side, a "
                     "gain error does not)")
    elif "torque_sensor_gain" in [e["id"] for e in effects] + close_first:
        notes.append("a transducer gain error and a friction level error look alike in "
                     "forward driving; back-driven segments separate them")
    return notes



def headline(effects, calibration, close) -> tuple:
    """A diagnosis's headline from its named ``effects`` (largest first) and ``calibration``
    (the friction level, {} if none): ``(effect, its description, parameters, look-alikes,
    suggested test)``. The parameters are the first effect's with the calibration beside them
    (the friction level's own when it is the headline); ``close`` are the headline's
    look-alikes, and the suggested test is the separating runs of it and of them (none
    without look-alikes)."""
    best = effects[0] if effects else None
    eid = best["id"] if best else "none"
    params = dict(best["parameters"]) if best else {}
    if calibration and eid != "friction_miscalibrated":
        params = {**calibration, **params}
    test = ("; ".join(EFFECTS[c].separating_run for c in [eid] + list(close)) if close
            else "")
    return eid, EFFECTS[eid].description, params, list(close), test

def _located(P, y, rem, mismatch: bool) -> dict:
    """Where the residual ``y`` (block means) sits over the operating points
    (``residual.locate``), with the shaft orders that stand beyond their twins; without a
    named effect or a remainder (``mismatch`` False), that there is nothing to locate."""
    located = R.locate(P.blocks["t"], y, P.blocks["w_in"], P.blocks["T_out"],
                       P.blocks["T_in"], P.blocks["alpha"], P.blocks["temperature"])
    located["orders"] = {k: a for k, (a, c) in rem.orders_all.items()
                         if c is not None and c.stands}
    if not mismatch:
        located["statement"] = ("the model explains the recording within its noise: "
                                "there is no mismatch to locate.")
    elif located["orders"]:
        located["statement"] = located["statement"][:-1] + "; it sits at " + ", ".join(
            f"{k} of the input speed ({1e3 * v:.1f} mN*m)" for k, v in located["orders"].items()
        ) + "."
    return located


def report(rec, first, sel, J, rem, P, rel1, first_P, cal_offsets=None) -> Diagnosis:
    """Stage ``report``: ``first`` is the first analysis's selection (at the design's own
    friction level and calibration), ``sel``/``P`` the final one's; ``cal_offsets`` the
    calibration changes the re-linearisation applied ({effect: change})."""
    cal_offsets = cal_offsets or {}
    prob, S = sel.prob, rem.S
    base0 = first.base
    effects, calibration, temp_form, cal_entry = [], {}, False, None
    for t in S.terms:
        entry, form = _entry(t, S, prob, P, (first.S, first.prob, first_P)
                             if first is not sel else None, rel1, base0.rss, sel.stability,
                             J.checks.get(t.effect), cal_offsets.get(t.effect, 0.0))
        temp_form = temp_form or form
        if t.effect == "friction_miscalibrated":
            calibration, cal_entry = entry["parameters"], entry
        else:
            effects.append(entry)
    effects.sort(key=lambda e: -e["explained_rms_Nm"])
    un = rem.unexplained
    if not effects and calibration and not (rem.friction_doubted and un["present"]):
        effects = [cal_entry]
    eid = effects[0]["id"] if effects else "none"
    # look-alikes where the claims were made: at the first linearisation when the calibration
    # was re-linearised (there the forced calibration terms carry only the last correction)
    close = (lookalikes(first.prob, first.S, first.opts) if cal_offsets and first is not sel
             else lookalikes(prob, S, sel.opts))
    close = {k: list(dict.fromkeys(e for e in v if e not in S.ids)) for k, v in close.items()}
    # where the claims were made: at the first linearisation when the calibration was
    # re-linearised (the forced calibration terms carry only the last correction there)
    told = first.backdriven if cal_offsets and first is not sel else sel.backdriven
    if not told:
        # the back-driven blocks (none, or, held out, without a preference:
        # select_effects.flow_told_apart) do not tell a gain from losses: the look-alike groups
        # are alike by physics, whatever the fit's BIC says (a difference there comes from
        # transients and shapes, not from the flow reversal that separates them)
        for a, b in LOOKALIKE_GROUPS:
            for mine, other in ((a, b), (b, a)):
                for t in S.terms:
                    if t.effect in mine:
                        close.setdefault(t.effect, []).extend(
                            e for e in other if e in sel.opts and e not in S.ids
                            and e not in close[t.effect])
    for e in effects:
        e["indistinguishable_from"] = close.get(e["id"], [])
    close_first = close.get(eid if effects else "friction_miscalibrated", [])
    y_before = first_P.y
    y_after = block_means(rem.residual_raw, P.m)
    located = _located(P, y_before if sel is first else P.y, rem,
                       bool(effects) or un["present"])
    fitted = rec.torque_in - P.T_model_f - rem.residual_raw
    z_before = zeta_d(rec.speed_in, rec.torque_in, rec.speed_out, rec.torque_out,
                      first_P.rp.T_model, P.m)
    z_after = zeta_d(rec.speed_in, rec.torque_in, rec.speed_out, rec.torque_out,
                     P.rp.T_model + fitted, P.m)
    notes = _notes(sel, rem, P, effects, close_first)
    un.pop("_rejected", None)
    eid, description, params, close_first, test = headline(effects, calibration, close_first)
    d = Diagnosis(
        effects=effects, calibration=calibration, unexplained=un, effect=eid,
        effect_description=description, parameters=params,
        evidence=evidence(prob, S, sel.opts), located=located,
        rmse_before_Nm=base0.cv_rmse,
        rmse_after_Nm=S.cv_rmse if eid != "none" or S.terms else base0.cv_rmse,
        zeta_d_before=z_before, zeta_d_after=z_after, indistinguishable_from=close_first,
        suggested_test=test, back_driven=told,
        whiteness_before=R.ljung_box_p(y_before), whiteness_after=R.ljung_box_p(y_after),
        excluded_blocks=sel.n_spikes, withdrawn=rem.withdrawn, unstable=sel.unstable,
        notes=notes, temperature_form=temp_form,
        series={"t": P.blocks["t"], "residual_before": y_before[:len(y_after)],
                "residual_after": y_after, "speed_in": P.blocks["w_in"],
                "torque_out": P.blocks["T_out"], "temperature": P.blocks["temperature"]})
    return d
