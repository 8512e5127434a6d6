"""Discovery of forms outside the library: recovery over seeds, modes and plans.

For each form (a loss the library does not hold, hidden with the model in a clean plan, the
friction level off by nothing) and each seed: is a form proposed, is it the hidden law (family
and exponents), the coefficient's error, the held-out RMS of the remainder before and after,
the share of its structured RMS removed, and whether re-diagnosing with the updated design
leaves anything. Negative controls (clean recordings, library effects) must give no proposal.

    python benchmarks/bench_discover.py [n_seeds]
"""
import math
import sys
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
from test_discover import FORMS  # noqa: E402

from cyclo_fmu.diagnosis import Diagnoser  # noqa: E402
from cyclo_fmu.diagnosis.discover import removed_share  # noqa: E402
from cyclo_fmu.synth import SynthSettings, synthesize  # noqa: E402


def rec(r):
    return SimpleNamespace(time=r["time_s"], speed_in=r["speed_in_rpm"] * np.pi / 30,
                           torque_in=r["torque_in_Nm"], speed_out=r["speed_out_rpm"] * np.pi / 30,
                           torque_out=r["torque_out_Nm"], temperature=r.get("temperature_C"))


def main(n_seeds=3):
    s = SynthSettings()
    noise = s.torque_noise / math.sqrt(0.01 * s.sample_rate)
    print(f"{'form':24s} {'seed':>4s} mode plan           law  coef_err  before  after  "
          f"removed closes  s")
    plans = ("full", "four_quadrant")
    for name, (form, (family, shape), coef) in FORMS.items():
        for k in range(n_seeds):
            seed, mode, plan = 100 + k, ("S1", "S2")[k % 2], plans[(k // 2) % 2]
            t0 = time.perf_counter()
            r = synthesize("none", seed, mode, "small", added_torque=form, plan=plan)
            D = Diagnoser(None, mode).fit(rec(r))
            p = D.diagnosis_.unexplained.get("proposed")
            dt = time.perf_counter() - t0
            if not p or not p["formula"]:
                print(f"{name:24s} {seed:4d} {mode}   {plan:13s} none  ({p and p['refused']})")
                continue
            dterm = D.discovery_.design_terms[0] if D.discovery_.design_terms else None
            got = None if dterm is None else (
                dterm.speed_exponent if family == "speed" else dterm.load_exponent
                if family == "load" else (dterm.speed_exponent, dterm.load_exponent))
            law = [t["family"] for t in p["terms"]] == [family] and got == shape
            err = (dterm.coefficient / coef - 1) if dterm else float("nan")
            share = removed_share(p["heldout_rms_before_Nm"], p["heldout_rms_after_Nm"], noise)
            fixed, _ = D.updated_design()
            again = Diagnoser(fixed, mode).fit(rec(r)).diagnosis_
            closes = not again.unexplained["present"] and not again.effects
            print(f"{name:24s} {seed:4d} {mode}   {plan:13s} {'yes' if law else 'NO ':4s} "
                  f"{100 * err:+7.1f}%  {1e3 * p['heldout_rms_before_Nm']:5.2f}  "
                  f"{1e3 * p['heldout_rms_after_Nm']:5.2f}  {100 * share:6.0f}%  "
                  f"{'yes' if closes else 'no':5s} {dt:4.1f}")
    print(f"(block-level noise of the synthesised transducer {1e3 * noise:.2f} mN*m; RMS in mN*m)")
    for hidden in ("none", "load_independent_loss", "low_speed_friction", "inertia"):
        for k in range(n_seeds):
            seed, mode = 200 + k, ("S1", "S2")[k % 2]
            r = synthesize(hidden, seed, mode, "small", plan=plans[(k // 2) % 2])
            d = Diagnoser(None, mode).fit(rec(r)).diagnosis_
            p = d.unexplained.get("proposed")
            print(f"control {hidden:22s} {seed} {mode}: "
                  f"{'proposed ' + p['formula'] if p and p['formula'] else 'no proposal'}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 3)
