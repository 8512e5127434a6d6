"""Speed of the bench: the paper scenario (48 s simulated, 1 ms steps, 7 FMUs in fmpy's SSP
master) in simulated seconds per wall-clock second.
Run: python benchmarks/bench_bench.py
"""
import tempfile
import time

from cyclo_fmu.bench import build_ssp, paper_scenario, run_ssp
from cyclo_fmu.fmu_build import SLAVES, build_fmu


def main():
    with tempfile.TemporaryDirectory() as tmp:
        for name in SLAVES:
            build_fmu(name, tmp)
        for mode in ("S1", "S2"):
            sc = paper_scenario(mode)
            ssp = build_ssp(f"{tmp}/TestBench_{mode}.ssp", tmp, sc)
            t = time.perf_counter()
            res = run_ssp(ssp, sc.stop_time)
            wall = time.perf_counter() - t
            print(f"paper scenario {mode}: {sc.stop_time:.0f} s simulated, {len(res)} steps of 1 ms, "
                  f"{wall:.1f} s wall -> {sc.stop_time / wall:.1f} simulated s per wall s "
                  f"({wall / len(res) * 1e6:.0f} us per co-simulation step)")


if __name__ == "__main__":
    main()
