"""What it costs that the reducer FMU leaves the host's allocator alone (issue 20).

The Python FMU solves a loss map at initialization for any design, mode or range it does not
ship (the default design's S1/S2 maps are shipped). It used to raise glibc's mmap and trim
thresholds around that solve (mallopt in the host's process); it no longer does. This script
solves one map (the default design, mode 12, the FMU's grid) in fresh processes, with glibc's
defaults (what an FMU now gets) and with cyclo_fmu.slaves.heap.keep_temporaries_on_heap() (what
our own processes still use), and prints wall time and minor page faults, min and median over
the runs, both measured in the same run of this script.

    python benchmarks/bench_fmu_heap.py [runs]
"""
import json
import statistics
import subprocess
import sys

CODE = """
import json, resource, sys, time, warnings
import numpy as np
from model_core import DriveDesign
from model_core.lossmap import ModeMap
if sys.argv[1] == "heap":
    from cyclo_fmu.slaves.heap import keep_temporaries_on_heap
    keep_temporaries_on_heap()
d = DriveDesign()
warnings.simplefilter("ignore")
np.seterr(all="ignore")
f0 = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
t = time.perf_counter()
ModeMap(d, "12", 30.0, 350.0)
print(json.dumps([time.perf_counter() - t, resource.getrusage(resource.RUSAGE_SELF).ru_minflt - f0]))
"""


def main(runs=7):
    res = {"glibc defaults (FMU)": [], "keep_temporaries_on_heap": []}
    for _ in range(runs):      # interleaved, so that the machine's load hits both alike
        for label, arg in (("glibc defaults (FMU)", "plain"), ("keep_temporaries_on_heap", "heap")):
            out = subprocess.run([sys.executable, "-c", CODE, arg], capture_output=True,
                                 text=True, check=True).stdout
            res[label].append(json.loads(out))
    print(f"one map solve (default design, mode 12, 30 N*m x 350 rad/s), {runs} fresh processes")
    for label, rows in res.items():
        t = [r[0] * 1e3 for r in rows]
        f = [r[1] for r in rows]
        print(f"  {label:26s} min {min(t):6.1f} ms  median {statistics.median(t):6.1f} ms  "
              f"minor faults {statistics.median(f):7.0f}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 7)
