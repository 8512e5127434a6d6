"""Randomised check of the diagnosis: 0-3 library effects at 0.6-2x their default size, a form
outside the library in a third of the cases (load squared, speed x load, 50 Hz pick-up), sample
rates 200 Hz-2 kHz, transducer noise 2-6 mN*m, S1 or S2. A case is right when the named set
equals the hidden set and nothing is unexplained, or, with an outside form, when something is
unexplained and nothing outside the hidden set is named. Misses are counted apart from wrong
names (a wrong name is the failure that matters most).
Run: python benchmarks/fuzz_diagnosis.py [SEED] [N]
"""
import sys
from types import SimpleNamespace

import numpy as np

from cyclo_fmu.diagnosis import Diagnoser
from cyclo_fmu.synth import SynthSettings, synthesize
from model_core.effects import EFFECTS

#: the losses through standstill (loss_transition) show only where a drive creeps at 1-3 r/min
#: under load, which this plan (the synthesiser's 'full') never does: hidden, it could not be
#: found; nor is it a candidate here (model_core.effects.OPT_IN: only when asked)
LIBRARY = [e for e in EFFECTS if e not in ("none", "friction_miscalibrated", "torque_sensor_gain",
                                           "loss_transition")]


def load_squared(s):
    return np.sign(s["w_in"]) * 0.010 * (s["T_in_model"] / 0.8) ** 2


def speed_times_load(s):
    return np.sign(s["w_in"]) * 0.012 * np.abs(s["w_in"]) / 300 * np.abs(s["T_in_model"]) / 0.8


def mains(s):
    return 0.004 * np.sin(2 * np.pi * 50 * s["t"])


FORMS = {"load2": load_squared, "speedload": speed_times_load, "mains": mains}


def as_recording(r):
    return SimpleNamespace(time=r["time_s"], speed_in=r["speed_in_rpm"] * np.pi / 30,
                           torque_in=r["torque_in_Nm"], speed_out=r["speed_out_rpm"] * np.pi / 30,
                           torque_out=r["torque_out_Nm"], temperature=r.get("temperature_C"))


def main(seed=0, n=20):
    rng = np.random.default_rng(seed)
    right = wrong = missed = 0
    for _ in range(n):
        effects = [str(e) for e in rng.choice(LIBRARY, rng.integers(0, 4), replace=False)]
        spec = {}
        for e in effects:
            values, shape = EFFECTS[e].synth_default
            scale = rng.uniform(0.6, 2.0)
            spec[e] = ({p: v * scale for p, v in values.items()}, shape)
        form = str(rng.choice(["", "", "", "load2", "speedload", "mains"]))
        fs = float(rng.choice([200.0, 500.0, 1000.0, 2000.0]))
        noise = float(rng.uniform(0.002, 0.006))
        settings = SynthSettings(sample_rate=fs, torque_noise=noise, bandwidth=min(1000.0, 0.4 * fs))
        mode = "S1" if rng.random() < 0.5 else "S2"
        r = synthesize(spec or {"none": None}, int(rng.integers(1, 10 ** 6)), mode, "small",
                       settings=settings, added_torque=FORMS.get(form))
        d = Diagnoser(mode=mode).fit(as_recording(r)).diagnosis_
        named = {e["id"] for e in d.effects} - {"friction_miscalibrated"}
        truth = set(effects)
        unexplained = d.unexplained["present"]
        if form:
            ok, bad_name = unexplained and named <= truth, not named <= truth
        else:
            ok, bad_name = named == truth and not unexplained, bool(named - truth) or unexplained
        right += ok
        wrong += (not ok) and bad_name
        missed += (not ok) and not bad_name
        print(f"{'right ' if ok else 'WRONG ' if bad_name else 'missed'} {mode} {fs:6.0f} Hz "
              f"noise {1e3 * noise:.1f} mN*m hidden {sorted(truth)} {form or '-'} -> named "
              f"{sorted(named)}{' + unexplained' if unexplained else ''}", flush=True)
    print(f"{right} of {n} right, {missed} missed, {wrong} wrongly named")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 0, int(sys.argv[2]) if len(sys.argv) > 2 else 20)
