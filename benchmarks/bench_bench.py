"""Speed of the bench: the paper scenario (48 s simulated, 7 FMUs) in simulated seconds per
wall-clock second, next to the floor of the same master stepping seven trivial pythonfmu FMUs
with the bench's connectors (no physics: do_step returns), measured in the same run.

Rows: the lean master behind ``run_bench`` (``run_fmus``: Gauss-Seidel, its C inner loop) at
1 ms, fmpy's SSP master at 1 ms (the SSP file as written), and the lean master at the step
chosen by the convergence check (``bench.converged_step``, run here on the paper scenario with
ideal sensors). Wall times include the FMUs' unpacking, instantiation and initialization; the
per-step cost without them is printed too (a 10 ms run measures the fixed part). Target
(issue 9): the paper scenario at 1 ms at least 20x real time.
Run: python benchmarks/bench_bench.py
"""
import tempfile
import time
from pathlib import Path

from cyclo_fmu.bench import (COMPONENTS, Sensors, bench_parameters, build_ssp, converged_step,
                             paper_scenario, run_fmus, run_ssp, steady_step)
from cyclo_fmu.fmu_build import SLAVES, build_fmu


def trivial_fmus(dest: Path):
    """One trivial pythonfmu FMU per bench FMU, with the same connector names."""
    from pythonfmu.builder import FmuBuilder
    for fmu in sorted({f for f, _ in COMPONENTS.values()}):
        cons = next(c for f, c in COMPONENTS.values() if f == fmu)
        src = ["from pythonfmu import Fmi2Causality, Fmi2Slave, Real", "", "",
               f"class {fmu}(Fmi2Slave):", "    def __init__(self, **kwargs):",
               "        super().__init__(**kwargs)"]
        for c, k in cons:
            src += [f"        self.{c} = 0.0",
                    f"        self.register_variable(Real({c!r}, causality=Fmi2Causality.{k}))"]
        src += ["", "    def do_step(self, t, dt):", "        return True", ""]
        script = dest / f"{fmu}.py"
        script.write_text("\n".join(src))
        FmuBuilder.build_FMU(script, dest=dest, needsExecutionTool="false")


def timed(fn):
    t = time.perf_counter()
    fn()
    return time.perf_counter() - t


def main():
    sc = paper_scenario("S1")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        (tmp / "real").mkdir()
        (tmp / "trivial").mkdir()
        for name in SLAVES:
            build_fmu(name, tmp / "real")
        trivial_fmus(tmp / "trivial")
        params = bench_parameters(sc, Sensors())
        run_fmus(tmp / "real", params, 0.01, 1e-3)        # compiles the C loop once
        floor_fixed = timed(lambda: run_fmus(tmp / "trivial", {}, 0.01, 1e-3))
        floor = timed(lambda: run_fmus(tmp / "trivial", {}, sc.stop_time, 1e-3))
        fixed = timed(lambda: run_fmus(tmp / "real", params, 0.01, 1e-3))
        lean = timed(lambda: run_fmus(tmp / "real", params, sc.stop_time, 1e-3))
        ssp = build_ssp(tmp / "TestBench.ssp", tmp / "real", sc)
        fmpy_ssp = timed(lambda: run_ssp(ssp, sc.stop_time, 1e-3))
        h = steady_step()
        coarse = timed(lambda: run_fmus(tmp / "real", params, sc.stop_time, h))
        chosen, report = converged_step(tmp / "real", sc)
        n = sc.stop_time / 1e-3
        print(f"paper scenario S1, {sc.stop_time:.0f} s simulated (measured under the machine's "
              "current load):")
        print(f"  {'':<55} {'wall':>8}  {'x real time':>12}  {'us/step':>8}  {'us/step w/o setup':>18}")
        for label, wall, steps, setup in (
                ("7 trivial pythonfmu FMUs, lean master, 1 ms (floor)", floor, n, floor_fixed),
                ("bench, lean master (run_bench), 1 ms", lean, n, fixed),
                ("bench, fmpy's SSP master, 1 ms", fmpy_ssp, n, None),
                (f"bench, lean master, {h * 1e3:g} ms (steady_step)", coarse, sc.stop_time / h,
                 fixed)):
            net = "" if setup is None else f"{(wall - setup) / steps * 1e6:8.0f}"
            print(f"  {label:<55} {wall:6.2f} s  {sc.stop_time / wall:10.1f}x  "
                  f"{wall / steps * 1e6:8.0f}  {net:>18}")
        print(f"  setup (unpack, instantiate, initialize): bench {fixed:.2f} s, floor "
              f"{floor_fixed:.2f} s")
        print(f"steady step chosen by converged_step on this scenario: {chosen * 1e3:g} ms "
              f"(bench.STEADY_STEP = {h * 1e3:g} ms); largest differences to 1 ms "
              "(efficiency, mean input speed r/min): "
              + ", ".join(f"{k * 1e3:g} ms: {e:.1e}, {v:.2g}" for k, (e, v) in report.items()))


if __name__ == "__main__":
    main()
