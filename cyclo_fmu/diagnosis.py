"""Diagnosis: where simulation and recording differ, which left-out physics explains it.

``Diagnoser(design, mode).fit(recording)`` replays the recording through the reducer model the
FMU carries (measured input speed and output torque in, input torque out), locates the
mismatch in the residual, fits every candidate effect of model_core.effects jointly with the
model's uncertain coefficient (the friction level: a scale on the model's losses), ranks them
by BIC and by blocked, time-ordered cross-validation, and reports a ``Diagnosis``.

Fitting works on means over short blocks (default 10 ms): linear terms stay linear, white
transducer noise averages down, and ten minutes at 1 kHz become 60 000 rows.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from model_core import DriveDesign
from model_core.effects import EFFECTS
from model_core.kinematics import parse_mode, shaft_speeds
from model_core.lossmap import ModeMap

from .synth import signals_for_effects

#: what separates two effects that the data could not tell apart (discrepancy.md)
SEPARATING_TEST = {
    "load_independent_loss": "a speed sweep at light load, in both directions",
    "thermal_drift": "a cold start held at one operating point, with a temperature channel",
    "inertia": "slow and fast ramps up and down",
    "mesh_ripple": "an order analysis at several constant speeds",
    "low_speed_friction": "a low-speed sweep at constant load",
    "torque_sensor_offset": "a zero reading at standstill and runs in both directions",
    "friction_miscalibrated": "a load sweep at constant speed",
}
DELTA_BIC = 10.0     # 'very strong' evidence on the Kass-Raftery scale
PRACTICAL = 0.10     # and at least 10 % less held-out RMSE: long recordings make tiny,
#                      meaningless terms (e.g. a time skew between channels) 'significant'



@dataclass
class CandidateFit:
    id: str
    values: np.ndarray           # linear parameters: [loss scale error, effect params...]
    names: list
    units: list
    shape: float | None
    rss: float
    n: int
    k: int
    bic: float
    cv_rmse: float
    stderr: np.ndarray

    def as_dict(self):
        return {"id": self.id, "bic": self.bic, "cv_rmse_Nm": self.cv_rmse,
                "rss": self.rss, "n_parameters": self.k,
                "parameters": {n: float(v) for n, v in zip(self.names, self.values)},
                "shape": self.shape}


@dataclass
class Diagnosis:
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
    series: dict = field(default_factory=dict, repr=False)   # block-mean signals for plots

    def to_json(self) -> dict:
        return {"effect": self.effect, "effect_description": self.effect_description,
                "parameters": self.parameters, "evidence": self.evidence,
                "located": self.located, "rmse_before_Nm": self.rmse_before_Nm,
                "rmse_after_Nm": self.rmse_after_Nm, "zeta_d_before": self.zeta_d_before,
                "zeta_d_after": self.zeta_d_after,
                "indistinguishable_from": self.indistinguishable_from,
                "suggested_test": self.suggested_test,
                "whiteness_p_before": self.whiteness_before,
                "whiteness_p_after": self.whiteness_after}


def _block_means(x, m):
    n = (len(x) // m) * m
    return x[:n].reshape(-1, m, *x.shape[1:]).mean(1)


def _first_order(x, dt, bandwidth):
    if bandwidth <= 0:
        return x
    from scipy.signal import lfilter
    a = math.exp(-2 * math.pi * bandwidth * dt)
    zi = a * x[:1]          # start in steady state: shape (1,) or (1, k)
    return lfilter([1 - a], [1, -a], x, axis=0, zi=zi)[0]


def ljung_box_p(x, lags=20):
    """p-value of the Ljung-Box test that x is white (small p: structure left)."""
    from scipy.stats import chi2
    x = np.asarray(x, float) - np.mean(x)
    n = len(x)
    denom = np.dot(x, x)
    if denom == 0 or n <= lags + 1:
        return 1.0
    q = 0.0
    for k in range(1, lags + 1):
        r = np.dot(x[k:], x[:-k]) / denom
        q += r * r / (n - k)
    return float(chi2.sf(n * (n + 2) * q, lags))


class Diagnoser:
    """Estimator: ``fit(recording)`` returns a Diagnosis (scikit-learn style, no state kept
    between fits except the settings)."""

    def __init__(self, design: DriveDesign = None, mode: str = "S1", bandwidth: float = 1000.0,
                 block: float = 0.01, n_folds: int = 5):
        self.design = design or DriveDesign()
        self.mode = "".join(parse_mode(mode)[:2])
        self.bandwidth = bandwidth
        self.block = block
        self.n_folds = n_folds

    # -- replay ------------------------------------------------------------------------------
    def replay(self, t, w_in, T_in, w_out, T_out, design=None):
        """Model input torque for the measured input speed and output torque (N*m)."""
        tau_out = -T_out
        tmax = float(np.max(np.abs(tau_out))) * 1.05 + 1e-6
        wmax = float(np.max(np.abs(w_in))) * 1.05 + 1e-6
        sol = ModeMap(design or self.design, self.mode, tmax, wmax).solve_arrays(w_in, tau_out)
        b = self.mode[1]
        ratio = float(shaft_speeds(self.mode, 1.0, self.design.z1)[b])
        lossless = -tau_out * ratio
        return sol["tau_in"], sol["tau_in"] - lossless

    def friction_sensitivity(self, t, w_in, T_in, w_out, T_out, T_model):
        """d T_in_model / d ln(mu_boundary): the column of the model's uncertain coefficient
        (the friction level), by a 10 % finite difference of the full model."""
        from dataclasses import replace
        d = self.design
        hi = replace(d, friction=replace(d.friction, mu_boundary=d.friction.mu_boundary * 1.1))
        return (self.replay(t, w_in, T_in, w_out, T_out, hi)[0] - T_model) / 0.1

    # -- fitting ------------------------------------------------------------------------------
    def _fit_one(self, y, X, folds):
        n, k = X.shape
        if k == 0:
            rss = float(y @ y)
            cv = float(np.sqrt(np.mean(y ** 2)))
            return np.zeros(0), rss, cv, np.zeros(0)
        coef, *_ = np.linalg.lstsq(X, y, rcond=None)
        res = y - X @ coef
        rss = float(res @ res)
        err = np.empty_like(y)
        for f in range(self.n_folds):
            test = folds == f
            c, *_ = np.linalg.lstsq(X[~test], y[~test], rcond=None)
            err[test] = y[test] - X[test] @ c
        cv = float(np.sqrt(np.mean(err ** 2)))
        sigma2 = rss / max(n - k, 1)
        try:
            cov = sigma2 * np.linalg.inv(X.T @ X)
            se = np.sqrt(np.clip(np.diag(cov), 0, None))
        except np.linalg.LinAlgError:
            se = np.full(k, np.nan)
        return coef, rss, cv, se

    def prepare(self, rec) -> dict:
        """Replay and the regression problem in 10 ms block means: the residual ``y`` (measured -
        model input torque), the friction-level column ``fric``, ``columns(effect_id, shape)``
        for any candidate, and the block-mean signals (time, speed, output torque)."""
        t, w_in, T_in = rec.time, rec.speed_in, rec.torque_in
        w_out, T_out = rec.speed_out, rec.torque_out
        dt = float(np.median(np.diff(t)))
        T_model, loss_in = self.replay(t, w_in, T_in, w_out, T_out)
        sens_f = _first_order(self.friction_sensitivity(t, w_in, T_in, w_out, T_out, T_model),
                              dt, self.bandwidth)
        # smooth the measured speed before differentiating it (20 ms)
        m_s = max(1, int(round(0.02 / dt)))
        from scipy.ndimage import uniform_filter1d
        w_s = uniform_filter1d(w_in, m_s, mode="nearest")
        sig = signals_for_effects(t, w_s, loss_in, self.mode, self.design.z1,
                                  getattr(rec, "temperature", None))
        # the design's own extra physics (after an earlier diagnosis) belongs to the model
        from model_core.effects import extra_torque
        T_model = T_model + extra_torque(self.design.extra, sig)
        T_model_f = _first_order(T_model, dt, self.bandwidth)
        m = max(1, int(round(self.block / dt)))
        fric = _block_means(sens_f, m)[:, None]

        def columns(eid, shape=None):
            if eid == "none":
                return np.zeros((len(fric), 0))
            if eid == "friction_miscalibrated":
                return fric
            B = _first_order(EFFECTS[eid].basis(sig, shape), dt, self.bandwidth)
            return np.hstack([fric, _block_means(B, m)])
        return {"y": _block_means(T_in - T_model_f, m), "t": _block_means(t, m), "fric": fric,
                "columns": columns, "w_in": _block_means(w_in, m),
                "T_out": _block_means(T_out, m), "T_in": _block_means(T_in, m),
                "alpha": _block_means(sig["alpha_in"], m), "m": m, "dt": dt, "sig": sig,
                "sens_f": sens_f, "T_model": T_model, "T_model_f": T_model_f}

    def fit(self, rec) -> Diagnosis:
        """Diagnose a recording (cyclo_fmu.recordings.Recording, SI units)."""
        t, w_in, T_in = rec.time, rec.speed_in, rec.torque_in
        w_out, T_out = rec.speed_out, rec.torque_out
        P = self.prepare(rec)
        y, tb, fric, m, dt, sig = P["y"], P["t"], P["fric"], P["m"], P["dt"], P["sig"]
        sens_f, T_model, T_model_f = P["sens_f"], P["T_model"], P["T_model_f"]
        n = len(y)
        folds = np.minimum((np.arange(n) * self.n_folds) // n, self.n_folds - 1)
        fits = []
        for eid, eff in EFFECTS.items():
            shapes = eff.shape or (None,)
            best = None
            for shape in shapes:
                X = P["columns"](eid, shape)
                coef, rss, cv, se = self._fit_one(y, X, folds)
                if best is None or rss < best[2]:
                    best = (shape, coef, rss, cv, se, X.shape[1])
            shape, coef, rss, cv, se, k = best
            k_tot = k + (1 if eff.shape else 0)
            bic = n * math.log(max(rss, 1e-300) / n) + k_tot * math.log(n)
            names = ([] if eid == "none" else ["mu_boundary_rel_error"]) + \
                [p.name for p in eff.parameters if eid != "friction_miscalibrated"]
            units = ([] if eid == "none" else ["1"]) + \
                [p.unit for p in eff.parameters if eid != "friction_miscalibrated"]
            fits.append(CandidateFit(eid, coef, names, units, shape, rss, n, k_tot, bic, cv, se))
        by_id = {f.id: f for f in fits}
        ranked = sorted(fits, key=lambda f: f.bic)
        # decision: an effect must beat friction-only, which must beat the plain model
        base = by_id["none"]
        fr = by_id["friction_miscalibrated"]
        best = ranked[0]
        # statistically (BIC) and practically (held-out RMSE down by PRACTICAL) better
        if best.id not in ("none", "friction_miscalibrated") and (
                fr.bic - best.bic < DELTA_BIC or best.cv_rmse > (1 - PRACTICAL) * fr.cv_rmse):
            best = fr
        if best.id == "friction_miscalibrated" and (
                base.bic - fr.bic < DELTA_BIC or fr.cv_rmse > (1 - PRACTICAL) * base.cv_rmse):
            best = base
        close = [f.id for f in ranked if f.id not in (best.id, "none", "friction_miscalibrated")
                 and f.bic - best.bic < DELTA_BIC]
        if best.id in ("none", "friction_miscalibrated"):
            close = []
        eff = EFFECTS[best.id]
        params = {}
        for name, unit, v, s in zip(best.names, best.units, best.values, best.stderr):
            params[name] = {"value": float(v), "unit": unit,
                            "ci95": [float(v - 1.96 * s), float(v + 1.96 * s)]}
        if best.shape is not None:
            params[eff.shape_name] = {"value": float(best.shape), "unit": eff.shape_unit,
                                      "ci95": None}
        # residuals after the fix, for whiteness and zeta_d
        if best.id == "none":
            fitted = np.zeros_like(T_in)
        else:
            B = sens_f[:, None] if best.id == "friction_miscalibrated" else np.hstack(
                [sens_f[:, None], _first_order(eff.basis(sig, best.shape), dt, self.bandwidth)])
            fitted = B @ best.values
        y_after = _block_means(T_in - T_model_f - fitted, m)
        located = self._locate(tb, y, _block_means(w_in, m), _block_means(T_out, m),
                               _block_means(T_in, m), _block_means(sig["alpha_in"], m))
        located.update(self._orders(T_in - T_model_f, sig))
        if located["orders"]:
            located["statement"] = located["statement"][:-1] + "; it sits at " + ", ".join(
                f"{k} of the input speed ({1e3 * v:.1f} mN*m)"
                for k, v in located["orders"].items()) + "."
        z_before = self._zeta_d(w_in, T_in, w_out, T_out, T_model, m)
        z_after = self._zeta_d(w_in, T_in, w_out, T_out, T_model + fitted, m)
        return Diagnosis(
            effect=best.id, effect_description=eff.description, parameters=params,
            evidence=[f.as_dict() for f in ranked], located=located,
            rmse_before_Nm=base.cv_rmse, rmse_after_Nm=best.cv_rmse,
            zeta_d_before=z_before, zeta_d_after=z_after, indistinguishable_from=close,
            suggested_test="; ".join(SEPARATING_TEST.get(c, "") for c in [best.id] + close)
            if close else "",
            whiteness_before=ljung_box_p(y), whiteness_after=ljung_box_p(y_after),
            series={"t": tb, "residual_before": y, "residual_after": y_after,
                    "speed_in": _block_means(w_in, m), "torque_out": _block_means(T_out, m)})

    # -- location and the paper's additional-loss factor -------------------------------------
    @staticmethod
    def _zeta_d(w_in, T_in, w_out, T_out, T_in_model, m):
        """Eq. (31) over the recording's driven samples: (P_t - P_e)/P_in(e), where P_t is the
        model's output power at the measured input power: zeta_d = eta_model - eta_measured."""
        p_in = _block_means(T_in * w_in, m)
        p_out = _block_means(T_out * w_out, m)
        p_in_model = _block_means(T_in_model * w_in, m)
        sel = (p_in > 0.1 * np.max(p_in)) & (p_out > 0) & (p_in_model > 0)
        if not sel.any():
            return float("nan")
        eta_model = p_out[sel].sum() / p_in_model[sel].sum()
        eta_meas = p_out[sel].sum() / p_in[sel].sum()
        return float(eta_model - eta_meas)

    @staticmethod
    def _orders(r, sig):
        """Amplitude of the raw residual at the 1x and roller-pass orders of the input speed
        (least-squares projection on sin/cos of the shaft angle), where it stands out."""
        th, k = sig["theta_in"], sig["order_roller"]
        moving = np.abs(sig["w_in"]) > 0.05 * np.max(np.abs(sig["w_in"]))
        if moving.sum() < 100:
            return {"orders": {}}
        B = np.stack([np.sin(th), np.cos(th), np.sin(k * th), np.cos(k * th),
                      np.ones_like(th)], -1)[moving]
        rr = r[moving] - np.mean(r[moving])
        coef, *_ = np.linalg.lstsq(B, rr, rcond=None)
        sigma = float(np.std(rr - B @ coef))
        se = sigma * math.sqrt(2.0 / len(rr))           # standard error of one amplitude
        out = {}
        for name, (a, b) in (("1x", coef[0:2]), (f"order {k:g} (roller pass)", coef[2:4])):
            amp = math.hypot(a, b)
            if amp > 8 * se:
                out[name] = amp
        return {"orders": out}

    @staticmethod
    def _locate(t, r, w, T_out, T_in, alpha):
        """Where the residual (measured - model input torque, N*m) concentrates, and what it
        follows; a plain statement with the numbers behind it."""
        aw, aT = np.abs(w), np.abs(T_out)
        p = np.abs(T_in * w)
        def corr(a, b):
            if np.std(a) == 0 or np.std(b) == 0:
                return 0.0
            return float(np.corrcoef(a, b)[0, 1])
        moving = aw > 0.05 * aw.max()
        rs = np.where(w >= 0, r, -r)       # residual in the sense of the motion (a loss > 0)
        c_speed = corr(rs[moving], aw[moving])
        c_load = corr(rs[moving], aT[moving])
        c_time = corr(r, t)
        c_acc = corr(r, alpha)
        fwd, rev = moving & (w > 0), moving & (w < 0)
        mean_fwd = float(np.mean(r[fwd])) if fwd.any() else 0.0
        mean_rev = float(np.mean(r[rev])) if rev.any() else 0.0
        # concentration over the operating map: terciles of speed and load
        qs, qt = np.quantile(aw[moving], [1 / 3, 2 / 3]), np.quantile(aT[moving], [1 / 3, 2 / 3])
        cells = {}
        for i, sl in enumerate(("low", "mid", "high")):
            for j, tl in enumerate(("low", "mid", "high")):
                sel = moving & (np.digitize(aw, qs) == i) & (np.digitize(aT, qt) == j)
                if sel.sum() > 5:
                    cells[f"speed {sl}, load {tl}"] = float(np.mean(rs[sel]))
        worst = max(cells, key=lambda c: abs(cells[c])) if cells else ""
        # at a given speed: relative mismatch at light vs heavy load (the paper's observation
        # that theory and experiment agree worse at low input power)
        light, heavy = [], []
        for i in range(3):
            sp = moving & (np.digitize(aw, qs) == i)
            if sp.sum() > 10:
                lo_t, hi_t = np.quantile(aT[sp], [1 / 3, 2 / 3])
                for sel, acc in ((sp & (aT <= lo_t), light), (sp & (aT >= hi_t), heavy)):
                    if sel.any():
                        acc.append(np.mean(rs[sel]) / max(np.mean(np.abs(T_in[sel])), 1e-12))
        rel_light = float(np.mean(light)) if light else float("nan")
        rel_heavy = float(np.mean(heavy)) if heavy else float("nan")
        low_p = moving & (p < np.quantile(p[moving], 0.33))
        high_p = moving & (p > np.quantile(p[moving], 0.67))
        rel_low = float(np.mean(rs[low_p]) / max(np.mean(np.abs(T_in[low_p])), 1e-12))
        rel_high = float(np.mean(rs[high_p]) / max(np.mean(np.abs(T_in[high_p])), 1e-12))
        parts = []
        under = np.mean(rs[moving]) > 0
        parts.append(f"the model {'under' if under else 'over'}-predicts the input torque, most "
                     f"at {worst}" if worst else "no operating region stands out")
        parts.append(f"relative to the input torque the mismatch is {100 * rel_low:+.1f} % at low "
                     f"and {100 * rel_high:+.1f} % at high input power")
        if math.isfinite(rel_light) and abs(rel_light) > 1.5 * abs(rel_heavy):
            parts.append(f"at a given speed it is larger at light load ({100 * rel_light:+.1f} % "
                         f"against {100 * rel_heavy:+.1f} % at heavy load)")
        parts.append(("the missing torque grows with speed" if c_speed > 0.3 else
                      "it falls with speed" if c_speed < -0.3 else "it does not follow speed")
                     + (", scales with load" if abs(c_load) > 0.3 else ", does not scale with load"))
        if abs(c_time) > 0.3:
            parts.append("it drifts with time")
        if abs(c_acc) > 0.3:
            parts.append("it follows acceleration")
        if fwd.any() and rev.any():
            parts.append("it keeps its sign when the rotation reverses (like an offset)"
                         if mean_fwd * mean_rev > 0 else
                         "it flips with the rotation (like friction)")
        return {"statement": "; ".join(parts) + ".",
                "corr_speed": c_speed, "corr_load": c_load, "corr_time": c_time,
                "corr_acceleration": c_acc, "mean_forward_Nm": mean_fwd,
                "mean_reverse_Nm": mean_rev, "by_region_Nm": cells,
                "relative_low_power": rel_low, "relative_high_power": rel_high,
                "relative_light_load_same_speed": rel_light,
                "relative_heavy_load_same_speed": rel_heavy}


