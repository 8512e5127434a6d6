"""Cost of one CycloidDrive doStep against a trivial pythonfmu FMU, both driven by the same
fmpy loop (setReal of the two inputs, doStep, getReal of four outputs); then 10^6 steps of the
reducer FMU with the process's resident memory before and after.

Target (issue 3): the reducer's step costs at most 2x the trivial FMU's.
Run: python benchmarks/bench_fmu.py [--steps-long 1000000]
"""
import argparse
import os
import tempfile
import textwrap
import time
from pathlib import Path

from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

TRIVIAL = textwrap.dedent('''
    from pythonfmu import Fmi2Causality, Fmi2Slave, Real


    class TrivialGear(Fmi2Slave):
        """Same ports as CycloidDrive; a fixed ratio and efficiency."""

        def __init__(self, **kwargs):
            super().__init__(**kwargs)
            self.w_in = self.tau_out = 0.0
            self.w_out = self.tau_in = self.P_loss = self.eta = 0.0
            for n in ("w_in", "tau_out"):
                self.register_variable(Real(n, causality=Fmi2Causality.input))
            for n in ("w_out", "tau_in", "P_loss", "eta"):
                self.register_variable(Real(n, causality=Fmi2Causality.output))

        def do_step(self, t, dt):
            self.w_out = self.w_in / 15.0
            self.tau_in = -self.tau_out / 15.0 / 0.65
            self.P_loss = self.tau_in * self.w_in + self.tau_out * self.w_out
            self.eta = 0.65
            return True
''')


def rss_mb():
    with open(f"/proc/{os.getpid()}/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2 ** 20


def open_fmu(path, params=None):
    md = read_model_description(path)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(path),
                    modelIdentifier=md.coSimulation.modelIdentifier, instanceName="bench")
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    for k, v in (params or {}).items():
        fmu.setString([vr[k]], [v])
    fmu.exitInitializationMode()
    return fmu, vr


def loop(fmu, vr, n, dt=1e-3):
    ins = [vr["w_in"], vr["tau_out"]]
    outs = [vr[k] for k in ("w_out", "tau_in", "P_loss", "eta")]
    t = 0.0
    start = time.perf_counter()
    for k in range(n):
        fmu.setReal(ins, [250.0 + (k % 100) * 0.1, -7.0 - (k % 37) * 0.01])
        fmu.doStep(currentCommunicationPoint=t, communicationStepSize=dt)
        fmu.getReal(outs)
        t += dt
    return (time.perf_counter() - start) / n


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--steps", type=int, default=50_000)
    ap.add_argument("--steps-long", type=int, default=1_000_000)
    args = ap.parse_args()
    from cyclo_fmu.fmu_build import build_fmu
    from pythonfmu.builder import FmuBuilder
    with tempfile.TemporaryDirectory() as tmp:
        drive = str(build_fmu("CycloidDrive", tmp))
        script = Path(tmp) / "bench_trivial_gear.py"
        script.write_text(TRIVIAL)
        trivial = str(FmuBuilder.build_FMU(script, dest=tmp, needsExecutionTool="false"))
        f_t, vr_t = open_fmu(trivial)
        f_d, vr_d = open_fmu(drive, {"mode": "S1"})
        loop(f_t, vr_t, 2000), loop(f_d, vr_d, 2000)    # warm-up
        t_triv = min(loop(f_t, vr_t, args.steps) for _ in range(3))
        t_drive = min(loop(f_d, vr_d, args.steps) for _ in range(3))
        print(f"trivial pythonfmu FMU : {t_triv * 1e6:6.2f} us per step (set 2, doStep, get 4)")
        print(f"CycloidDrive (map)    : {t_drive * 1e6:6.2f} us per step")
        print(f"ratio                 : {t_drive / t_triv:5.2f} (target <= 2)")
        before = rss_mb()
        t_long = loop(f_d, vr_d, args.steps_long)
        after = rss_mb()
        print(f"{args.steps_long} steps: {t_long * 1e6:.2f} us per step, resident memory "
              f"{before:.1f} MB -> {after:.1f} MB (growth {after - before:+.1f} MB)")
        for f in (f_t, f_d):
            f.terminate()
            f.freeInstance()


if __name__ == "__main__":
    main()
