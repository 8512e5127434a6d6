"""Speed of the diagnosis: a 10-minute recording at 1 kHz (600 000 samples) written by
``synth``, read, checked and diagnosed (the stages replay, select, twins, remainder, report:
every candidate with its shape grid, stepwise selection with fold stability, 64 twins of the
recording judging every claim, orders, peaks, bursts). Target (issue 18): 600 000 samples
diagnosed, twins included, in <= 4 s and <= 0.5 GB as a command (``cyclo-fmu diagnose --json``,
timed with its peak resident memory); read and checks are timed separately in-process.
Run: python benchmarks/bench_diagnosis.py
"""
import tempfile
import time
from pathlib import Path

from cyclo_fmu.diagnosis import Diagnoser
from cyclo_fmu.synth import synthesize, write_synth


def main():
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "large.csv"
        t = time.perf_counter()
        rec = synthesize("thermal_drift", 1, "S1", "large")
        write_synth(path, rec)
        t_synth = time.perf_counter() - t
        import pyarrow.csv as pc
        from cyclo_fmu.io.checks import check_plausibility
        from cyclo_fmu.recordings import read_recording
        pc.read_csv(path)                      # warm the file cache and pyarrow's imports
        t = time.perf_counter()
        pc.read_csv(path)
        t_ref = time.perf_counter() - t
        t = time.perf_counter()
        r = read_recording(path, check=False)
        t_read = time.perf_counter() - t
        t = time.perf_counter()
        mode, checks = check_plausibility(r, "S1")
        t_check = time.perf_counter() - t
        t = time.perf_counter()
        d = Diagnoser(mode=mode).fit(r).diagnosis_
        t_fit = time.perf_counter() - t
        import os
        import resource
        import subprocess
        import sys
        cli = os.path.join(os.path.dirname(sys.executable), "cyclo-fmu")
        t = time.perf_counter()
        p = subprocess.run([cli, "diagnose", str(path), "--mode", "S1", "--json"],
                           capture_output=True, text=True)
        t_cmd = time.perf_counter() - t
        rss = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024 ** 2   # GB
        t = time.perf_counter()
        subprocess.run([sys.executable, "-c", "import numpy, scipy.signal, pyarrow.csv"])
        t_imp = time.perf_counter() - t
        print(f"as a command: {t_cmd:.1f} s, peak memory {rss:.2f} GB (target <= 4 s, <= 0.5 GB;"
              f" reference: a bare interpreter importing numpy, scipy.signal and pyarrow "
              f"{t_imp:.1f} s); exit {p.returncode}")
        print(f"600 000 samples: synth + write {t_synth:.1f} s; read {t_read:.2f} s (reference: "
              f"bare pyarrow parse of the same file {t_ref:.2f} s), checks {t_check:.2f} s, "
              f"diagnose {t_fit:.1f} s; total read + check + diagnose "
              f"{t_read + t_check + t_fit:.1f} s (in-process); effect found: {d.effect}")


if __name__ == "__main__":
    main()
