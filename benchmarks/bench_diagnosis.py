"""Speed of the diagnosis: a 10-minute recording at 1 kHz (600 000 samples) written by
``synth``, read, checked and diagnosed (replay, location, every candidate with its shape grid, stepwise selection with fold stability, the structure test,
BIC and 5-fold blocked cross-validation). Target (issue 10): read + check + diagnose at most
3 s on this 2-core machine; read and checks are timed separately.
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
        print(f"600 000 samples: synth + write {t_synth:.1f} s; read {t_read:.2f} s (reference: "
              f"bare pyarrow parse of the same file {t_ref:.2f} s), checks {t_check:.2f} s, "
              f"diagnose {t_fit:.1f} s; total read + check + diagnose "
              f"{t_read + t_check + t_fit:.1f} s (target <= 3 s); effect found: {d.effect}")


if __name__ == "__main__":
    main()
