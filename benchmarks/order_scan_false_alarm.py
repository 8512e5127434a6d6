"""False-alarm rate of the order scan (``cyclo_fmu.diagnosis.order_scan``) on residuals of
noise alone: the share of recordings in which a line at some order is claimed, against the
stated family-wise rate (``twins.FALSE_ALARM``, 1 %).

Residuals: white, AR(1) (a = 0.95) and flicker (1/f) noise, 5 mN*m RMS, at 1 kHz, two
minutes; speed plans: a drive cycle (two sines of 37 s and 11 s about 150 rad/s), four
quadrants (a 60 s sine through zero: reversals), stairs of five held speeds (20 s each), and
one held speed. Each recording is judged with ``min_amplitude=0`` (the significance alone).

    python benchmarks/order_scan_false_alarm.py [--draws 25] [--seconds 120] [--fs 1000]
"""
from __future__ import annotations

import argparse
import math
import time

import numpy as np

from cyclo_fmu.diagnosis.order_scan import order_scan

PLANS = ("drive cycle", "four quadrants", "stairs", "one speed")
NOISES = ("white", "ar1", "flicker")


def speed(plan, t):
    """Input speed [rad/s] of the plan at times ``t``."""
    if plan == "drive cycle":
        return 150 + 100 * np.sin(2 * np.pi * t / 37) + 40 * np.sin(2 * np.pi * t / 11 + 1)
    if plan == "four quadrants":
        return 250 * np.sin(2 * np.pi * t / 60)
    if plan == "stairs":
        return np.array([60.0, 120, 180, 240, 300])[(t // 20).astype(int) % 5]
    return np.full(t.size, 160.0)


def noise(kind, n, rng, sd=0.005):
    e = rng.standard_normal(n)
    if kind == "ar1":
        from scipy.signal import lfilter
        e = lfilter([1.0], [1.0, -0.95], e)
    elif kind == "flicker":
        f = np.fft.rfftfreq(n)
        X = np.fft.rfft(e)
        X[1:] /= np.sqrt(f[1:])
        X[0] = 0.0
        e = np.fft.irfft(X, n)
    return sd * e / np.std(e)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--draws", type=int, default=25)
    ap.add_argument("--seconds", type=float, default=120.0)
    ap.add_argument("--fs", type=float, default=1000.0)
    a = ap.parse_args()
    n = int(a.seconds * a.fs)
    t = np.arange(n) / a.fs
    total = hits = 0
    cpu = 0.0
    print(f"| plan | noise | recordings | claimed | share |\n|---|---|---|---|---|")
    for ip, plan in enumerate(PLANS):
        w = speed(plan, t)
        th = np.cumsum(w) / a.fs
        for ik, kind in enumerate(NOISES):
            h = m = 0
            for d in range(a.draws):
                rng = np.random.default_rng([ip, ik, d])
                r = noise(kind, n, rng)
                c0 = time.process_time()
                sc = order_scan(r, th, w, 1 / a.fs, listed=(1, 2, 3, 1 / 14, 2 / 14),
                                min_amplitude=0.0, rng=rng)
                cpu += time.process_time() - c0
                if sc is None:
                    continue
                m += 1
                h += bool(sc.lines)
            total += m
            hits += h
            print(f"| {plan} | {kind} | {m} | {h} | {h / max(m, 1):.3f} |")
    print(f"\nall: {hits} of {total} recordings claim a line ({hits / max(total, 1):.4f}; "
          f"stated 0.01); scan CPU {cpu / max(total, 1) * 1e3:.0f} ms per recording of {n}")


if __name__ == "__main__":
    main()
