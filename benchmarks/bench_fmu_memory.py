"""Memory of the Python FMUs' instances in one host process (issue 20: "50 instances take
53 MB that freeing does not return").

In a fresh process per FMU (fmpy's FMU2Slave, the FMU's C front, as a Python host runs it):
one instance first (interpreter, modules, the first loss map), then N more instances, each
instantiated, initialised and stepped 10 times; then all N terminated and freed; then N again.
Printed per FMU: resident memory (RSS) the N instances add, what Python objects they hold
(tracemalloc, a second process: tracing inflates RSS), what is left after freeing, and what a
second round of N adds (freed memory that the process reuses). RSS freed by the FMU goes back
to the allocator, which keeps it for the process (glibc trims only its heap's top; an FMU must
not call malloc_trim or mallopt in the host: docs/explanation/fmu-safety.md).

    python benchmarks/bench_fmu_memory.py [N] [FMU ...]      (default 50 CycloidDrive FeltBrake)
"""
import json
import subprocess
import sys
import tempfile
from pathlib import Path

CODE = r"""
import gc, json, os, sys
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
fmu, n, trace = sys.argv[1], int(sys.argv[2]), sys.argv[3] == "trace"
md = read_model_description(fmu)
d = extract(fmu)


def rss():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


def make(i):
    f = FMU2Slave(guid=md.guid, unzipDirectory=d, modelIdentifier=md.coSimulation.modelIdentifier,
                  instanceName=f"i{i}")
    f.instantiate()
    f.setupExperiment(startTime=0.0)
    f.enterInitializationMode()
    f.exitInitializationMode()
    for k in range(10):
        f.doStep(k * 1e-3, 1e-3)
    return f


def free(fs):
    for f in fs:
        f.terminate()
        f.freeInstance()
    fs.clear()
    gc.collect()


first = make(0)
gc.collect()
if trace:
    import tracemalloc
    tracemalloc.start()
    now = lambda: tracemalloc.get_traced_memory()[0] / 2**20
else:
    now = rss
m0 = now()
fs = [make(i + 1) for i in range(n)]
m1 = now()
free(fs)
m2 = now()
fs = [make(i + 1) for i in range(n)]
m3 = now()
free(fs)
print(json.dumps({"added": m1 - m0, "left": m2 - m0, "second": m3 - m2}))
"""


def measure(fmu, n, mode):
    out = subprocess.run([sys.executable, "-c", CODE, str(fmu), str(n), mode],
                         capture_output=True, text=True, check=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def main(n=50, names=("CycloidDrive", "FeltBrake")):
    from cyclo_fmu.fmu_build import build_any
    with tempfile.TemporaryDirectory(prefix="bench_fmu_memory_") as tmp:
        print(f"{n} instances (initialised, 10 steps) after a first one, in fresh processes")
        print(f"{'FMU':14s} {'RSS added':>10s} {'per inst.':>10s} {'objects':>9s} "
              f"{'per inst.':>10s} | after freeing: {'RSS kept':>9s} {'objects':>8s} | "
              f"{'2nd round RSS':>13s}")
        for name in names:
            fmu = build_any(name, Path(tmp))
            r, t = measure(fmu, n, "rss"), measure(fmu, n, "trace")
            print(f"{name:14s} {r['added']:8.1f} MB {r['added'] / n * 1024:7.0f} kB "
                  f"{t['added']:6.1f} MB {t['added'] / n * 1024:7.0f} kB | "
                  f"{'':15s}{r['left']:6.1f} MB {t['left']:5.2f} MB | "
                  f"{r['second']:10.1f} MB")


if __name__ == "__main__":
    args = sys.argv[1:]
    n = int(args.pop(0)) if args and args[0].isdigit() else 50
    main(n, tuple(args) or ("CycloidDrive", "FeltBrake"))
