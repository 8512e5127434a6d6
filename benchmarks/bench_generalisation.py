"""Generalisation: fit on the low-speed half of a recording, test on the high-speed half.

The physics fix (the diagnosed effect's term, fitted jointly with the friction level) against a
generic black-box residual model, a SINDy-style sparse polynomial regression (sequentially
thresholded least squares on all monomials up to degree 3 of input speed, output torque and the
direction), fitted on the same half. Both predict the input-torque residual (10 ms means); the
numbers are RMSE on the high-speed half. Run: python benchmarks/bench_generalisation.py
"""
import itertools
from types import SimpleNamespace

import numpy as np

from cyclo_fmu.diagnosis import Diagnoser
from cyclo_fmu.synth import synthesize
from model_core.effects import EFFECTS


def polynomial_library(w, T):
    x = {"w": w / 300.0, "T": T / 10.0, "s": np.sign(w)}
    names, cols = ["1"], [np.ones_like(w)]
    keys = list(x)
    for deg in (1, 2, 3):
        for combo in itertools.combinations_with_replacement(keys, deg):
            names.append("*".join(combo))
            cols.append(np.prod([x[k] for k in combo], axis=0))
    return names, np.stack(cols, -1)


def stlsq(X, y, threshold=1e-3, iterations=10):
    """Sequentially thresholded least squares (Brunton et al. 2016), columns normalised."""
    scale = np.linalg.norm(X, axis=0) / np.sqrt(len(X))
    scale[scale == 0] = 1.0
    Xn = X / scale
    keep = np.ones(X.shape[1], bool)
    coef = np.zeros(X.shape[1])
    for _ in range(iterations):
        c, *_ = np.linalg.lstsq(Xn[:, keep], y, rcond=None)
        coef[:] = 0
        coef[keep] = c
        small = np.abs(coef) < threshold
        if not np.any(small & keep):
            break
        keep &= ~small
    return coef / scale


def run(effect, seed, mode="S1", size="medium"):
    r = synthesize(effect, seed, mode, size)
    rec = SimpleNamespace(time=r["time_s"], speed_in=r["speed_in_rpm"] * np.pi / 30,
                          torque_in=r["torque_in_Nm"], speed_out=r["speed_out_rpm"] * np.pi / 30,
                          torque_out=r["torque_out_Nm"], temperature=None)
    diag = Diagnoser(mode=mode)
    # which physics: diagnosed from the low-speed half alone
    sw = np.abs(rec.speed_in)
    half = sw <= np.median(sw[sw > 0.05 * sw.max()])
    low_rec = SimpleNamespace(**{k: (v[half] if isinstance(v, np.ndarray) else v)
                                 for k, v in vars(rec).items()})
    found = diag.fit(low_rec).diagnosis_
    P = diag.problem(rec)
    y, w, T = P["y"], P["blocks"]["w_in"], P["blocks"]["T_out"]
    aw = np.abs(w)
    moving = aw > 0.05 * aw.max()
    low = moving & (aw <= np.median(aw[moving]))
    high = moving & (aw > np.median(aw[moving]))
    chosen = list(found.effects)
    if found.calibration and found.effect != "friction_miscalibrated":
        chosen.append({"id": "friction_miscalibrated", "parameters": found.calibration})
    cols = []
    for e in chosen:
        eff = EFFECTS[e["id"]]
        shape = eff.shape_from({k: v["value"] for k, v in e["parameters"].items()}) \
            if eff.shape else None
        cols += list(next(t for t in P["options"][e["id"]] if t.shape == shape).cols)
    X = P["X"][:, cols]
    rmse = lambda e: float(np.sqrt(np.mean(e ** 2)))
    out = {"diagnosed on the low half": ", ".join(e["id"] for e in found.effects) or "none",
           "no fix": rmse(y[high])}
    if X.shape[1]:
        c, *_ = np.linalg.lstsq(X[low], y[low], rcond=None)
        out["physics fix"] = rmse(y[high] - X[high] @ c)
    names, L = polynomial_library(w, T)
    c = stlsq(L[low], y[low])
    out[f"black box (STLSQ, {int(np.sum(c != 0))} of {len(names)} terms)"] = rmse(y[high] - L[high] @ c)
    return out


def main():
    for effect in ("load_independent_loss", "low_speed_friction", "friction_miscalibrated"):
        res = run(effect, 1)
        found = res.pop("diagnosed on the low half")
        print(f"{effect} (diagnosed on the low-speed half: {found}); RMSE on the high-speed "
              "half, mN*m: " + ", ".join(f"{k} {1e3 * v:.2f}" for k, v in res.items()))


if __name__ == "__main__":
    main()