def plot_diagnosis(d: Diagnosis, out) -> list:
    """Residual over time and over the operating map, before and after the fix (PNG)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from pathlib import Path
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    s = d.series
    fig, axes = plt.subplots(2, 2, figsize=(11, 7.5))
    ax = axes[0, 0]
    ax.plot(s["t"], 1e3 * s["residual_before"], lw=0.4, label="before")
    ax.plot(s["t"], 1e3 * s["residual_after"], lw=0.4, label=f"after ({d.effect})")
    ax.set(xlabel="time / s", ylabel="input torque residual / mN*m",
           title="measured - model input torque (10 ms means)")
    ax.legend(fontsize=7)
    for ax, key, title in ((axes[0, 1], "residual_before", "before"),
                           (axes[1, 0], "residual_after", "after")):
        sc = ax.scatter(s["speed_in"] * 30 / np.pi, s["torque_out"], c=1e3 * s[key], s=2,
                        cmap="coolwarm", vmin=-15, vmax=15)
        fig.colorbar(sc, ax=ax, label="residual / mN*m")
        ax.set(xlabel="input speed / (r/min)", ylabel="output torque / N*m",
               title=f"residual over the operating map, {title}")
    ax = axes[1, 1]
    ev = d.evidence
    ax.barh([e["id"] for e in ev], [e["bic"] - ev[0]["bic"] for e in ev])
    ax.set(xlabel="BIC - best BIC", title=f"evidence: {d.effect}")
    fig.tight_layout()
    f = out / "diagnosis.png"
    fig.savefig(f, dpi=100)
    plt.close(fig)
    return [f]


def updated_design(design: DriveDesign, d: Diagnosis):
    """The design with the diagnosed physics switched on (design.extra) and the friction level
    corrected; notes for what is not physics of the drive (a transducer offset)."""
    from dataclasses import replace
    p = {k: v["value"] for k, v in d.parameters.items()}
    fr = design.friction
    if "mu_boundary_rel_error" in p:
        fr = replace(fr, mu_boundary=fr.mu_boundary * (1 + p["mu_boundary_rel_error"]))
    from model_core.effects import switch_on
    shape = p.get(EFFECTS[d.effect].shape_name) if EFFECTS[d.effect].shape else None
    ex = switch_on(design.extra, d.effect, p, shape)
    notes = [f"updated by cyclo-fmu diagnose: effect {d.effect}"]
    if d.effect == "torque_sensor_offset":
        notes.append(f"diagnosed: input torque transducer zero offset {p['offset']:.6g} N*m "
                     "(a sensor fault, not physics of the drive: re-zero the transducer)")
    return replace(design, friction=fr, extra=ex), notes
