"""Speed of the physics core on this machine.

Targets (issue 8, item 8): a 50 x 50 efficiency map, every point mesh-cycle averaged with its
contacts solved, in at most 80 ms; one operating point in at most 0.5 ms. The reference measured in
the same run is the straightforward per-position path (losses.partial_losses(..., dedup=False)),
which solves every mesh position's contact problem on its own.
Run: python benchmarks/bench_core.py
"""
import statistics
import time

import numpy as np

from model_core import losses
from model_core import DriveDesign, efficiency_map, operating_point, rpm_to_rad_s


def best_of(fn, repeat):
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return min(times), statistics.median(times)


def main():
    d = DriveDesign()
    speeds = rpm_to_rad_s(np.linspace(500, 2800, 50))
    torques = np.linspace(0.1, 0.85, 50)
    efficiency_map(d, "S1", speeds, torques)   # warm-up (imports, caches of numpy)
    print(f"design: paper bench, {d.n_positions} mesh positions per roller pitch, "
          f"contact law {d.contact_law}")
    for mode in ("S1", "S2", "1S", "12"):
        best, med = best_of(lambda: efficiency_map(d, mode, speeds, torques), 5)
        print(f"50x50 map, mode {mode}: best {best * 1e3:7.1f} ms, median {med * 1e3:7.1f} ms "
              f"(target <= 80 ms)")
    T = np.repeat(torques * 100.0, 50)
    W = np.tile(speeds / d.i0, 50)
    for dedup in (True, False):
        best, med = best_of(lambda: losses.partial_losses(d, T, W, dedup=dedup), 5)
        print(f"2500 mesh-cycle averaged loss evaluations, "
              f"{'distinct problems once' if dedup else 'reference per position'}: "
              f"best {best * 1e3:7.1f} ms, median {med * 1e3:7.1f} ms")
    for mode in ("S1", "S2"):
        best, med = best_of(lambda: operating_point(d, mode, 290.0, 0.6), 200)
        print(f"one operating point, mode {mode}: best {best * 1e3:6.2f} ms, "
              f"median {med * 1e3:6.2f} ms (target <= 0.5 ms)")


if __name__ == "__main__":
    main()
