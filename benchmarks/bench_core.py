"""Speed of the physics core on this machine.

Targets (issue 8): a 50 x 50 efficiency map, every point mesh-cycle averaged with its contacts
solved iteratively, in at most 0.08 s; one operating point in at most 0.5 ms; the FMU's map
(ModeMap, 48 x 28 points x 2 flow directions) in at most 50 ms. The reference measured in the
same run is the straightforward path (every mesh position and contact problem solved on its own,
``dedup=False``), which gives the same numbers.
Run: python benchmarks/bench_core.py
"""
import statistics
import time

import numpy as np

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
    import functools
    import model_core.efficiency as eff
    from model_core.losses import partial_losses
    fast = eff.partial_losses

    def reference(fn, repeat):
        eff.partial_losses = functools.partial(partial_losses, dedup=False)
        try:
            return best_of(fn, repeat)
        finally:
            eff.partial_losses = fast
    for mode in ("S1", "S2", "1S", "12"):
        best, med = best_of(lambda: efficiency_map(d, mode, speeds, torques), 5)
        ref, _ = reference(lambda: efficiency_map(d, mode, speeds, torques), 2)
        print(f"50x50 map, mode {mode}: best {best * 1e3:7.1f} ms, median {med * 1e3:7.1f} ms "
              f"(straightforward path {ref * 1e3:.0f} ms; target <= 80 ms)")
    for mode in ("S1", "S2"):
        best, med = best_of(lambda: operating_point(d, mode, 290.0, 0.6), 200)
        ref, _ = reference(lambda: operating_point(d, mode, 290.0, 0.6), 50)
        print(f"one operating point, mode {mode}: best {best * 1e3:6.2f} ms, "
              f"median {med * 1e3:6.2f} ms (straightforward path {ref * 1e3:.2f} ms; "
              f"target <= 0.5 ms)")
    from model_core.lossmap import ModeMap
    for mode in ("S1", "S2"):
        best, med = best_of(lambda: ModeMap(d, mode, 30.0, 350.0), 5)
        print(f"FMU map (ModeMap 48 x 28 x 2), mode {mode}: best {best * 1e3:6.1f} ms, "
              f"median {med * 1e3:6.1f} ms (target <= 50 ms)")


if __name__ == "__main__":
    main()
