"""Speed of the bench: the paper scenario (48 s simulated, 1 ms steps, 7 FMUs) in simulated
seconds per wall-clock second, next to references measured in the same run.

- floor: seven trivial pythonfmu FMUs with the bench's ports, stepped by the same lean master
  (what the FMI plumbing of pythonfmu alone costs);
- lean: ``run_bench(master="lean")``, the package's fixed-step Jacobi master over cached value
  references (target, issue 9: at least 20x real time at 1 ms);
- fmpy: ``run_bench(master="fmpy")``, fmpy's SSP master on the same SSP.

Convergence check for the step of steady scenarios: the paper scenario's window efficiencies at
2 and 5 ms against 1 ms; the largest step whose windows agree within ``TOL_PP`` is stated.
Run: python benchmarks/bench_bench.py
"""
import tempfile
import textwrap
import time
from pathlib import Path

import numpy as np

from cyclo_fmu.bench import COMPONENTS, _lean_loop, paper_scenario, run_bench
from cyclo_fmu.fmu_build import SLAVES, build_fmu

TOL_PP = 0.02      # percentage points of efficiency: a tenth of the bench-vs-core test tolerance

TRIVIAL = textwrap.dedent('''
    from pythonfmu import Fmi2Causality, Fmi2Slave, Real


    class Trivial(Fmi2Slave):
        """Up to five inputs and outputs, one multiply each: the pythonfmu floor."""

        def __init__(self, **kwargs):
            super().__init__(**kwargs)
            for k in range(5):
                setattr(self, f"u{k}", 0.0)
                setattr(self, f"y{k}", 0.0)
                self.register_variable(Real(f"u{k}", causality=Fmi2Causality.input))
                self.register_variable(Real(f"y{k}", causality=Fmi2Causality.output))

        def do_step(self, t, dt):
            self.y0 = 0.5 * self.u0
            self.y1 = 0.5 * self.u1
            self.y2 = 0.5 * self.u2
            self.y3 = 0.5 * self.u3
            self.y4 = 0.5 * self.u4
            return True
''')


def floor(tmp, stop_time, step=1e-3):
    """The lean loop over seven trivial FMUs wired like the bench (same port counts)."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave
    from pythonfmu import FmuBuilder
    script = Path(tmp) / "trivial.py"
    script.write_text(TRIVIAL)
    path = str(FmuBuilder.build_FMU(script, dest=tmp, needsExecutionTool="false"))
    md = read_model_description(path)
    var = {v.name: v.valueReference for v in md.modelVariables}
    unzipped = extract(path)
    comps = {}
    for name, (_, connectors) in COMPONENTS.items():
        f = FMU2Slave(guid=md.guid, unzipDirectory=unzipped,
                      modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
        f.instantiate()
        f.setupExperiment(startTime=0.0)
        f.enterInitializationMode()
        f.exitInitializationMode()
        ins = [(c, var[f"u{k}"]) for k, (c, kind) in
               enumerate([x for x in connectors if x[1] == "input"])]
        outs = [(c, var[f"y{k}"]) for k, (c, kind) in
                enumerate([x for x in connectors if x[1] == "output"])]
        comps[name] = (f, ins, outs)
    t = time.perf_counter()
    rows, _ = _lean_loop(comps, stop_time, step)
    wall = time.perf_counter() - t
    for f, _, _ in comps.values():
        f.terminate()
        f.freeInstance()
    return wall, len(rows)


def main():
    with tempfile.TemporaryDirectory() as tmp:
        for name in SLAVES:
            build_fmu(name, tmp)
        sc = paper_scenario("S1")
        wall, n = floor(tmp, sc.stop_time)
        print(f"floor: 7 trivial pythonfmu FMUs, lean master: {sc.stop_time / wall:.1f}x real time "
              f"({wall / n * 1e6:.0f} us per co-simulation step)")
        windows = {}
        for mode in ("S1", "S2"):
            sc = paper_scenario(mode)
            for master in ("lean", "fmpy"):
                t = time.perf_counter()
                run = run_bench(sc, tmp, master=master)
                wall = time.perf_counter() - t
                print(f"paper scenario {mode}, {master} master: {sc.stop_time:.0f} s simulated in "
                      f"{wall:.1f} s -> {sc.stop_time / wall:.1f}x real time "
                      f"({wall / len(run.result) * 1e6:.0f} us per step of 1 ms)"
                      + ("; target >= 20x" if master == "lean" else ""))
                if master == "lean" and mode == "S1":
                    windows[1e-3] = np.array([w["eta"] for w in run.windows])
        sc = paper_scenario("S1")
        chosen = 1e-3
        for step in (2e-3, 5e-3):
            t = time.perf_counter()
            run = run_bench(sc, tmp, step=step)
            wall = time.perf_counter() - t
            eta = np.array([w["eta"] for w in run.windows])
            dev = 100 * np.max(np.abs(eta - windows[1e-3]))
            ok = dev <= TOL_PP
            if ok and chosen == {2e-3: 1e-3, 5e-3: 2e-3}[step]:
                chosen = step
            print(f"convergence: step {step * 1e3:.0f} ms, {sc.stop_time / wall:.1f}x real time; "
                  f"window efficiencies differ from 1 ms by up to {dev:.3f} percentage points "
                  f"({'within' if ok else 'beyond'} {TOL_PP} pp)")
        print(f"step for steady scenarios by this check: {chosen * 1e3:.0f} ms")


if __name__ == "__main__":
    main()
